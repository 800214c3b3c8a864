"""BlowBlow: falling off the platform, blows (their cone, shielding, recoil and cooldown), the end when a
team has no agent left and the results of cut matches, shoving, headings, the seat frames' rotational
symmetry, the observation cell by cell, bounds, measures, determinism and copies, the heuristic
against random play, layouts and game kwargs, the default tree and its verification, the picture,
the controls and the replay scene."""

from __future__ import annotations

import copy
import math
import pickle

import numpy as np
import pytest
from physics2d_matches import assert_replays_bit_for_bit, heuristic_against_random, play, trace

from arena_league.envs import make
from arena_league.envs.games.blowblow import (
    AGENT_RADIUS,
    BLOW_COOLDOWN,
    BLOW_IMPULSE,
    BLOW_RANGE,
    DT,
    SPACE_DAMPING,
    VELOCITY_BOUND,
    VELOCITY_UNIT,
    BlowBlowControls,
    BlowBlowRules,
)
from arena_league.envs.rendering import TEAM_COLOURS

NOOP, E, N, W, S, BLOW = 0, 1, 3, 5, 7, 9  # discrete actions in the seat frame
R = 3.0  # the default platform radius
LAYOUTS = [(2, 1), (2, 2)]


def rules(teams: int = 2, players: int = 1, action_type: str = "discrete", seed: int = 0, **kwargs) -> BlowBlowRules:
    r = BlowBlowRules(teams, players, action_type, **kwargs)
    r.reset(seed)
    return r


def still(r: BlowBlowRules) -> np.ndarray:
    return np.zeros(r.n_agents, dtype=np.int64)


def positions(r: BlowBlowRules) -> np.ndarray:
    return r.agents()[0]


def velocities(r: BlowBlowRules) -> np.ndarray:
    return r.agents()[1]


# --- falling and the end of the match -------------------------------------------------------------
def test_an_agent_whose_centre_leaves_the_platform_falls_and_its_team_loses():
    r = rules()
    r.place([(-R + 0.05, 0.0), (1.0, 0.0)], [(-1.0, 0.0), (0.0, 0.0)])
    r.step(still(r))
    assert r.events() == [{"kind": "fall", "seat": 0}]
    assert r.on_platform.tolist() == [False, True]
    assert r.measures.active.tolist() == [False, True] and r.measures.alive.tolist() == [False, True]
    assert r.game_over and r.team_result().tolist() == [0.0, 1.0]
    assert r.measures.outcome.tolist() == [-1.0, 1.0]
    assert np.linalg.norm(positions(r)[0]) > R
    assert not r.observe()[0].any(), "a seat that fell sees nothing"
    assert r.observe()[1, 9] == 0.0 and r.observe()[1, 0] == 1.0  # and is not seen


def test_an_agent_just_inside_the_edge_stays_on():
    r = rules()
    r.place([(-R + 0.02, 0.0), (1.0, 0.0)])
    for _ in range(5):
        r.step(np.array([E, NOOP]))
    assert r.on_platform.all() and not r.game_over and r.events() == []


def test_a_fallen_agent_is_still_out_of_play_while_its_teammate_fights_on():
    r = rules(2, 2)
    r.place([(-R + 0.05, 0.0), (-1.0, -1.0), (1.0, 1.0), (1.5, -1.0)], [(-1.0, 0.0), (0, 0), (0, 0), (0, 0)])
    r.step(still(r))
    assert r.events() == [{"kind": "fall", "seat": 0}] and not r.game_over
    where = positions(r)[0].copy()
    kept = r.measures.target_distance[0]
    for _ in range(10):
        r.step(np.array([W, NOOP, W, W]))  # the seat that fell ignores its action
    assert np.array_equal(positions(r)[0], where) and velocities(r)[0].tolist() == [0.0, 0.0]
    assert r.measures.target_distance[0] == kept and r.measures.speed[0] == 0.0 and r.measures.energy[0] == 0.0
    assert not r.observe()[0].any()
    # every other seat sees it as gone: its block is the teammate's first, the opponents' second
    assert not r.observe()[1, 9:17].any() and not r.observe()[2, 17:25].any() and not r.observe()[3, 17:25].any()
    assert r.observe()[2, 25] == 1.0 and r.state()[0:8].tolist() == [0.0] * 8
    r.place([(-2.0, 0.0), (-1.0, -1.0), (1.0, 1.0), (1.5, -1.0)])
    assert np.array_equal(positions(r)[0], where), "place ignores the seats that fell"


def test_each_seat_targets_the_opponent_across_and_then_the_one_left():
    r = rules(2, 2)
    # seats 0 and 3 start across from each other, as do seats 1 and 2
    r.place([(-1.0, 0.5), (-1.0, -1.5), (0.5, -1.0), (R - 0.05, 0.0)], [(0, 0), (0, 0), (0, 0), (1.0, 0.0)])
    xy = positions(r)
    mates = {0: 3, 1: 2, 2: 1, 3: 0}
    for seat, marked in mates.items():
        assert r.measures.target_distance[seat] == pytest.approx(np.linalg.norm(xy[marked] - xy[seat]))
    r.step(still(r))
    assert r.events() == [{"kind": "fall", "seat": 3}]
    xy = positions(r)
    # on the step of the fall the target is still the one it marked, where it fell
    assert r.measures.target_distance[0] == pytest.approx(np.linalg.norm(xy[3] - xy[0]))
    kept = r.measures.target_distance[3], r.measures.facing_target[3]
    r.step(still(r))
    xy = positions(r)
    assert r.measures.target_distance[0] == pytest.approx(np.linalg.norm(xy[2] - xy[0])), "now the one left"
    assert r.measures.target_distance[1] == pytest.approx(np.linalg.norm(xy[2] - xy[1]))
    assert r.measures.target_distance[2] == pytest.approx(np.linalg.norm(xy[1] - xy[2]))
    assert (r.measures.target_distance[3], r.measures.facing_target[3]) == kept, "the seat that fell keeps its own"


def test_the_last_agents_of_both_teams_falling_together_is_a_draw():
    r = rules()
    r.place([(-R + 0.05, 0.0), (R - 0.05, 0.0)], [(-1.0, 0.0), (1.0, 0.0)])
    r.step(still(r))
    assert r.game_over and sorted(e["seat"] for e in r.events()) == [0, 1]
    assert r.team_result().tolist() == [0.5, 0.5] and r.measures.outcome.tolist() == [0.0, 0.0]


def test_the_env_ends_when_a_team_has_no_agent_left():
    env = make("BlowBlow-2T2P-v1")
    env.reset(seed=0)
    r = env.rules
    r.place([(-1.0, 0.5), (-1.0, -0.5), (R - 0.05, 0.2), (R - 0.05, -0.2)], [(0, 0), (0, 0), (1.0, 0.0), (1.0, 0.0)])
    _, _, terminations, truncations, _ = env.step(dict.fromkeys(env.agents, NOOP))
    assert all(terminations.values()) and not any(truncations.values()) and env.agents == []
    assert r.team_result().tolist() == [1.0, 0.0]


def test_a_cut_match_goes_to_the_team_with_more_agents_on_then_to_the_one_nearer_the_centre():
    r = rules(2, 2)
    r.place([(-R + 0.05, 0.0), (-2.0, -1.0), (2.0, 1.0), (2.0, -1.0)], [(-1.0, 0.0), (0, 0), (0, 0), (0, 0)])
    r.step(still(r))
    assert not r.game_over
    play(r, still, max_cycles=1)  # the cut: one agent against two
    assert r.team_result().tolist() == [0.0, 1.0] and r.measures.outcome.tolist() == [-1.0, -1.0, 1.0, 1.0]

    r = rules()
    r.place([(-1.0, 0.0), (0.0, 1.8)])
    play(r, still, max_cycles=2)
    assert not r.game_over and r.team_result().tolist() == [1.0, 0.0], "as many on: the one nearer the centre"
    assert r.measures.outcome.tolist() == [1.0, -1.0]


def test_a_cut_mirrored_match_is_a_draw():
    env = make("BlowBlow-2T1P-v1", max_cycles=40)
    env.reset(seed=3)
    for _ in range(40):
        obs = np.stack([env.last_obs[i] for i in range(2)])
        actions = BlowBlowRules.heuristic(obs, "discrete")
        _, _, terminations, truncations, _ = env.step({"player_0": actions[0], "player_1": actions[1]})
    assert all(truncations.values()) and not any(terminations.values())
    assert env.rules.team_result().tolist() == [0.5, 0.5] and env.rules.measures.outcome.tolist() == [0.0, 0.0]


# --- blowing --------------------------------------------------------------------------------------
def test_a_blow_pushes_the_opponent_in_front_away_and_the_blower_back():
    r = rules()
    r.place([(-1.0, 0.0), (0.0, 0.0)])
    r.step(np.array([BLOW, NOOP]))  # along the heading kept: east, at seat 1, 1 apart
    assert r.events() == [{"kind": "blow", "seat": 0, "target": 1}]
    caught = BLOW_IMPULSE * (1.0 - 1.0 / BLOW_RANGE)  # the share 1 - d / range of the puff
    np.testing.assert_allclose(velocities(r), [(-BLOW_IMPULSE, 0.0), (caught, 0.0)], atol=1e-9)
    assert r.measures.force.tolist() == pytest.approx([0.0, 0.0], abs=1e-9), "a blow's impulses are no contacts"
    before = positions(r)[1, 0]
    for _ in range(10):
        r.step(still(r))
    assert positions(r)[1, 0] - before > 0.2, "the opponent slid on"


def test_a_blow_reaches_only_the_cone_in_front_within_range():
    r = rules()
    for where, hit in (((0.5, 0.0), 1), ((1.4, 0.0), 1), ((-1.0 + BLOW_RANGE + 0.05, 0.0), None),
                       ((0.0, 0.55), 1), ((0.0, 0.62), None), ((-2.0, 0.0), None)):
        r.reset(0)
        r.place([(-1.0, 0.0), where])
        r.step(np.array([BLOW, NOOP]))
        assert r.events() == [{"kind": "blow", "seat": 0, "target": hit}], where  # 30 degrees: tan = 0.577
        assert velocities(r)[0, 0] == pytest.approx(-BLOW_IMPULSE)


def test_the_nearest_agent_in_the_cone_shields_the_one_behind_and_teammates_are_pushed_too():
    r = rules(2, 2)
    r.place([(-1.0, 0.0), (-0.4, 0.05), (0.5, 0.0), (2.0, 2.0)])
    r.step(np.array([BLOW, NOOP, NOOP, NOOP]))  # the teammate stands in front of the opponent
    assert r.events() == [{"kind": "blow", "seat": 0, "target": 1}]
    assert velocities(r)[1, 0] > 0.5 and abs(velocities(r)[2, 0]) < 1e-9


def test_a_blow_goes_along_the_heading_the_last_move_set_and_noop_keeps_it():
    r = rules(start_jitter=0.0)
    r.place([(0.0, 0.0), (0.0, 1.2)])
    r.step(np.array([N, NOOP]))  # face north
    r.step(np.array([BLOW, NOOP]))  # no thrust, and at seat 1
    assert r.events() == [{"kind": "blow", "seat": 0, "target": 1}] and r.measures.energy[0] == 0.0
    np.testing.assert_allclose(r.agents()[2], [(0.0, 1.0), (-1.0, 0.0)], atol=1e-12)  # seat 1 faces -x from the start
    r.step(still(r))
    np.testing.assert_allclose(r.agents()[2], [(0.0, 1.0), (-1.0, 0.0)], atol=1e-12)


def test_blowing_waits_for_the_cooldown():
    r = rules()
    r.place([(-1.0, 0.0), (1.0, 0.0)])
    blown = []
    for step in range(2 * BLOW_COOLDOWN + 2):
        r.step(np.array([BLOW, NOOP]))
        blown += [step for e in r.events() if e["kind"] == "blow"]
        if step == 0:
            cool = (BLOW_COOLDOWN - 1) / BLOW_COOLDOWN
            assert r.cooldown().tolist() == [BLOW_COOLDOWN - 1, 0] and r.observe()[0, 8] == pytest.approx(cool)
            assert r.observe()[1, 9 + 7] == pytest.approx(cool), "the opponent sees the cooldown too"
    assert blown == [0, BLOW_COOLDOWN, 2 * BLOW_COOLDOWN]
    assert r.cooldown().tolist() == [BLOW_COOLDOWN - 2, 0]
    assert r.observe()[0, 8] == pytest.approx((BLOW_COOLDOWN - 2) / BLOW_COOLDOWN)


def test_a_seat_that_fell_cannot_blow_nor_be_blown():
    r = rules(2, 2)
    r.place([(-R + 0.05, 0.0), (-1.0, 1.0), (0.0, 1.0), (2.0, -2.0)], [(-1.0, 0.0), (0, 0), (0, 0), (0, 0)])
    r.step(still(r))
    r.place([(0.0, 0.0), (-1.0, 1.0), (-1.0, 0.2), (2.0, -2.0)], heading=[0.0, 0.0, math.pi, 0.0])
    r.step(np.array([BLOW, NOOP, BLOW, NOOP]))  # seat 2 blows west at where seat 0 fell
    assert r.events() == [{"kind": "blow", "seat": 2, "target": None}]


def test_continuous_blows_when_its_third_cell_is_positive_and_a_small_thrust_keeps_the_heading():
    r = rules(action_type="continuous")
    r.place([(-1.0, 0.0), (0.0, 0.0)])
    r.step(np.array([[0.05, 0.05, -0.2], [0.0, 0.0, 0.0]], dtype=np.float32))
    assert r.events() == [] and r.agents()[2][0].tolist() == [1.0, 0.0]
    r.step(np.array([[0.3, 0.0, 0.01], [0.0, 0.0, 1.0]], dtype=np.float32))  # each blows at the other
    assert r.events() == [{"kind": "blow", "seat": 0, "target": 1}, {"kind": "blow", "seat": 1, "target": 0}]
    assert r.measures.energy.tolist() == pytest.approx([0.09, 0.0])
    r.step(np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0]], dtype=np.float32))
    np.testing.assert_allclose(r.agents()[2], [(0.0, 1.0), (-(0.5**0.5), -(0.5**0.5))], atol=1e-6)
    assert r.measures.energy.tolist() == pytest.approx([1.0, 1.0])  # scaled back to length 1


# --- bodies ---------------------------------------------------------------------------------------
def test_an_agent_shoves_a_rival_standing_still_and_feels_the_contact():
    r = rules()
    r.place([(-1.0, 0.0), (-1.0 + 2 * AGENT_RADIUS + 0.05, 0.0)])
    start = positions(r)[1]
    forces = []
    for _ in range(15):
        r.step(np.array([E, NOOP]))
        forces.append(r.measures.force.copy())
    moved = positions(r)[1] - start
    assert moved[0] > 1.0 and abs(moved[1]) < 0.05
    assert max(f[0] for f in forces) > 1.0 and max(f[1] for f in forces) > 1.0


def test_two_agents_pushing_head_on_hold_each_other():
    r = rules()
    r.place([(-0.3, 0.0), (0.3, 0.0)])
    for _ in range(20):
        r.step(np.array([E, E]))  # team 1's E is -x: both push toward each other
    xy = positions(r)
    assert np.abs(xy[:, 0]).max() < AGENT_RADIUS + 0.05 and np.abs(xy[:, 1]).max() < 1e-6


def test_a_standing_agent_slows_with_damping_alone():
    r = rules()
    r.place([(0.0, 0.0), (0.0, 2.0)], [(1.0, 0.0), (0.0, 0.0)])
    r.step(still(r))
    keep = SPACE_DAMPING**DT - 2.0 * DT  # damping, and the drag of 2 * velocity
    assert velocities(r)[0, 0] == pytest.approx(keep)


# --- the start, symmetry and the seat frames --------------------------------------------------------
@pytest.mark.parametrize("teams, players", LAYOUTS)
def test_every_match_starts_half_turned_and_each_seat_sees_what_its_counterpart_sees(teams, players):
    for seed in range(6):
        r = rules(teams, players, seed=seed)
        xy = positions(r)
        np.testing.assert_array_equal(xy[players:], -xy[:players])
        assert (xy[:players, 0] < 0).all() and np.abs(xy[:players, 0] + 0.45 * R).max() <= 0.3 + 1e-12
        np.testing.assert_array_equal(r.agents()[2], np.repeat([(1.0, 0.0), (-1.0, 0.0)], players, axis=0))
        obs = r.observe()
        np.testing.assert_allclose(obs[players:], obs[:players], atol=1e-6)
        actions = BlowBlowRules.heuristic(obs, "discrete")
        assert (actions[players:] == actions[:players]).all()


def test_mirrored_play_stays_mirrored():
    r = rules(2, 2, seed=4)
    rng = np.random.default_rng(0)
    for _ in range(60):
        team0 = rng.integers(0, 10, 2)
        r.step(np.concatenate([team0, team0]))  # the same actions in each seat frame
        obs = r.observe()
        np.testing.assert_allclose(obs[2:], obs[:2], atol=1e-5)
        if r.game_over:
            assert r.team_result().tolist() == [0.5, 0.5]
            break


def test_start_jitter_zero_puts_agents_on_their_spots():
    r = rules(2, 2, start_jitter=0.0)
    np.testing.assert_allclose(positions(r), [(-1.35, 0.75), (-1.35, -0.75), (1.35, -0.75), (1.35, 0.75)])
    r = rules(2, 1, start_jitter=0.0, platform_radius=2.0)
    np.testing.assert_allclose(positions(r), [(-0.9, 0.0), (0.9, 0.0)])
    assert not np.allclose(positions(rules(seed=0)), positions(rules(seed=1)))


def test_observation_layout_cell_by_cell():
    r = rules(2, 2)
    r.step(np.array([NOOP, BLOW, NOOP, NOOP]))  # seat 1 blows: its cooldown is 3 steps from now
    pos = np.array([[-1.5, 0.3], [-0.6, -1.2], [1.2, 0.9], [2.1, -0.3]])
    vel = np.array([[0.6, 0.0], [0.0, 0.0], [0.0, -0.9], [0.3, 0.3]])
    r.place(pos, vel, heading=[0.0, math.pi / 2, math.pi, -math.pi / 2])
    obs = r.observe()
    assert obs.dtype == np.float32 and obs.shape == (4, r.obs_dim) == (4, 33)
    ps, vs = 1.0 / R, 1.0 / VELOCITY_UNIT
    cool = (BLOW_COOLDOWN - 1) / BLOW_COOLDOWN
    np.testing.assert_allclose(obs[0], [
        1.0, R / 4, -1.5 * ps, 0.3 * ps, 0.6 * vs, 0.0, 1.0, 0.0, 0.0,  # own
        1.0, 0.9 * ps, -1.5 * ps, 0.0, 0.0, 0.0, 1.0, cool,  # the teammate, seat 1
        1.0, 2.7 * ps, 0.6 * ps, 0.0, -0.9 * vs, -1.0, 0.0, 0.0,  # opponent seat 2
        1.0, 3.6 * ps, -0.6 * ps, 0.3 * vs, 0.3 * vs, 0.0, -1.0, 0.0], atol=1e-6)  # opponent seat 3
    # seat 2 (team 1) sees the world turned by half a turn: every vector negated
    np.testing.assert_allclose(obs[2], [
        1.0, R / 4, -1.2 * ps, -0.9 * ps, 0.0, 0.9 * vs, 1.0, 0.0, 0.0,
        1.0, -0.9 * ps, 1.2 * ps, -0.3 * vs, -0.3 * vs, 0.0, 1.0, 0.0,  # its teammate, seat 3
        1.0, 2.7 * ps, 0.6 * ps, -0.6 * vs, 0.0, -1.0, 0.0, 0.0,  # opponent seat 0
        1.0, 1.8 * ps, 2.1 * ps, 0.0, 0.0, 0.0, -1.0, cool], atol=1e-6)  # opponent seat 1
    state = r.state()
    assert state.shape == (r.state_dim,) == (32,) and state.dtype == np.float32
    np.testing.assert_allclose(state[8:16], [1.0, -0.6 * ps, -1.2 * ps, 0.0, 0.0, 0.0, 1.0, cool], atol=1e-6)


def test_observations_stay_in_their_bounds_and_fast_agents_are_clipped():
    r = rules(2, 2)
    low, high = r.observation_bounds()
    state_low, state_high = r.state_bounds()
    assert (low[4], high[4], low[8], high[8], low[10], high[10]) == (-2.0, 2.0, 0.0, 1.0, -2.0, 2.0)
    r.place(positions(r), [(30.0, 0.0), (0, 0), (0, 0), (0, 0)])
    obs = r.observe()
    assert obs[0, 4] == VELOCITY_BOUND and obs[2, 17 + 3] == -VELOCITY_BOUND  # seen from seat 2, turned
    assert np.all((obs >= low) & (obs <= high)) and np.all((r.state() >= state_low) & (r.state() <= state_high))
    rng = np.random.default_rng(0)
    for seed in range(3):
        r.reset(seed)
        for _ in range(300):
            r.step(rng.integers(0, 10, 4))
            obs, state = r.observe(), r.state()
            assert np.all((obs >= low) & (obs <= high)) and np.all((state >= state_low) & (state <= state_high))
            if r.game_over:
                break


# --- measures ---------------------------------------------------------------------------------------
def test_measures_describe_the_way_to_the_opponent():
    r = rules()
    r.place([(-1.0, 0.0), (1.0, 1.0)], [(0.0, 1.0), (0.0, 0.0)], heading=[math.pi / 2, 0.0])
    m = r.measures
    way = np.array([2.0, 1.0])
    assert m.target_distance[0] == pytest.approx(np.linalg.norm(way))
    assert m.velocity_to_target[0] == pytest.approx(1.0 / np.linalg.norm(way))
    assert m.facing_target[0] == pytest.approx(1.0 / np.linalg.norm(way))  # heading north
    assert m.facing_target[1] == pytest.approx(-2.0 / np.linalg.norm(way))  # heading east, the target west
    assert m.speed.tolist() == [1.0, 0.0] and m.force.tolist() == [0.0, 0.0] and m.energy.tolist() == [0.0, 0.0]
    assert m.active.all() and m.outcome.tolist() == [0.0, 0.0]
    before = m.target_distance[0]
    r.step(np.array([1 + 1, NOOP]))  # NE, toward the target
    assert m.target_distance[0] < before and m.velocity_to_target[0] > 0.0 and m.facing_target[0] > 0.9
    assert m.energy.tolist() == [1.0, 0.0]
    r.step(np.array([BLOW, NOOP]))
    assert m.energy.tolist() == [0.0, 0.0], "a plain blow spends no thrust"


# --- determinism and copies -----------------------------------------------------------------------
MEASURES = ("target_distance", "velocity_to_target", "facing_target", "force", "speed", "energy", "outcome")


@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_same_seed_same_actions_bit_identical_whatever_was_played_before(action_type):
    assert_replays_bit_for_bit(lambda: BlowBlowRules(2, 2, action_type), MEASURES, steps=250, detour=90)
    traced = trace(BlowBlowRules(2, 2, action_type), 3, 250, MEASURES)
    assert any(e for e in traced if isinstance(e, list)), "the trace holds blows and falls"


@pytest.mark.parametrize("copier", ["pickle", "deepcopy"])
def test_a_copy_mid_match_goes_on_bit_for_bit_as_the_original(copier):
    r = rules(2, 2, "continuous", seed=9)
    rng = np.random.default_rng(2)
    r.place([(-R + 0.05, 0.0), (-1.0, 0.5), (1.0, 0.5), (1.0, -0.5)], [(-1.0, 0.0), (0, 0), (0, 0), (0, 0)])
    for _ in range(6):
        r.step(rng.uniform(-1, 1, (4, 3)).astype(np.float32))
    assert not r.on_platform[0] and not r.game_over
    duplicate = pickle.loads(pickle.dumps(r)) if copier == "pickle" else copy.deepcopy(r)
    assert np.array_equal(r.observe(), duplicate.observe()) and r.cooldown().tolist() == duplicate.cooldown().tolist()
    for _ in range(120):
        actions = rng.uniform(-1, 1, (4, 3)).astype(np.float32)
        r.step(actions)
        duplicate.step(actions)
        assert np.array_equal(r.observe(), duplicate.observe()) and np.array_equal(r.state(), duplicate.state())
        assert np.array_equal(r.measures.force, duplicate.measures.force)
        assert r.events() == duplicate.events() and r.game_over == duplicate.game_over
        if r.game_over:
            assert np.array_equal(r.team_result(), duplicate.team_result())
            break


# --- the heuristic --------------------------------------------------------------------------------
@pytest.mark.parametrize("teams, players, action_type", [(2, 1, "discrete"), (2, 2, "discrete"),
                                                         (2, 1, "continuous"), (2, 2, "continuous")])
def test_heuristic_beats_random_teams_over_40_matches(teams, players, action_type):
    wins = 0
    for seed in range(40):
        heuristic_team = seed % teams  # both seats of the layout in turn
        r = heuristic_against_random(BlowBlowRules, teams, players, action_type, seed, heuristic_team)
        wins += r.team_result()[heuristic_team] == 1.0
    assert wins >= 36, wins


def test_heuristic_pushes_a_rival_off_and_keeps_itself_on():
    for seed in range(5):
        r = rules(seed=seed)

        def policy(r: BlowBlowRules) -> np.ndarray:
            actions = BlowBlowRules.heuristic(r.observe(), "discrete")
            actions[1] = NOOP  # a rival that does nothing
            return actions

        steps = play(r, policy)
        assert r.game_over and r.team_result().tolist() == [1.0, 0.0] and steps < 150


def test_heuristic_blows_a_rival_in_front_toward_the_edge_but_never_toward_the_centre():
    r = rules()
    r.place([(0.5, 0.0), (1.8, 0.0)])  # the rival 1.3 away, between the seat and the edge; facing it
    assert BlowBlowRules.heuristic(r.observe(), "discrete")[0] == BLOW
    continuous = BlowBlowRules.heuristic(r.observe(), "continuous")[0]
    assert continuous[2] == 1.0 and continuous[0] > 0.9
    r.place([(-R + 0.3, 0.0), (-1.0, 0.0)])  # the seat at its own edge, the rival toward the centre
    assert BlowBlowRules.heuristic(r.observe(), "discrete")[0] < BLOW


def test_heuristic_takes_any_batch_of_observations_and_refuses_another_games():
    r = rules(2, 2)
    obs = r.observe()
    discrete = BlowBlowRules.heuristic(obs, "discrete")
    assert discrete.dtype == np.int64 and discrete.shape == (4,) and ((discrete >= 0) & (discrete < 10)).all()
    continuous = BlowBlowRules.heuristic(obs[:1], "continuous")
    assert continuous.dtype == np.float32 and continuous.shape == (1, 3)
    assert np.linalg.norm(continuous[0, :2]) == pytest.approx(1.0, abs=1e-5) and continuous[0, 2] in (-1.0, 1.0)
    assert BlowBlowRules.heuristic(np.zeros((1, 17), dtype=np.float32), "discrete").tolist() == [NOOP]
    with pytest.raises(ValueError, match="not BlowBlow's"):
        BlowBlowRules.heuristic(np.zeros((1, 19), dtype=np.float32), "discrete")


# --- layouts, kwargs, tree ------------------------------------------------------------------------
@pytest.mark.parametrize("teams, players", LAYOUTS)
@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_every_layout_constructs_with_its_documented_sizes(teams, players, action_type):
    r = rules(teams, players, action_type)
    n = teams * players
    assert r.n_agents == n and r.obs_dim == 8 * n + 1 and r.state_dim == 8 * n
    assert r.n_actions == 10 and r.act_dim == 3 and len(r.action_meanings) == 10 and r.action_meanings[9] == "blow"
    assert r.observe().shape == (n, r.obs_dim) and r.state().shape == (r.state_dim,)
    env = make(f"BlowBlow-{teams}T{players}P-v1", action_type=action_type)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {f"player_{i}" for i in range(n)}
    assert env.teams == {t: [f"player_{t * players + p}" for p in range(players)] for t in range(teams)}


def test_unsupported_layouts_and_unknown_or_bad_kwargs_are_refused():
    with pytest.raises(ValueError, match="no 4T1P layout; valid layouts: 2T1P, 2T2P"):
        BlowBlowRules(4, 1)
    with pytest.raises(ValueError, match=r"BlowBlow has no option 'radius'; its options: platform_radius: .*start_jitter"):
        BlowBlowRules(2, 1, radius=3.0)
    for bad in (1.5, 4.5, "3", True, float("nan")):
        with pytest.raises(ValueError, match=r"BlowBlow option platform_radius must be a number in \[2.0, 4.0\] "
                                             r"\(default 3.0"):
            BlowBlowRules(2, 1, platform_radius=bad)
    with pytest.raises(ValueError, match=r"BlowBlow option start_jitter must be a number in \[0.0, 0.5\]"):
        BlowBlowRules(2, 1, start_jitter=0.8)
    with pytest.raises(ValueError, match="action_type 'hybrid' is not offered"):
        BlowBlowRules(2, 1, "hybrid")
    with pytest.raises(ValueError, match="BlowBlow is offered as: BlowBlow-2T1P-v1"):
        make("BlowBlow-2T3P-v1")
    env = make("BlowBlow-2T1P-v1", platform_radius=4)
    env.reset(seed=0)
    assert env.rules.platform_radius == 4.0 and env.rules.observe()[0, 1] == 1.0
    with pytest.raises(ValueError, match="off the platform"):
        rules().place([(0.0, 0.0), (2.9, 1.0)])
    with pytest.raises(ValueError, match="at least 0.25 apart"):
        rules().place([(0.0, 0.0), (0.1, 0.0)])


def test_default_tree_is_win_loss_over_team_target_over_progress_to_the_opponents():
    tree = BlowBlowRules.default_tree(2, 2)
    assert (tree["scheme"], tree["reward"], tree["scale"]) == ("CP", "win_loss", 100)
    for team, node in enumerate(tree["children"]):
        assert (node["scheme"], node["reward"], node["scale"]) == ("CL", "team_target", 10)
        assert [leaf["agent"] for leaf in node["children"]] == [f"player_{2 * team}", f"player_{2 * team + 1}"]
        assert all((leaf["scheme"], leaf["reward"], leaf["scale"]) == ("IS", "target", 1) for leaf in node["children"])
    solo = BlowBlowRules.default_tree(2, 1)
    assert [(c["agent"], c["scheme"], c["reward"], c["scale"]) for c in solo["children"]] == [
        ("player_0", "IS", "target", 1), ("player_1", "IS", "target", 1)]


def test_the_root_pays_the_winner_at_the_end():
    env = make("BlowBlow-2T1P-v1")
    env.reset(seed=0)
    env.rules.place([(-1.0, 0.0), (R - 0.05, 0.0)], [(0.0, 0.0), (1.0, 0.0)])
    _, rewards, terminations, _, _ = env.step({"player_0": NOOP, "player_1": NOOP})
    assert all(terminations.values())
    assert rewards["player_0"] > 90.0 and rewards["player_1"] < -90.0  # 100 * (+-1), plus a little shaping


@pytest.mark.parametrize("game_id", ["BlowBlow-2T1P-v1", "BlowBlow-2T2P-v1"])
def test_default_tree_verifies_as_declared(game_id):
    from arena_league.envs.social.verify import verify

    report = verify(game_id, samples=16)
    assert report.ok, [(v.path, v.declared, v.verified) for v in report.nodes]
    assert report.nodes[0].path == "root" and report.nodes[0].verified == "CP"


# --- picture, controls, replay scene ----------------------------------------------------------------
def test_top_down_picture_shows_the_platform_the_teams_the_blows_and_who_fell():
    env = make("BlowBlow-2T2P-v1", render_mode="rgb_array")
    env.reset(seed=0)
    picture = env.render()
    assert picture.dtype == np.uint8 and picture.shape == (400, 400, 3)
    colours = {tuple(int(v) for v in c) for c in np.unique(picture.reshape(-1, 3), axis=0)}
    assert TEAM_COLOURS[0] in colours and TEAM_COLOURS[1] in colours and (205, 185, 140) in colours
    assert (170, 205, 235) not in colours
    r = env.rules
    r.place([(-R + 0.05, 0.0), (-1.0, 0.5), (0.0, 0.5), (1.0, -0.5)], [(-1.0, 0.0), (0, 0), (0, 0), (0, 0)])
    r.step(np.array([NOOP, BLOW, NOOP, NOOP]))
    after = {tuple(int(v) for v in c) for c in np.unique(r.render_topdown().reshape(-1, 3), axis=0)}
    assert (170, 205, 235) in after, "the cone of the blow"
    assert tuple(c // 3 for c in TEAM_COLOURS[0]) in after, "the agent that fell, darkened"


def test_controls_move_on_the_platform_as_drawn_for_either_team_and_b_blows():
    r = make("BlowBlow-2T1P-v1").rules
    r.reset(0)
    left, right = r.human_controls(0), r.human_controls(1)
    assert isinstance(left, BlowBlowControls)
    assert left.parse("e") == (E, None) and left.parse("ne") == (2, None) and left.parse("b") == (BLOW, None)
    assert right.parse("e") == (W, None) and right.parse("n") == (S, None) and right.parse("ne") == (6, None)
    assert right.parse("b") == (BLOW, None) and right.parse("blow") == (BLOW, None) and right.parse("9") == (BLOW, None)
    assert right.parse("1") == (W, None) and right.parse("noop") == (NOOP, None)
    command, problem = left.parse("%%")
    assert command is None and "b blows along your heading" in problem
    web = right.web()
    assert web["input"] == "keys" and web["release"] == "noop" and web["combine"] == "nsew"
    assert web["keys"]["ArrowRight"] == "e" and web["keys"][" "] == "b" and web["keys"]["B"] == "b"
    assert all(right.parse(answer)[1] is None for answer in [*web["accepts"], *web["keys"].values()])
    assert "step 3" in left.prompt(3) and "b to blow" in left.prompt(3) and "0" in left.view()
    with pytest.raises(ValueError, match="no human controls for continuous actions"):
        rules(2, 1, "continuous").human_controls(0)


def test_a_drawn_move_sends_every_seat_the_same_way_on_the_platform():
    r = rules(2, 2, start_jitter=0.0)
    start = positions(r)
    actions = np.array([r.human_controls(seat).parse("n")[0] for seat in range(4)])
    for _ in range(3):
        r.step(actions)
    moved = positions(r) - start
    assert (moved[:, 1] > 0.1).all() and np.abs(moved[:, 0]).max() < 1e-9


def test_replay_scene_has_the_platform_every_agent_the_blows_and_the_score():
    r = rules(2, 2)
    entities = r.scene_entities(2_000_000_000)
    assert [e["id"] for e in entities] == ["platform", "agent/0", "agent/1", "agent/2", "agent/3", "blows", "score"]
    x, y = positions(r)[3]
    pose = entities[4]["cylinders"][0]["pose"]["position"]
    assert (pose["x"], pose["y"]) == pytest.approx((x, y), abs=1e-6)
    assert entities[5]["arrows"] == [] and entities[-1]["texts"][0]["text"] == "2 : 2"
    r.place([(-R + 0.05, 0.0), (-1.0, 0.5), (0.0, 0.5), (1.0, -0.5)], [(-1.0, 0.0), (0, 0), (0, 0), (0, 0)])
    r.step(np.array([NOOP, BLOW, NOOP, NOOP]))
    entities = r.scene_entities(2_100_000_000)
    assert len(entities[5]["arrows"]) == 1 and entities[-1]["texts"][0]["text"] == "1 : 2"
    assert entities[1]["cylinders"][0]["color"]["a"] < 1.0 and entities[1]["arrows"] == []  # fell
    assert len(entities[2]["arrows"]) == 1
