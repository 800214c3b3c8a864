"""The lockstep rollout collector: slots and controllers, learners' batches hold only their own
seats, episodes end where the env says, turn-based games with masks, seeded determinism."""

from __future__ import annotations

import numpy as np
import pytest
from line_race import make_line_race

from arena_league.policies import StackedPolicy, init_parameters, scripted_policy
from arena_league.training import Learner, Opponent, PPOConfig, RolloutCollector, learner_batch, make_env_fn
from arena_league.training.ppo import game_architecture

CONFIG = PPOConfig(hidden=(16,), critic_hidden=(16,))


def learner_for(env_fn, seed=0):
    return Learner(game_architecture(CONFIG, env_fn()), CONFIG, seed)


def test_learner_seats_and_opponent_seats():
    env_fn = make_env_fn("Crossroads-2T2P-v1", max_cycles=15)
    learner = learner_for(env_fn)
    random = scripted_policy("random", "Crossroads-2T2P-v1")
    # team 0 is the learner's, team 1 the scripted opponent's
    collector = RolloutCollector(env_fn, 3, seed=0, seating=lambda k, e: np.array([0, 0, -1, -1]),
                                 opponents=[Opponent(random)])
    rollout = collector.collect([learner], 40)
    assert rollout.obs.shape == (40, 12, 25)
    assert rollout.env_steps == 120
    assert (rollout.controllers[:, rollout.seats < 2] == 0).all()
    assert (rollout.controllers[:, rollout.seats >= 2] == -1).all()
    # opponents' rows carry no value or log-probability; the learner's batch holds its seats only
    assert (rollout.values[:, rollout.seats >= 2] == 0).all()
    batch = learner_batch(rollout, 0, learner)
    assert len(batch) == 40 * 3 * 2
    # episodes end together every max_cycles steps at most, and are recorded with their result
    assert rollout.dones[14].all() and not rollout.dones[13].any()
    assert len(rollout.episodes) == 3 * 2
    for episode in rollout.episodes:
        assert episode.length == 15
        assert episode.team_scores.shape == (2,)
        assert list(episode.controllers) == [0, 0, -1, -1]


def test_stacked_opponents_play_their_own_members():
    env_fn = make_env_fn("Crossroads-2T1P-v1", max_cycles=10)
    learner = learner_for(env_fn)
    arch = learner.architecture
    pool = StackedPolicy(arch, [init_parameters(arch, 11), init_parameters(arch, 12)], greedy=True)
    # env k's opponent seat is played by pool member k % 2, all in one stacked forward
    collector = RolloutCollector(env_fn, 4, seed=0, seating=lambda k, e: np.array([0, -1 - (k % 2)]),
                                 opponents=[Opponent(pool, owner=0), Opponent(pool, owner=1)])
    rollout = collector.collect([learner], 12)
    for member in (0, 1):
        slots = [2 * k + 1 for k in range(4) if k % 2 == member]
        acted = rollout.acting[:, slots].reshape(-1)
        obs = rollout.obs[:, slots].reshape(-1, arch.obs_dim)[acted]
        expected, _ = pool.member(member).act(obs, np.zeros((len(obs), 1)))
        np.testing.assert_array_equal(rollout.env_actions[:, slots].reshape(-1)[acted], expected)


def test_same_seed_same_rollout():
    env_fn = make_env_fn("Crossroads-2T1P-v1", max_cycles=25)

    def collect(seed):
        collector = RolloutCollector(env_fn, 2, seed=seed, seating=lambda k, e: np.zeros(2, dtype=np.int64))
        return collector.collect([learner_for(env_fn)], 30)

    a, b, c = collect(5), collect(5), collect(6)
    for name in ("obs", "actions", "logprobs", "values", "rewards", "dones"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.actions, c.actions)


def test_turn_based_masked_game_plays_legal_moves():
    env_fn = make_env_fn("GoBang-2T1P-v1", env_kwargs={"size": 6})
    learner = learner_for(env_fn)
    collector = RolloutCollector(env_fn, 4, seed=0, seating=lambda k, e: np.zeros(2, dtype=np.int64))
    rollout = collector.collect([learner], 60)
    # one seat moves per step, and it only ever picks an empty cell (an illegal move would lose)
    assert (rollout.acting.reshape(60, 4, 2).sum(axis=2) == 1).all()
    acted = rollout.acting
    chosen = rollout.masks[acted, rollout.env_actions[acted]]
    assert chosen.all()
    assert rollout.episodes and all(e.team_scores.sum() == 1.0 for e in rollout.episodes)
    batch = learner_batch(rollout, 0, learner)
    assert int(batch.policy_mask.sum()) == int(acted.sum())


def test_seating_callback_errors_name_the_fix():
    env_fn = lambda: make_line_race(2, 1)  # noqa: E731
    with pytest.raises(ValueError, match="one per seat"):
        RolloutCollector(env_fn, 1, seed=0, seating=lambda k, e: np.zeros(3, dtype=np.int64))
    with pytest.raises(ValueError, match="set collector.opponents"):
        RolloutCollector(env_fn, 1, seed=0, seating=lambda k, e: np.array([0, -2]))
