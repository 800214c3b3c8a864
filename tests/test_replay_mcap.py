"""MCAP replays: one file per match that round-trips to the match result, opens in Foxglove
(a ``foxglove.SceneUpdate`` scene channel), and exports a GIF of the top-down view."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader
from PIL import Image

from arena_league.matchmaking import AgentRef, play_matches, specs_for_seatings
from arena_league.replay import (
    SCENE_SCHEMA_NAME,
    ReplayError,
    ReplayRecording,
    export_gif,
    iter_messages,
    read_replay,
    replay_file_name,
    scene_update_schema,
)

GAMES = {  # game id -> env options keeping the matches short
    "GoBang-2T1P-v1": {},
    "Crossroads-2T2P-v1": {"max_cycles": 30},
    "Soccer-2T1P-v1": {"max_cycles": 30},
    "Snake-4T1P-v1": {"max_cycles": 30},
}


def _record(game_id, env_kwargs, directory, seatings=None):
    agents = {name: AgentRef("scripted", name, game_id) for name in ("random", "heuristic")}
    from arena_league.envs import game_spec

    n_teams = game_spec(game_id).n_teams
    seatings = seatings or [tuple(["random", "heuristic"] * n_teams)[:n_teams]]
    specs = specs_for_seatings(game_id, seatings, league_seed=12, first_match_id=3)
    recorded = play_matches(specs, agents, env_kwargs=env_kwargs, recording=ReplayRecording(directory))
    plain = play_matches(specs, agents, env_kwargs=env_kwargs)
    return specs, recorded, plain


@pytest.mark.parametrize("game_id", sorted(GAMES))
def test_replay_round_trips_to_the_match_result(game_id, tmp_path):
    specs, recorded, plain = _record(game_id, GAMES[game_id], tmp_path)
    result = recorded[0]
    assert [r.without_replay() for r in recorded] == plain  # recording changes nothing
    assert result.replay_path == str(tmp_path / replay_file_name(specs[0]))
    summary = read_replay(result.replay_path)
    assert summary.result == result
    assert (summary.game_id, summary.seed, summary.seats, summary.steps) == (game_id, specs[0].seed,
                                                                             specs[0].seats, result.steps)
    assert summary.env_kwargs == GAMES[game_id]
    steps = result.steps
    counts = summary.channels
    assert counts["/observations"] == counts["/scene"] == steps + 1
    assert counts["/actions"] == counts["/rewards"] == steps
    assert counts["/match"] == counts["/result"] == 1
    assert summary.schemas["/scene"] == SCENE_SCHEMA_NAME == "foxglove.SceneUpdate"
    assert json.loads(json.dumps(summary.to_dict()))["steps"] == steps
    assert not list(tmp_path.glob("*.part"))


def test_scene_channel_is_foxglove_scene_update(tmp_path):
    _, recorded, _ = _record("Crossroads-2T2P-v1", {"max_cycles": 5}, tmp_path)
    path = recorded[0].replay_path
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        scene = next(c for c in summary.channels.values() if c.topic == "/scene")
        schema = summary.schemas[scene.schema_id]
        assert (schema.name, schema.encoding, scene.message_encoding) == ("foxglove.SceneUpdate", "jsonschema", "json")
        assert json.loads(schema.data)["title"] == "foxglove.SceneUpdate"
        assert reader.get_header().profile == "arena-league"
    required = scene_update_schema()["properties"]["entities"]["items"]["required"]
    updates = [message for _, message in iter_messages(path, ["/scene"])]
    assert len(updates) == 6
    entities = {e["id"]: e for e in updates[-1]["entities"]}
    assert {"roads", "agent/0", "agent/3", "target/2"} <= set(entities)
    for entity in entities.values():
        assert set(required) <= set(entity) and entity["frame_id"] == "arena"
    agent = entities["agent/0"]["spheres"][0]
    assert set(agent) == {"pose", "size", "color"} and 0 <= agent["color"]["a"] <= 1
    assert updates[-1]["entities"][0]["timestamp"] == {"sec": 0, "nsec": 500_000_000}
    # agents move: their scene positions follow the rules' state
    first = next(e for e in updates[0]["entities"] if e["id"] == "agent/0")["spheres"][0]["pose"]["position"]
    assert first != agent["pose"]["position"]


def test_gif_of_the_top_down_view(tmp_path):
    _, recorded, _ = _record("GoBang-2T1P-v1", {}, tmp_path)
    result = recorded[0]
    gif = tmp_path / "match.gif"
    frames = export_gif(result.replay_path, gif, fps=5)
    assert frames == result.steps + 1
    with Image.open(gif) as image:
        assert image.n_frames == frames and image.size[0] >= 240
    every = export_gif(result.replay_path, tmp_path / "sparse.gif", every=4)
    assert every == 1 + result.steps // 4 + (result.steps % 4 != 0)


def test_unreadable_replays_are_refused_with_the_reason(tmp_path):
    _, recorded, _ = _record("GoBang-2T1P-v1", {}, tmp_path)
    path = recorded[0].replay_path
    with pytest.raises(ReplayError, match="no replay"):
        read_replay(tmp_path / "missing.mcap")
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(Path(path).read_bytes()[:300])
    with pytest.raises(ReplayError, match="not a readable MCAP replay|not a finished"):
        read_replay(truncated)
    not_mcap = tmp_path / "notes.mcap"
    not_mcap.write_text("hello")
    with pytest.raises(ReplayError):
        read_replay(not_mcap)
