"""Reading arena-league replays: a summary of one MCAP file, its messages, and a GIF of the match.

The GIF is drawn by replaying the recorded actions through ``make(game_id,
render_mode="rgb_array")`` reset with the recorded seed: the games are deterministic (same seed,
same actions, same trajectory), so the pictures are those of the match as played. The replay is
checked against the recorded step count and result, and a mismatch (the game's code changed
since the recording) is an error rather than a wrong picture.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.exceptions import McapError
from mcap.reader import make_reader

from arena_league.matchmaking.specs import MatchResult, MatchSpec
from arena_league.replay.schemas import TOPICS

__all__ = ["ReplayError", "ReplaySummary", "export_gif", "iter_messages", "read_replay", "replay_frames"]


#: What the mcap reader raises on bytes that are not a whole MCAP file.
_UNREADABLE = (McapError, ValueError, EOFError, AssertionError, KeyError, struct.error)


class ReplayError(ValueError):
    """A file is not a readable arena-league replay, or does not replay as recorded."""


@dataclass(frozen=True)
class ReplaySummary:
    """What one replay holds."""

    path: str
    game_id: str
    match_id: int
    league_seed: int
    seed: int
    seats: tuple[str, ...]
    teams: tuple[int, ...]
    steps: int
    scores: tuple[float, ...]
    outcomes: tuple[str, ...]
    positions: tuple[int, ...] | None
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    half: int | None = None
    """0 or 1 for one match of a pair (see :meth:`arena_league.matchmaking.MatchSpec.halves`)."""
    points: tuple[float, ...] = ()
    """A half's ``pair_points`` per seat (empty for an unpaired match)."""
    channels: dict[str, int] = field(default_factory=dict)
    """Message count per topic."""
    schemas: dict[str, str] = field(default_factory=dict)
    """Schema name per topic (the scene's is ``foxglove.SceneUpdate``)."""

    @property
    def result(self) -> MatchResult:
        """The recorded result as a :class:`MatchResult` (``replay_path`` is this file)."""
        return MatchResult(match_id=self.match_id, game_id=self.game_id, league_seed=self.league_seed,
                           seed=self.seed, seats=self.seats, teams=self.teams, scores=self.scores,
                           outcomes=self.outcomes, positions=self.positions, steps=self.steps,
                           replay_path=self.path, half=self.half, points=self.points)

    @property
    def spec(self) -> MatchSpec:
        return MatchSpec(self.match_id, self.game_id, self.seats, self.league_seed, half=self.half)

    def to_dict(self) -> dict[str, Any]:
        return {"path": self.path, "game_id": self.game_id, "match_id": self.match_id,
                "league_seed": self.league_seed, "seed": self.seed, "seats": list(self.seats),
                "teams": list(self.teams), "steps": self.steps, "scores": list(self.scores),
                "outcomes": list(self.outcomes),
                "positions": None if self.positions is None else list(self.positions),
                "env_kwargs": self.env_kwargs, "half": self.half, "points": list(self.points),
                "channels": dict(self.channels),
                "schemas": dict(self.schemas)}


def _open(path: str | Path):
    path = Path(path)
    if not path.is_file():
        partial = path.with_name(path.name + ".part")
        hint = (" (an unfinished recording lies beside it: the match did not end)" if partial.exists() else "")
        raise ReplayError(f"no replay at {path}{hint}")
    return path


def iter_messages(path: str | Path, topics: Iterable[str] | None = None) -> Iterator[tuple[str, dict[str, Any]]]:
    """``(topic, message)`` pairs of a replay in log-time order, optionally only ``topics``
    (names such as ``"/actions"``)."""
    path = _open(path)
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        try:
            for _, channel, message in reader.iter_messages(topics=None if topics is None else list(topics)):
                yield channel.topic, json.loads(message.data)
        except _UNREADABLE as error:
            raise ReplayError(f"{path} is not a readable MCAP replay ({type(error).__name__}: {error}); "
                              "it may be truncated or not an arena-league replay") from error


def _first(path: Path, topic: str) -> dict[str, Any]:
    for _, message in iter_messages(path, [topic]):
        return message
    raise ReplayError(f"{path} has no {topic} message: it is not a finished arena-league replay "
                      "(written by arena_league.replay with the match played to its end)")


def read_replay(path: str | Path) -> ReplaySummary:
    """A summary of one replay: game, seeds, seats, steps, result and message counts per channel."""
    path = _open(path)
    counts: dict[str, int] = {}
    schemas: dict[str, str] = {}
    try:
        with open(path, "rb") as stream:
            summary = make_reader(stream).get_summary()
    except _UNREADABLE as error:
        raise ReplayError(f"{path} is not a readable MCAP replay ({type(error).__name__}: {error})") from error
    if summary is not None and summary.statistics is not None:
        for channel_id, channel in summary.channels.items():
            counts[channel.topic] = int(summary.statistics.channel_message_counts.get(channel_id, 0))
            schema = summary.schemas.get(channel.schema_id)
            schemas[channel.topic] = schema.name if schema is not None else ""
    else:  # no summary section: count by reading every message
        for topic, _ in iter_messages(path):
            counts[topic] = counts.get(topic, 0) + 1
    match = _first(path, TOPICS["match"])
    result = _first(path, TOPICS["result"])
    positions = result.get("positions")
    return ReplaySummary(
        path=str(path), game_id=match["game_id"], match_id=int(match["match_id"]),
        league_seed=int(match["league_seed"]), seed=int(match["seed"]), seats=tuple(match["seats"]),
        teams=tuple(int(t) for t in match["teams"]), steps=int(result["steps"]),
        scores=tuple(float(s) for s in result["scores"]), outcomes=tuple(result["outcomes"]),
        positions=None if positions is None else tuple(int(p) for p in positions),
        env_kwargs=dict(match.get("env_kwargs", {})), half=match.get("half"),
        points=tuple(float(p) for p in result.get("points", ())), channels=counts, schemas=schemas)


def replay_frames(path: str | Path, every: int = 1) -> Iterator[np.ndarray]:
    """Top-down pictures ``uint8[H, W, 3]`` of the match, at reset and after every ``every``-th
    step (and the last), by replaying the recorded actions; raises :class:`ReplayError` if the
    replay does not reproduce the recorded result."""
    for _, picture in _replayed(path, every, read_replay(path)):
        yield picture


def _replayed(path: str | Path, every: int, summary: ReplaySummary) -> Iterator[tuple[int, np.ndarray]]:
    """``(step, picture)`` at reset and after every ``every``-th step and the last (see
    :func:`replay_frames`)."""
    from arena_league.envs import make

    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise ValueError(f"every must be a positive integer (keep one frame in `every`), not {every!r}")
    env = make(summary.game_id, render_mode="rgb_array", **summary.env_kwargs)
    env.reset_arrays(summary.seed)
    yield 0, env.render()
    dtype = np.int64 if env.rules.action_type == "discrete" else np.float32
    done = False
    for _, message in iter_messages(path, [TOPICS["actions"]]):
        if done:
            raise ReplayError(f"{path}: actions recorded after the match ended at step {env.step_count}; the "
                              "game's rules differ from those that recorded it")
        _, _, terminated, truncated = env.step_arrays(np.asarray(message["actions"], dtype=dtype))
        done = terminated or truncated
        if done or env.step_count % every == 0:
            yield env.step_count, env.render()
    scores = tuple(float(s) for s in env.team_result()[list(summary.teams)]) if done else None
    if not done or env.step_count != summary.steps or scores != summary.scores:
        raise ReplayError(
            f"{path}: replaying the recorded actions gave {env.step_count} steps and scores {scores}, but the "
            f"recording says {summary.steps} steps and {summary.scores}; the game's rules or its options changed "
            "since it was recorded")


def export_gif(path: str | Path, gif_path: str | Path, *, fps: float = 10.0, every: int = 1,
               captions: bool = True, hold: float = 2.5) -> int:
    """Writes the top-down view of a replay as an animated GIF (Pillow); returns the frame count.

    With ``captions`` (the default) every frame carries a band above the picture naming each
    team's agents in the team's colour, and a band below with the step and, on the last frame,
    the outcome: the winner or a draw, and every team's score (see
    :mod:`arena_league.replay.captions`). The last frame stays ``hold`` seconds (at least one
    frame's time), so the outcome can be read before the GIF loops.
    """
    from PIL import Image

    from arena_league.replay.captions import MatchCaption

    if not fps > 0:
        raise ValueError(f"fps must be positive, not {fps!r}")
    if not hold >= 0:
        raise ValueError(f"hold must be a number of seconds >= 0, not {hold!r}")
    summary = read_replay(path)
    caption: MatchCaption | None = None
    frames = []
    for step, picture in _replayed(path, every, summary):
        if captions:
            if caption is None:
                caption = MatchCaption(picture.shape[1], summary.game_id, summary.seats, summary.teams,
                                       summary.steps, summary.scores, summary.outcomes)
            image = caption.draw(picture, step, final=step == summary.steps)
        else:
            image = Image.fromarray(picture)
        # a palette image per frame: a third of the memory of RGB, and what the GIF stores anyway
        frames.append(image.convert("P", palette=Image.Palette.ADAPTIVE))
    gif_path = Path(gif_path)
    gif_path.parent.mkdir(parents=True, exist_ok=True)
    duration = max(20, round(1000 / fps))
    durations = [duration] * (len(frames) - 1) + [max(duration, round(1000 * hold))]
    frames[0].save(gif_path, save_all=True, append_images=frames[1:], duration=durations, loop=0,
                   optimize=False)
    return len(frames)
