"""PBT: matchmaking among the population with online Elo, the exploit/explore rule (copy below 30%
Elo-predicted chance, perturb by 0.8 or 1.2), a population that improves on a tiny game, and a run
whose snapshots load as arena-policy agents."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from line_race import make_line_race

from arena_league.policies import load_policy
from arena_league.training import PBT, PPOConfig, run_scheme

HURRY = {"scheme": "CP", "reward": "ranking", "scale": 1, "children": [
    {"agent": "player_0", "scheme": "IS", "reward": "time_penalty", "scale": 1},
    {"agent": "player_1", "scheme": "IS", "reward": "time_penalty", "scale": 1}]}
SMALL = PPOConfig(num_envs=8, num_steps=32, learning_rate=3e-3, hidden=(16,), critic_hidden=(16,))


def line_race():
    return make_line_race(2, 1, tree=HURRY)


def test_population_has_its_own_hyperparameters_and_ratings_move():
    pbt = PBT(line_race, SMALL, seed=0, population_size=4, interval=100)
    rates = [lr.config.learning_rate for lr in pbt.learners]
    assert len(set(rates)) == 4 and all(SMALL.learning_rate / 2 <= r <= SMALL.learning_rate * 2 for r in rates)
    pbt.iterate()
    assert pbt.matches.sum() > 0
    assert pbt.ratings.sum() == pytest.approx(4000.0)  # online Elo moves points between players
    assert not np.allclose(pbt.ratings, 1000.0)


def test_exploit_copies_a_much_stronger_learner_and_perturbs():
    pbt = PBT(line_race, SMALL, seed=0, population_size=2, min_matches=5, hyperparameters=("learning_rate", "ent_coef"))
    weak, strong = pbt.learners
    pbt.ratings[:] = [800.0, 1200.0]  # Elo-predicted chance of the weak one: 0.09
    pbt.matches[:] = [10, 10]
    events = pbt.exploit_and_explore()
    assert len(events) == 1 and "pbt0" in events[0]
    for name, tensor in strong.actor.state_dict().items():
        assert torch.equal(weak.actor.state_dict()[name], tensor)
    for hyper in ("learning_rate", "ent_coef"):
        ratio = getattr(weak.config, hyper) / getattr(strong.config, hyper)
        assert ratio == pytest.approx(0.8) or ratio == pytest.approx(1.2)
    assert pbt.ratings[0] == 1200.0 and pbt.matches[0] == 0
    # close ratings (chance >= 30%), or too few matches: nobody copies
    pbt.ratings[:] = [1000.0, 1100.0]
    pbt.matches[:] = [10, 10]
    assert pbt.exploit_and_explore() == []
    pbt.ratings[:] = [800.0, 1200.0]
    pbt.matches[:] = [2, 10]
    assert pbt.exploit_and_explore() == []


def test_population_improves():
    pbt = PBT(line_race, SMALL, seed=0, population_size=3, interval=4, min_matches=5)
    returns = [pbt.iterate()["episode_return"] for _ in range(12)]
    assert np.mean(returns[-3:]) > np.mean(returns[:2]) + 2.0


def test_run_scheme_saves_every_member(tmp_path):
    game = "Crossroads-2T1P-v1"
    snapshots = run_scheme("pbt", game, steps=512, seed=2, snapshot_every=None, out_dir=tmp_path, max_cycles=20,
                           num_envs=4, num_steps=64, hidden=(16,), population_size=3, interval=1, min_matches=1)
    assert [s.learner for s in snapshots] == ["pbt0", "pbt1", "pbt2"]
    for snapshot in snapshots:
        assert set(snapshot.metrics["hyperparameters"]) == {"learning_rate", "ent_coef"}
        assert "elo" in snapshot.metrics
        policy = load_policy(snapshot.path, game)
        obs = np.zeros((3, policy.spec.obs_dim), dtype=np.float32)
        actions, _ = policy.act(obs, np.full((3, 1), 0.5))
        assert actions.shape == (3,)
