"""Boomer's one-board engine (what ``BoomerRules`` plays) against the batched engine, the reference:
the same maps from the same keys, and step by step the same cells, seats, flags, observations, global
states, team scores and ends, over seeded random and heuristic matches of every layout and of
non-default options (chain reactions, kicks, power-ups and simultaneous deaths all happen), on
set-up positions, and through the rules' measures, events and results."""

from __future__ import annotations

import copy
from collections import Counter

import numpy as np
import pytest

from arena_league.envs import make
from arena_league.envs.games.boomer import QUARTER_TURNS, BoomerRules
from arena_league.envs.games.boomer.board import BoomerBoard
from arena_league.envs.games.boomer.boards import BoomerBoards
from arena_league.envs.games.boomer.heuristic import heuristic_actions

STOP, UP, DOWN, LEFT, RIGHT, BOMB = range(6)
ARRAYS = ("terrain", "hidden", "flame", "bomb_timer", "bomb_strength", "bomb_owner", "bomb_direction", "position",
          "alive", "ammo", "strength", "can_kick", "death_step", "picked", "died", "laid", "kicked", "t", "done",
          "truncated")
TEAM_2T2P = {"team_of": [0, 0, 1, 1], "quarter_turns": list(QUARTER_TURNS[(2, 2)])}
# (seats, options, seed, what the seeded matches must show): every layout at the defaults, then smaller,
# larger and item-rich boards; all show power-ups taken and bombs set off early by a blast or a flame
MATCHES = [
    (2, {}, 2, ()),
    (4, TEAM_2T2P, 0, ("kick", "deaths on one step")),
    (4, {}, 0, ("kick", "deaths on one step")),
    (2, {"size": 9, "n_rigid": 16, "n_wood": 24, "n_items": 24, "blast_strength": 4}, 1, ()),
    (4, {"size": 13, "n_rigid": 40, "n_wood": 60, "n_items": 60, "blast_strength": 3}, 0, ("kick", "deaths on one step")),
    (2, {"size": 8, "n_rigid": 16, "n_wood": 16, "n_items": 8, "max_steps": 40}, 1, ("truncated",)),
]


def _assert_same(one: BoomerBoard, boards: BoomerBoards, b: int) -> None:
    for name in ARRAYS:
        assert np.array_equal(getattr(one, name)[0], getattr(boards, name)[b]), name
    assert np.array_equal(one.team_scores(), boards.team_scores([b]))
    assert np.array_equal(one.final_scores, boards.final_scores[b:b + 1], equal_nan=True)


def _lockstep(seats: int, options: dict, seed: int, n_boards: int = 8, steps: int = 160) -> Counter:
    """Play ``n_boards`` matches on both engines (heuristic moves, a third of them random); return what happened."""
    rng = np.random.default_rng(seed)
    batched = BoomerBoards(n_boards, seats, **options)
    keys = rng.integers(0, 2**64, size=n_boards, dtype=np.uint64)
    batched.reset(keys=keys)
    ones = [BoomerBoard(seats, **options) for _ in range(n_boards)]
    for b, one in enumerate(ones):
        one.reset(keys=keys[b:b + 1])
    seen: Counter = Counter()
    for _ in range(steps):
        obs, state = batched.observe(), batched.state()
        for b, one in enumerate(ones):
            assert np.array_equal(one.observe()[0], obs[b]) and np.array_equal(one.state()[0], state[b])
        if batched.done.all():
            break
        actions = heuristic_actions(obs.reshape(n_boards * seats, -1)).reshape(n_boards, seats)
        actions = np.where(rng.random(actions.shape) < 1 / 3, rng.integers(6, size=actions.shape), actions)
        bombs, due = (batched.bomb_timer > 0).sum(axis=1), (batched.bomb_timer == 1).sum(axis=1)
        live = ~batched.done
        batched.step(actions)
        for b, one in enumerate(ones):
            one.step(actions[b:b + 1])  # a finished match only clears its step's flags, as the batched engine's
            _assert_same(one, batched, b)
        gone = bombs + batched.laid.sum(axis=1) - (batched.bomb_timer > 0).sum(axis=1)
        seen["early explosion"] += int((live & (gone > due)).sum())  # set off by a blast or a flame
        seen["kick"] += int(batched.kicked.sum())
        seen["power-up"] += int(batched.picked.sum())
        seen["deaths on one step"] += int((batched.died.sum(axis=1) >= 2).sum())
        seen["truncated"] += int(batched.truncated.sum())
    return seen


@pytest.mark.parametrize(("seats", "options", "seed", "expected"), MATCHES)
def test_the_one_board_engine_plays_every_match_as_the_batched_engine(seats, options, seed, expected):
    seen = _lockstep(seats, options, seed)
    for what in ("power-up", "early explosion", *expected):
        assert seen[what], what


@pytest.mark.parametrize(("seats", "options"), [(2, {}), (4, {"size": 13, "n_rigid": 40, "n_wood": 60,
                                                                "n_items": 60}), (2, {"size": 7, "n_items": 0,
                                                                                       "n_rigid": 0, "n_wood": 4})])
def test_the_same_key_draws_the_same_map(seats, options):
    keys = np.random.default_rng(5).integers(0, 2**64, size=150, dtype=np.uint64)
    batched = BoomerBoards(len(keys), seats, **options)
    batched.reset(keys=keys)  # most keys need more than one draw of rigid walls, some more than four
    one = BoomerBoard(seats, **options)
    for b in range(len(keys)):
        one.reset(keys=keys[b:b + 1])
        assert np.array_equal(one.terrain[0], batched.terrain[b]) and np.array_equal(one.hidden[0], batched.hidden[b])


def test_a_set_up_kick_into_flames_chain_and_double_death_play_alike():
    batched = BoomerBoards(1, 4, size=7, n_rigid=0, n_wood=0, n_items=0, quarter_turns=[0, 0, 0, 0])
    batched.set_board(0, ["....2..",
                          ".......",
                          "......1",
                          "0......",
                          ".......",
                          ".....3.",
                          "......."])
    batched.can_kick[0, 0] = True
    batched.lay_bomb(0, 22, owner=0, timer=9)  # (3, 1): seat 0 kicks it right, toward (3, 4)
    batched.lay_bomb(0, 11, owner=1, timer=2, strength=3)  # (1, 4): its blast burns (3, 4) and reaches (1, 6)
    batched.lay_bomb(0, 13, owner=2, timer=9)  # (1, 6): set off by the first, it burns seat 1 at (2, 6)
    one = BoomerBoard(4, size=7, n_rigid=0, n_wood=0, n_items=0, quarter_turns=[0, 0, 0, 0])
    one.load(batched)
    for k in range(6):
        actions = np.array([[RIGHT if k == 0 else STOP, STOP, STOP, STOP]])
        batched.step(actions)
        one.step(actions)
        _assert_same(one, batched, 0)
        assert np.array_equal(one.observe(), batched.observe()) and np.array_equal(one.state(), batched.state())
        if k == 0:
            assert batched.kicked[0, 0]
        if k == 1:  # the chain: both bombs go off, seats 1 and 2 die on the same step
            assert batched.died[0].tolist() == [False, True, True, False] and (batched.bomb_timer[0] > 0).sum() == 1
        if k == 2:  # the kicked bomb slides into the flames and goes off at once
            assert batched.bomb_timer[0].max() == 0


def test_the_rules_measures_events_and_results_follow_the_batched_engine():
    for (teams, per_team), seed in (((2, 1), 3), ((2, 2), 4), ((4, 1), 5)):
        env = make(f"Boomer-{teams}T{per_team}P-v1", max_cycles=60)
        rules = env.rules
        batched = BoomerBoards(1, teams * per_team, team_of=rules.team_of, quarter_turns=QUARTER_TURNS[(teams,
                                                                                                         per_team)])
        rng = np.random.default_rng(seed)
        for episode in range(3):
            obs, _ = env.reset(seed=seed * 10 + episode)
            batched.reset(keys=rules.engine.keys)
            ended = False
            while not ended:
                actions = heuristic_actions(np.stack([obs[a] for a in env.possible_agents]))
                actions = np.where(rng.random(len(actions)) < 0.2, rng.integers(6, size=len(actions)), actions)
                obs, _, terminated, truncated, _ = env.step(dict(zip(env.possible_agents, actions.tolist(), strict=True)))
                batched.step(actions[None])
                assert np.array_equal(rules.measures.alive, batched.alive[0])
                assert np.array_equal(rules.measures.resource_gain, batched.picked[0])
                assert rules.events() == [{"kind": kind, "seat": int(s)} for kind, flags in (
                    ("laid_a_bomb", batched.laid), ("kicked_a_bomb", batched.kicked),
                    ("took_a_power_up", batched.picked), ("death", batched.died)) for s in np.flatnonzero(flags[0])]
                assert np.array_equal(obs["player_0"], batched.observe()[0, 0])
                ended = terminated["player_0"] or truncated["player_0"]
                assert terminated["player_0"] == bool(batched.done[0])
            assert np.array_equal(env.team_result(), batched.team_scores()[0])
            scores = batched.team_scores()[0][rules.team_of]
            assert np.array_equal(rules.measures.outcome, 2.0 * scores / (teams - 1) - 1.0)


def test_a_copy_of_the_one_board_engine_goes_on_as_the_original():
    rules = BoomerRules(2, 2, "discrete")
    rules.reset(7)
    rng = np.random.default_rng(1)
    for _ in range(12):
        rules.step(rng.integers(6, size=4))
    twin = copy.deepcopy(rules.engine)
    for _ in range(12):
        actions = rng.integers(6, size=(1, 4))
        twin.step(actions)
        rules.engine.step(actions)
        assert np.array_equal(twin.observe(), rules.engine.observe())
        assert np.array_equal(twin.state(), rules.engine.state())
    with pytest.raises(ValueError, match="integer actions of shape"):
        twin.step(np.zeros((2, 4), dtype=np.int64))
