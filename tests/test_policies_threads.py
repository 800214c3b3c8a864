"""Torch's thread count: league calls that run many tiny forwards use one thread and give the
caller's setting back, whether they end normally or raise."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from line_race import make_line_race

from arena_league.league import ensure_scripted_agents, evaluate, open_home, rank, submit
from arena_league.policies import torch_threads
from arena_league.training import PPO, PPOConfig

GAME = "Crossroads-2T2P-v1"
EXAMPLE = Path(__file__).resolve().parent.parent / "submissions" / "crossroads-2t2p-mlp.onnx"


@pytest.fixture
def two_threads():
    """The caller's setting, different from the one the league runs on."""
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    yield 2
    torch.set_num_threads(before)


def test_the_block_runs_on_the_count_asked_and_restores_after_an_error(two_threads):
    with torch_threads(1):
        assert torch.get_num_threads() == 1
    assert torch.get_num_threads() == two_threads
    with pytest.raises(RuntimeError, match="inside"), torch_threads(1):
        raise RuntimeError("inside")
    assert torch.get_num_threads() == two_threads
    with pytest.raises(ValueError, match="at least 1"), torch_threads(0):
        pass


def test_evaluate_and_rank_leave_the_callers_thread_count(tmp_path, two_threads):
    with open_home(tmp_path / "league") as league:
        scripted = ensure_scripted_agents(league, GAME)
        submit(league, EXAMPLE, GAME, "alice")
        evaluate(league, GAME, scripted, matches_per_pair=2)
        assert torch.get_num_threads() == two_threads
        rank(league, "alice", budget=8, population="league")
        assert torch.get_num_threads() == two_threads


def test_a_training_iteration_leaves_the_callers_thread_count(two_threads):
    config = PPOConfig(num_envs=2, num_steps=8, hidden=(8,), critic_hidden=(8,))
    trainer = PPO(lambda: make_line_race(2, 1), config, seed=0)
    trainer.iterate()
    assert torch.get_num_threads() == two_threads
