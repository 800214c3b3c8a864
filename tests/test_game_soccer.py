"""Soccer: goals and winners, physical collisions, the seat frame's mirror symmetry, measures,
determinism, the heuristic against random play, layouts and game kwargs."""

from __future__ import annotations

import numpy as np
import pytest
from physics2d_matches import assert_replays_bit_for_bit, heuristic_against_random, play

from arena_league.envs import make
from arena_league.envs.games.soccer import (
    AGENT_RADIUS,
    BALL_RADIUS,
    DT,
    HALF_LENGTH,
    HALF_WIDTH,
    POSITION_SCALE,
    VELOCITY_UNIT,
    SoccerRules,
)

E, W, NOOP = 1, 5, 0  # discrete moves: toward the attacked goal, away from it, none


def rules(players: int = 2, action_type: str = "discrete", seed: int = 0, **kwargs) -> SoccerRules:
    r = SoccerRules(2, players, action_type, **kwargs)
    r.reset(seed)
    return r


def far_corners(n: int) -> np.ndarray:
    """Agent positions out of the way of play, near the side walls."""
    xs = np.linspace(-2.5, 2.5, n)
    return np.stack([xs, np.where(np.arange(n) % 2 == 0, 2.0, -2.0)], axis=1)


# --- goals ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("scorer", [0, 1])
def test_ball_rolled_into_a_goal_ends_the_match_and_the_attacking_team_wins(scorer):
    r = rules(2)
    side = 1.0 if scorer == 0 else -1.0  # team 0 attacks +x
    r.place(far_corners(4), ball_xy=(side * (HALF_LENGTH - 1.0), 0.1), ball_velocity=(side * 2.5, 0.0))
    steps = play(r, lambda r: np.zeros(4, dtype=np.int64), max_cycles=30)
    assert r.game_over and steps < 30
    winners = r.team_of == scorer
    assert r.measures.outcome.tolist() == np.where(winners, 1.0, -1.0).tolist()
    assert r.team_result().tolist() == ([1.0, 0.0] if scorer == 0 else [0.0, 1.0])
    assert r.score.tolist() == ([1, 0] if scorer == 0 else [0, 1])
    assert r.events() == [{"kind": "goal", "team": scorer}]
    assert r.state()[-2:].tolist() == r.score.tolist()


@pytest.mark.parametrize("team", [0, 1])
def test_an_agent_pushing_the_ball_forward_scores_for_its_team(team):
    # the same seat-frame action (E, toward the attacked goal) scores for either team
    r = rules(1)
    side = 1.0 if team == 0 else -1.0
    agents = np.array([[0.0, 2.0], [0.0, -2.0]])
    agents[team] = (side * 1.5, 0.0)
    r.place(agents, ball_xy=(side * (1.5 + AGENT_RADIUS + BALL_RADIUS + 0.05), 0.0))
    actions = np.zeros(2, dtype=np.int64)
    actions[team] = E
    steps = play(r, lambda r: actions, max_cycles=100)
    assert r.game_over and steps < 100
    assert r.team_result()[team] == 1.0 and r.measures.outcome[team] == 1.0


def test_ball_against_the_end_wall_beside_the_mouth_is_no_goal():
    r = rules(1)
    r.place(far_corners(2), ball_xy=(HALF_LENGTH - 1.0, 1.8), ball_velocity=(3.0, 0.0))
    play(r, lambda r: np.zeros(2, dtype=np.int64), max_cycles=20)
    assert not r.game_over
    bx = r.state()[8] / POSITION_SCALE
    assert bx < HALF_LENGTH - BALL_RADIUS + 0.05, "the ball bounced off the wall, it did not go through"


def test_a_match_cut_at_max_cycles_is_a_draw():
    r = rules(2)
    steps = play(r, lambda r: np.zeros(4, dtype=np.int64), max_cycles=50)
    assert steps == 50 and not r.game_over
    assert r.measures.outcome.tolist() == [0.0] * 4
    assert r.team_result().tolist() == [0.5, 0.5]


# --- physics --------------------------------------------------------------------------------------
def test_agent_running_into_the_ball_sets_it_rolling():
    r = rules(1)
    r.place([[-1.0, 0.0], [0.0, 2.0]], ball_xy=(0.0, 0.0))
    for _ in range(15):
        r.step(np.array([E, NOOP]))
    ball_x, ball_y, ball_vx = r.state()[8], r.state()[9], r.state()[10]
    assert ball_x / POSITION_SCALE > 0.3 and ball_vx > 0.0 and abs(ball_y) < 0.05
    assert r.measures.object_progress[0] > 0 > r.measures.object_progress[1]


def test_bodies_do_not_pass_through_each_other_or_the_walls():
    r = rules(1)
    r.place([[-1.0, 0.0], [1.0, 0.0]], ball_xy=(0.0, 1.5))
    gaps = []
    for _ in range(40):  # head-on: both press E in their own frame, i.e. toward each other
        r.step(np.array([E, E]))
        a, b = r.state()[0:2], r.state()[4:6]
        gaps.append(np.linalg.norm(a - b) / POSITION_SCALE - 2 * AGENT_RADIUS)
    # the step of impact overlaps a little (fixed steps), the solver then keeps them apart
    assert min(gaps) > -0.2 and min(gaps[-20:]) > -0.02
    assert r.measures.force.min() > 1.0, "pressing against each other shows as a contact force"
    for _ in range(60):  # now both run north into the side wall
        r.step(np.array([3, 3]))
    ys = r.state()[[1, 5]] / POSITION_SCALE
    assert np.all(ys < HALF_WIDTH - AGENT_RADIUS + 0.05) and np.all(ys > HALF_WIDTH - AGENT_RADIUS - 0.1)


def test_force_measure_matches_the_contact_impulse_pymunk_applied():
    r = rules(1)
    r.place([[-1.0, 0.0], [0.0, 2.0]], ball_xy=(-1.0 + AGENT_RADIUS + BALL_RADIUS + 0.02, 0.0))
    saw_contact = False
    for _ in range(8):
        r.step(np.array([E, NOOP]))
        impulses: list = []
        r.world.bodies["agent"][0].each_arbiter(impulses.append)
        impulses = [arbiter.total_impulse for arbiter in impulses]
        if len(impulses) == 1:
            saw_contact = True
            assert r.measures.force[0] == pytest.approx(abs(impulses[0]) / DT, rel=1e-6, abs=1e-9)
        elif not impulses:
            assert r.measures.force[0] == pytest.approx(0.0, abs=1e-9)
        assert r.measures.force[1] == pytest.approx(0.0, abs=1e-9)  # player_1 stands alone
    assert saw_contact


def test_thrust_caps_the_speed_and_energy_counts_the_effort():
    r = rules(1, "continuous")
    r.place([[-3.0, -2.0], [3.0, 1.5]], ball_xy=(0.0, 1.5))
    for _ in range(15):
        r.step(np.array([[1.0, 1.0], [0.0, 0.0]], dtype=np.float32))
    m = r.measures
    assert m.energy.tolist() == [pytest.approx(1.0), 0.0]  # the corner (1, 1) is scaled back to length 1
    assert 1.2 < m.speed[0] < 1.8 and m.speed[1] == 0.0
    vx, vy = r.state()[2:4] * VELOCITY_UNIT
    assert vx == pytest.approx(vy, rel=1e-6)
    r.step(np.array([[0.6, 0.0], [0.0, 0.0]], dtype=np.float32))
    assert m.energy[0] == pytest.approx(0.36)
    d = rules(1)
    d.step(np.array([2, NOOP]))
    assert d.measures.energy.tolist() == [pytest.approx(1.0), 0.0]  # diagonals are no stronger


def test_kinematic_measures_describe_the_way_to_the_ball():
    r = rules(2)
    r.place(far_corners(4), ball_xy=(0.5, -0.5), agent_velocity=np.tile([1.0, 0.0], (4, 1)))
    m = r.measures
    pos = far_corners(4)
    to_ball = np.array([0.5, -0.5]) - pos
    distance = np.linalg.norm(to_ball, axis=1)
    np.testing.assert_allclose(m.target_distance, distance)
    np.testing.assert_allclose(m.velocity_to_target, to_ball[:, 0] / distance)
    np.testing.assert_allclose(m.speed, 1.0)
    before = r.state()[16]
    r.step(np.zeros(4, dtype=np.int64))
    dx = (r.state()[16] - before) / POSITION_SCALE
    np.testing.assert_allclose(m.object_progress, [dx, dx, -dx, -dx], atol=1e-6)
    assert m.active.all()


# --- the seat frame -------------------------------------------------------------------------------
def test_mirrored_position_gives_each_team_the_mirrored_observation():
    rng = np.random.default_rng(5)
    for players in (1, 2, 3):
        n = 2 * players
        pos = rng.uniform([-3.5, -2.0], [3.5, 2.0], (n, 2))
        vel = rng.uniform(-1.0, 1.0, (n, 2))
        ball, ball_v = rng.uniform(-2.0, 2.0, 2), rng.uniform(-1.0, 1.0, 2)
        flip = np.array([-1.0, 1.0])
        swap = np.r_[np.arange(players, n), np.arange(players)]  # seat k of one team <-> of the other
        a = rules(players)
        a.place(pos, ball, vel, ball_v)
        b = rules(players)
        b.place(pos[swap] * flip, ball * flip, vel[swap] * flip, ball_v * flip)
        np.testing.assert_allclose(a.observe(), b.observe()[swap], atol=1e-6)
        np.testing.assert_array_equal(SoccerRules.heuristic(a.observe(), "discrete"),
                                      SoccerRules.heuristic(b.observe(), "discrete")[swap])
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
    # player_2 (team 1) sees x mirrored: it attacks +x of its own frame
    seat2 = [1.0, -1.0 * ps, 1.0 * ps, 0.0, -0.6 * vs, 0.5 * ps, -0.75 * ps, -0.5 * ps, 0.25 * ps, -0.9 * vs, 0.0,
             5.0 * ps, -1.0 * ps, -3.0 * ps, -1.0 * ps,
             -1.0 * ps, -1.5 * ps, 0.0, 0.0,  # teammate player_3
             2.0 * ps, -0.5 * ps, -0.3 * vs, 0.0,  # opponent player_0
             3.0 * ps, -2.0 * ps, 0.0, 0.0]  # opponent player_1
    np.testing.assert_allclose(obs[2], seat2, atol=1e-6)
    state = r.state()
    assert state.shape == (r.state_dim,) == (22,) and state.dtype == np.float32
    np.testing.assert_allclose(state[16:20], [0.5 * ps, 0.25 * ps, 0.9 * vs, 0.0], atol=1e-6)


# --- determinism ----------------------------------------------------------------------------------
@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_same_seed_same_actions_bit_identical_whatever_was_played_before(action_type):
    measures = ("target_distance", "velocity_to_target", "force", "object_progress",
                "energy", "outcome")
    assert_replays_bit_for_bit(lambda: SoccerRules(2, 2, action_type), measures, steps=250, detour=90)


# --- the heuristic --------------------------------------------------------------------------------
@pytest.mark.parametrize("players, action_type", [(1, "discrete"), (2, "discrete"), (3, "discrete"),
                                                  (2, "continuous")])
def test_heuristic_beats_a_random_team_in_most_matches(players, action_type):
    wins = losses = 0
    for seed in range(20):
        heuristic_team = seed % 2  # play both sides
        r = heuristic_against_random(SoccerRules, 2, players, action_type, seed, heuristic_team)
        result = r.team_result()[heuristic_team]
        wins += result == 1.0
        losses += result == 0.0
    assert wins >= 15 and losses <= 1


def test_heuristic_takes_any_batch_of_observations():
    r = rules(3)
    obs = r.observe()
    discrete = SoccerRules.heuristic(obs, "discrete")
    assert discrete.dtype == np.int64 and discrete.shape == (6,) and ((discrete >= 0) & (discrete < 9)).all()
    continuous = SoccerRules.heuristic(obs[:1], "continuous")
    assert continuous.dtype == np.float32 and continuous.shape == (1, 2) and np.abs(continuous).max() <= 1.0


# --- layouts, kwargs, tree, picture ---------------------------------------------------------------
@pytest.mark.parametrize("players", [1, 2, 3])
@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_every_layout_constructs_with_its_documented_sizes(players, action_type):
    r = rules(players, action_type)
    n = 2 * players
    assert r.n_agents == n and r.obs_dim == 15 + 4 * (n - 1) and r.state_dim == 4 * n + 6
    assert r.n_actions == 9 and r.act_dim == 2 and len(r.action_meanings) == 9
    assert r.observe().shape == (n, r.obs_dim) and r.state().shape == (r.state_dim,)
    assert np.abs(r.observe()).max() <= 2.5  # relative positions span the field: up to about 2.3
    env = make(f"Soccer-2T{players}P-v1", action_type=action_type)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {f"player_{i}" for i in range(n)}
    assert env.teams == {0: [f"player_{i}" for i in range(players)],
                         1: [f"player_{i}" for i in range(players, n)]}


def test_unsupported_layout_and_unknown_or_bad_kwargs_are_refused():
    with pytest.raises(ValueError, match="no 3T2P layout; valid layouts: 2T1P, 2T2P, 2T3P"):
        SoccerRules(3, 2)
    with pytest.raises(ValueError, match=r"Soccer has no option 'goal_size' \(did you mean 'goal_width'\?\); "
                                         r"its options: goal_width: .*kickoff_jitter"):
        SoccerRules(2, 2, goal_size=2.0)
    with pytest.raises(ValueError, match=r"Soccer option goal_width must be a number in \[0.6, 4.0\] \(default 1.6"):
        SoccerRules(2, 2, goal_width=10.0)
    with pytest.raises(ValueError, match="Soccer has no option 'gravity'"):
        make("Soccer-2T2P-v1", gravity=1.0)
    wide = make("Soccer-2T1P-v1", goal_width=3.0)
    assert wide.rules.goal_half_width == 1.5


def test_default_tree_is_win_loss_over_team_progress_over_ball_chasing():
    tree = SoccerRules.default_tree(2, 2)
    assert (tree["scheme"], tree["reward"], tree["scale"]) == ("CP", "win_loss", 100)
    for team, node in enumerate(tree["children"]):
        assert (node["scheme"], node["reward"], node["scale"]) == ("CL", "team_progress", 10)
        assert [leaf["agent"] for leaf in node["children"]] == [f"player_{2 * team}", f"player_{2 * team + 1}"]
        assert all((leaf["scheme"], leaf["reward"]) == ("IS", "target") for leaf in node["children"])


def test_default_tree_verifies_as_declared():
    from arena_league.envs.social.verify import verify

    report = verify("Soccer-2T2P-v1", samples=16)
    assert all(v.ok for v in report.nodes), [(v.path, v.declared, v.verified) for v in report.nodes]


def test_top_down_picture_shows_field_teams_and_ball():
    r = rules(2)
    picture = r.render_topdown()
    assert picture.dtype == np.uint8 and picture.ndim == 3 and picture.shape[2] == 3
    colours = {tuple(c) for c in np.unique(picture.reshape(-1, 3), axis=0)}
    from arena_league.envs.rendering import TEAM_COLOURS

    assert TEAM_COLOURS[0] in colours and TEAM_COLOURS[1] in colours and (250, 250, 250) in colours
