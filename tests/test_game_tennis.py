"""Tennis: points for a ball landing twice, out, in the net or held, serves and their faults, the end
of the match and cut matches, rackets kept to their side and reach while the ball crosses, gravity
and bounces, measures, the observation cell by cell and the mirrored seat frames, determinism and
copies, the heuristic against random play, layouts and game kwargs, the default tree, the picture,
the controls and the replay scene."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from physics2d_matches import assert_replays_bit_for_bit, heuristic_against_random, play

from arena_league.envs import make
from arena_league.envs.games.tennis import (
    BALL_RADIUS,
    BARRIER_RADIUS,
    CONTACT,
    GRAVITY,
    HALF_LENGTH,
    HOLD_LIMIT,
    NET_HEIGHT,
    POINT_REASONS,
    POSITION_SCALE,
    RACKET_RADIUS,
    RACKET_TOP_SPEED,
    REACH_HEIGHT,
    THRUST,
    TOSS_SPEED,
    TOSS_XY,
    VELOCITY_BOUND,
    VELOCITY_UNIT,
    TennisControls,
    TennisRules,
)
from arena_league.envs.rendering import TEAM_COLOURS

NOOP, E, N, W, S = 0, 1, 3, 5, 7  # discrete moves in the seat frame


def rules(players: int = 1, action_type: str = "discrete", seed: int = 0, **kwargs) -> TennisRules:
    r = TennisRules(2, players, action_type, **kwargs)
    r.reset(seed)
    return r


def out_of_play(n: int) -> np.ndarray:
    """Racket positions out of every ball's way: high up at the back of each side."""
    team0 = [(-4.5, 2.1), (-3.6, 2.1)][: n // 2]
    return np.array(team0 + [(-x, y) for x, y in team0])


def still(r: TennisRules) -> np.ndarray:
    return np.zeros(r.n_agents, dtype=np.int64)


def rackets(r: TennisRules) -> np.ndarray:
    """Every racket's world ``x, y``."""
    return r.state()[: 4 * r.n_agents].reshape(-1, 4)[:, :2].astype(np.float64) / POSITION_SCALE


def ball(r: TennisRules) -> np.ndarray:
    """The ball's world ``x, y, vx, vy``."""
    n = r.n_agents
    return r.state()[4 * n: 4 * n + 4].astype(np.float64) * np.repeat([1 / POSITION_SCALE, VELOCITY_UNIT], 2)


def until_point(r: TennisRules, policy=still, max_cycles: int = 100) -> tuple[dict, list[dict]]:
    """Step until a point ends; returns its event and every event before it."""
    seen = []
    for _ in range(max_cycles):
        r.step(policy(r))
        seen += r.events()
        points = [e for e in r.events() if e["kind"] == "point"]
        if points:
            return points[0], seen
    raise AssertionError(f"no point within {max_cycles} steps")


def mirror(team: int, x: float) -> float:
    """``x`` in team ``team``'s seat frame, in the world."""
    return x if team == 0 else -x


# --- points -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("hitter", [0, 1])
def test_a_ball_that_bounces_in_and_lands_again_is_the_hitters_point(hitter):
    r = rules()
    r.place(out_of_play(2), (mirror(hitter, 2.0), 1.5), played=hitter)
    point, seen = until_point(r)
    assert seen[0] == {"kind": "bounce", "side": 1 - hitter}
    assert point == {"kind": "point", "team": hitter, "reason": "not_returned"}
    assert r.score.tolist() == ([1, 0] if hitter == 0 else [0, 1])
    assert r.measures.resource_gain.tolist() == [1.0 - hitter, float(hitter)]


def test_a_ball_landing_beyond_the_baseline_or_on_the_back_fence_is_out():
    r = rules()
    r.place(out_of_play(2), (HALF_LENGTH + 0.3, 1.0), played=0)
    point, seen = until_point(r)
    assert point == {"kind": "point", "team": 1, "reason": "out"} and seen == [point]
    r.place(out_of_play(2), (-3.0, 0.6), ball_velocity=(-5.0, 1.5), played=1)  # long: onto team 0's fence
    point, seen = until_point(r)
    assert point == {"kind": "point", "team": 0, "reason": "out"} and seen == [point]
    assert mirror(r.rally["server"], ball(r)[0]) < -2.0, "the next toss is on the next server's side"
    assert r.score.tolist() == [1, 1]


def test_a_ball_landing_just_inside_the_baseline_is_in():
    r = rules()
    r.place(out_of_play(2), (HALF_LENGTH - 0.2, 1.0), played=0)
    point, seen = until_point(r)
    assert seen[0] == {"kind": "bounce", "side": 1} and point["reason"] == "not_returned" and point["team"] == 0


@pytest.mark.parametrize("team", [0, 1])
def test_a_ball_that_does_not_cross_the_net_is_the_other_teams_point(team):
    # struck into the net: it drops on the hitter's own side
    r = rules()
    r.place(out_of_play(2), (mirror(team, -1.2), 0.6), ball_velocity=(mirror(team, 3.0), 0.5), played=team)
    point, _ = until_point(r)
    assert point == {"kind": "point", "team": 1 - team, "reason": "net"}
    assert abs(ball(r)[0]) > 2.0, "a new serve is laid out at once"
    # and a ball that only falls on the hitter's side
    r.place(out_of_play(2), (mirror(team, -2.0), 1.0), played=team)
    point, _ = until_point(r)
    assert point == {"kind": "point", "team": 1 - team, "reason": "net"}


def test_the_net_stops_a_low_ball_and_a_high_one_passes_over():
    r = rules()
    r.place(out_of_play(2), (-1.0, 0.5), ball_velocity=(4.0, 0.0), played=0)
    flight = []
    for _ in range(10):
        r.step(still(r))
        if r.events():
            break
        flight.append(ball(r))
    assert r.events() == [{"kind": "point", "team": 1, "reason": "net"}]
    xs, vxs = [b[0] for b in flight], [b[2] for b in flight]
    assert max(xs) < -BALL_RADIUS + 0.02 and min(vxs) < 0.0, "it rebounded from the net"
    r.place(out_of_play(2), (-1.0, NET_HEIGHT + 0.6), ball_velocity=(4.0, 1.0), played=0)
    for _ in range(5):
        r.step(still(r))
    assert ball(r)[0] > 0.5


def test_a_ball_kept_on_one_side_for_40_steps_is_the_other_teams_point():
    r = rules()
    # the ball rests on racket 0 pressed up against its reach: it never lands, nor crosses the net
    r.place([(-2.0, 1.5), (4.5, 2.1)], (-2.0, 2.3), played=1)
    obs_clock = []
    for step in range(HOLD_LIMIT):
        r.step(np.array([N, NOOP]))
        if step < HOLD_LIMIT - 1:
            obs_clock.append(r.observe()[0, 14])
            assert r.rally["side"] == 0 and not any(e["kind"] == "point" for e in r.events())
    assert r.events()[-1] == {"kind": "point", "team": 1, "reason": "held"}
    assert {"kind": "hit", "seat": 0} in r.events(), "team 0 played it, bouncing on its racket"
    np.testing.assert_allclose(obs_clock, np.arange(1, HOLD_LIMIT) / HOLD_LIMIT, atol=1e-6)
    assert r.score.tolist() == [0, 1]


def test_the_side_clock_starts_afresh_when_the_ball_crosses_the_net():
    r = rules()
    r.place(out_of_play(2), (-0.6, 2.5), ball_velocity=(1.5, 0.0), played=0)
    clocks = []
    for _ in range(5):
        r.step(still(r))
        clocks.append((r.rally["side"], r.rally["clock"]))
    assert clocks[0] == (0, 1) and clocks[-1][0] == 1 and clocks[-1][1] < 5
    assert r.observe()[1, 14] == pytest.approx(clocks[-1][1] / HOLD_LIMIT)


def test_a_racket_touching_the_ball_makes_it_that_teams_shot():
    r = rules()
    r.place([(-4.5, 2.1), (2.0, 0.6)], (2.0, 1.5), played=0, bounced=True)  # falls onto racket 1
    hits = []
    for _ in range(6):
        r.step(still(r))
        hits += [e for e in r.events() if e["kind"] == "hit"]
    assert hits[0] == {"kind": "hit", "seat": 1}
    assert r.rally["played"] == 1 and not r.rally["bounced"] and not r.rally["toss"]
    assert r.observe()[1, 11] == 1.0 and r.observe()[0, 11] == 0.0


@pytest.mark.parametrize("came_from", [0, 1])
def test_rackets_of_both_teams_touching_the_ball_at_once_give_it_to_the_side_it_is_on(came_from):
    r = rules()
    r.place([(-0.5, 1.2), (0.5, 1.2)], (mirror(came_from, -1.0), 1.0))
    # exactly above the net between two rackets: the ball is on the side it came from
    r.place([(-0.41, 1.2), (0.41, 1.2)], (0.0, 1.6), played=1 - came_from)
    for _ in range(4):
        r.step(still(r))
        if r.events():
            break
    assert [e["seat"] for e in r.events() if e["kind"] == "hit"] == [0, 1]
    assert r.rally["played"] == came_from


# --- serves --------------------------------------------------------------------------------------------
def test_each_point_starts_with_a_toss_on_the_servers_side_and_the_serve_alternates():
    r = rules(2, seed=4, start_jitter=0.0)
    first = r.rally["server"]
    assert r.rally == {"played": first, "bounced": False, "toss": True, "side": first, "clock": 0, "server": first}
    assert ball(r) == pytest.approx((mirror(first, TOSS_XY[0]), TOSS_XY[1], 0.0, TOSS_SPEED))
    obs = r.observe()
    assert (obs[:, 13] == 1.0).all() and (obs[:, 11] == (r.team_of == first)).all()
    # nobody strikes the toss (it falls beside the server's racket): it lands on the server's side,
    # a fault, and the other team serves
    point, seen = until_point(r)
    assert point == {"kind": "point", "team": 1 - first, "reason": "fault"} and seen == [point]
    assert r.rally["server"] == 1 - first and r.rally["toss"] and r.rally["clock"] == 0
    assert ball(r)[:2] == pytest.approx((mirror(1 - first, TOSS_XY[0]), TOSS_XY[1]))
    assert r.measures.force.tolist() == [0.0] * 4, "a step that lays out a serve has no contact force"
    point, _ = until_point(r)
    assert point == {"kind": "point", "team": first, "reason": "fault"} and r.rally["server"] == first


def test_start_jitter_zero_puts_the_rackets_and_the_toss_on_their_spots():
    r = rules(2, start_jitter=0.0)
    np.testing.assert_allclose(rackets(r), [(-3.0, 0.8), (-1.2, 0.5), (3.0, 0.8), (1.2, 0.5)], atol=1e-6)
    assert ball(r)[:2] == pytest.approx((mirror(r.rally["server"], TOSS_XY[0]), TOSS_XY[1]))
    np.testing.assert_allclose(rackets(rules(1, start_jitter=0.0)), [(-3.0, 0.8), (3.0, 0.8)], atol=1e-6)


def test_the_first_server_and_the_jitter_come_from_the_seed():
    servers = {rules(seed=seed).rally["server"] for seed in range(8)}
    assert servers == {0, 1}
    assert rules(seed=3).rally["server"] == rules(seed=3).rally["server"]
    assert np.array_equal(rackets(rules(seed=3)), rackets(rules(seed=3)))
    assert not np.allclose(rackets(rules(seed=3)), rackets(rules(seed=5)))
    assert 0.0 < np.abs(rackets(rules(seed=3)) - [(-3.0, 0.8), (3.0, 0.8)]).max() <= 0.2


def test_a_struck_toss_is_in_play_and_may_bounce_in():
    bounced = 0
    for seed in range(6):
        r = rules(seed=seed)
        server = r.rally["server"]

        def serve(r, server=server):
            actions = TennisRules.heuristic(r.observe(), "discrete")
            actions[r.team_of != server] = 4  # NW: the receiver backs away up to its fence
            return actions

        point, seen = until_point(r, serve)
        kinds = [e["kind"] for e in seen]
        assert kinds[0] == "hit" and seen[0]["seat"] == server, "the server struck its toss"
        if "bounce" in kinds:
            bounced += 1
            assert seen[kinds.index("bounce")]["side"] == 1 - server
            assert point == {"kind": "point", "team": server, "reason": "not_returned"}
    assert bounced >= 5


# --- the end of the match ---------------------------------------------------------------------------------
def test_the_first_team_to_win_points_points_wins_the_match():
    env = make("Tennis-2T1P-v1")
    env.reset(seed=0)
    r = env.rules
    assert r.points == 7
    r.place(out_of_play(2), (-2.0, 1.5), played=1, score=(3, 6))
    for _ in range(30):
        _, _, terminations, truncations, _ = env.step({"player_0": NOOP, "player_1": NOOP})
        if not env.agents:
            break
    assert all(terminations.values()) and not any(truncations.values())
    assert r.game_over and r.score.tolist() == [3, 7]
    assert r.team_result().tolist() == [0.0, 1.0] and r.measures.outcome.tolist() == [-1.0, 1.0]
    assert r.events()[-1] == {"kind": "point", "team": 1, "reason": "not_returned"}
    assert r.state()[-7:-5].tolist() == pytest.approx([3 / 7, 1.0])
    one = rules(points=1)
    point, _ = until_point(one)
    assert one.game_over and point["reason"] == "fault" and one.team_result()[point["team"]] == 1.0


def test_a_cut_match_goes_to_the_team_with_more_points_and_equal_points_draw():
    env = make("Tennis-2T1P-v1", max_cycles=5)
    env.reset(seed=1)
    for _ in range(5):
        _, _, terminations, truncations, _ = env.step({"player_0": NOOP, "player_1": NOOP})
    assert all(truncations.values()) and not any(terminations.values())
    assert env.rules.score.tolist() == [0, 0]
    assert env.rules.team_result().tolist() == [0.5, 0.5] and env.rules.measures.outcome.tolist() == [0.0, 0.0]
    r = rules(2)
    r.place(out_of_play(4), (-2.0, 4.0), played=1, score=(4, 2))
    steps = play(r, still, max_cycles=3)
    assert steps == 3 and not r.game_over
    assert r.team_result().tolist() == [1.0, 0.0] and r.measures.outcome.tolist() == [1.0, 1.0, -1.0, -1.0]


def test_a_point_is_shared_among_the_winning_teams_members_and_the_root_pays_its_share():
    r = rules(2)
    r.place(out_of_play(4), (2.0, 1.5), played=0)
    until_point(r)
    assert r.measures.resource_gain.tolist() == [0.5, 0.5, 0.0, 0.0]
    r.step(still(r))
    assert r.measures.resource_gain.tolist() == [0.0] * 4
    tree = {"scheme": "CP", "reward": "resource_share", "scale": 1, "children": ["player_0", "player_1"]}
    env = make("Tennis-2T1P-v1", tree=tree)
    env.reset(seed=0)
    env.rules.place(out_of_play(2), (-1.0, 0.2), ball_velocity=(0.0, -1.0), played=0)  # lands at once: net
    _, rewards, *_ = env.step({"player_0": NOOP, "player_1": NOOP})
    assert rewards == {"player_0": -0.5, "player_1": 0.5}


# --- bodies: gravity, bounces, the barriers -------------------------------------------------------------
def test_gravity_pulls_the_ball_but_rackets_are_held():
    r = rules()
    r.place([(-2.0, 1.0), (2.0, 1.0)], (-1.0, 5.0), played=0)
    r.step(still(r))
    _, _, _, vy = ball(r)
    # two physics steps of 0.05 s, air drag keeping 0.9 of the velocity per second
    assert vy == pytest.approx(-GRAVITY * 0.1, rel=0.02)
    for _ in range(5):
        r.step(still(r))
    np.testing.assert_allclose(rackets(r), [(-2.0, 1.0), (2.0, 1.0)], atol=1e-9)


def test_the_ball_bounces_off_the_floor_keeping_most_of_its_height():
    r = rules()
    r.place(out_of_play(2), (2.0, 2.0), played=0)
    heights, landed = [], False
    for _ in range(40):
        r.step(still(r))
        if any(e["kind"] == "point" for e in r.events()):
            break
        landed |= any(e["kind"] == "bounce" for e in r.events())
        if landed:
            heights.append(ball(r)[1])
    # restitution 0.81: a bounce reaches about 0.81 ** 2 of the drop (less air drag)
    assert 0.5 * 2.0 < max(heights) < 0.7 * 2.0


@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_rackets_cannot_cross_the_net_or_leave_their_reach_but_the_ball_crosses(action_type):
    r = rules(2, action_type)
    # team 0 presses toward the net and up, team 1 toward the net and down (its frame is mirrored),
    # while the ball flies over the net
    r.place([(-1.0, 1.6), (-1.2, 1.4), (1.0, 1.0), (1.2, 0.8)], (-2.0, 5.0), ball_velocity=(2.5, 0.0), played=0)
    actions = (np.array([2, 2, 8, 8]) if action_type == "discrete"
               else np.array([[1, 1], [1, 1], [1, -1], [1, -1]], dtype=np.float32))
    for _ in range(12):
        r.step(actions)
    assert r.score.tolist() == [0, 0] and ball(r)[0] > 0.5
    xy = rackets(r)
    clear = RACKET_RADIUS + BARRIER_RADIUS
    assert np.all(np.abs(xy[:, 0]) > clear - 0.05) and np.all(np.abs(xy[:, 0]) < clear + 0.05)
    assert np.all(xy[:2, 1] < REACH_HEIGHT - RACKET_RADIUS + 0.05) and np.all(xy[:2, 1] > REACH_HEIGHT - RACKET_RADIUS - 0.05)
    assert np.all(xy[2:, 1] > RACKET_RADIUS - 0.05) and np.all(xy[2:, 1] < RACKET_RADIUS + 0.05)
    assert (np.sign(xy[:, 0]) == [-1, -1, 1, 1]).all()


def test_teammates_pass_each_other():
    r = rules(2)
    r.place([(-3.0, 1.0), (-2.0, 1.0), (3.0, 2.0), (2.0, 2.0)], (1.0, 4.0), played=0)
    for _ in range(12):
        r.step(np.array([E, W, NOOP, NOOP]))
    xy = rackets(r)
    assert xy[0, 0] > -2.0 and xy[1, 0] < -3.0, "each ran through the other's place"
    assert abs(xy[0, 1] - 1.0) < 1e-6 and abs(xy[1, 1] - 1.0) < 1e-6


def test_thrust_caps_the_speed_and_energy_counts_the_effort():
    r = rules()
    # the ball rests on racket 1, pressed up against its reach, out of the way
    r.place([(-4.6, 0.4), (4.6, 2.0)], (4.6, 2.5), played=1)
    for _ in range(12):
        r.step(np.array([E, NOOP]))
    assert r.measures.speed[0] == pytest.approx(RACKET_TOP_SPEED, rel=0.02)
    assert r.measures.energy.tolist() == [1.0, 0.0]
    c = rules(action_type="continuous")
    c.step(np.array([[0.6, 0.0], [1.0, 1.0]], dtype=np.float32))
    assert c.measures.energy.tolist() == [pytest.approx(0.36), pytest.approx(1.0)]  # scaled back to length 1


def test_force_measure_is_the_contact_impulse_on_the_racket_over_dt():
    r = rules()
    r.place([(-0.41, 1.0), (4.5, 2.1)], (1.0, 5.0), played=0)
    forces = []
    for _ in range(10):
        r.step(np.array([E, NOOP]))  # pressing on the net's plane: the barrier holds the full thrust
        forces.append(r.measures.force[0])
    assert forces[-1] == pytest.approx(THRUST, rel=0.05) and r.measures.force[1] == pytest.approx(0.0, abs=1e-9)
    r.place([(-2.0, 1.0), (4.5, 2.1)], (1.0, 5.0), played=0)
    r.step(np.array([E, NOOP]))
    assert r.measures.force[0] == pytest.approx(0.0, abs=1e-9), "a free racket meets no contact force"


def test_kinematic_measures_describe_the_way_to_the_ball():
    r = rules()
    r.place([(-2.0, 1.0), (2.0, 1.0)], (-1.0, 2.0), racket_velocity=[(1.0, 0.0), (0.0, 0.0)], played=0)
    m = r.measures
    assert m.target_distance.tolist() == pytest.approx([np.hypot(1.0, 1.0), np.hypot(3.0, 1.0)])
    assert m.velocity_to_target[0] == pytest.approx(1.0 / np.sqrt(2.0)) and m.velocity_to_target[1] == 0.0
    assert m.speed.tolist() == [1.0, 0.0] and m.force.tolist() == [0.0, 0.0] and m.energy.tolist() == [0.0, 0.0]
    assert m.active.all() and m.outcome.tolist() == [0.0, 0.0]


# --- the observation and the seat frames -------------------------------------------------------------
def test_observation_layout_cell_by_cell():
    r = rules(2)
    pos = np.array([[-2.0, 1.0], [-1.0, 0.5], [2.5, 1.5], [1.0, 2.0]])
    vel = np.array([[0.4, 0.0], [0.0, 0.0], [0.0, -0.8], [0.0, 0.0]])
    r.place(pos, (-1.5, 2.0), racket_velocity=vel, ball_velocity=(2.0, 1.0), played=1, score=(2, 1))
    obs = r.observe()
    assert obs.dtype == np.float32 and obs.shape == (4, r.obs_dim) == (4, 29)
    ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
    np.testing.assert_allclose(obs[0], [
        1.0, -2.0 * ps, 1.0 * ps, 0.4 * vs, 0.0,  # active, own position and velocity
        0.5 * ps, 1.0 * ps, -1.5 * ps, 2.0 * ps, 2.0 * vs, 1.0 * vs,  # ball: relative, absolute, velocity
        0.0, 0.0, 0.0, 0.0, 2 / 7, 1 / 7,  # team 1 played it; not bounced; no toss; clock; points
        1.0 * ps, -0.5 * ps, 0.0, 0.0,  # teammate player_1
        4.5 * ps, 0.5 * ps, 0.0, -0.8 * vs,  # opponent player_2
        3.0 * ps, 1.0 * ps, 0.0, 0.0], atol=1e-6)  # opponent player_3
    # team 1 sees the court mirrored in x: itself on x < 0, hitting toward +x
    np.testing.assert_allclose(obs[2], [
        1.0, -2.5 * ps, 1.5 * ps, 0.0, -0.8 * vs,
        4.0 * ps, 0.5 * ps, 1.5 * ps, 2.0 * ps, -2.0 * vs, 1.0 * vs,
        1.0, 0.0, 0.0, 0.0, 1 / 7, 2 / 7,
        1.5 * ps, 0.5 * ps, 0.0, 0.0,  # teammate player_3
        4.5 * ps, -0.5 * ps, -0.4 * vs, 0.0,  # opponent player_0
        3.5 * ps, -1.0 * ps, 0.0, 0.0], atol=1e-6)  # opponent player_1
    state = r.state()
    assert state.shape == (r.state_dim,) == (4 * 4 + 11,) and state.dtype == np.float32
    np.testing.assert_allclose(state[16:], [-1.5 * ps, 2.0 * ps, 2.0 * vs, 1.0 * vs, 2 / 7, 1 / 7,
                                            0.0, 1.0, 0.0, 0.0, 0.0], atol=1e-6)


def test_mirrored_position_gives_each_team_the_mirrored_observation():
    r = rules(2, seed=2)
    pos = np.array([[-2.0, 1.0], [-1.0, 0.5], [2.5, 1.5], [1.0, 2.0]])
    vel = np.array([[0.4, 0.3], [0.0, -0.2], [0.1, -0.8], [0.5, 0.0]])
    r.place(pos, (-1.5, 2.0), racket_velocity=vel, ball_velocity=(2.0, 1.0), played=1, bounced=True, score=(3, 1))
    before = r.observe()
    swapped = [2, 3, 0, 1]
    r.place(pos[swapped] * [-1.0, 1.0], (1.5, 2.0), racket_velocity=vel[swapped] * [-1.0, 1.0],
            ball_velocity=(-2.0, 1.0), played=0, bounced=True, score=(1, 3))
    after = r.observe()
    np.testing.assert_allclose(after, before[swapped], atol=1e-6)
    actions = TennisRules.heuristic(after, "discrete")
    assert (actions == TennisRules.heuristic(before, "discrete")[swapped]).all()


def test_observations_stay_in_their_bounds_and_fast_balls_are_clipped():
    r = rules(2)
    low, high = r.observation_bounds()
    state_low, state_high = r.state_bounds()
    r.place(out_of_play(4), (0.5, 5.5), ball_velocity=(30.0, 0.0), played=0)
    obs = r.observe()
    assert obs[0, 9] == VELOCITY_BOUND and obs[2, 9] == -VELOCITY_BOUND  # seen from team 1: mirrored
    assert np.all((obs >= low) & (obs <= high)) and np.all((r.state() >= state_low) & (r.state() <= state_high))
    assert (low[1], high[1], low[2], high[2], low[8], high[8]) == (-1.25, 0.0, 0.0, 0.625, 0.0, 1.5)
    rng = np.random.default_rng(0)
    for _ in range(300):
        r.step(rng.integers(0, 9, 4))
        assert np.all((r.observe() >= low) & (r.observe() <= high))
        assert np.all((r.state() >= state_low) & (r.state() <= state_high))
        if r.game_over:
            break


# --- determinism and copies -----------------------------------------------------------------------------
@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_same_seed_same_actions_bit_identical_whatever_was_played_before(action_type):
    measures = ("target_distance", "velocity_to_target", "force", "speed", "resource_gain", "energy", "outcome")
    assert_replays_bit_for_bit(lambda: TennisRules(2, 2, action_type), measures, steps=200, detour=70)


@pytest.mark.parametrize("copier", ["pickle", "deepcopy"])
def test_a_copy_mid_match_goes_on_bit_for_bit_as_the_original(copier):
    r = rules(2, "continuous", seed=9)
    rng = np.random.default_rng(2)
    for _ in range(30):
        r.step(TennisRules.heuristic(r.observe(), "continuous"))
    r.place(rackets(r), (-2.0, 2.0), ball_velocity=(1.0, 0.0), played=1)
    duplicate = pickle.loads(pickle.dumps(r)) if copier == "pickle" else copy.deepcopy(r)
    assert np.array_equal(r.score, duplicate.score) and r.rally == duplicate.rally
    for _ in range(150):
        actions = TennisRules.heuristic(r.observe(), "continuous")
        actions[2:] = rng.uniform(-1, 1, (2, 2))
        r.step(actions)
        duplicate.step(actions)
        assert np.array_equal(r.observe(), duplicate.observe()) and np.array_equal(r.state(), duplicate.state())
        assert np.array_equal(r.measures.force, duplicate.measures.force)
        assert r.events() == duplicate.events() and r.game_over == duplicate.game_over
        if r.game_over:
            assert np.array_equal(r.team_result(), duplicate.team_result())
            break


# --- the heuristic ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("players, action_type", [(1, "discrete"), (2, "discrete"), (1, "continuous"),
                                                  (2, "continuous")])
def test_heuristic_beats_a_random_team_over_40_matches(players, action_type):
    wins = won = lost = 0
    for seed in range(40):
        heuristic_team = seed % 2  # either side in turn
        r = heuristic_against_random(TennisRules, 2, players, action_type, seed, heuristic_team)
        wins += r.team_result()[heuristic_team] == 1.0
        won += r.score[heuristic_team]
        lost += r.score[1 - heuristic_team]
    assert wins >= 38, wins
    assert won > 5 * lost, (won, lost)


def test_heuristic_rallies_with_itself_and_every_point_has_a_documented_reason():
    hits, reasons = 0, set()
    r = rules(action_type="continuous", seed=3)
    for _ in range(300):
        r.step(TennisRules.heuristic(r.observe(), "continuous"))
        hits += sum(e["kind"] == "hit" for e in r.events())
        reasons |= {e["reason"] for e in r.events() if e["kind"] == "point"}
        if r.game_over:
            break
    assert hits > 15 and r.score.sum() >= 2
    assert reasons and reasons <= set(POINT_REASONS)


def test_heuristic_takes_any_batch_of_observations_and_refuses_another_games():
    r = rules(2)
    obs = r.observe()
    discrete = TennisRules.heuristic(obs, "discrete")
    assert discrete.dtype == np.int64 and discrete.shape == (4,) and ((discrete >= 0) & (discrete < 9)).all()
    continuous = TennisRules.heuristic(obs[:1], "continuous")
    assert continuous.dtype == np.float32 and continuous.shape == (1, 2) and np.abs(continuous).max() <= 1.0
    assert TennisRules.heuristic(rules(1).observe(), "discrete").shape == (2,)
    with pytest.raises(ValueError, match="not Tennis's"):
        TennisRules.heuristic(np.zeros((1, 19), dtype=np.float32), "discrete")


@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_heuristic_returns_a_ball_over_the_net_and_waits_while_the_other_side_plays(action_type):
    r = rules(action_type=action_type)
    r.place([(-3.0, 0.8), (3.0, 0.8)], (1.5, 2.0), ball_velocity=(-3.0, 0.5), played=1)  # coming at team 0
    spot = rackets(r)[1]
    for _ in range(30):
        r.step(TennisRules.heuristic(r.observe(), action_type))
        if r.rally["played"] == 0:
            break
        assert np.linalg.norm(rackets(r)[1] - spot) < 0.05, "team 1 waits on its spot while team 0 plays"
    assert r.rally["played"] == 0 and r.score.tolist() == [0, 0], "team 0 struck it"
    for _ in range(30):
        r.step(TennisRules.heuristic(r.observe(), action_type))
        if r.rally["side"] == 1 or r.score.sum():
            break
    assert r.rally["side"] == 1 and r.score.tolist() == [0, 0], "over the net"


# --- layouts, kwargs, tree ---------------------------------------------------------------------------------
@pytest.mark.parametrize("players", [1, 2])
@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_every_layout_constructs_with_its_documented_sizes(players, action_type):
    r = rules(players, action_type)
    n = 2 * players
    assert r.n_agents == n and r.obs_dim == 17 + 4 * (n - 1) and r.state_dim == 4 * n + 11
    assert r.obs_dim == {1: 21, 2: 29}[players]
    assert r.n_actions == 9 and r.act_dim == 2 and len(r.action_meanings) == 9
    assert r.observe().shape == (n, r.obs_dim) and r.state().shape == (r.state_dim,)
    env = make(f"Tennis-2T{players}P-v1", action_type=action_type)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {f"player_{i}" for i in range(n)}
    assert env.teams == {t: [f"player_{t * players + p}" for p in range(players)] for t in range(2)}
    assert env.max_cycles == TennisRules.default_max_cycles == 600


def test_unsupported_layouts_and_unknown_or_bad_kwargs_are_refused():
    with pytest.raises(ValueError, match="no 4T1P layout; valid layouts: 2T1P, 2T2P"):
        TennisRules(4, 1)
    with pytest.raises(ValueError, match=r"Tennis has no option 'sets'; its options: points: .*start_jitter"):
        TennisRules(2, 1, sets=3)
    for bad in (0, 22, 7.0, True, "7"):
        with pytest.raises(ValueError, match=r"Tennis option points must be an integer in \[1, 21\] "
                                             r"\(default 7: points to win the match\)"):
            TennisRules(2, 1, points=bad)
    for bad in (-0.1, 0.5, True):
        with pytest.raises(ValueError, match=r"Tennis option start_jitter must be a number in \[0.0, 0.3\]"):
            TennisRules(2, 1, start_jitter=bad)
    with pytest.raises(ValueError, match="action_type 'hybrid' is not offered"):
        TennisRules(2, 1, "hybrid")
    with pytest.raises(ValueError, match="Tennis is offered as: Tennis-2T1P-v1"):
        make("Tennis-3T1P-v1")
    assert make("Tennis-2T2P-v1", points=11).rules.points == 11
    r = rules()
    with pytest.raises(ValueError, match="outside its side or reach"):
        r.place([(0.1, 1.0), (2.0, 1.0)], (1.0, 1.0))
    with pytest.raises(ValueError, match="outside its side or reach"):
        r.place([(-2.0, REACH_HEIGHT), (2.0, 1.0)], (1.0, 1.0))
    with pytest.raises(ValueError, match="the ball at .* is outside the hall"):
        r.place(out_of_play(2), (1.0, BALL_RADIUS / 2))
    with pytest.raises(ValueError, match=r"score must be two points counts in \[0, 6\]"):
        r.place(out_of_play(2), (1.0, 1.0), score=(7, 0))
    with pytest.raises(ValueError, match="played is the team that struck the ball last, 0 or 1"):
        r.place(out_of_play(2), (1.0, 1.0), played=2)
    with pytest.raises(RuntimeError, match=r"call reset\(seed\) before place\(\)"):
        TennisRules(2, 1).place(out_of_play(2), (1.0, 1.0))


def test_default_tree_is_point_share_over_team_target_over_progress_to_the_ball():
    tree = TennisRules.default_tree(2, 2)
    assert (tree["scheme"], tree["reward"], tree["scale"]) == ("CP", "resource_share", 100)
    for team, node in enumerate(tree["children"]):
        assert (node["scheme"], node["reward"], node["scale"]) == ("CL", "team_target", 10)
        assert [leaf["agent"] for leaf in node["children"]] == [f"player_{2 * team}", f"player_{2 * team + 1}"]
        assert all((leaf["scheme"], leaf["reward"], leaf["scale"]) == ("IS", "target", 1) for leaf in node["children"])
    solo = TennisRules.default_tree(2, 1)
    assert [(c["agent"], c["scheme"], c["reward"], c["scale"]) for c in solo["children"]] == [
        ("player_0", "IS", "target", 1), ("player_1", "IS", "target", 1)]


@pytest.mark.parametrize("game_id", ["Tennis-2T1P-v1", "Tennis-2T2P-v1"])
def test_default_tree_verifies_as_declared(game_id):
    from arena_league.envs.social.verify import verify

    report = verify(game_id, samples=12, max_cycles=150)
    assert report.ok, [(v.path, v.declared, v.verified) for v in report.nodes]
    assert report.nodes[0].path == "root" and report.nodes[0].verified == "CP"
    assert {v.verified for v in report.nodes[1:]} <= {"IS", "CL"}


# --- picture, controls, replay scene ----------------------------------------------------------------------
def test_side_picture_shows_the_court_the_teams_and_the_ball():
    env = make("Tennis-2T2P-v1", render_mode="rgb_array")
    env.reset(seed=0)
    picture = env.render()
    assert picture.dtype == np.uint8 and picture.shape[1] == 400 and picture.shape[0] > 200
    colours = {tuple(c) for c in np.unique(picture.reshape(-1, 3), axis=0)}
    assert TEAM_COLOURS[0] in colours and TEAM_COLOURS[1] in colours and (250, 250, 250) in colours
    # team 0 is drawn on the left, team 1 on the right; the ball where the server tossed it
    left, right = picture[:, :200], picture[:, 200:]
    assert (left == TEAM_COLOURS[0]).all(axis=2).any() and not (left == TEAM_COLOURS[1]).all(axis=2).any()
    assert (right == TEAM_COLOURS[1]).all(axis=2).any() and not (right == TEAM_COLOURS[0]).all(axis=2).any()
    white = (picture == 250).all(axis=2)
    on_left = white[:, :200].sum() > white[:, 200:].sum()
    assert on_left == (env.rules.rally["server"] == 0)


def test_controls_move_on_the_court_as_drawn_for_either_team():
    r = rules()
    left, right = r.human_controls(0), r.human_controls(1)
    assert isinstance(left, TennisControls)
    assert left.parse("e") == (E, None) and left.parse("n") == (N, None) and left.parse("ne") == (2, None)
    assert right.parse("e") == (W, None) and right.parse("n") == (N, None) and right.parse("ne") == (4, None)
    assert right.parse("noop") == (NOOP, None) and left.parse("%%")[0] is None
    web = right.web()
    assert web["input"] == "keys" and web["release"] == "noop" and web["keys"]["ArrowUp"] == "n"
    assert "racket" in left.prompt(3) and "step 3" in left.prompt(3)
    view = left.view()
    assert "0" in view and "1" in view and "o" in view
    with pytest.raises(ValueError, match="no human controls for continuous actions"):
        rules(action_type="continuous").human_controls(0)


def test_a_drawn_move_sends_both_rackets_the_same_way_on_the_court():
    r = rules(start_jitter=0.0)
    start = rackets(r)
    actions = np.array([r.human_controls(seat).parse("w")[0] for seat in range(2)])
    for _ in range(3):
        r.step(actions)
    moved = rackets(r) - start
    assert (moved[:, 0] < -0.1).all() and np.abs(moved[:, 1]).max() < 1e-6


def test_replay_scene_has_the_court_every_racket_the_ball_and_the_score():
    r = rules(2)
    entities = r.scene_entities(2_000_000_000)
    assert [e["id"] for e in entities] == ["court", "agent/0", "agent/1", "agent/2", "agent/3", "ball", "score"]
    x, y = rackets(r)[3]
    pose = entities[4]["spheres"][0]["pose"]["position"]
    assert (pose["x"], pose["z"]) == pytest.approx((x, y), abs=1e-5) and pose["y"] == pytest.approx(-0.4)
    bx, by = ball(r)[:2]
    ball_pose = entities[5]["spheres"][0]["pose"]["position"]
    assert (ball_pose["x"], ball_pose["z"]) == pytest.approx((bx, by), abs=1e-5)
    assert entities[-1]["texts"][0]["text"] == "0 : 0"
    r.place(out_of_play(4), (2.0, 1.5), played=0)
    until_point(r)
    assert r.scene_entities(2_100_000_000)[-1]["texts"][0]["text"] == "1 : 0"
    net = entities[0]["cubes"][-1]
    assert net["size"]["z"] == pytest.approx(NET_HEIGHT) and CONTACT > 0
