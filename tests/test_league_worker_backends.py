"""A worker plays its jobs' matches where it is told (here, a process pool, or a Ray cluster), and
the league stores the same matches, once, whichever plays them."""

from __future__ import annotations

import pytest

from arena_league.league import (
    ensure_scripted_agents,
    open_home,
    queue_evaluation,
    recent_matches,
    run_worker,
)

GAME = "GoBang-2T1P-v1"


def _evaluated(home, **worker) -> list[tuple]:
    """The matches an evaluation job stores when a worker with ``worker`` options runs it."""
    with open_home(home) as league:
        base = ensure_scripted_agents(league, GAME)
        queue_evaluation(league, GAME, base, matches_per_pair=6, seed=3)
        summary = run_worker(league, until_idle=True, **worker)
        assert summary.completed == 1 and summary.failed == 0
        return sorted((m["match_key"], m["seed"], tuple((s["agent"], s["outcome"]) for s in m["seats"]))
                      for m in recent_matches(league, GAME, limit=100))


def test_a_worker_with_a_process_pool_stores_what_an_in_process_worker_stores(tmp_path):
    here = _evaluated(tmp_path / "here")
    pooled = _evaluated(tmp_path / "pool", backend="process", workers=2)
    assert len(here) == 6 and pooled == here


def test_a_worker_refuses_a_backend_it_does_not_know_before_taking_a_job(tmp_path):
    with open_home(tmp_path / "league") as league:
        queue_evaluation(league, GAME, ensure_scripted_agents(league, GAME), matches_per_pair=2)
        with pytest.raises(ValueError, match="unknown match backend 'slurm'; valid: inprocess, process, ray"):
            run_worker(league, until_idle=True, backend="slurm")
        with pytest.raises(ValueError, match="a Ray address is for --backend ray"):
            run_worker(league, until_idle=True, address="127.0.0.1:6379")
        assert recent_matches(league, GAME) == []  # the job is still queued, nothing played
