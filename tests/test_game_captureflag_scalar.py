"""CaptureFlag's one-board scalar engine (what the rules play) against the batched engine (the
reference): every step of many seeded matches alike, options and layouts varied."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs.core import Measures
from arena_league.envs.games.captureflag import CaptureFlagBoards, CaptureFlagRules
from arena_league.envs.games.captureflag.engine import match_key, write_measures

OPTIONS = [{}, {"rows": 7, "cols": 10, "wall_segments": 3, "respawn_delay": 1, "captures_to_win": 1},
           {"rows": 13, "cols": 24, "wall_segments": 14, "respawn_delay": 3, "captures_to_win": 2}]
MEASURES = ("active", "target_distance", "velocity_to_target", "object_progress", "outcome")


def reference_events(boards: CaptureFlagBoards, k: int) -> list[dict]:
    events = [{"kind": "tag", "seat": int(i)} for i in np.flatnonzero(boards.tagged[k])]
    events += [{"kind": "pickup", "seat": int(i)} for i in np.flatnonzero(boards.picked[k])]
    return events + [{"kind": "capture", "team": int(t)} for t in np.flatnonzero(boards.scored[k])]


def assert_alike(matches: list[CaptureFlagRules], boards: CaptureFlagBoards, measures: Measures,
                 rows: np.ndarray, scratch: CaptureFlagBoards) -> None:
    """The rules' matches ``rows`` equal those boards: state arrays (through ``scratch``, as many
    boards), observations, global states, measures, results."""
    for k in rows:
        matches[k]._board.store(scratch, k)
    for name in ("pos", "active", "respawn", "carrier", "captures", "held_steps", "t", "done", "tagged", "picked",
                 "scored", "target_distance", "toward_target", "flag_progress", "carrying", "flag_at"):
        assert np.array_equal(getattr(scratch, name)[rows], getattr(boards, name)[rows]), name
    assert np.array_equal(np.stack([matches[k].observe() for k in rows]), boards.observe()[rows])
    assert np.array_equal(np.stack([matches[k].state() for k in rows]), boards.state()[rows])
    for name in MEASURES:
        mine = np.stack([getattr(matches[k].measures, name) for k in rows])
        assert np.array_equal(mine, getattr(measures, name)[rows]), name
    assert [matches[k].game_over for k in rows] == boards.done[rows].tolist()
    assert np.array_equal(np.stack([matches[k].team_result() for k in rows]), boards.team_scores(rows))


@pytest.mark.parametrize("players", [1, 2])
def test_the_scalar_engine_plays_every_step_as_the_batched_one(players):
    """24 matches of each option set: one team plays the heuristic (mostly) and the other at random,
    or both a noisy heuristic, so tags, pick-ups, captures, respawns and the held-steps tie-break
    all come up; the matches still open after 100 steps are cut as at ``max_cycles``."""
    n_boards, n = 24, 2 * players
    seen = dict.fromkeys(("tag", "pickup", "capture", "respawn", "held_steps_decide", "win", "cut"), 0)
    for o, options in enumerate(OPTIONS):
        seeds = [1000 * o + 7 * k for k in range(n_boards)]
        boards = CaptureFlagBoards(n_boards, players, **options)
        boards.reset(keys=np.concatenate([match_key(s) for s in seeds]))
        measures = Measures.allocate(n, CaptureFlagRules.measures_provided, n_boards)
        write_measures(measures, boards, np.arange(n_boards), np.zeros(0, dtype=np.int64))
        matches = []
        for seed in seeds:
            rules = CaptureFlagRules(2, players, "discrete", **options)
            rules.reset(seed)
            matches.append(rules)
        rng = np.random.default_rng(o)
        kind = np.arange(n_boards) % 3  # 0: team 0 plays the heuristic, 1: team 1 does, 2: both, noisily
        heuristic_seat = (kind[:, None] == 2) | (boards.team_of[None, :] == kind[:, None])
        noise = np.where(kind == 2, 0.2, 0.05)[:, None]
        scratch = CaptureFlagBoards(n_boards, players, **options)
        assert_alike(matches, boards, measures, np.arange(n_boards), scratch)
        for _ in range(100):
            playing = np.flatnonzero(~boards.done)
            if not playing.size:
                break
            planned = CaptureFlagRules.heuristic(boards.observe().reshape(n_boards * n, -1), "discrete")
            random = rng.integers(5, size=(n_boards, n))
            use = heuristic_seat & (rng.random((n_boards, n)) >= noise)
            actions = np.where(use, planned.reshape(n_boards, n), random)
            was_active = boards.active.copy()
            boards.step(actions)
            ended = playing[boards.done[playing]]
            write_measures(measures, boards, playing, ended)
            for k in playing:
                rules = matches[k]
                rules.step(actions[k])
                assert rules.events() == reference_events(boards, k)
                for event in rules.events():
                    seen[event["kind"]] += 1
                seen["respawn"] += int((boards.active[k] & ~was_active[k]).sum())
                seen["win"] += int(boards.done[k])
            assert_alike(matches, boards, measures, playing, scratch)
        for k in np.flatnonzero(~boards.done):  # cut: the result decided by captures, then held steps
            rules = matches[k]
            rules.finish()
            write_measures(measures, boards, np.array([k]), np.array([k]))
            np.testing.assert_array_equal(rules.measures.outcome, measures.outcome[k])
            seen["cut"] += 1
            captures, held = boards.captures[k], boards.held_steps[k]
            seen["held_steps_decide"] += int(captures[0] == captures[1] and held[0] != held[1])
    assert all(seen.values()), seen


def test_a_tool_holding_the_engine_edits_the_match_and_sees_every_step():
    rules = CaptureFlagRules(2, 2, "discrete", respawn_delay=2)
    rules.reset(3)
    boards = CaptureFlagBoards(1, 2, respawn_delay=2)
    boards.reset(keys=match_key(3))
    rng = np.random.default_rng(5)
    for step in range(60):
        if step == 20:
            engine = rules.engine  # from now on the engine is the match between steps
            for edited in (engine, boards):
                edited.carrier[0, 1] = 1  # seat 1 suddenly carries team 1's flag
                edited.pos[0, 1] = edited.stands[0]
        actions = rng.integers(5, size=(1, 4))
        if step == 20:
            actions[0, 1] = 0  # it stays there: its flag is home, so it scores
        boards.step(actions)
        rules.step(actions[0])
        if step >= 20:
            np.testing.assert_array_equal(engine.pos, boards.pos)
            np.testing.assert_array_equal(engine.captures, boards.captures)
        np.testing.assert_array_equal(rules.observe(), boards.observe()[0])
        if rules.game_over:
            break
    assert boards.captures[0, 0] >= 1  # the edit counted: seat 1 scored on its own stand
