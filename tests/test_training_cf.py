"""CF, COMA's counterfactual baseline: the advantage against a hand computation, the critic's input
holding the other seats' actions fixed, TD(lambda) targets, learning a tiny team game, the
refusal of continuous actions, and ``run_scheme`` into loadable arena-policy snapshots."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from line_race import make_line_race

from arena_league.envs import make
from arena_league.policies import load_policy
from arena_league.training import run_scheme
from arena_league.training.cf import (
    CF,
    CFConfig,
    counterfactual_advantage,
    counterfactual_critic_inputs,
    policy_probabilities,
    td_lambda_targets,
)

TEAM_TREE = {"scheme": "NL", "reward": "none", "children": [
    {"scheme": "CL", "reward": "team_target", "children": ["player_0", "player_1"]},
    {"scheme": "CL", "reward": "team_target", "children": ["player_2", "player_3"]}]}


def line_race_fn(max_cycles: int = 5):
    return lambda: make_line_race(2, 2, tree=TEAM_TREE, max_cycles=max_cycles)


def test_counterfactual_advantage_matches_a_hand_computation():
    # Q of the seat's 3 actions with the others' actions fixed, and its policy:
    # baseline = 0.5 * 1 + 0.25 * 2 + 0.25 * 4 = 2
    q = torch.tensor([[1.0, 2.0, 4.0], [1.0, 2.0, 4.0], [3.0, -1.0, 0.0]])
    pi = torch.tensor([[0.5, 0.25, 0.25], [0.5, 0.25, 0.25], [0.0, 0.5, 0.5]])
    taken = torch.tensor([2, 0, 0])
    # row 3: baseline = 0.5 * -1 + 0.5 * 0 = -0.5; it took an action its policy never plays: 3 + 0.5
    torch.testing.assert_close(counterfactual_advantage(q, pi, taken), torch.tensor([2.0, -1.0, 3.5]))
    # the advantage has zero mean under the policy, whatever Q is
    every_action = counterfactual_advantage(q[:1].expand(3, 3), pi[:1].expand(3, 3), torch.arange(3))
    assert abs(float((pi[0] * every_action).sum())) < 1e-6


def test_critic_input_holds_the_other_seats_actions_and_not_the_own():
    state = np.array([0.5, -0.5], dtype=np.float32)
    acting = np.array([True, True, False])
    x = counterfactual_critic_inputs(state, np.array([1, 2, 0]), acting, n_actions=3)
    assert x.shape == (3, 2 + 3 + 9)
    # seat 0: state | id 0 | own block zero | seat 1 took 2 | seat 2 inactive: zero
    np.testing.assert_array_equal(x[0], [0.5, -0.5, 1, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0])
    # seat 1: seat 0 took 1, own block zero
    np.testing.assert_array_equal(x[1], [0.5, -0.5, 0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0])
    # changing only seat 1's action leaves seat 1's input unchanged (its alternatives share one
    # forward) and changes the others'
    y = counterfactual_critic_inputs(state, np.array([1, 0, 0]), acting, n_actions=3)
    np.testing.assert_array_equal(x[1], y[1])
    assert not np.array_equal(x[0], y[0])
    # leading axes ([T, K] in training) broadcast
    z = counterfactual_critic_inputs(np.stack([state, state])[None], np.array([[[1, 2, 0], [1, 0, 0]]]),
                                     np.ones((1, 2, 3), dtype=bool), n_actions=3)
    assert z.shape == (1, 2, 3, 14)


def test_baseline_equals_the_policy_weighted_q_of_every_counterfactual_joint_action():
    # Against the trained critic: for each alternative u' of seat a, build the joint action with
    # only seat a's action replaced, ask the critic for Q of u', and weight by pi(u').
    trainer = CF(line_race_fn(), CFConfig(num_envs=2, num_steps=8, update_epochs=1), seed=4)
    trainer.iterate()
    env = line_race_fn()()
    obs = env.reset_arrays(11)
    state, joint = env.state(), np.array([2, 0, 1, 1])
    acting = np.ones(4, dtype=bool)
    probs = policy_probabilities(trainer.learners[0], torch.from_numpy(obs), None)
    for seat in range(4):
        counterfactual_q = []
        for alternative in range(3):
            u = joint.copy()
            u[seat] = alternative
            x = torch.from_numpy(counterfactual_critic_inputs(state, u, acting, 3)[seat])
            with torch.no_grad():
                counterfactual_q.append(float(trainer.critic(x[None])[0, alternative]))
        by_hand = counterfactual_q[joint[seat]] - float(np.dot(probs[seat].numpy(), counterfactual_q))
        x = torch.from_numpy(counterfactual_critic_inputs(state, joint, acting, 3)[seat])
        with torch.no_grad():
            advantage = counterfactual_advantage(trainer.critic(x[None]), probs[seat][None],
                                                 torch.tensor([joint[seat]]))
        assert float(advantage[0]) == pytest.approx(by_hand, abs=1e-5)


def test_td_lambda_targets_by_hand():
    rewards = np.array([[1.0], [2.0], [3.0]], dtype=np.float32)
    q = np.array([[10.0], [20.0], [30.0]], dtype=np.float32)
    # no episode end: G2 = q2 bootstraps (no target of its own); G1 = 2 + 0.9 * 30 = 29;
    # G0 = 1 + 0.9 * (0.5 * 20 + 0.5 * 29) = 23.05
    targets, valid = td_lambda_targets(rewards, np.zeros((3, 1), dtype=bool), q, gamma=0.9, td_lambda=0.5)
    np.testing.assert_allclose(targets[:, 0], [23.05, 29.0, 30.0], rtol=1e-6)
    assert valid[:, 0].tolist() == [True, True, False]
    # the episode ends with step 1: G1 = 2; G0 = 1 + 0.9 * (0.5 * 20 + 0.5 * 2) = 10.9; step 2
    # starts a new episode and still has no target
    dones = np.array([[False], [True], [False]])
    targets, valid = td_lambda_targets(rewards, dones, q, gamma=0.9, td_lambda=0.5)
    np.testing.assert_allclose(targets[:2, 0], [10.9, 2.0], rtol=1e-6)
    assert valid[:, 0].tolist() == [True, True, False]
    # an episode ending with the last step gives it its reward as target; lambda 0 is one-step TD
    dones = np.array([[False], [False], [True]])
    targets, valid = td_lambda_targets(rewards, dones, q, gamma=0.9, td_lambda=0.0)
    np.testing.assert_allclose(targets[:, 0], [1 + 0.9 * 20, 2 + 0.9 * 30, 3.0], rtol=1e-6)
    assert valid.all()


def test_cf_improves_on_a_cooperative_line_race():
    trainer = CF(line_race_fn(), CFConfig(num_envs=8, num_steps=32), seed=0)
    records = [trainer.iterate() for _ in range(10)]
    returns = [r["episode_return"] for r in records]
    assert returns[0] < 6.0
    assert np.mean(returns[-3:]) > returns[0] + 2.5, returns
    assert np.mean(returns[-3:]) > 8.5, returns
    # the critic trained: it explains most of its TD(lambda) targets by the end
    assert records[-1]["losses"][0]["explained_variance"] > 0.3


def test_cf_refuses_continuous_actions_with_the_fix(tmp_path):
    with pytest.raises(ValueError, match="needs discrete actions.*action_type='discrete'.*'cc'"):
        CF(lambda: make("Crossroads-2T2P-v1", action_type="continuous", max_cycles=10), seed=0)
    with pytest.raises(ValueError, match="needs discrete actions"):
        run_scheme("cf", "Soccer-2T2P-v1", steps=16, seed=0, snapshot_every=None, out_dir=tmp_path,
                   action_type="continuous", max_cycles=10, num_envs=1, num_steps=8)


def test_cf_runs_end_to_end_through_run_scheme(tmp_path):
    game = "Crossroads-2T2P-v1"
    snapshots = run_scheme("cf", game, steps=128, seed=3, snapshot_every=64, out_dir=tmp_path, max_cycles=16,
                           num_envs=2, num_steps=32, update_epochs=2, td_lambda=0.6)
    assert [s.steps for s in snapshots] == [64, 128]
    for snapshot in snapshots:
        manifest = json.loads((snapshot.path / "manifest.json").read_text())
        assert manifest["provenance"]["scheme"] == "cf"
        policy = load_policy(snapshot.path, game)
        actions, _ = policy.act(np.zeros((3, 25), dtype=np.float32), np.full((3, 1), 0.5))
        assert actions.shape == (3,) and ((actions >= 0) & (actions < 5)).all()
    config = snapshots[-1].metrics["config"]
    assert config["td_lambda"] == 0.6 and config["critic_lr"] == CFConfig().critic_lr
    assert snapshots[-1].metrics["critic_steps"] > 0
    # a finished run asked for again is read back, not retrained
    again = run_scheme("cf", game, steps=128, seed=3, snapshot_every=64, out_dir=tmp_path, max_cycles=16,
                       num_envs=2, num_steps=32, update_epochs=2, td_lambda=0.6)
    assert [s.path for s in again] == [s.path for s in snapshots]
    assert all(torch.equal(a.params[k], b.params[k]) for a, b in zip(again, snapshots) for k in a.params)
