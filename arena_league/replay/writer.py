"""Recording a match as one MCAP file (https://mcap.dev), as the match engine plays it.

One file per match (per half of a pair: :func:`replay_file_name`), named
``<game_id>-m<match_id>-s<league_seed>.mcap``, written to a ``.part``
file and renamed when the match ends, so a crashed worker never leaves a file that looks whole; a
match that fails instead (an error while opening the file, in a policy or the env during a step, or
while finishing the file) leaves no file at all: the engine calls :meth:`MatchRecorder.abort`, and a
recorder whose own opening or closing fails removes its ``.part`` file itself.

Every message is JSON (``json`` message encoding, ``jsonschema`` schemas from
:mod:`arena_league.replay.schemas`); log times are ``step * STEP_NS``:

=================  =====================================================  ========================
topic              one message                                            at steps
=================  =====================================================  ========================
``/match``         game, match id, league seed, env seed, seats, teams,   0
                   env options (everything needed to replay it)
``/observations``  every seat's observation                               0 .. T
``/actions``       every seat's action, and which seats acted             0 .. T - 1
``/rewards``       every seat's social-tree reward                        1 .. T
``/events``        one rules event (``{"kind": ...}``)                    when the rules report one
``/scene``         ``foxglove.SceneUpdate``: the top-down scene           0 .. T
``/result``        per-seat scores and outcomes, steps                    T
=================  =====================================================  ========================

The file also carries two MCAP metadata records, ``arena_league.match`` and
``arena_league.result``, with the same content as string values (for tools that list metadata).
"""

from __future__ import annotations

import contextlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from mcap.writer import Writer

from arena_league.matchmaking.specs import MatchResult, MatchSpec
from arena_league.replay.scenes import scene_update
from arena_league.replay.schemas import CHANNEL_SCHEMAS, SCENE_SCHEMA_NAME, TOPICS, scene_update_schema

__all__ = ["FORMAT_VERSION", "PROFILE", "STEP_NS", "MatchRecorder", "ReplayRecording", "replay_file_name"]

#: Nanoseconds of log time per env step (0.1 s: the physics step of the pymunk games).
STEP_NS = 100_000_000
FORMAT_VERSION = 1
#: The MCAP profile string of arena-league replays.
PROFILE = "arena-league"


def replay_file_name(spec: MatchSpec) -> str:
    """The file name of the replay of ``spec`` (a pair's halves: ``...-h0.mcap`` and ``...-h1.mcap``)."""
    half = "" if spec.half is None else f"-h{spec.half}"
    return f"{spec.game_id}-m{spec.match_id}-s{spec.league_seed}{half}.mcap"


def _dumps(message: dict[str, Any]) -> bytes:
    return json.dumps(message, separators=(",", ":"), allow_nan=False).encode()


@dataclass(frozen=True)
class ReplayRecording:
    """Records every match into ``directory``, one MCAP file each: give it to the match engine as
    ``play_matches(specs, agents, recording=ReplayRecording("replays/"))``. Pickles, so process-pool
    and Ray workers write their matches' replays themselves."""

    directory: str | Path
    record_observations: bool = True

    def __call__(self, spec: MatchSpec, env: Any, env_kwargs: dict[str, Any]) -> MatchRecorder:
        return MatchRecorder.open(self.directory, spec, env, env_kwargs, self.record_observations)


class MatchRecorder:
    """Writes one match's replay while it is played.

    The engine calls :meth:`open` just after the env's reset, :meth:`before_step` with each step's
    actions, :meth:`after_step` with its rewards, and :meth:`close` with the result, or
    :meth:`abort` when the match does not reach its end.
    """

    def __init__(self, path: Path, spec: MatchSpec, env: Any, env_kwargs: dict[str, Any],
                 record_observations: bool = True) -> None:
        try:
            json.dumps(env_kwargs)
        except TypeError as error:
            raise ValueError(f"env_kwargs must be JSON-serialisable to be recorded in a replay ({error}); pass "
                             "the social tree as a dict, not a SocialTree object") from error
        self.path = Path(path)
        self.spec = spec
        self.env = env
        self.record_observations = record_observations
        self._part = self.path.with_name(self.path.name + ".part")
        self._stream = open(self._part, "wb")  # noqa: SIM115 - held open until close() or abort()
        try:
            self._start(env_kwargs)
        except BaseException:
            self.abort()
            raise

    def _start(self, env_kwargs: dict[str, Any]) -> None:
        """Writes the header, the channels, the match record and the state at reset."""
        spec, env = self.spec, self.env
        self._writer = Writer(self._stream)
        self._writer.start(profile=PROFILE, library="arena-league")
        self._channels: dict[str, int] = {}
        for name, schema in CHANNEL_SCHEMAS.items():
            schema_id = self._writer.register_schema(schema["title"], "jsonschema", json.dumps(schema).encode())
            self._channels[name] = self._writer.register_channel(TOPICS[name], "json", schema_id)
        scene_id = self._writer.register_schema(SCENE_SCHEMA_NAME, "jsonschema",
                                                json.dumps(scene_update_schema()).encode())
        self._channels["scene"] = self._writer.register_channel(TOPICS["scene"], "json", scene_id)
        self._sequence = 0
        self._step = 0
        self._match = {
            "format_version": FORMAT_VERSION, "match_id": spec.match_id, "game_id": spec.game_id,
            "league_seed": spec.league_seed, "seed": spec.seed, "seats": list(spec.seats),
            "teams": [int(t) for t in env.rules.team_of], "env_kwargs": dict(env_kwargs),
        }
        if spec.half is not None:
            self._match["half"] = spec.half
        self._write("match", self._match)
        self._writer.add_metadata("arena_league.match", {k: json.dumps(v) for k, v in self._match.items()})
        self._record_state(env.last_obs)

    @classmethod
    def open(cls, record_dir: str | Path, spec: MatchSpec, env: Any, env_kwargs: dict[str, Any],
             record_observations: bool = True) -> MatchRecorder:
        """Starts the replay of ``spec`` in ``record_dir`` (created if missing); ``env`` has just been
        reset with ``spec.seed``."""
        directory = Path(record_dir)
        directory.mkdir(parents=True, exist_ok=True)
        return cls(directory / replay_file_name(spec), spec, env, env_kwargs, record_observations)

    def _write(self, channel: str, message: dict[str, Any], step: int | None = None) -> None:
        time = (self._step if step is None else step) * STEP_NS
        self._writer.add_message(self._channels[channel], log_time=time, data=_dumps(message),
                                 publish_time=time, sequence=self._sequence)
        self._sequence += 1

    def _record_state(self, obs: np.ndarray) -> None:
        if self.record_observations:
            self._write("observations", {"step": self._step, "obs": np.asarray(obs, dtype=np.float64).tolist()})
        self._write("scene", scene_update(self.env.rules, self._step * STEP_NS))

    def before_step(self, obs: np.ndarray, actions: np.ndarray, acting: np.ndarray | None = None) -> None:
        """Records the actions every seat sends at the current step."""
        message: dict[str, Any] = {"step": self._step, "actions": np.asarray(actions).tolist()}
        if acting is not None:
            message["acting"] = [bool(a) for a in acting]
        self._write("actions", message)

    def after_step(self, rewards: np.ndarray) -> None:
        """Records the step's rewards, events, observations and scene."""
        self._step += 1
        self._write("rewards", {"step": self._step, "rewards": np.asarray(rewards, dtype=np.float64).tolist()})
        for raw in self.env.rules.events():
            event = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in dict(raw).items()}
            self._write("events", {"step": self._step, "kind": str(event.get("kind", "")), "event": event})
        self._record_state(self.env.last_obs)

    def close(self, result: MatchResult) -> Path:
        """Writes the result, finishes the file and returns its path. If any of it fails, the
        unfinished file is removed (as by :meth:`abort`) and the error raised."""
        try:
            summary = {"steps": result.steps, "scores": list(result.scores), "outcomes": list(result.outcomes),
                       "positions": None if result.positions is None else list(result.positions)}
            if result.points:
                summary["points"] = list(result.points)
            self._write("result", summary)
            self._writer.add_metadata("arena_league.result", {k: json.dumps(v) for k, v in summary.items()})
            self._writer.finish()
            self._stream.close()
            os.replace(self._part, self.path)
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Drops an unfinished replay (the match was not played to its end, or its file could not be
        written): the ``.part`` file is removed, and no replay file is left. Harmless after
        :meth:`close`, which leaves nothing to drop."""
        try:
            # a buffer that cannot be flushed belongs to a file about to be removed
            with contextlib.suppress(OSError):
                self._stream.close()
        finally:
            self._part.unlink(missing_ok=True)
