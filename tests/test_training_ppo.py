"""The PPO core: GAE by hand, value normalisation, a learner that improves within seconds on a tiny
game (discrete, recurrent, both continuous heads), bit-identical runs from one seed, and the update
reused without a critic and with a centralised critic's input (what the CC and CF learners need)."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from line_race import make_line_race
from scipy.special import ndtri

from arena_league.policies import Architecture, TorchPolicy
from arena_league.training import PPO, Batch, Learner, PPOConfig, RunningMeanStd, gae, make_env_fn, ppo_update
from arena_league.training.rollout import RolloutCollector, learner_batch

#: Every seat pays 1 per step in play: the return is minus the steps a seat takes to finish.
HURRY = {"scheme": "CP", "reward": "ranking", "scale": 1, "children": [
    {"agent": "player_0", "scheme": "IS", "reward": "time_penalty", "scale": 1},
    {"agent": "player_1", "scheme": "IS", "reward": "time_penalty", "scale": 1}]}
SMALL = PPOConfig(num_envs=8, num_steps=32, learning_rate=3e-3, hidden=(16,), critic_hidden=(16,))


def line_race():
    return make_line_race(2, 1, tree=HURRY)


def returns_of(trainer, iterations: int) -> list[float]:
    return [trainer.iterate()["episode_return"] for _ in range(iterations)]


def test_gae_by_hand():
    gamma, lam = 0.9, 0.8
    rewards = np.array([[1.0], [0.0], [2.0]])
    values = np.array([[0.5], [0.4], [0.3]])
    dones = np.array([[False], [True], [False]])
    next_values = np.array([0.7])
    adv, ret = gae(rewards, values, dones, next_values, gamma, lam)
    d2 = 2.0 + gamma * 0.7 - 0.3
    d1 = 0.0 - 0.4  # the episode ended with step 1: no bootstrap, no carry
    d0 = 1.0 + gamma * 0.4 - 0.5
    expected = np.array([d0 + gamma * lam * d1, d1, d2])
    np.testing.assert_allclose(adv[:, 0], expected, rtol=1e-6)
    np.testing.assert_allclose(ret[:, 0], expected + values[:, 0], rtol=1e-6)


def test_running_mean_std_matches_numpy():
    rng = np.random.default_rng(0)
    chunks = [rng.normal(3.0, 2.0, size=n) for n in (5, 50, 500)]
    stats = RunningMeanStd(epsilon=0.0)
    for chunk in chunks:
        stats.update(chunk)
    everything = np.concatenate(chunks)
    assert stats.mean == pytest.approx(everything.mean())
    assert stats.std == pytest.approx(everything.std())


def test_ppo_return_rises_on_line_race():
    ppo = PPO(line_race, SMALL, seed=0)
    returns = returns_of(ppo, 14)
    # random play takes about 10 steps to run 10 cells; running every step takes 5
    assert np.mean(returns[:2]) < -8.5
    assert np.mean(returns[-3:]) > -6.0


def test_gru_actor_improves_on_line_race():
    config = PPOConfig.with_overrides(SMALL, family="gru", gru_size=8)
    ppo = PPO(line_race, config, seed=0)
    assert ppo.learners[0].architecture.recurrent
    returns = returns_of(ppo, 10)
    assert np.mean(returns[-3:]) > np.mean(returns[:2]) + 2.0


@pytest.mark.parametrize("head", ["clip", "tanh"])
def test_continuous_heads_improve_on_crossroads(head):
    env_fn = make_env_fn("Crossroads-2T1P-v1", max_cycles=60, action_type="continuous")
    config = PPOConfig(num_envs=8, num_steps=64, learning_rate=1e-3, continuous_head=head)
    ppo = PPO(env_fn, config, seed=0)
    returns = returns_of(ppo, 10)
    # the default tree pays the progress toward one's target: driving there must be learnt
    assert np.mean(returns[-2:]) > np.mean(returns[:2]) + 2.5
    rollout = ppo.collector.collect(ppo.learners, 4)
    assert np.abs(rollout.env_actions).max() <= 1.0
    # A snapshot carries the learned log_std and samples as the learner does from the same draws.
    learner = ppo.learners[0]
    snapshot = TorchPolicy(learner.snapshot_architecture, learner.snapshot_parameters())
    assert snapshot.architecture.noise == {"clip": "gaussian", "tanh": "squashed"}[head]
    obs = rollout.obs.reshape(-1, rollout.obs.shape[-1])[:64]
    uniforms = np.random.default_rng(1).random((64, learner.architecture.act_dim))
    sampled = learner.act(obs, ndtri(uniforms)).env_actions
    np.testing.assert_allclose(snapshot.act(obs, uniforms)[0], sampled, atol=1e-5)


def test_same_seed_same_parameters_after_two_updates():
    def parameters(seed):
        ppo = PPO(line_race, SMALL, seed=seed)
        returns_of(ppo, 2)
        learner = ppo.learners[0]
        return {**learner.actor.state_dict(), **{f"critic.{k}": v for k, v in learner.critic.state_dict().items()}}

    first, again, other = parameters(3), parameters(3), parameters(4)
    assert all(torch.equal(first[k], again[k]) for k in first)
    assert not all(torch.equal(first[k], other[k]) for k in first)


def test_update_without_critic_takes_outside_advantages():
    """A counterfactual learner brings its own advantages and trains its critic elsewhere."""
    arch = Architecture("mlp", 3, "discrete", n_actions=3, hidden=(8,))
    learner = Learner(arch, SMALL, seed=0, critic_dim=0)
    assert learner.critic is None
    obs = torch.rand(64, 3)
    actions = torch.tensor([2, 0] * 32)
    advantages = torch.tensor([1.0, -1.0] * 32)  # action 2 did better than action 0
    with torch.no_grad():
        logprobs, _ = learner.evaluate(obs, actions)
    batch = Batch(obs, actions, logprobs, advantages=advantages, returns=torch.zeros(64), values=torch.zeros(64))
    before = torch.softmax(learner.actor(obs)[0], 1)[:, 2].mean()
    stats = ppo_update(learner, batch, learner.config, learner.optimiser, np.random.default_rng(0))
    after = torch.softmax(learner.actor(obs)[0], 1)[:, 2].mean()
    assert stats.value_loss == 0.0
    assert after > before + 0.01  # the better action became more likely


class StateCritic(Learner):
    """A centralised critic as the CC learner builds one: global state plus a one-hot seat id."""

    needs_state = True

    def critic_features(self, obs, state, seat, n_agents):
        return np.concatenate([state, np.eye(n_agents, dtype=np.float32)[seat]], axis=1)


def test_centralised_critic_reads_state_and_seat():
    env_fn = make_env_fn("Crossroads-2T1P-v1", max_cycles=20)
    probe = env_fn()
    rules = probe.rules
    arch = Architecture("mlp", rules.obs_dim, "discrete", n_actions=rules.n_actions, hidden=(16,))
    learner = StateCritic(arch, SMALL, seed=0, critic_dim=rules.state_dim + rules.n_agents)
    collector = RolloutCollector(env_fn, 3, seed=0, seating=lambda k, e: np.zeros(rules.n_agents, dtype=np.int64))
    rollout = collector.collect([learner], 25)
    assert rollout.states.shape == (25, 3, rules.state_dim)
    np.testing.assert_array_equal(rollout.critic_inputs[0][:, :, : rules.state_dim],
                                  rollout.states[:, np.repeat(np.arange(3), rules.n_agents)])
    batch = learner_batch(rollout, 0, learner)
    assert batch.critic_input.shape == (25 * 3 * rules.n_agents, rules.state_dim + rules.n_agents)
    stats = learner.update(batch, np.random.default_rng(0))
    assert np.isfinite(stats.value_loss) and stats.value_loss > 0


def test_config_rejects_bad_values_with_the_fix():
    with pytest.raises(ValueError, match="cnn"):
        PPOConfig(family="cnn")
    with pytest.raises(ValueError, match="num_steps"):
        PPOConfig(num_steps=0)
    with pytest.raises(TypeError, match="unknown PPOConfig field"):
        PPOConfig.with_overrides(learning_rat=1e-3)
