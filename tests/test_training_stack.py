"""Learners stacked: a run's results do not depend on how its learners are stacked, and a stack of
one updates as the one-learner PPO update does."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import torch

from arena_league.training import DPPO, PBT, PPOConfig, make_env_fn
from arena_league.training.ppo import Learner, ppo_update
from arena_league.training.rollout import RolloutCollector, learner_batch
from arena_league.training.stack import LearnerStack, stackable, stacks_of
from arena_league.training.trainer import TrainerBase

SMALL = PPOConfig(num_envs=2, num_steps=32, num_minibatches=2, update_epochs=2, hidden=(16, 16),
                  critic_hidden=(16, 16))


def _weights(learner: Learner) -> dict[str, torch.Tensor]:
    params = {f"actor.{k}": v for k, v in learner.actor.state_dict().items()}
    if learner.critic is not None:
        params.update({f"critic.{k}": v for k, v in learner.critic.state_dict().items()})
    if learner.log_std is not None:
        params["log_std"] = learner.log_std.detach()
    return params


def _trained(trainer_cls: type[TrainerBase], stacked: bool, iterations: int = 3, **options) -> TrainerBase:
    trainer = trainer_cls(make_env_fn(options.pop("game", "Crossroads-2T2P-v1")), SMALL, seed=5, **options)
    trainer.stack_learners = stacked
    for _ in range(iterations):
        trainer.iterate()
    return trainer


@pytest.mark.parametrize(("trainer_cls", "options"), [
    (DPPO, {}),
    (DPPO, {"game": "Sumo-2T1P-v1"}),
    (PBT, {"population_size": 3, "interval": 2, "min_matches": 1}),
])
def test_learners_train_the_same_stacked_or_one_by_one(trainer_cls: type[TrainerBase], options: dict) -> None:
    stacked = _trained(trainer_cls, True, **copy.deepcopy(options))
    alone = _trained(trainer_cls, False, **copy.deepcopy(options))
    assert len(stacked.learners) > 1
    for a, b in zip(stacked.learners, alone.learners):
        wa, wb = _weights(a), _weights(b)
        assert wa.keys() == wb.keys()
        for name in wa:
            torch.testing.assert_close(wa[name], wb[name], rtol=1e-5, atol=1e-6, msg=f"{a.name} {name}")
        assert a.updates == b.updates
        for p, q in zip(a.trainable_parameters(), b.trainable_parameters()):
            assert (p in a.optimiser.state) == (q in b.optimiser.state)
            if p in a.optimiser.state:
                torch.testing.assert_close(a.optimiser.state[p]["exp_avg"], b.optimiser.state[q]["exp_avg"],
                                           rtol=1e-5, atol=1e-7)
    # learners that held unequal numbers of seats were padded in the stack, and more than one learned
    assert sum(learner.updates > 0 for learner in stacked.learners) > 1


def _rollout_batch(game: str, learner_seed: int = 3) -> tuple[Learner, object]:
    env_fn = make_env_fn(game)
    probe = env_fn()
    from arena_league.training.ppo import game_architecture

    learner = Learner(game_architecture(SMALL, probe), SMALL, learner_seed)
    collector = RolloutCollector(env_fn, 2, seed=1, seating=lambda k, e: np.zeros(probe.rules.n_agents, dtype=np.int64))
    rollout = collector.collect([learner], 48)
    return learner, learner_batch(rollout, 0, learner)


@pytest.mark.parametrize("game", ["Crossroads-2T2P-v1", "Sumo-2T1P-v1", "GoBang-2T1P-v1", "Snake-2T2P-v1"])
def test_a_stack_of_one_updates_as_the_ppo_update(game: str) -> None:
    learner, batch = _rollout_batch(game)
    reference = copy.deepcopy(learner)
    stats = LearnerStack([learner]).update([batch], [1e-3])[0]
    expected = ppo_update(reference, batch, reference.config, reference.optimiser, reference.rng, learning_rate=1e-3)
    for name, value in _weights(reference).items():
        torch.testing.assert_close(_weights(learner)[name], value, rtol=1e-4, atol=1e-6, msg=name)
    assert stats.policy_loss == pytest.approx(expected.policy_loss, rel=1e-4, abs=1e-6)
    assert stats.value_loss == pytest.approx(expected.value_loss, rel=1e-4)
    assert stats.entropy == pytest.approx(expected.entropy, rel=1e-5)
    assert stats.explained_variance == pytest.approx(expected.explained_variance, rel=1e-3, abs=1e-5)
    # the Adam moments went back into the learner's own optimiser: a second update, one by one, agrees too
    again = copy.deepcopy(learner)
    LearnerStack([learner]).update([batch], [1e-3])
    ppo_update(again, batch, again.config, again.optimiser, again.rng, learning_rate=1e-3)
    for name, value in _weights(again).items():
        torch.testing.assert_close(_weights(learner)[name], value, rtol=1e-4, atol=1e-6, msg=name)


def test_a_stacked_learner_acts_as_it_does_alone() -> None:
    learner, _ = _rollout_batch("Crossroads-2T2P-v1")
    other = Learner(learner.architecture, learner.config, 11)
    rng = np.random.default_rng(0)
    obs = rng.standard_normal((9, learner.architecture.obs_dim)).astype(np.float32)
    noise = rng.random(9)
    members = np.array([0, 1, 1, 0, 1, 0, 0, 0, 1])
    together = LearnerStack([learner, other]).act(members, obs, noise, None, obs)
    for index, single in enumerate((learner, other)):
        rows = members == index
        alone = single.act(obs[rows], noise[rows], critic_input=obs[rows])
        np.testing.assert_array_equal(together.env_actions[rows], alone.env_actions)
        np.testing.assert_allclose(together.logprobs[rows], alone.logprobs, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(together.values[rows], alone.values, rtol=1e-5, atol=1e-6)


def test_learners_that_differ_in_what_an_update_shares_are_not_stacked() -> None:
    learner, _ = _rollout_batch("Crossroads-2T2P-v1")
    same = Learner(learner.architecture, learner.config, 4)
    more_epochs = Learner(learner.architecture, PPOConfig.with_overrides(learner.config, update_epochs=3), 5)
    gru = Learner(learner.architecture.__class__(**{**learner.architecture.__dict__, "family": "gru",
                                                      "gru_size": 8}), learner.config, 6)
    assert stackable([learner, same])
    assert not stackable([learner, more_epochs])
    assert not stackable([gru])
    assert stacks_of([0, 1, 2, 3], [learner, more_epochs, same, gru]) == [[0, 2], [1], [3]]
    with pytest.raises(ValueError, match="do not stack"):
        LearnerStack([learner, more_epochs])


@pytest.mark.parametrize("game", ["Crossroads-2T2P-v1", "Sumo-2T1P-v1"])
def test_a_snapshot_pool_plays_as_the_stacked_policy(game: str) -> None:
    from arena_league.policies.families import StackedPolicy
    from arena_league.training.stack import SnapshotPool

    learner, _ = _rollout_batch(game)
    members = [Learner(learner.architecture, learner.config, seed).actor_parameters() for seed in range(5)]
    pool = SnapshotPool(learner.architecture, members)
    reference = StackedPolicy(learner.architecture, members, compute_dtype=torch.float32)
    rng = np.random.default_rng(2)
    for owners in (np.array([4, 0, 4, 2, 2, 4, 0]), np.array([1]), np.array([3, 3, 3])):
        obs = rng.standard_normal((len(owners), learner.architecture.obs_dim)).astype(np.float32)
        uniforms = rng.random((len(owners), max(1, learner.architecture.act_dim)))
        ours, _ = pool.act(obs, uniforms, owners=owners)
        theirs, _ = reference.act(obs, uniforms, owners=owners)
        np.testing.assert_allclose(ours, theirs, rtol=1e-5, atol=1e-6)
    with pytest.raises(ValueError, match="owners"):
        pool.act(obs, uniforms, owners=np.array([5, 0, 0]))
