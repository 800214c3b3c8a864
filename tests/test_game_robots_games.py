"""The four robot games one by one: how matches end and who wins, the heuristics against random
torques, the game cells of the observations, default trees, and PushBox's social-tree verification
(IS per agent, CL per team, CP at the root)."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs import make
from arena_league.envs.games.pushbox import BOX_TO_TARGET, TARGET, PushBoxRules
from arena_league.envs.games.runtogoal import RunToGoalRules
from arena_league.envs.games.sumo import SumoRules
from arena_league.envs.games.youshallnotpass import GOAL_LINE, ROLE, YouShallNotPassRules
from arena_league.envs.robots import StartPose, stand
from arena_league.envs.robots import observation as cells

STILL = np.zeros((2, 8), np.float32)


def pose(xy, yaw, roll=None, box_xy=None, box_yaw=None) -> StartPose:
    box_xy = np.zeros((0, 2)) if box_xy is None else np.asarray(box_xy, dtype=np.float64)
    box_yaw = np.zeros(len(box_xy)) if box_yaw is None else np.asarray(box_yaw, dtype=np.float64)
    return StartPose(np.asarray(xy, dtype=np.float64), np.asarray(yaw, dtype=np.float64), box_xy, box_yaw,
                     None if roll is None else np.asarray(roll, dtype=np.float64))


def duel(rules_cls, heuristic_team: int, opponent: str, seed: int, max_cycles: int = 400, **kwargs):
    """One match: the heuristic on ``heuristic_team``, random torques or standing on the other side."""
    rules = rules_cls(*rules_cls.layouts[0], **kwargs)
    rules.reset(seed)
    rng = np.random.default_rng(1000 + seed)
    other = rules.team_of != heuristic_team
    for _ in range(max_cycles):
        obs = rules.observe()
        actions = rules_cls.heuristic(obs, "continuous")
        if opponent == "random":
            actions[other] = rng.uniform(-1, 1, (int(other.sum()), 8))
        else:
            actions[other] = stand(obs[other])
        rules.step(actions)
        if rules.game_over:
            break
    if not rules.game_over:
        rules.finish()
    return rules


# --- Sumo -----------------------------------------------------------------------------------------------
def test_sumo_an_ant_out_of_the_ring_loses_at_once():
    rules = SumoRules(2, 1)
    rules.reset(0)
    rules.arrange(pose([[-0.5, 0.0], [2.3, 0.0]], [0.0, np.pi]))
    rules.step(STILL)
    assert rules.game_over
    assert rules.measures.outcome.tolist() == [1.0, -1.0] and rules.team_result().tolist() == [1.0, 0.0]
    assert rules.measures.alive.tolist() == [True, False]
    assert rules.events() == [{"kind": "out", "seat": 1}]


def test_sumo_a_fallen_ant_loses_and_both_at_once_is_a_draw():
    rules = SumoRules(2, 1)
    rules.reset(0)
    rules.arrange(pose([[-1.0, 0.0], [1.0, 0.0]], [0.0, np.pi], roll=[np.pi, 0.0]))
    rules.step(STILL)
    assert rules.game_over and rules.team_result().tolist() == [0.0, 1.0]
    assert rules.events() == [{"kind": "fall", "seat": 0}]
    rules.reset(1)
    rules.arrange(pose([[-2.5, 0.0], [1.0, 0.0]], [0.0, np.pi], roll=[0.0, np.pi]))
    rules.step(STILL)
    assert rules.game_over and rules.team_result().tolist() == [0.5, 0.5]
    assert rules.measures.outcome.tolist() == [0.0, 0.0]


def test_sumo_a_match_cut_at_max_cycles_is_a_draw():
    env = make("Sumo-2T1P-v1", max_cycles=5)
    env.reset(seed=0)
    for _ in range(5):
        _, _, term, trunc, _ = env.step({a: np.zeros(8, np.float32) for a in env.agents})
    assert all(trunc.values()) and not any(term.values())
    assert env.team_result().tolist() == [0.5, 0.5] and env.rules.measures.outcome.tolist() == [0.0, 0.0]


def test_sumo_heuristic_pushes_a_standing_ant_out_and_beats_random_torques():
    against_standing = [duel(SumoRules, seed % 2, "stand", seed).team_result()[seed % 2] for seed in range(8)]
    against_random = [duel(SumoRules, seed % 2, "random", seed).team_result()[seed % 2] for seed in range(8)]
    assert against_standing.count(1.0) >= 5 and 0.0 not in against_standing  # wins, or at worst a draw
    assert against_random.count(1.0) >= 7


# --- RunToGoal ---------------------------------------------------------------------------------------------
def test_run_to_goal_the_first_ant_over_its_line_wins():
    rules = RunToGoalRules(2, 1)
    rules.reset(0)
    rules.arrange(pose([[2.6, 0.5], [1.0, -0.5]], [0.0, np.pi]))  # ant 0 already past x = +2.5
    rules.step(STILL)
    assert rules.game_over and rules.team_result().tolist() == [1.0, 0.0]
    assert rules.measures.arrived.tolist() == [True, False] and rules.measures.active.tolist() == [False, True]
    assert rules.events() == [{"kind": "arrive", "seat": 0}]
    assert rules.observe()[:, cells.ACTIVE].tolist() == [0.0, 1.0]
    rules.reset(1)
    rules.arrange(pose([[2.6, 0.5], [-2.6, -0.5]], [0.0, np.pi]))
    rules.step(STILL)
    assert rules.team_result().tolist() == [0.5, 0.5]


def test_run_to_goal_target_is_the_goal_line_and_cut_is_a_draw():
    env = make("RunToGoal-2T1P-v1", max_cycles=3, field_length=6.0)
    env.reset(seed=0)
    rules = env.rules
    rules.arrange(pose([[-2.0, 0.4], [1.0, -0.3]], [0.0, np.pi]))
    assert rules.measures.target_distance == pytest.approx([5.0, 4.0], abs=1e-6)
    obs = rules.observe()
    np.testing.assert_allclose(obs[:, cells.TARGET], [[5.0 / 4, 0.0], [4.0 / 4, 0.0]], atol=1e-6)
    assert obs[:, cells.ROBOT_CELLS].tolist() == [0.75, 0.75]  # half the field, /4
    for _ in range(3):
        env.step({a: np.zeros(8, np.float32) for a in env.agents})
    assert not env.agents and env.team_result().tolist() == [0.5, 0.5]


def test_run_to_goal_heuristic_outruns_random_torques():
    # a flailing opponent met head-on can knock the runner over now and then
    wins = sum(duel(RunToGoalRules, seed % 2, "random", seed).team_result()[seed % 2] == 1.0 for seed in range(8))
    assert wins >= 6


# --- YouShallNotPass ------------------------------------------------------------------------------------------
def test_you_shall_not_pass_runner_crossing_wins_runner_falling_loses():
    rules = YouShallNotPassRules(2, 1)
    rules.reset(0)
    rules.arrange(pose([[2.6, 0.0], [0.5, 0.0]], [0.0, np.pi]))
    rules.step(STILL)
    assert rules.game_over and rules.team_result().tolist() == [1.0, 0.0]
    assert rules.measures.arrived.tolist() == [True, False]
    assert rules.events() == [{"kind": "arrive", "seat": 0}]
    rules.reset(0)
    rules.arrange(pose([[-2.0, 0.0], [0.5, 0.0]], [0.0, np.pi], roll=[np.pi, 0.0]))
    rules.step(STILL)
    assert rules.game_over and rules.team_result().tolist() == [0.0, 1.0]
    assert rules.events() == [{"kind": "fall", "seat": 0}]
    rules.reset(0)
    rules.arrange(pose([[-2.0, 0.0], [0.5, 0.0]], [0.0, np.pi], roll=[0.0, np.pi]))
    rules.step(STILL)
    assert not rules.game_over, "a fallen blocker plays on"
    rules.finish()
    assert rules.team_result().tolist() == [0.0, 1.0], "time out: the blocker wins"


def test_you_shall_not_pass_observations_say_role_and_goal_line():
    rules = YouShallNotPassRules(2, 1)
    rules.reset(0)
    rules.arrange(pose([[-2.0, 0.3], [0.5, -0.2]], [0.0, np.pi]))
    obs = rules.observe()
    assert obs[:, ROLE].tolist() == [1.0, -1.0]
    np.testing.assert_allclose(obs[:, GOAL_LINE], [4.5 / 4, -2.0 / 4], atol=1e-6)  # the blocker's frame is turned
    np.testing.assert_allclose(obs[1, cells.TARGET], [2.5 / 4, -0.5 / 4], atol=1e-6)  # the runner, turned
    with pytest.raises(ValueError, match=r"YouShallNotPass option blocker_distance must be a number in "
                                         r"\[0.5, field_length = 3.0\] \(default 2.0: .*\), not 3.5$"):
        YouShallNotPassRules(2, 1, field_length=3.0, blocker_distance=3.5)


def test_you_shall_not_pass_heuristics_beat_random_torques_on_both_sides():
    runner_wins = sum(duel(YouShallNotPassRules, 0, "random", seed).team_result()[0] == 1.0 for seed in range(4))
    blocker_wins = sum(duel(YouShallNotPassRules, 1, "random", seed).team_result()[1] == 1.0 for seed in range(4))
    assert runner_wins >= 3 and blocker_wins == 4


# --- PushBox -----------------------------------------------------------------------------------------------------
def test_push_box_a_box_on_the_target_takes_its_team_home_first():
    env = make("PushBox-2T2P-v1")
    env.reset(seed=0)
    rules = env.rules
    ants = [[-3.0, 0.5], [-3.0, -0.5], [3.0, -0.5], [3.0, 0.5]]
    rules.arrange(pose(ants, [0, 0, np.pi, np.pi], box_xy=[[1.5, 1.5], [0.2, 0.1]]))
    _, rewards, term, _, _ = env.step({a: np.zeros(8, np.float32) for a in env.agents})
    assert all(term.values())
    assert rules.measures.arrived.tolist() == [False, False, True, True]
    assert rules.measures.active.tolist() == [True, True, False, False]
    assert rules.team_result().tolist() == [0.0, 1.0] and rules.events() == [{"kind": "arrive", "team": 1}]
    # the ranking at the root pays +100 to the first team home, -100 to the other
    assert rewards["player_2"] - rewards["player_0"] == pytest.approx(200.0, abs=1.0)


def test_push_box_progress_is_the_box_distance_gained_and_shared_by_teammates():
    rules = PushBoxRules(2, 2)
    rules.reset(3)
    rng = np.random.default_rng(0)
    distance = rules.match.absolute[0, rules.complex_group["box_to_target"]].copy()
    for _ in range(40):
        obs = rules.observe()
        actions = PushBoxRules.heuristic(obs, "continuous")
        actions[2:] = rng.uniform(-1, 1, (2, 8))
        rules.step(actions)
        now = rules.match.absolute[0, rules.complex_group["box_to_target"]].copy()
        np.testing.assert_allclose(rules.measures.object_progress, distance - now, atol=1e-12)
        assert rules.measures.object_progress[0] == rules.measures.object_progress[1]
        distance = now
        box_to_target = rules.observe()[:, BOX_TO_TARGET] * cells.POSITION_UNIT
        np.testing.assert_allclose(np.linalg.norm(box_to_target, axis=1), now, atol=1e-5)
        obs = rules.observe()
        to_box = obs[:, cells.TARGET] * cells.POSITION_UNIT  # the IS target of a PushBox seat: its box
        np.testing.assert_allclose(np.linalg.norm(to_box, axis=1), rules.measures.target_distance, atol=1e-5)
        np.testing.assert_allclose(obs[:, TARGET], -obs[:, cells.POSITION], atol=1e-6)  # the target disc at 0


def test_push_box_cut_goes_to_the_nearer_box():
    rules = PushBoxRules(2, 2)
    rules.reset(0)
    ants = [[-3.0, 0.5], [-3.0, -0.5], [3.0, -0.5], [3.0, 0.5]]
    rules.arrange(pose(ants, [0, 0, np.pi, np.pi], box_xy=[[-1.0, 0.0], [1.6, 0.0]]))
    rules.finish()
    assert rules.team_result().tolist() == [1.0, 0.0] and rules.measures.outcome.tolist() == [1, 1, -1, -1]
    rules.reset(0)
    rules.arrange(pose(ants, [0, 0, np.pi, np.pi], box_xy=[[-1.5, 0.0], [1.5, 0.0]]))
    rules.finish()
    assert rules.team_result().tolist() == [0.5, 0.5]


def test_push_box_heuristic_team_gets_its_box_home_against_random_torques():
    wins = home = 0
    for seed in range(4):
        rules = duel(PushBoxRules, seed % 2, "random", seed, max_cycles=PushBoxRules.default_max_cycles)
        wins += rules.team_result()[seed % 2] == 1.0
        home += bool(rules.measures.arrived[rules.team_of == seed % 2].all())
    assert wins == 4 and home >= 3


def test_push_box_default_tree_is_the_papers_example_and_verifies_as_declared():
    from arena_league.envs.social.verify import verify

    tree = PushBoxRules.default_tree(2, 2)
    assert (tree["scheme"], tree["reward"], tree["params"]) == ("CP", "ranking", {"order": "depart"})
    for team, node in enumerate(tree["children"]):
        assert (node["scheme"], node["reward"]) == ("CL", "team_progress")
        assert [(leaf["agent"], leaf["scheme"], leaf["reward"]) for leaf in node["children"]] == [
            (f"player_{2 * team + k}", "IS", "robot_motion") for k in range(2)]
    report = verify("PushBox-2T2P-v1", samples=16, seed=0)
    verdicts = {node.path: (node.declared, node.verified) for node in report.nodes}
    assert verdicts["root"] == ("CP", "CP")
    assert verdicts["root/0"] == verdicts["root/1"] == ("CL", "CL")
    assert all(verdicts[f"root/{k // 2}/player_{k}"] == ("IS", "IS") for k in range(4))
    assert report.ok


@pytest.mark.parametrize("rules_cls", [SumoRules, RunToGoalRules, YouShallNotPassRules])
def test_duel_default_tree_is_win_loss_over_the_dense_motor_reward(rules_cls):
    tree = rules_cls.default_tree(2, 1)
    assert (tree["scheme"], tree["reward"], tree["scale"]) == ("CP", "win_loss", 100)
    assert [(c["agent"], c["scheme"], c["reward"], c["scale"]) for c in tree["children"]] == [
        ("player_0", "IS", "robot_motion", 1), ("player_1", "IS", "robot_motion", 1)]
