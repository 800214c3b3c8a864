"""The job queue: leases, retries, fencing of lost leases, crashed workers and concurrent claims."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections import Counter
from datetime import UTC, datetime, timedelta

import pytest
from registry_fixtures import (
    GAME_ID,
    HANDLERS,
    add_players,
    start_worker_process,
    wait_until,
)
from sqlalchemy import func, select

from arena_league.registry import (
    InvalidRecordError,
    JobContext,
    League,
    LeaseLostError,
    Match,
    MatchSeat,
    claim_job,
    complete_job,
    count_matches,
    enqueue,
    fail_job,
    get_job,
    list_jobs,
    queue_counts,
    renew_lease,
    run_worker,
)

pytest_plugins = ["registry_fixtures"]  # the league, pg_url, ... fixtures

T0 = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)


def _enqueue(league: League, kind: str = "eval", payload: dict | None = None, **options: object) -> int:
    """Queue a job, due from T0 (so tests that pass `now=` run on a fixed clock)."""
    options.setdefault("run_after", T0)
    with league.transaction() as session:
        return enqueue(session, kind, payload or {}, **options).id


def _job(league: League, job_id: int):
    with league.reading() as session:
        return get_job(session, job_id)


def _matches_per_job(league: League) -> Counter[int]:
    with league.reading() as session:
        return Counter(session.scalars(select(Match.job_id)))


def test_jobs_are_claimed_by_priority_then_age_and_only_once(league: League) -> None:
    low = _enqueue(league, priority=0)
    high = _enqueue(league, priority=5)
    later = _enqueue(league, run_after=T0 + timedelta(hours=1))
    other_kind = _enqueue(league, kind="report")

    first = claim_job(league, "w1", lease_seconds=7200, kinds=["eval"], now=T0)
    second = claim_job(league, "w2", lease_seconds=7200, kinds=["eval"], now=T0)
    assert (first.id, second.id) == (high, low)
    assert claim_job(league, "w3", kinds=["eval"], now=T0) is None  # `later` is not due, `report` not wanted
    assert claim_job(league, "w3", kinds=["eval"], now=T0 + timedelta(hours=1)).id == later
    assert claim_job(league, "w4", now=T0).id == other_kind
    assert first.attempt == 1 and first.lease_expires_at == T0 + timedelta(hours=2)
    with league.reading() as session:
        assert queue_counts(session) == {"queued": 0, "running": 4, "done": 0, "failed": 0, "cancelled": 0}


def test_an_expired_lease_is_reclaimed_and_the_old_worker_is_fenced_off(league: League) -> None:
    job_id = _enqueue(league, payload={"pairing": [1, 2]})
    old = claim_job(league, "worker-a", lease_seconds=10, now=T0)
    renewed = renew_lease(league, old, lease_seconds=10, now=T0 + timedelta(seconds=8))
    assert claim_job(league, "worker-b", lease_seconds=10, now=T0 + timedelta(seconds=12)) is None  # renewed

    new = claim_job(league, "worker-b", lease_seconds=10, now=T0 + timedelta(seconds=19))
    assert (new.id, new.attempt, new.payload) == (job_id, 2, {"pairing": [1, 2]})

    with pytest.raises(LeaseLostError, match="held by worker-b"):
        complete_job(league, renewed, {"winner": "a"})
    with pytest.raises(LeaseLostError):
        renew_lease(league, renewed)
    with pytest.raises(LeaseLostError):
        fail_job(league, renewed, "too late")
    complete_job(league, new, {"winner": "b"})

    job = _job(league, job_id)
    assert (job.status, job.result, job.attempts, job.lease_owner) == ("done", {"winner": "b"}, 2, None)
    with pytest.raises(LeaseLostError, match="now done"):
        complete_job(league, new, {"winner": "b again"})


def test_a_failing_job_is_retried_then_failed_with_its_error_kept(league: League) -> None:
    job_id = _enqueue(league, max_attempts=2)
    first = claim_job(league, "w", now=T0)
    assert fail_job(league, first, "ValueError: bad pairing", retry_delay_seconds=60, now=T0) == "queued"
    assert claim_job(league, "w", now=T0 + timedelta(seconds=30)) is None  # waiting out the retry delay
    second = claim_job(league, "w", now=T0 + timedelta(seconds=61))
    assert second.attempt == 2
    assert (
        fail_job(league, second, "ValueError: bad pairing again", now=T0 + timedelta(seconds=62)) == "failed"
    )
    job = _job(league, job_id)
    assert (job.status, job.error, job.attempts) == ("failed", "ValueError: bad pairing again", 2)
    assert job.finished_at == T0 + timedelta(seconds=62)
    assert claim_job(league, "w", now=T0 + timedelta(days=1)) is None


def test_a_job_whose_workers_keep_dying_stops_after_max_attempts(league: League) -> None:
    job_id = _enqueue(league, max_attempts=2)
    assert claim_job(league, "a", lease_seconds=10, now=T0).attempt == 1
    assert claim_job(league, "b", lease_seconds=10, now=T0 + timedelta(seconds=11)).attempt == 2
    assert claim_job(league, "c", lease_seconds=10, now=T0 + timedelta(seconds=22)) is None
    job = _job(league, job_id)
    assert job.status == "failed" and "lease expired on the last allowed attempt" in job.error


def test_the_worker_loop_runs_handlers_and_records_failures(league: League) -> None:
    red, blue = add_players(league)
    played = _enqueue(league, "play", {"game_id": GAME_ID, "agents": [red, blue], "n_matches": 3})
    broken = _enqueue(
        league, "play", {"game_id": GAME_ID, "agents": [red, 999], "n_matches": 1}, max_attempts=1
    )
    unhandled = _enqueue(league, "train")

    report = run_worker(league, HANDLERS, "w", lease_seconds=5, poll_seconds=0.01, until_idle=True)

    assert (report.completed, report.failed, report.lost) == (1, 1, 0)
    assert sorted(report.job_ids) == [played, broken]
    assert _job(league, played).result == {"created": 3, "existing": 0}
    failed = _job(league, broken)
    assert failed.status == "failed" and "InvalidRecordError" in failed.error and "agent #999" in failed.error
    assert _job(league, unhandled).status == "queued"  # no handler for "train": left for another worker
    with league.reading() as session:
        assert count_matches(session, GAME_ID) == 3


def test_the_lease_is_renewed_while_a_long_handler_runs(league: League) -> None:
    job_id = _enqueue(league, "slow")
    stolen: list[object] = []

    def slow(context: JobContext) -> str:
        for _ in range(24):  # 3 s, twice the lease, progressing all along
            time.sleep(0.125)
            context.heartbeat()
            stolen.append(claim_job(league, "thief", lease_seconds=5))
        return "finished"

    # a lease of 1.5 s is renewed every 0.5 s: a loaded machine's stall of a few tenths (a 0.6 s lease
    # once ran out under CI) does not let it lapse
    report = run_worker(league, {"slow": slow}, "w", lease_seconds=1.5, poll_seconds=0.01, max_jobs=1)
    assert report.completed == 1 and set(stolen) == {None}
    job = _job(league, job_id)
    assert (job.status, job.result, job.attempts) == ("done", "finished", 1)


def test_a_handler_that_makes_no_progress_is_not_kept_and_another_worker_takes_its_job(league: League) -> None:
    job_id = _enqueue(league, "stuck")
    taken: list[object] = []

    def stuck(context: JobContext) -> str:
        # no heartbeat: a hung agent or a deadlock; the lease runs out and another worker claims the job
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and not taken:
            time.sleep(0.05)
            claim = claim_job(league, "rescuer", lease_seconds=60)
            if claim is not None:
                taken.append(claim)
        return "too late"

    report = run_worker(league, {"stuck": stuck}, "w", lease_seconds=0.6, poll_seconds=0.01, max_jobs=1)
    assert taken and taken[0].id == job_id and taken[0].attempt == 2
    assert (report.completed, report.lost) == (0, 1)
    job = _job(league, job_id)
    assert (job.status, job.lease_owner, job.result) == ("running", "rescuer", None)


def test_a_worker_that_lost_its_lease_does_not_complete_the_job(league: League) -> None:
    job_id = _enqueue(league, "long")

    def overtaken(context: JobContext) -> str:
        # Another worker, its clock past our lease, takes the job over.
        later = datetime.now(UTC) + timedelta(seconds=5)
        assert claim_job(league, "newcomer", lease_seconds=60, now=later).id == context.job.id
        assert context.lease_lost.wait(5), "the lease keeper did not notice"
        return "stale result"

    report = run_worker(league, {"long": overtaken}, "old", lease_seconds=0.3, poll_seconds=0.01, max_jobs=1)
    assert (report.completed, report.lost) == (0, 1)
    job = _job(league, job_id)
    assert (job.status, job.lease_owner, job.attempts, job.result) == ("running", "newcomer", 2, None)


def test_ctrl_c_hands_the_job_back(league: League) -> None:
    job_id = _enqueue(league, "interrupted")

    def interrupted(context: JobContext) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_worker(league, {"interrupted": interrupted}, "w", lease_seconds=5, max_jobs=1)
    job = _job(league, job_id)
    assert (job.status, job.attempts, job.lease_owner) == ("queued", 0, None)


def test_payloads_and_results_must_be_json(league: League) -> None:
    with pytest.raises(InvalidRecordError, match="not JSON"), league.transaction() as session:
        enqueue(session, "eval", {"when": datetime.now(UTC)})
    job_id = _enqueue(league, "odd")
    report = run_worker(league, {"odd": lambda context: {1.5, 2.5}}, "w", max_jobs=1, poll_seconds=0.01)
    assert report.failed == 1
    assert "not JSON" in _job(league, job_id).error
    with league.reading() as session:
        assert [job.id for job in list_jobs(session, status="queued")] == [job_id]  # retried later


def test_a_worker_killed_mid_job_is_retried_without_duplicate_matches(league: League) -> None:
    red, blue = add_players(league)
    n_matches = 8
    job_id = _enqueue(
        league, "play", {"game_id": GAME_ID, "agents": [red, blue], "n_matches": n_matches, "delay_s": 0.1}
    )

    def recorded() -> int:
        with league.reading() as session:
            return count_matches(session, GAME_ID)

    doomed = start_worker_process(league, "doomed-worker", lease_seconds=1.0)
    wait_until(lambda: recorded() >= 3)
    os.kill(doomed.pid, signal.SIGKILL)
    doomed.wait(timeout=10)
    assert doomed.returncode == -signal.SIGKILL

    crashed = _job(league, job_id)
    recorded_before = recorded()
    assert (crashed.status, crashed.lease_owner, crashed.attempts) == ("running", "doomed-worker", 1)
    assert 3 <= recorded_before < n_matches

    # The lease runs out within a second; the next worker takes the job and finishes it.
    report = run_worker(league, HANDLERS, "rescuer", lease_seconds=5, poll_seconds=0.05, max_jobs=1)

    assert (report.job_ids, report.completed) == ([job_id], 1)
    job = _job(league, job_id)
    assert (job.status, job.attempts, job.lease_owner) == ("done", 2, None)
    assert job.result == {"created": n_matches - recorded_before, "existing": recorded_before}
    with league.reading() as session:
        assert session.scalar(select(func.count()).select_from(Match)) == n_matches
        assert session.scalar(select(func.count()).select_from(MatchSeat)) == 4 * n_matches
        keys = list(session.scalars(select(Match.match_key)))
    assert sorted(keys) == sorted(f"job-{job_id}/match-{i}" for i in range(n_matches))
    # Nothing is left to run: the job completed once.
    assert run_worker(league, HANDLERS, "late", lease_seconds=5, until_idle=True).job_ids == []


def test_concurrent_claims_hand_each_job_to_one_worker(league: League) -> None:
    jobs = {_enqueue(league) for _ in range(3)}
    barrier = threading.Barrier(8)
    claimed: list[object] = []

    def claim(worker: str) -> None:
        barrier.wait()
        claimed.append(claim_job(league, worker, lease_seconds=30))

    threads = [threading.Thread(target=claim, args=(f"w{i}",)) for i in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    winners = [job for job in claimed if job is not None]
    assert sorted(job.id for job in winners) == sorted(jobs)
    assert len({job.worker_id for job in winners}) == 3


def test_two_worker_threads_run_each_job_exactly_once(league: League) -> None:
    red, blue = add_players(league)
    payload = {"game_id": GAME_ID, "agents": [red, blue], "delay_s": 0.005}
    jobs = {_enqueue(league, "play-fresh", payload) for _ in range(24)}
    reports = []

    def work(worker: str) -> None:
        reports.append(
            run_worker(league, HANDLERS, worker, lease_seconds=10, poll_seconds=0.01, until_idle=True)
        )

    threads = [threading.Thread(target=work, args=(f"w{i}",)) for i in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()

    assert _matches_per_job(league) == Counter(dict.fromkeys(jobs, 1))
    claimed = [job_id for report in reports for job_id in report.job_ids]
    assert sorted(claimed) == sorted(jobs)
    with league.reading() as session:
        assert queue_counts(session)["done"] == len(jobs)


def test_two_worker_processes_run_each_job_exactly_once(sqlite_league: League) -> None:
    # SQLite is where processes differ from threads (file locks); PostgreSQL sees connections
    # either way, and the thread test above covers it.
    league = sqlite_league
    red, blue = add_players(league)
    payload = {"game_id": GAME_ID, "agents": [red, blue], "delay_s": 0.01}
    jobs = {_enqueue(league, "play-fresh", payload) for _ in range(20)}

    workers = [start_worker_process(league, f"proc-{i}", lease_seconds=10, max_jobs=None) for i in range(2)]
    for worker in workers:
        _, stderr = worker.communicate(timeout=60)
        assert worker.returncode == 0, stderr.decode()

    assert _matches_per_job(league) == Counter(dict.fromkeys(jobs, 1))
    with league.reading() as session:
        owners = Counter(job.result["worker"] for job in list_jobs(session))
        assert queue_counts(session)["done"] == len(jobs)
    assert sum(owners.values()) == len(jobs)


def test_a_stopped_worker_hands_its_job_back_through_a_busy_database(league, monkeypatch):
    """A release that meets a locked database is tried again, so the job is queued at once rather than
    left running until its lease expires (a killed server's workers all hand back together)."""
    from sqlalchemy.exc import OperationalError

    from arena_league.registry import jobs

    job_id = _enqueue(league)
    job = claim_job(league, "w1", lease_seconds=60, now=T0)
    real, calls = jobs.release_job, []

    def busy_once(league_, job_):
        calls.append(job_.id)
        if len(calls) == 1:
            raise OperationalError("UPDATE jobs", {}, Exception("database is locked"))
        real(league_, job_)

    monkeypatch.setattr(jobs, "release_job", busy_once)
    jobs._hand_back(league, job)
    assert calls == [job_id, job_id]
    row = _job(league, job_id)
    assert (row.status, row.lease_owner, row.attempts) == ("queued", None, 0)
