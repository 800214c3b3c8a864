"""AirHockey: goals and winners, the puck's sliding and rebounds, each mallet kept to its own half
(the puck crossing freely), measures, the seat frame's mirror symmetry, determinism and copies,
the heuristic against random play, layouts and game kwargs, the picture, the controls and the
replay scene."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from physics2d_matches import assert_replays_bit_for_bit, heuristic_against_random, play

from arena_league.envs import make
from arena_league.envs.games.airhockey import (
    BARRIER_RADIUS,
    DT,
    GOAL_DEPTH,
    HALF_LENGTH,
    HALF_WIDTH,
    MALLET_RADIUS,
    MALLET_TOP_SPEED,
    POSITION_SCALE,
    PUCK_MASS,
    PUCK_RADIUS,
    RAIL_RADIUS,
    SPACE_DAMPING,
    THRUST,
    VELOCITY_UNIT,
    AirHockeyControls,
    AirHockeyRules,
)
from arena_league.envs.rendering import TEAM_COLOURS

E, N, W, S, NOOP = 1, 3, 5, 7, 0  # discrete moves in the seat frame
#: Where a mallet pressing on the centre line (or a goal-mouth bar) comes to rest: its face this
#: far from the line's middle.
STOP = MALLET_RADIUS + BARRIER_RADIUS


def rules(players: int = 1, action_type: str = "discrete", seed: int = 0, **kwargs) -> AirHockeyRules:
    r = AirHockeyRules(2, players, action_type, **kwargs)
    r.reset(seed)
    return r


def out_of_play(n: int) -> np.ndarray:
    """Mallet positions out of the way, near the side rails, each in its team's half."""
    team0 = [(-1.5, 1.6), (-3.0, -1.6)][: n // 2]
    return np.array(team0 + [(-x, -y) for x, y in team0])


def puck(r: AirHockeyRules) -> np.ndarray:
    """The puck's world ``x, y, vx, vy``."""
    n = r.n_agents
    return r.state()[4 * n: 4 * n + 4].astype(np.float64) * np.repeat([1 / POSITION_SCALE, VELOCITY_UNIT], 2)


def mallets(r: AirHockeyRules) -> np.ndarray:
    """Every mallet's world ``x, y``."""
    return r.state()[: 4 * r.n_agents].reshape(-1, 4)[:, :2].astype(np.float64) / POSITION_SCALE


def still(r: AirHockeyRules) -> np.ndarray:
    return np.zeros(r.n_agents, dtype=np.int64)


# --- goals ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("scorer", [0, 1])
def test_puck_sliding_into_a_goal_ends_the_match_and_the_attacking_team_wins(scorer):
    r = rules(2)
    side = 1.0 if scorer == 0 else -1.0  # team 0 attacks +x
    r.place(out_of_play(4), puck_xy=(side * (HALF_LENGTH - 1.5), 0.1), puck_velocity=(side * 2.0, 0.0))
    steps = play(r, still, max_cycles=30)
    assert r.game_over and steps < 30
    winners = r.team_of == scorer
    assert r.measures.outcome.tolist() == np.where(winners, 1.0, -1.0).tolist()
    assert r.team_result().tolist() == ([1.0, 0.0] if scorer == 0 else [0.0, 1.0])
    assert r.score.tolist() == ([1, 0] if scorer == 0 else [0, 1])
    assert r.events() == [{"kind": "goal", "team": scorer}]
    assert r.state()[-2:].tolist() == r.score.tolist()
    assert abs(puck(r)[0]) > HALF_LENGTH + PUCK_RADIUS, "the whole puck is past the goal line"


@pytest.mark.parametrize("team", [0, 1])
def test_a_mallet_striking_the_puck_forward_scores_for_its_team(team):
    # the same seat-frame action (E, toward the attacked goal) scores for either team
    r = rules(1)
    side = 1.0 if team == 0 else -1.0
    agents = out_of_play(2)
    agents[team] = (side * -1.5, 0.0)
    r.place(agents, puck_xy=(side * (-1.5 + MALLET_RADIUS + PUCK_RADIUS + 0.3), 0.0))
    actions = np.zeros(2, dtype=np.int64)
    actions[team] = E
    steps = play(r, lambda r: actions, max_cycles=100)
    assert r.game_over and steps < 100
    assert r.team_result()[team] == 1.0 and r.measures.outcome[team] == 1.0


def test_an_own_goal_counts_for_the_other_team():
    r = rules(1)
    r.place(out_of_play(2), puck_xy=(-2.0, 0.0), puck_velocity=(-2.0, 0.0))  # at team 0's own goal
    play(r, still, max_cycles=30)
    assert r.game_over and r.team_result().tolist() == [0.0, 1.0]


def test_puck_against_the_end_rail_beside_the_mouth_is_no_goal_and_rebounds():
    r = rules(1)
    r.place(out_of_play(2), puck_xy=(HALF_LENGTH - 1.5, 1.0), puck_velocity=(2.5, 0.0))
    play(r, still, max_cycles=20)
    assert not r.game_over
    x, _, vx, _ = puck(r)
    assert x < HALF_LENGTH - PUCK_RADIUS + 0.05 and vx < -1.5, "it came back off the rail"


def test_a_match_cut_with_the_puck_on_the_centre_line_all_along_is_a_draw():
    r = rules(2)
    r.place(out_of_play(4), puck_xy=(0.0, 0.0))  # no serve: the puck stays on the centre spot
    steps = play(r, still, max_cycles=50)
    assert steps == 50 and not r.game_over
    assert r.puck_steps.tolist() == [0, 0]
    assert r.measures.outcome.tolist() == [0.0] * 4
    assert r.team_result().tolist() == [0.5, 0.5]


@pytest.mark.parametrize("pressing", [0, 1])
def test_a_match_cut_without_a_goal_goes_to_the_team_that_kept_the_puck_in_the_other_half(pressing):
    r = rules(2)
    side = 1.0 if pressing == 0 else -1.0  # the puck rests in the half of the team that does not press
    r.place(out_of_play(4), puck_xy=(side * 2.0, 1.5))
    play(r, still, max_cycles=30)
    assert not r.game_over and r.puck_steps[1 - pressing] == 30 and r.puck_steps[pressing] == 0
    expected = np.where(r.team_of == pressing, 1.0, -1.0)
    assert r.measures.outcome.tolist() == expected.tolist()
    assert r.team_result().tolist() == [1.0 if t == pressing else 0.0 for t in range(2)]


def test_territory_counts_every_step_in_each_half_and_starts_afresh():
    r = rules(1)
    r.place(out_of_play(2), puck_xy=(-0.5, 1.0), puck_velocity=(2.0, 0.0))  # crosses the centre line
    play(r, still, max_cycles=10)
    assert r.puck_steps.sum() == 10 and 0 < r.puck_steps[0] < r.puck_steps[1]
    assert r.team_result().tolist() == [1.0, 0.0]  # the puck spent more steps in team 1's half
    r.reset(0)
    assert r.puck_steps.tolist() == [0, 0]


# --- the puck -------------------------------------------------------------------------------------
def test_puck_slides_with_little_friction():
    r = rules(1)
    r.place(out_of_play(2), puck_xy=(-1.0, 0.0), puck_velocity=(1.0, 0.5))
    for _ in range(10):  # one second of free sliding
        r.step(still(r))
    x, y, vx, vy = puck(r)
    assert np.hypot(vx, vy) == pytest.approx(np.hypot(1.0, 0.5) * SPACE_DAMPING, rel=1e-6)
    assert (x, y) == pytest.approx((-0.005, 0.4975), abs=0.02)  # about 1 and 0.5 further on


def test_puck_rebounds_from_the_side_rails_keeping_most_of_its_speed():
    r = rules(1)
    r.place(out_of_play(2) * (1.0, -1.0), puck_xy=(-2.0, 1.0), puck_velocity=(1.0, 2.0))
    vy_before = puck(r)[3]
    for _ in range(10):
        r.step(still(r))
    _, y, vx, vy = puck(r)
    assert y < HALF_WIDTH - PUCK_RADIUS and vy < 0 < vx, "it bounced off the rail at y = +2"
    assert -vy / vy_before == pytest.approx(0.9 * SPACE_DAMPING, abs=0.05)  # restitution 0.95 * 0.95
    for _ in range(30):  # and it slides on, bouncing off the other side rail too
        r.step(still(r))
    assert puck(r)[3] > 0.0 and np.hypot(*puck(r)[2:]) > 1.5


# --- each mallet in its own half ------------------------------------------------------------------
@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_mallets_cannot_cross_the_centre_line_but_the_puck_can(action_type):
    r = rules(1, action_type)
    r.place([(-1.0, 0.0), (1.0, 0.5)], puck_xy=(-0.6, 1.2), puck_velocity=(2.0, 0.0))
    forward = np.array([E, E]) if action_type == "discrete" else np.array([[1.0, 0.0]] * 2, dtype=np.float32)
    seat_x, puck_x = [], []
    for _ in range(40):  # both press toward the other half at full thrust
        r.step(forward)
        seat_x.append(mallets(r)[:, 0] * [1.0, -1.0])  # each in its own frame: its half is x < 0
        puck_x.append(puck(r)[0])
    seat_x = np.array(seat_x)
    # the step of impact overlaps a little (fixed steps), the solver then holds them off the line
    assert seat_x.max() < -MALLET_RADIUS + 0.1
    np.testing.assert_allclose(seat_x[-10:], -STOP, atol=0.02)
    assert r.measures.force.min() > 1.0, "pressing on the line shows as a contact force"
    assert max(puck_x) > 3.0, "the puck slid on into team 1's half, to its end rail"


@pytest.mark.parametrize("team", [0, 1])
def test_mallets_cannot_enter_their_goal_slot(team):
    r = rules(1)
    side = -1.0 if team == 0 else 1.0  # the goal the team defends
    agents = out_of_play(2)
    agents[team] = (side * (HALF_LENGTH - 1.0), 0.0)
    r.place(agents, puck_xy=(0.3 * side, 1.5))
    actions = np.zeros(2, dtype=np.int64)
    actions[team] = W  # back, into the own goal's mouth
    for _ in range(40):
        r.step(actions)
    assert abs(mallets(r)[team, 0]) == pytest.approx(HALF_LENGTH - STOP, abs=0.02), "stopped by the bar"
    assert not r.game_over


def test_play_keeps_every_body_on_the_table_and_every_mallet_in_its_half():
    for seed in range(6):
        r = rules(1 + seed % 2, ("discrete", "continuous")[seed // 2 % 2], seed)
        rng = np.random.default_rng(seed)
        for _ in range(300):
            actions = AirHockeyRules.heuristic(r.observe(), r.action_type)
            for seat in np.flatnonzero(r.team_of == seed % 2):
                actions[seat] = r.random_action(int(seat), rng)
            r.step(actions)
            # the bodies as pymunk has them (the state clips them): a fast body overlaps a rail or
            # a barrier on the step it arrives, never nearly as far as the rail's middle line
            x, y = r.world.bodies["puck"][0].position
            assert abs(x) < HALF_LENGTH + GOAL_DEPTH + RAIL_RADIUS / 2 and abs(y) < HALF_WIDTH + RAIL_RADIUS / 2
            seat_x = np.array([body.position.x for body in r.world.bodies["mallet"]]) * np.where(r.team_of == 0, 1.0, -1.0)
            assert seat_x.max() < -MALLET_RADIUS + 0.1 and seat_x.min() > -HALF_LENGTH
            if r.game_over:
                break


def test_a_mallet_placed_outside_its_half_is_refused():
    r = rules(1)
    with pytest.raises(ValueError, match="mallet 0 at .* is outside its team's half: team 0 plays in x < 0"):
        r.place([(0.5, 0.0), (1.0, 0.0)], puck_xy=(0.0, 0.0))
    with pytest.raises(ValueError, match="mallet 1 .* team 1 plays in x > 0"):
        r.place([(-1.0, 0.0), (-1.0, 1.0)], puck_xy=(0.0, 0.0))
    with pytest.raises(ValueError, match="the puck at .* is off the table"):
        r.place([(-1.0, 0.0), (1.0, 0.0)], puck_xy=(0.0, 3.0))


# --- measures -------------------------------------------------------------------------------------
def test_force_measure_is_the_contact_impulse_on_the_mallet_over_dt():
    r = rules(1)
    r.place([(-1.0, 0.0), (1.5, 1.5)], puck_xy=(-1.0 + MALLET_RADIUS + PUCK_RADIUS + 0.02, 0.0))
    keep = SPACE_DAMPING**DT
    strikes = 0
    for _ in range(12):  # strike the puck, catch it up and strike again, then press on the centre line
        puck_velocity = r.world.bodies["puck"][0].velocity
        r.step(np.array([E, NOOP]))
        arbiters: list = []
        r.world.bodies["mallet"][0].each_arbiter(arbiters.append)
        bodies = [{shape.body for shape in arbiter.shapes} for arbiter in arbiters]
        if bodies == [{r.world.bodies["mallet"][0], r.world.bodies["puck"][0]}]:
            # what the puck gained beyond its damping is what the mallet lost (pymunk's own
            # total_impulse also counts an earlier contact's impulse when the two meet again soon)
            gained = (r.world.bodies["puck"][0].velocity - puck_velocity * keep) * PUCK_MASS
            assert r.measures.force[0] == pytest.approx(abs(gained) / DT, rel=1e-6)
            strikes += 1
        elif not arbiters:
            assert r.measures.force[0] == pytest.approx(0.0, abs=1e-9)
        assert r.measures.force[1] == pytest.approx(0.0, abs=1e-9)  # player_1 stands alone
    assert strikes == 2
    assert r.measures.force[0] == pytest.approx(THRUST), "at rest on the line, it holds the full thrust"


def test_thrust_caps_the_speed_and_energy_counts_the_effort():
    r = rules(1, "continuous")
    r.place([(-3.5, -1.6), (1.0, 1.5)], puck_xy=(0.0, 1.5))
    for _ in range(15):
        r.step(np.array([[1.0, 1.0], [0.0, 0.0]], dtype=np.float32))
    m = r.measures
    assert m.energy.tolist() == [pytest.approx(1.0), 0.0]  # the corner (1, 1) is scaled back to length 1
    assert MALLET_TOP_SPEED - 0.3 < m.speed[0] < MALLET_TOP_SPEED + 0.05 and m.speed[1] == 0.0
    vx, vy = r.state()[2:4] * VELOCITY_UNIT
    assert vx == pytest.approx(vy, rel=1e-6)
    r.step(np.array([[0.6, 0.0], [0.0, 0.0]], dtype=np.float32))
    assert m.energy[0] == pytest.approx(0.36)
    d = rules(1)
    d.step(np.array([2, NOOP]))
    assert d.measures.energy.tolist() == [pytest.approx(1.0), 0.0]  # diagonals are no stronger


def test_kinematic_measures_describe_the_way_to_the_puck():
    r = rules(2)
    pos = out_of_play(4)
    r.place(pos, puck_xy=(0.5, -0.5), mallet_velocity=np.tile([1.0, 0.0], (4, 1)))
    m = r.measures
    to_puck = np.array([0.5, -0.5]) - pos
    distance = np.linalg.norm(to_puck, axis=1)
    np.testing.assert_allclose(m.target_distance, distance)
    np.testing.assert_allclose(m.velocity_to_target, to_puck[:, 0] / distance)
    np.testing.assert_allclose(m.speed, 1.0)
    assert m.force.tolist() == [0.0] * 4 and m.energy.tolist() == [0.0] * 4
    r.place(pos, puck_xy=(0.5, -0.5), puck_velocity=(1.5, 0.0))
    before = puck(r)[0]
    r.step(still(r))
    dx = puck(r)[0] - before
    assert dx > 0.1
    np.testing.assert_allclose(m.object_progress, [dx, dx, -dx, -dx], atol=1e-6)
    assert m.active.all()


# --- the seat frame -------------------------------------------------------------------------------
def test_mirrored_position_gives_each_team_the_mirrored_observation():
    rng = np.random.default_rng(5)
    for players in (1, 2):
        n = 2 * players
        sign = np.where(np.arange(n) < players, -1.0, 1.0)  # team 0 in x < 0
        pos = np.stack([sign * rng.uniform(0.5, 3.5, n), rng.uniform(-1.6, 1.6, n)], axis=1)
        vel = rng.uniform(-1.0, 1.0, (n, 2))
        puck_xy, puck_v = rng.uniform(-1.5, 1.5, 2), rng.uniform(-1.0, 1.0, 2)
        flip = np.array([-1.0, 1.0])
        swap = np.r_[np.arange(players, n), np.arange(players)]  # seat k of one team <-> of the other
        a = rules(players)
        a.place(pos, puck_xy, vel, puck_v)
        b = rules(players)
        b.place(pos[swap] * flip, puck_xy * flip, vel[swap] * flip, puck_v * flip)
        np.testing.assert_allclose(a.observe(), b.observe()[swap], atol=1e-6)
        np.testing.assert_array_equal(AirHockeyRules.heuristic(a.observe(), "discrete"),
                                      AirHockeyRules.heuristic(b.observe(), "discrete")[swap])
        # the same seat-frame actions keep the two matches mirrored
        actions = rng.integers(0, 9, n)
        for _ in range(5):
            a.step(actions)
            b.step(actions[swap])
        np.testing.assert_allclose(a.observe(), b.observe()[swap], atol=1e-4)


def test_observation_layout_cell_by_cell():
    r = rules(2)
    pos = np.array([[-1.0, 0.5], [-2.0, -1.0], [1.0, 1.0], [2.0, -0.5]])
    vel = np.array([[0.3, 0.0], [0.0, 0.0], [0.0, -0.6], [0.0, 0.0]])
    r.place(pos, (0.5, 0.25), vel, (0.9, 0.0))
    obs = r.observe()
    assert obs.dtype == np.float32 and obs.shape == (4, r.obs_dim) == (4, 27)
    ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
    seat0 = [1.0, -1.0 * ps, 0.5 * ps, 0.3 * vs, 0.0, 1.5 * ps, -0.25 * ps, 0.5 * ps, 0.25 * ps, 0.9 * vs, 0.0,
             5.0 * ps, -0.5 * ps, -3.0 * ps, -0.5 * ps,
             -1.0 * ps, -1.5 * ps, 0.0, 0.0,  # teammate player_1
             2.0 * ps, 0.5 * ps, 0.0, -0.6 * vs,  # opponent player_2
             3.0 * ps, -1.0 * ps, 0.0, 0.0]  # opponent player_3
    np.testing.assert_allclose(obs[0], seat0, atol=1e-6)
    # player_2 (team 1) sees x mirrored: it plays in x < 0 and attacks +x of its own frame
    seat2 = [1.0, -1.0 * ps, 1.0 * ps, 0.0, -0.6 * vs, 0.5 * ps, -0.75 * ps, -0.5 * ps, 0.25 * ps, -0.9 * vs, 0.0,
             5.0 * ps, -1.0 * ps, -3.0 * ps, -1.0 * ps,
             -1.0 * ps, -1.5 * ps, 0.0, 0.0,  # teammate player_3
             2.0 * ps, -0.5 * ps, -0.3 * vs, 0.0,  # opponent player_0
             3.0 * ps, -2.0 * ps, 0.0, 0.0]  # opponent player_1
    np.testing.assert_allclose(obs[2], seat2, atol=1e-6)
    state = r.state()
    assert state.shape == (r.state_dim,) == (22,) and state.dtype == np.float32
    np.testing.assert_allclose(state[16:20], [0.5 * ps, 0.25 * ps, 0.9 * vs, 0.0], atol=1e-6)


def test_observations_stay_in_their_bounds_and_fast_pucks_are_clipped():
    r = rules(2)
    low, high = r.observation_bounds()
    state_low, state_high = r.state_bounds()
    r.place(out_of_play(4), puck_xy=(0.0, 0.0), puck_velocity=(30.0, 0.0))
    obs = r.observe()
    assert obs[0, 9] == 2.0 and obs[2, 9] == -2.0  # 30 units/s, seen clipped to VELOCITY_BOUND
    assert np.all((obs >= low) & (obs <= high)) and np.all((r.state() >= state_low) & (r.state() <= state_high))
    # the documented bounds: own half, the attacked goal ahead, opponents in the other half
    assert (low[1], high[1], low[11], high[11], low[13], high[13]) == (-1.0, 0.0, 1.0, 2.0, -1.0, 0.0)
    assert (low[19], high[19], low[23], high[23]) == (0.0, 2.0, 0.0, 2.0)  # the two opponents' x


# --- determinism and copies -----------------------------------------------------------------------
@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_same_seed_same_actions_bit_identical_whatever_was_played_before(action_type):
    measures = ("target_distance", "velocity_to_target", "force", "speed",
                "object_progress", "energy", "outcome")
    assert_replays_bit_for_bit(lambda: AirHockeyRules(2, 2, action_type), measures, steps=250, detour=90)


@pytest.mark.parametrize("copier", ["pickle", "deepcopy"])
def test_a_copy_mid_match_goes_on_bit_for_bit_as_the_original(copier):
    r = rules(2, "continuous", seed=9)
    r.place(out_of_play(4), puck_xy=(-0.5, 0.3), puck_velocity=(-1.0, 0.4))
    rng = np.random.default_rng(2)
    for _ in range(40):
        r.step(rng.uniform(-1, 1, (4, 2)).astype(np.float32))
    duplicate = pickle.loads(pickle.dumps(r)) if copier == "pickle" else copy.deepcopy(r)
    for _ in range(60):
        actions = rng.uniform(-1, 1, (4, 2)).astype(np.float32)
        r.step(actions)
        duplicate.step(actions)
        assert np.array_equal(r.observe(), duplicate.observe()) and np.array_equal(r.state(), duplicate.state())
        assert np.array_equal(r.measures.force, duplicate.measures.force)
        assert r.game_over == duplicate.game_over
        if r.game_over:
            break


# --- the heuristic --------------------------------------------------------------------------------
@pytest.mark.parametrize("players, action_type", [(1, "discrete"), (2, "discrete"), (1, "continuous"),
                                                  (2, "continuous")])
def test_heuristic_beats_a_random_team_over_40_matches(players, action_type):
    wins = losses = 0
    for seed in range(40):
        heuristic_team = seed % 2  # play both sides
        r = heuristic_against_random(AirHockeyRules, 2, players, action_type, seed, heuristic_team)
        result = r.team_result()[heuristic_team]
        wins += result == 1.0
        losses += result == 0.0
    # a match without a goal goes on territory: a puck that lingers in the random team's half, out of
    # the heuristic's reach, counts for the heuristic (35 to 37 wins here, no draws)
    assert wins >= 33 and losses <= 7, (wins, losses)


def test_heuristic_takes_any_batch_of_observations():
    r = rules(2)
    obs = r.observe()
    discrete = AirHockeyRules.heuristic(obs, "discrete")
    assert discrete.dtype == np.int64 and discrete.shape == (4,) and ((discrete >= 0) & (discrete < 9)).all()
    continuous = AirHockeyRules.heuristic(obs[:1], "continuous")
    assert continuous.dtype == np.float32 and continuous.shape == (1, 2) and np.abs(continuous).max() <= 1.0


@pytest.mark.parametrize("mallet_xy, puck_xy, puck_velocity", [
    ((-2.0, 1.0), (-0.8, -0.2), (-1.2, 0.1)),
    ((-1.5, -1.0), (-0.5, 0.8), (-1.5, -0.3)),
])
def test_heuristic_blocks_a_puck_sliding_at_its_goal(mallet_xy, puck_xy, puck_velocity):
    for keeper in ("noop", "heuristic"):
        r = rules(1)
        r.place([mallet_xy, (2.0, 0.0)], puck_xy=puck_xy, puck_velocity=puck_velocity)
        play(r, lambda r, keeper=keeper: np.array(
            [AirHockeyRules.heuristic(r.observe(), "discrete")[0] if keeper == "heuristic" else NOOP, NOOP]),
            max_cycles=40)
        conceded = bool(r.game_over and r.team_result()[0] == 0.0)
        assert conceded is (keeper == "noop")


# --- layouts, kwargs, tree ------------------------------------------------------------------------
@pytest.mark.parametrize("players", [1, 2])
@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_every_layout_constructs_with_its_documented_sizes(players, action_type):
    r = rules(players, action_type)
    n = 2 * players
    assert r.n_agents == n and r.obs_dim == 15 + 4 * (n - 1) and r.state_dim == 4 * n + 6
    assert r.n_actions == 9 and r.act_dim == 2 and len(r.action_meanings) == 9
    assert r.observe().shape == (n, r.obs_dim) and r.state().shape == (r.state_dim,)
    env = make(f"AirHockey-2T{players}P-v1", action_type=action_type)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {f"player_{i}" for i in range(n)}
    assert env.teams == {0: [f"player_{i}" for i in range(players)],
                         1: [f"player_{i}" for i in range(players, n)]}


def test_the_face_off_serves_the_puck_toward_a_half_drawn_from_the_seed():
    sides = set()
    for seed in range(12):
        r = rules(2, seed=seed)
        x, y, vx, vy = puck(r)
        assert x == 0.0 and abs(y) <= 0.3 and abs(vx) == pytest.approx(0.6) and vy == 0.0
        sides.add(np.sign(vx))
        seat_x = mallets(r)[:, 0] * np.where(r.team_of == 0, 1.0, -1.0)
        assert seat_x.max() < -1.0
    assert sides == {-1.0, 1.0}


def test_unsupported_layout_and_unknown_or_bad_kwargs_are_refused():
    with pytest.raises(ValueError, match="no 2T3P layout; valid layouts: 2T1P, 2T2P"):
        AirHockeyRules(2, 3)
    with pytest.raises(ValueError, match=r"AirHockey has no option 'goal_size' \(did you mean 'goal_width'\?\); "
                                         r"its options: goal_width: .*kickoff_jitter"):
        AirHockeyRules(2, 1, goal_size=2.0)
    with pytest.raises(ValueError, match=r"AirHockey option goal_width must be a number in \[0.6, 2.8\] \(default 1.2"):
        AirHockeyRules(2, 1, goal_width=4.0)
    with pytest.raises(ValueError, match="AirHockey is offered as: AirHockey-2T1P-v1"):
        make("AirHockey-3T1P-v1")
    wide = make("AirHockey-2T1P-v1", goal_width=2.0)
    assert wide.rules.goal_half_width == 1.0


def test_a_wider_goal_takes_a_puck_the_default_one_turns_away():
    for goal_width, scores in ((1.2, False), (2.0, True)):
        r = rules(1, goal_width=goal_width)
        r.place(out_of_play(2), puck_xy=(HALF_LENGTH - 1.5, 0.8), puck_velocity=(2.0, 0.0))
        play(r, still, max_cycles=20)
        assert r.game_over is scores


def test_default_tree_is_win_loss_over_team_progress_over_puck_chasing():
    tree = AirHockeyRules.default_tree(2, 2)
    assert (tree["scheme"], tree["reward"], tree["scale"]) == ("CP", "win_loss", 100)
    for team, node in enumerate(tree["children"]):
        assert (node["scheme"], node["reward"], node["scale"]) == ("CL", "team_progress", 10)
        assert [leaf["agent"] for leaf in node["children"]] == [f"player_{2 * team}", f"player_{2 * team + 1}"]
        assert all((leaf["scheme"], leaf["reward"], leaf["scale"]) == ("IS", "target", 1)
                   for leaf in node["children"])


@pytest.mark.parametrize("game_id", ["AirHockey-2T2P-v1", "AirHockey-2T1P-v1"])
def test_default_tree_verifies_as_declared(game_id):
    from arena_league.envs.social.verify import verify

    report = verify(game_id, samples=16)
    assert report.ok, [(v.path, v.declared, v.verified) for v in report.nodes]


# --- picture, controls, replay scene ----------------------------------------------------------------
def test_top_down_picture_shows_table_teams_and_puck():
    env = make("AirHockey-2T2P-v1", render_mode="rgb_array")
    env.reset(seed=0)
    picture = env.render()
    assert picture.dtype == np.uint8 and picture.ndim == 3 and picture.shape[2] == 3
    assert picture.shape[1] == 400 and picture.shape[0] > 200  # twice as long as wide, with the rails
    colours = {tuple(c) for c in np.unique(picture.reshape(-1, 3), axis=0)}
    assert TEAM_COLOURS[0] in colours and TEAM_COLOURS[1] in colours and (250, 250, 250) in colours


def test_controls_move_on_the_table_as_drawn_for_either_team():
    r = make("AirHockey-2T1P-v1").rules
    r.reset(0)
    left, right = r.human_controls(0), r.human_controls(1)
    assert isinstance(left, AirHockeyControls)
    assert left.parse("e") == (E, None) and left.parse("ne") == (2, None)
    assert right.parse("e") == (W, None) and right.parse("ne") == (4, None)  # team 1 sees the table flipped
    assert right.parse("n") == (N, None) and right.parse("s") == (S, None)
    assert right.parse("")[1] is None and left.parse("%%")[0] is None
    web = right.web()
    assert web["input"] == "keys" and web["release"] == "noop" and web["combine"] == "nsew"
    assert web["keys"]["ArrowRight"] == "e" and web["keys"]["a"] == "w" and "ne" in web["accepts"]
    assert "step 3" in left.prompt(3) and "0" in left.view()
    with pytest.raises(ValueError, match="no human controls for continuous actions"):
        rules(1, "continuous").human_controls(0)


def test_replay_scene_has_the_table_every_mallet_the_puck_and_the_score():
    r = rules(2)
    entities = r.scene_entities(2_000_000_000)
    assert [e["id"] for e in entities] == ["table", "agent/0", "agent/1", "agent/2", "agent/3", "puck", "score"]
    x, y = mallets(r)[3]
    pose = entities[4]["cylinders"][0]["pose"]["position"]
    assert (pose["x"], pose["y"]) == pytest.approx((x, y), abs=1e-5)
    assert entities[-1]["texts"][0]["text"] == "0 : 0"
