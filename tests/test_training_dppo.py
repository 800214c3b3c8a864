"""D-PPO: independent learners (one per seat or per team) that do not share parameters, each
improving on a tiny game within seconds."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from line_race import make_line_race

from arena_league.training import DPPO, PPOConfig

SMALL = PPOConfig(num_envs=8, num_steps=32, learning_rate=3e-3, hidden=(16,), critic_hidden=(16,))


def hurry(n_teams, players):
    seats = [f"player_{i}" for i in range(n_teams * players)]
    return {"scheme": "CP", "reward": "ranking", "scale": 1, "children": [
        {"agent": seat, "scheme": "IS", "reward": "time_penalty", "scale": 1} for seat in seats]}


def test_each_seat_learner_improves():
    dppo = DPPO(lambda: make_line_race(2, 1, tree=hurry(2, 1)), SMALL, seed=0)
    assert [lr.name for lr in dppo.learners] == ["seat0", "seat1"]
    records = [dppo.iterate() for _ in range(14)]
    for seat in range(2):
        early = np.mean([r["learner_returns"][seat] for r in records[:2]])
        late = np.mean([r["learner_returns"][seat] for r in records[-3:]])
        assert late > early + 2.0, (seat, early, late)
    # independent learners: the same start would still give different weights (different seeds and data)
    first, second = (lr.actor.state_dict() for lr in dppo.learners)
    assert not all(torch.equal(first[k], second[k]) for k in first)


def test_one_learner_per_team():
    dppo = DPPO(lambda: make_line_race(2, 2, tree=hurry(2, 2)), SMALL, seed=0, per="team")
    assert [lr.name for lr in dppo.learners] == ["team0", "team1"]
    rollout = dppo.collector.collect(dppo.learners, 8)
    np.testing.assert_array_equal(rollout.controllers[0, :4], [0, 0, 1, 1])
    record = dppo.iterate()
    assert len(record["losses"]) == 2 and all(np.isfinite(loss["policy_loss"]) for loss in record["losses"])
    with pytest.raises(ValueError, match="'agent'"):
        DPPO(lambda: make_line_race(2, 1), SMALL, per="squad")
