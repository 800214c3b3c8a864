"""The fair claim: among runnable jobs, workers take the owner with the fewest jobs running, then the
owner served least recently (priority orders an owner's own jobs), so one owner's burst never holds back another's
job; and the migration that records jobs' owners upgrades a league made before it. Times are an
injected clock; no worker runs."""

from __future__ import annotations

import threading
from datetime import UTC, datetime, timedelta

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from registry_fixtures import GAME_ID
from sqlalchemy import text

from arena_league.registry import (
    League,
    claim_job,
    complete_job,
    enqueue,
    ensure_game,
    get_job,
    open_league,
)
from arena_league.registry.db import alembic_config
from arena_league.registry.models import Base

pytest_plugins = ["registry_fixtures"]  # the league, pg_url, ... fixtures

START = datetime(2026, 11, 28, 12, 0, 0, tzinfo=UTC)


def queue(league: League, owner: str | None, count: int, *, kind: str = "verify", priority: int = 60) -> list[int]:
    with league.transaction() as session:
        return [enqueue(session, kind, {"n": i}, priority=priority, owner=owner,
                        run_after=START.replace(tzinfo=None)).id
                for i in range(count)]


def owners_in_claim_order(league: League, claims: int, *, complete: bool, workers: int = 1) -> list[str | None]:
    """Who owned each claimed job, claiming one a second; with ``complete``, each job ends before the
    next claim (one worker), else the jobs stay running (as many workers as claims)."""
    order = []
    for step in range(claims):
        job = claim_job(league, f"worker-{step % workers}", now=START + timedelta(seconds=step + 1))
        assert job is not None
        with league.reading() as session:
            order.append(get_job(session, job.id).owner)
        if complete:
            complete_job(league, job, now=START + timedelta(seconds=step + 1.5))
    return order


def test_one_worker_serves_owners_in_turn(league: League) -> None:
    queue(league, "alice", 6)
    queue(league, "bob", 2)
    assert owners_in_claim_order(league, 8, complete=True) == [
        "alice", "bob", "alice", "bob", "alice", "alice", "alice", "alice"]


def test_a_free_worker_takes_the_owner_with_fewest_jobs_running(league: League) -> None:
    queue(league, "alice", 300)
    queue(league, "bob", 1)
    # two workers: one runs alice's first job; the second takes bob's at once, not alice's second
    assert owners_in_claim_order(league, 3, complete=False) == ["alice", "bob", "alice"]


def test_priority_orders_an_owners_own_jobs(league: League) -> None:
    queue(league, "alice", 3)
    urgent = queue(league, "alice", 1, priority=100)
    queue(league, "bob", 1)
    first = claim_job(league, "w", now=START + timedelta(seconds=1))
    assert first is not None and first.id == urgent[0]
    assert owners_in_claim_order(league, 2, complete=False) == ["bob", "alice"]


def test_a_burst_of_a_higher_priority_kind_does_not_pass_another_owner(league: League) -> None:
    queue(league, "alice", 4, kind="replay", priority=70)
    queue(league, "bob", 1, kind="rank", priority=60)
    assert owners_in_claim_order(league, 3, complete=True) == ["alice", "bob", "alice"]


def test_the_leagues_own_jobs_count_as_one_owner(league: League) -> None:
    queue(league, None, 3, kind="evaluate")
    queue(league, "alice", 3)
    assert owners_in_claim_order(league, 6, complete=True) == [None, "alice", None, "alice", None, "alice"]


def test_an_expired_lease_is_still_taken_again_once(league: League) -> None:
    [job_id] = queue(league, "alice", 1)
    first = claim_job(league, "w1", lease_seconds=10, now=START + timedelta(seconds=1))
    assert first is not None and first.id == job_id
    assert claim_job(league, "w2", lease_seconds=10, now=START + timedelta(seconds=2)) is None
    again = claim_job(league, "w2", lease_seconds=10, now=START + timedelta(seconds=20))
    assert again is not None and again.id == job_id and again.attempt == 2


def test_a_league_made_before_job_owners_upgrades(fresh_league: League) -> None:
    with fresh_league.transaction() as session:
        ensure_game(session, GAME_ID)
    with fresh_league.engine.begin() as connection:
        command.downgrade(alembic_config(connection), "0006")
        connection.execute(text(
            "INSERT INTO jobs (kind, payload, status, priority, attempts, max_attempts, run_after, created_at) "
            "VALUES ('verify', '{}', 'queued', 60, 0, 3, '2026-11-01', '2026-11-01')"))
    url = fresh_league.engine.url.render_as_string(hide_password=False)
    reopened = open_league(url, home=fresh_league.home)
    try:
        with reopened.transaction() as session:
            old = session.execute(text("SELECT id, owner FROM jobs")).one()
            assert old.owner is None
            enqueue(session, "verify", {}, priority=60, owner="alice", run_after=START.replace(tzinfo=None))
        with reopened.engine.connect() as connection:
            assert compare_metadata(MigrationContext.configure(connection, opts={"compare_type": True}),
                                    Base.metadata) == []
        first = claim_job(reopened, "w", now=START + timedelta(seconds=1))
        assert first is not None and first.id == old.id  # the league's own and older: both never served
    finally:
        reopened.close()


def test_concurrent_fair_claims_take_each_job_once(league: League) -> None:
    for owner in ("alice", "bob", "carol", "dave"):
        queue(league, owner, 10)
    claimed: list[int] = []

    def claim_all(worker: str) -> None:
        while (job := claim_job(league, worker)) is not None:
            claimed.append(job.id)

    threads = [threading.Thread(target=claim_all, args=(f"w{i}",)) for i in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(claimed) == sorted(set(claimed)) and len(claimed) == 40
