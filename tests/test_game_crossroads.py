"""Crossroads rules: driving, arrival, physical collisions, determinism, layouts and bad kwargs."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs.games.crossroads import (
    AGENT_RADIUS,
    ARM_LENGTH,
    CASE_STUDY_TREES,
    PHYSICS_DT,
    RULES,
    TOP_SPEED,
    CrossroadsRules,
)

NOOP, FORWARD = 0, 1


def _positions(rules: CrossroadsRules) -> np.ndarray:
    """World positions of every seat, from the global state (9 cells per seat, x / L first)."""
    return rules.state().reshape(rules.n_agents, 9)[:, 0:2].astype(np.float64) * ARM_LENGTH


def _idle(rules: CrossroadsRules) -> np.ndarray:
    if rules.action_type == "discrete":
        return np.full(rules.n_agents, NOOP, dtype=np.int64)
    return np.zeros((rules.n_agents, 2), dtype=np.float32)


@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_heuristic_alone_arrives_well_within_max_cycles(action_type, seed):
    rules = CrossroadsRules(2, 1, action_type)
    rules.reset(seed)
    start = rules.measures.target_distance[0]
    for step in range(1, rules.default_max_cycles + 1):  # noqa: B007 - read after the loop
        actions = _idle(rules)
        actions[0] = rules.heuristic(rules.observe(), action_type)[0]  # seat 1 stays parked
        rules.step(actions)
        if rules.measures.arrived[0]:
            break
    assert rules.measures.arrived[0] and not rules.measures.active[0]
    assert step < rules.default_max_cycles / 2, f"took {step} steps to drive {start:.1f}"
    assert not rules.game_over, "the parked seat has not arrived, so the match goes on"


def test_heuristic_beats_random_play():
    rules = CrossroadsRules(2, 2, "discrete")
    rules.reset(5)
    rng = np.random.default_rng(0)
    for _ in range(rules.default_max_cycles):
        actions = rules.heuristic(rules.observe(), "discrete")
        actions[2:] = [rules.random_action(s, rng) for s in (2, 3)]  # team 1 plays at random
        rules.step(actions)
        if rules.measures.arrived[:2].all():
            break
    assert rules.measures.arrived[:2].all() and not rules.measures.arrived[2:].any()
    rules.finish()
    assert rules.team_result().tolist() == [1.0, 0.0]
    assert rules.measures.outcome.tolist() == [1.0, 1.0, -1.0, -1.0]


#: Chipmunk sees a contact once shapes overlap: two agents closing at full speed may sink this
#: far into each other within one physics step (plus its slop) before the contact pushes back.
_MAX_SINK = 2 * TOP_SPEED * PHYSICS_DT + 0.02


def _chase(obs: np.ndarray, other_cells: np.ndarray, action_type: str) -> np.ndarray:
    """Turn toward the agent at ``other_cells`` of each row's observation and drive at it."""
    rel = obs[np.arange(len(obs))[:, None], other_cells]
    heading = obs[:, 4:6]
    error = np.arctan2(heading[:, 0] * rel[:, 1] - heading[:, 1] * rel[:, 0],
                       heading[:, 0] * rel[:, 0] + heading[:, 1] * rel[:, 1])
    if action_type == "discrete":
        return np.where(error > 0.15, 3, np.where(error < -0.15, 4, FORWARD)).astype(np.int64)
    return np.stack([np.ones(len(obs)), np.clip(error / 0.3, -1, 1)], axis=1).astype(np.float32)


def _drive_head_on(rules: CrossroadsRules, steps: int) -> tuple[list[float], list[np.ndarray]]:
    """Seats 0 (west) and 2 (east) of 4T1P drive at each other; seats 1 and 3 stay put."""
    gaps, forces = [], []
    # Seat 0 sees seat 2 second among its opponents (cells 15, 16); seat 2 sees seat 0 first.
    cells = np.array([[15, 16], [10, 11]])
    for _ in range(steps):
        actions = _idle(rules)
        actions[[0, 2]] = _chase(rules.observe()[[0, 2]], cells, rules.action_type)
        rules.step(actions)
        p = _positions(rules)
        gaps.append(float(np.hypot(*(p[0] - p[2]))))
        forces.append(rules.measures.force.copy())
    return gaps, forces


@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_agents_driven_into_each_other_collide_and_bounce(action_type):
    rules = CrossroadsRules(4, 1, action_type)
    rules.reset(3)
    for _ in range(120):
        gaps, forces = _drive_head_on(rules, 1)
        if forces[0][0] > 0:
            break
    assert forces[0][0] > 0, "the agents never touched"
    assert gaps[0] < 2 * AGENT_RADIUS + 0.1, "the force comes from their contact"
    assert forces[0][2] == pytest.approx(forces[0][0]), "action equals reaction"
    assert forces[0][1] == forces[0][3] == 0.0
    # Both let go: the elastic contact pushes them apart.
    gaps = []
    for _ in range(5):
        rules.step(_idle(rules))
        p = _positions(rules)
        gaps.append(np.hypot(*(p[0] - p[2])))
    assert gaps[0] > 2 * AGENT_RADIUS - _MAX_SINK
    assert np.all(np.diff(gaps) > 0)


@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_pushing_keeps_bodies_apart(action_type):
    rules = CrossroadsRules(4, 1, action_type)
    rules.reset(3)
    gaps, forces = _drive_head_on(rules, 100)
    assert min(gaps) > 2 * AGENT_RADIUS - _MAX_SINK, "bodies never pass through each other"
    forces = np.array(forces)
    assert (forces[:, [0, 2]] > 0).all(axis=1).sum() >= 5, "they keep pushing into each other"
    assert (forces >= 0).all()


def test_walls_bound_the_roads():
    rules = CrossroadsRules(2, 1, "discrete")
    rules.reset(0)
    for _ in range(150):  # both drive straight on, whatever their heading jitter
        rules.step(np.array([FORWARD, FORWARD]))
    p = _positions(rules)
    assert np.all(np.abs(p) < ARM_LENGTH)
    on_a_road = (np.abs(p[:, 0]) < 2.5) | (np.abs(p[:, 1]) < 2.5)
    assert on_a_road.all()
    assert (rules.measures.force > 0).any(), "they rest against walls"


def test_arrival_makes_a_seat_inactive_and_everyone_arriving_ends_the_match():
    rules = CrossroadsRules(2, 2, "continuous")
    rules.reset(4)
    arrived_at, frozen = {}, {}
    for step in range(1, rules.default_max_cycles + 1):
        obs = rules.observe()
        rules.step(rules.heuristic(obs, "continuous"))
        for event in rules.events():
            assert event["kind"] == "arrive" and event["step"] == step
            arrived_at[event["seat"]] = step
            frozen[event["seat"]] = _positions(rules)[event["seat"]]
        for seat, where in frozen.items():
            assert not rules.measures.active[seat] and rules.measures.arrived[seat]
            assert np.array_equal(_positions(rules)[seat], where), "an arrived seat stays put"
            assert rules.measures.force[seat] == 0.0 and rules.measures.speed[seat] == 0.0
            assert rules.observe()[seat, 9] == 0.0, "its observation says it is inactive"
        if rules.game_over:
            break
    assert rules.game_over and rules.measures.arrived.all() and not rules.measures.active.any()
    assert sorted(arrived_at) == [0, 1, 2, 3]
    assert step == max(arrived_at.values())
    finish = [max(arrived_at[0], arrived_at[1]), max(arrived_at[2], arrived_at[3])]
    expected = [1.0, 0.0] if finish[0] < finish[1] else [0.0, 1.0] if finish[0] > finish[1] else [0.5, 0.5]
    assert rules.team_result().tolist() == expected
    assert rules.measures.outcome.tolist() == [2 * r - 1 for r in expected for _ in range(2)]


def test_inactive_seats_actions_are_ignored():
    rules = CrossroadsRules(2, 1, "discrete")
    rules.reset(0)
    while not rules.measures.arrived[0]:
        actions = rules.heuristic(rules.observe(), "discrete")
        actions[1] = NOOP
        rules.step(actions)
    where = _positions(rules)[0]
    for _ in range(10):
        rules.step(np.array([FORWARD, NOOP]))
    assert np.array_equal(_positions(rules)[0], where)
    assert rules.measures.energy[0] == 0.0


def test_timeout_ranks_unfinished_teams_last_and_tied():
    rules = CrossroadsRules(4, 1, "discrete")
    rules.reset(0)
    for _ in range(20):
        rules.step(np.full(4, NOOP))
    rules.finish()
    assert rules.team_result().tolist() == [1.5, 1.5, 1.5, 1.5]
    assert rules.measures.outcome.tolist() == [0.0] * 4


def _trajectory(seed: int, action_type: str, steps: int = 200) -> list[np.ndarray]:
    rules = CrossroadsRules(2, 4, action_type)
    rules.reset(seed)
    rng = np.random.default_rng(seed)
    trace = []
    for _ in range(steps):
        obs = rules.observe()
        actions = rules.heuristic(obs, action_type)
        for seat in np.flatnonzero(rng.random(rules.n_agents) < 0.3):  # mix in random moves
            actions[seat] = rules.random_action(int(seat), rng)
        rules.step(actions)
        m = rules.measures
        trace += [obs, rules.state(), m.active.copy(), m.target_distance.copy(), m.velocity_to_target.copy(),
                  m.facing_target.copy(), m.energy.copy(), m.force.copy(), m.speed.copy(), m.outcome.copy()]
    return trace


@pytest.mark.parametrize("action_type", ["discrete", "continuous"])
def test_same_seed_same_trajectory(action_type):
    first, second = _trajectory(11, action_type), _trajectory(11, action_type)
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))
    assert any(f.any() for f in first[7::10]), "the trajectory includes collisions"
    other = _trajectory(12, action_type)
    assert not all(np.array_equal(a, b) for a, b in zip(first, other))


@pytest.mark.parametrize("layout", RULES.layouts)
@pytest.mark.parametrize("action_type", RULES.action_types)
def test_every_layout_constructs_and_observes_from_its_own_frame(layout, action_type):
    n_teams, players = layout
    rules = RULES(n_teams, players, action_type)
    rules.reset(0)
    n = n_teams * players
    obs = rules.observe()
    assert obs.shape == (n, rules.obs_dim) == (n, 10 + 5 * (n - 1)) and obs.dtype == np.float32
    assert rules.state().shape == (rules.state_dim,) == (9 * n,) and rules.state().dtype == np.float32
    assert np.abs(obs).max() <= 1.0
    # Every seat starts on its own arm, x ~ -0.8 in its team frame, heading down the road (+x),
    # with its target about 16 ahead.
    assert np.all(np.abs(obs[:, 0] + 0.8) <= 0.051)
    assert np.all(obs[:, 4] > np.cos(0.26))
    assert np.allclose(obs[:, 8], np.hypot(obs[:, 6], obs[:, 7]))
    assert np.all(np.abs(obs[:, 6] - 0.8) <= 0.051)
    assert np.all(obs[:, 9] == 1.0)
    # The first other seat is a teammate when there is one, and its position is relative.
    p = _positions(rules)
    for seat in range(n):
        other = [j for j in range(n) if j != seat and rules.team_of[j] == rules.team_of[seat]]
        other += [j for j in range(n) if rules.team_of[j] != rules.team_of[seat]]
        distances = np.hypot(*(p[other] - p[seat]).T) / (2 * ARM_LENGTH)
        assert np.allclose(np.hypot(obs[seat, 10::5], obs[seat, 11::5]), distances, atol=1e-6)
    tree = RULES.default_tree(n_teams, players)
    assert tree["scheme"] == "CP" and tree["reward"] == "ranking" and tree["scale"] == 100
    assert tree["params"] == {"order": "depart"} and len(tree["children"]) == n_teams
    leaves = list(tree["children"]) if players == 1 else [
        leaf for team in tree["children"] for leaf in team["children"]]
    if players > 1:
        assert all(team["scheme"] == "NL" for team in tree["children"])
    assert [leaf["agent"] for leaf in leaves] == [f"player_{i}" for i in range(n)]
    assert all((leaf["scheme"], leaf["reward"], leaf["scale"]) == ("IS", "target", 1) for leaf in leaves)
    picture = rules.render_topdown()
    assert picture.dtype == np.uint8 and picture.ndim == 3 and picture.shape[2] == 3


def test_observation_scales_motion_and_measures_agree():
    rules = CrossroadsRules(2, 2, "discrete")
    rules.reset(2)
    for _ in range(30):
        rules.step(np.full(4, FORWARD))
    obs, m = rules.observe(), rules.measures
    speed_from_obs = np.hypot(obs[:, 2], obs[:, 3]) * TOP_SPEED
    assert np.allclose(speed_from_obs, m.speed, rtol=1e-5)
    assert np.allclose(obs[:, 8] * 2 * ARM_LENGTH, m.target_distance, rtol=1e-5)
    facing = (obs[:, 4] * obs[:, 6] + obs[:, 5] * obs[:, 7]) / np.hypot(obs[:, 6], obs[:, 7])
    assert np.allclose(facing, m.facing_target, atol=1e-5)
    assert np.allclose(m.energy, 0.5)


def test_case_study_trees_cover_the_four_agents_of_2t2p():
    def agents(node):
        if isinstance(node, str):
            return [node]
        if "agent" in node:
            return [node["agent"]]
        return [a for child in node["children"] for a in agents(child)]

    assert set(CASE_STUDY_TREES) == {"all_IS", "all_CL", "CL_under_CP"}
    for tree in CASE_STUDY_TREES.values():
        assert sorted(agents(tree)) == [f"player_{i}" for i in range(4)]
    assert (CASE_STUDY_TREES["all_IS"]["scheme"], CASE_STUDY_TREES["all_IS"]["reward"]) == ("IS", "target")
    assert (CASE_STUDY_TREES["all_CL"]["scheme"], CASE_STUDY_TREES["all_CL"]["reward"]) == ("CL", "team_target")
    cp = CASE_STUDY_TREES["CL_under_CP"]
    assert (cp["scheme"], cp["reward"]) == ("CP", "ranking")
    assert [(c["scheme"], c["reward"]) for c in cp["children"]] == [("CL", "team_target")] * 2


def test_box_agents_play_too():
    rules = CrossroadsRules(2, 2, "discrete", agent_shape="box", arrival_radius=1.5)
    rules.reset(0)
    for _ in range(rules.default_max_cycles):
        rules.step(rules.heuristic(rules.observe(), "discrete"))
        if rules.game_over:
            break
    assert rules.game_over


def test_unknown_or_bad_kwargs_are_refused_with_the_valid_ones_listed():
    with pytest.raises(ValueError, match=r"Crossroads has no option 'speed_limit'; its options: arrival_radius: "
                                         r".*agent_shape"):
        CrossroadsRules(2, 2, "discrete", speed_limit=3)
    with pytest.raises(ValueError, match=r"Crossroads option arrival_radius must be a number in \(0.0, 8.0\) "
                                         r"\(default 1.0"):
        CrossroadsRules(2, 2, "discrete", arrival_radius=-1)
    with pytest.raises(ValueError, match=r"Crossroads option agent_shape must be one of 'circle', 'box'"):
        CrossroadsRules(2, 2, "discrete", agent_shape="triangle")
    with pytest.raises(ValueError, match="no 3T1P layout; valid layouts: 2T1P, 2T2P, 2T3P, 2T4P, 4T1P"):
        CrossroadsRules(3, 1, "discrete")
    with pytest.raises(ValueError, match="action_type 'analog' is not offered"):
        CrossroadsRules(2, 2, "analog")
