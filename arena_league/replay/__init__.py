"""Match replays: one MCAP file per match (JSON schemas; observations, actions, rewards, events and
a ``foxglove.SceneUpdate`` top-down scene that Foxglove Studio opens), a reader that summarises
one, and GIF export of the top-down view, captioned with the agents of each team in its colour,
the step and the outcome (:mod:`arena_league.replay.captions`).

    results = play_matches(specs, agents, recording=ReplayRecording("replays/"))   # --record
    summary = read_replay(results[0].replay_path)                                    # arena-league replay FILE
    export_gif(results[0].replay_path, "match.gif")                                  # --gif match.gif
"""

from arena_league.replay.reader import (
    ReplayError,
    ReplaySummary,
    export_gif,
    iter_messages,
    read_replay,
    replay_frames,
)
from arena_league.replay.scenes import FRAME_ID, scene_entities, scene_update
from arena_league.replay.schemas import CHANNEL_SCHEMAS, SCENE_SCHEMA_NAME, TOPICS, scene_update_schema
from arena_league.replay.writer import (
    FORMAT_VERSION,
    PROFILE,
    STEP_NS,
    MatchRecorder,
    ReplayRecording,
    replay_file_name,
)

__all__ = [
    "CHANNEL_SCHEMAS",
    "FORMAT_VERSION",
    "FRAME_ID",
    "PROFILE",
    "SCENE_SCHEMA_NAME",
    "STEP_NS",
    "TOPICS",
    "MatchRecorder",
    "ReplayError",
    "ReplayRecording",
    "ReplaySummary",
    "export_gif",
    "iter_messages",
    "read_replay",
    "replay_file_name",
    "replay_frames",
    "scene_entities",
    "scene_update",
    "scene_update_schema",
]
