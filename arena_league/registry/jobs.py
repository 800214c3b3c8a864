"""The league's job queue: leased jobs, claimed by workers, retried after a crash without duplicates.

Arena's league (Song et al., AAAI 2020) keeps evaluating: every new agent plays the base
population, and schedules re-rank the league. That work is queued here as jobs, each a `kind`
(which handler runs it) and a JSON `payload`.

A worker *claims* a job by taking a *lease* on it until `lease_expires_at`, and renews the lease
while it works, every third of the lease, but only while the work progresses: a renewal needs a
sign of progress from the handler (`JobContext.heartbeat`, which the match engine gives every
step) since the one before. A worker whose handler is stuck therefore lets its lease run out
within one lease length, and another worker can take the job; the stuck one's result, should it
ever come, is refused. If the worker dies, the lease runs out and the next claim takes the job again;
each claim counts one attempt, and a job that has used `max_attempts` is failed with its error
kept. The attempt number is a fencing token: renewing, completing or failing a job needs the
attempt one claimed, so a worker that lost its lease can no longer complete the job.

Claims are fair across owners (`Job.owner`, who queued the job; None for the league's own jobs):
among the runnable jobs of the highest priority, the claim takes the owner with the fewest jobs
running, then the owner served least recently (whose last claim is oldest, or who was never
served), then that owner's oldest job. So a burst of one owner's jobs delays another owner's job
by at most the length of one job on each worker, not by the whole burst.

Claims never hand one job to two workers:
- SQLite: one `UPDATE ... WHERE id = (SELECT ... LIMIT 1) RETURNING ...` inside a BEGIN IMMEDIATE
  transaction, which holds the database's single write lock;
- PostgreSQL: the same UPDATE with `FOR UPDATE SKIP LOCKED` on the inner SELECT, so concurrent
  workers skip each other's rows instead of waiting on them.

A worker rides out database trouble, but not for ever. A failed claim is retried after a pause
that doubles each time (from `poll_seconds` up to `MAX_BACKOFF_SECONDS`); after `max_db_failures`
failures in a row (default `DB_FAILURES_UNTIL_IDLE` = 5 for `until_idle`, so a one-off run ends
within seconds, and `DB_FAILURES_LONG_RUNNING` = 10 for a long-running worker, about four minutes
of outage at the default poll of 1 s: a database restart) it stops with `WorkerGaveUpError`,
naming the last cause, for its supervisor to restart it and a person to see why. A database that
cannot be written or is damaged (`ReadOnlyDatabaseError`, `CorruptDatabaseError`) stops it at
once: waiting does not fix those. Each failure is logged as one line, not a traceback.

Handlers must make their results idempotent (the registry's `record_match` with a match key
derived from the job does this), since a job retried after a crash runs again from the start.
Times come from the workers' clocks (keep them in sync with NTP) and are stored as UTC.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import os
import signal
import socket
import sys
import threading
import time
import traceback
import uuid
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Any

from sqlalchemy import and_, case, func, or_, select, text, update
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session

from arena_league.registry.db import League
from arena_league.registry.errors import (
    CorruptDatabaseError,
    DatabaseStateError,
    InvalidRecordError,
    LeaseLostError,
    ReadOnlyDatabaseError,
    WorkerGaveUpError,
)
from arena_league.registry.models import Game, Job, JobStatus, utcnow

logger = logging.getLogger(__name__)

#: Failed claims in a row after which `run_worker(until_idle=True)` stops.
DB_FAILURES_UNTIL_IDLE = 5
#: Failed claims in a row after which a long-running `run_worker` stops.
DB_FAILURES_LONG_RUNNING = 10
#: The longest pause between two claims that failed on a database error.
MAX_BACKOFF_SECONDS = 60.0
_PERMANENT_ERRORS = (ReadOnlyDatabaseError, CorruptDatabaseError)
_DATABASE_ERRORS = (SQLAlchemyError, DatabaseStateError)

# Any constant: the class of the per-owner PostgreSQL advisory locks (the owner's hash is the key).
_PG_OWNER_LOCK_CLASS = 0x41524F57  # "AROW"
_PR_SET_PDEATHSIG = 1  # prctl's option number, from linux/prctl.h

_EXHAUSTED_LEASE_ERROR = (
    "the lease expired on the last allowed attempt (the worker crashed or stalled); not retried"
)


@dataclass(frozen=True)
class ClaimedJob:
    """A job as one worker holds it: what to run, and the attempt that fences its lease."""

    id: int
    kind: str
    payload: dict[str, Any]
    attempt: int  # 1 for the first claim; the lease is valid only for this attempt
    max_attempts: int
    worker_id: str
    lease_expires_at: datetime


@dataclass(frozen=True)
class JobContext:
    """What a handler receives: the league, the job, whether the lease has been lost, and the
    heartbeat by which it shows progress (see the module docstring)."""

    league: League
    job: ClaimedJob
    lease_lost: threading.Event
    progressed: threading.Event = field(default_factory=threading.Event)

    def heartbeat(self) -> None:
        """Say the job made progress (a step played, a result stored): the lease may be renewed."""
        self.progressed.set()

    def raise_if_lease_lost(self) -> None:
        """Stop a long handler early once another worker may have taken the job."""
        if self.lease_lost.is_set():
            raise LeaseLostError(f"worker {self.job.worker_id} lost its lease on job {self.job.id}")


Handler = Callable[[JobContext], Any]


@dataclass
class WorkerReport:
    """What a worker loop did: jobs completed, handler failures, and leases lost."""

    completed: int = 0
    failed: int = 0
    lost: int = 0
    job_ids: list[int] = field(default_factory=list)  # every job claimed, in order


def enqueue(
    session: Session,
    kind: str,
    payload: Mapping[str, Any] | None = None,
    *,
    priority: int = 0,
    max_attempts: int = 3,
    run_after: datetime | None = None,
    schedule_id: int | None = None,
    owner: str | None = None,
) -> Job:
    """Queue a job in the caller's transaction; higher `priority` runs first, then the owner served
    least (see the module docstring), then older jobs. `owner` is who asked for it (None: the
    league itself)."""
    if max_attempts < 1:
        raise InvalidRecordError(f"max_attempts must be at least 1, not {max_attempts}")
    body = dict(payload or {})
    _require_json(body, f"payload of the {kind!r} job")
    job = Job(
        kind=kind,
        payload=body,
        status=JobStatus.QUEUED.value,
        priority=priority,
        max_attempts=max_attempts,
        run_after=run_after or utcnow(),
        schedule_id=schedule_id,
        owner=owner,
    )
    session.add(job)
    session.flush()
    return job


def claim_job(
    league: League,
    worker_id: str,
    *,
    lease_seconds: float = 60.0,
    kinds: Iterable[str] | None = None,
    now: datetime | None = None,
    job_id: int | None = None,
) -> ClaimedJob | None:
    """Claim the next runnable job (queued and due, or running with an expired lease), or None;
    with `job_id`, that job only (e.g. one the caller just queued and runs itself).

    Jobs whose lease expired on their last allowed attempt are failed on the way.
    """
    moment = _naive_utc(now)
    expires = moment + timedelta(seconds=lease_seconds)
    wanted = sorted(set(kinds)) if kinds is not None else None
    with league.transaction() as session:
        session.execute(
            update(Job)
            .where(
                Job.status == JobStatus.RUNNING.value,
                Job.lease_expires_at < moment,
                Job.attempts >= Job.max_attempts,
            )
            .values(
                status=JobStatus.FAILED.value,
                error=func.coalesce(Job.error + "\n", "") + _EXHAUSTED_LEASE_ERROR,
                finished_at=moment,
                lease_owner=None,
                lease_expires_at=None,
            )
            .execution_options(synchronize_session=False)
        )
        candidate = (
            select(Job.id)
            .where(
                or_(
                    and_(Job.status == JobStatus.QUEUED.value, Job.run_after <= moment),
                    and_(
                        Job.status == JobStatus.RUNNING.value,
                        Job.lease_expires_at < moment,
                        Job.attempts < Job.max_attempts,
                    ),
                )
            )
            .order_by(*_fair_order(), Job.priority.desc(), Job.id)
            .limit(1)
        )
        if wanted is not None:
            candidate = candidate.where(Job.kind.in_(wanted))
        if job_id is not None:
            candidate = candidate.where(Job.id == job_id)
        if league.dialect == "postgresql":
            candidate = candidate.with_for_update(skip_locked=True)
        row = session.execute(
            update(Job)
            .where(Job.id == candidate.scalar_subquery())
            .values(
                status=JobStatus.RUNNING.value,
                attempts=Job.attempts + 1,
                lease_owner=worker_id,
                lease_expires_at=expires,
                started_at=moment,
            )
            .returning(Job.id, Job.kind, Job.payload, Job.attempts, Job.max_attempts)
            .execution_options(synchronize_session=False)
        ).one_or_none()
    if row is None:
        return None
    return ClaimedJob(
        id=row.id,
        kind=row.kind,
        payload=row.payload,
        attempt=row.attempts,
        max_attempts=row.max_attempts,
        worker_id=worker_id,
        lease_expires_at=expires.replace(tzinfo=UTC),
    )


def renew_lease(
    league: League, job: ClaimedJob, *, lease_seconds: float = 60.0, now: datetime | None = None
) -> ClaimedJob:
    """Extend a held lease to `now + lease_seconds`; raises LeaseLostError if it is no longer held."""
    expires = _naive_utc(now) + timedelta(seconds=lease_seconds)
    with league.transaction() as session:
        _fenced_update(session, job, "renew the lease of", lease_expires_at=expires)
    return dataclasses.replace(job, lease_expires_at=expires.replace(tzinfo=UTC))


def complete_job(league: League, job: ClaimedJob, result: Any = None, *, now: datetime | None = None) -> None:
    """Mark a held job done with its (JSON) result; raises LeaseLostError if the lease was lost."""
    _require_json(result, f"result of job {job.id}")
    with league.transaction() as session:
        _fenced_update(
            session,
            job,
            "complete",
            status=JobStatus.DONE.value,
            result=result,
            error=None,
            finished_at=_naive_utc(now),
            lease_owner=None,
            lease_expires_at=None,
        )


def fail_job(
    league: League,
    job: ClaimedJob,
    error: str,
    *,
    retry_delay_seconds: float = 0.0,
    now: datetime | None = None,
) -> JobStatus:
    """Record a failed attempt: queue the job again (after the delay) or, on its last attempt, fail it.

    Returns the job's new status. Raises LeaseLostError if the lease was lost.
    """
    moment = _naive_utc(now)
    retry = job.attempt < job.max_attempts
    with league.transaction() as session:
        _fenced_update(
            session,
            job,
            "fail",
            status=JobStatus.QUEUED.value if retry else JobStatus.FAILED.value,
            error=error,
            run_after=moment + timedelta(seconds=retry_delay_seconds) if retry else Job.run_after,
            finished_at=None if retry else moment,
            lease_owner=None,
            lease_expires_at=None,
        )
    return JobStatus.QUEUED if retry else JobStatus.FAILED


def release_job(league: League, job: ClaimedJob) -> None:
    """Hand a held job back to the queue without using up an attempt (e.g. on Ctrl-C)."""
    with league.transaction() as session:
        _fenced_update(
            session,
            job,
            "release",
            status=JobStatus.QUEUED.value,
            attempts=Job.attempts - 1,
            lease_owner=None,
            lease_expires_at=None,
        )


def release_jobs_of_process(league: League, pid: int, host: str | None = None) -> list[int]:
    """Hand back to the queue every job still held by the worker process ``pid`` of ``host`` (this
    machine by default; owners are :func:`default_worker_id`'s ``host:pid:random``), which ended
    without doing it itself (killed while it stopped, say), without using up an attempt, as
    :func:`release_job` does. Returns the jobs' ids. Only the process that ran the worker knows
    that it ended: a supervisor calls this after the worker's exit."""
    owner = f"{host or socket.gethostname()}:{pid}:"
    with league.transaction() as session:
        held = session.scalars(select(Job).where(Job.status == JobStatus.RUNNING.value,
                                                 Job.lease_owner.startswith(owner, autoescape=True))).all()
        for job in held:
            job.status = JobStatus.QUEUED.value
            job.attempts = job.attempts - 1
            job.lease_owner = None
            job.lease_expires_at = None
        session.flush()
        return [job.id for job in held]


def cancel_job(league: League, job_id: int, *, now: datetime | None = None) -> Job:
    """Cancel a queued or running job: it will not run (again). A worker running it loses its
    lease at the next renewal and discards its result; matches it already stored stay. Cancelling
    a cancelled job changes nothing. Raises InvalidRecordError for an unknown or finished job."""
    with league.transaction() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise InvalidRecordError(f"there is no job {job_id}; see `arena-league jobs list`")
        if job.status in (JobStatus.DONE.value, JobStatus.FAILED.value):
            raise InvalidRecordError(f"job {job_id} has already ended ({job.status}); there is nothing to cancel")
        if job.status != JobStatus.CANCELLED.value:
            job.status = JobStatus.CANCELLED.value
            job.finished_at = _naive_utc(now)
            job.lease_owner = None
            job.lease_expires_at = None
            session.flush()
        return job


def _cancel_held(league: League, job: ClaimedJob) -> None:
    """Cancel a job this process holds (its caller gave up on it, e.g. on Ctrl-C)."""
    with league.transaction() as session:
        _fenced_update(session, job, "cancel", status=JobStatus.CANCELLED.value, finished_at=_naive_utc(None),
                       lease_owner=None, lease_expires_at=None)


def record_finished_job(session: Session, kind: str, payload: Mapping[str, Any], result: Any) -> Job:
    """A job that was done outside any worker (a person's placement after a match played live):
    recorded as done at once, with its result, so that it reads like every other finished job."""
    _require_json(payload, "job payload")
    _require_json(result, "job result")
    now = utcnow()
    job = Job(kind=kind, payload=dict(payload), status=JobStatus.DONE.value, attempts=1, result=result,
              created_at=now, started_at=now, finished_at=now, run_after=now)
    session.add(job)
    session.flush()
    return job


def set_job_progress(league: League, job: ClaimedJob, progress: Mapping[str, Any]) -> None:
    """Note what a running job has done (JSON), for anyone watching it; raises LeaseLostError if the
    lease is no longer held."""
    _require_json(dict(progress), "job progress")
    with league.transaction() as session:
        _fenced_update(session, job, "report the progress of", progress=dict(progress))


def set_job_payload(session: Session, job: ClaimedJob, payload: Mapping[str, Any]) -> None:
    """Replace a held job's payload in the caller's transaction (e.g. with the plan its handler made,
    so a retry replays the same plan); raises LeaseLostError if the lease is no longer held."""
    body = dict(payload)
    _require_json(body, f"payload of job {job.id}")
    _fenced_update(session, job, "update the payload of", payload=body)


def live_jobs(session: Session, kind: str, *, exclude_job_id: int | None = None) -> list[Job]:
    """The queued and running jobs of a kind (those that may still store results), oldest first."""
    query = (
        select(Job)
        .where(Job.kind == kind, Job.status.in_((JobStatus.QUEUED.value, JobStatus.RUNNING.value)))
        .order_by(Job.id)
    )
    if exclude_job_id is not None:
        query = query.where(Job.id != exclude_job_id)
    return list(session.scalars(query))


def _fair_order() -> list[Any]:
    """The claim's order across owners, before priority (which orders an owner's own jobs, so that
    no kind of job lets one owner pass another): the owner with the fewest running jobs, then the
    owner served least recently (never served first). Each is one index lookup on (owner, ...) per
    candidate; the league's own jobs (owner None) count as one owner, looked up once."""
    peer = Job.__table__.alias("peer")

    def per_owner(value: Any, *where: Any) -> Any:
        mine = select(value).select_from(peer).where(peer.c.owner == Job.owner, *where).scalar_subquery()
        league_own = select(value).select_from(peer).where(peer.c.owner.is_(None), *where).scalar_subquery()
        return case((Job.owner.is_(None), league_own), else_=mine)

    running = per_owner(func.count(), peer.c.status == JobStatus.RUNNING.value)
    served = per_owner(func.max(peer.c.started_at))
    return [running.asc(), served.asc().nulls_first()]


def lock_owner(session: Session, owner: str) -> None:
    """Hold ``owner``'s lock until the caller's transaction ends, so that checking a per-owner limit
    and queueing under it is one step across requests and servers. PostgreSQL: a transaction-level
    advisory lock on the owner's hash; SQLite: the write transaction's BEGIN IMMEDIATE already holds
    the database's single write lock. Call it inside `League.transaction()`."""
    if session.get_bind().dialect.name == "postgresql":
        session.execute(text("SELECT pg_advisory_xact_lock(:lock_class, hashtext(:owner))"),
                        {"lock_class": _PG_OWNER_LOCK_CLASS, "owner": owner})


def count_live_jobs(session: Session, owner: str) -> int:
    """How many of ``owner``'s jobs are queued or running."""
    return int(session.scalar(select(func.count(Job.id)).where(
        Job.owner == owner, Job.status.in_((JobStatus.QUEUED.value, JobStatus.RUNNING.value)))))


def lock_game(session: Session, game_id: str) -> None:
    """Hold the game's lock until the caller's transaction ends, so that jobs planning work on one
    game plan one at a time, each seeing the plans committed before it. PostgreSQL: a row lock on
    the game (SELECT ... FOR UPDATE); SQLite: the write transaction's BEGIN IMMEDIATE already holds
    the database's single write lock. Call it inside `League.transaction()`."""
    session.execute(select(Game.id).where(Game.id == game_id).with_for_update()).all()


def get_job(session: Session, job_id: int) -> Job | None:
    """The job with this id, or None."""
    return session.get(Job, job_id)


def list_jobs(
    session: Session,
    *,
    status: JobStatus | str | None = None,
    kind: str | None = None,
    limit: int | None = None,
) -> list[Job]:
    """Jobs, newest first, optionally of one status or kind."""
    query = select(Job).order_by(Job.id.desc())
    if status is not None:
        query = query.where(Job.status == JobStatus(status).value)
    if kind is not None:
        query = query.where(Job.kind == kind)
    if limit is not None:
        query = query.limit(limit)
    return list(session.scalars(query))


def queue_counts(session: Session) -> dict[str, int]:
    """How many jobs are in each status (every status listed, zero included)."""
    counts = dict(session.execute(select(Job.status, func.count(Job.id)).group_by(Job.status)).all())
    return {status.value: int(counts.get(status.value, 0)) for status in JobStatus}


def default_worker_id() -> str:
    """`host:pid:random`, unique per worker process and readable in `lease_owner`."""
    return f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:6]}"


#: Set when this process was asked to stop (SIGTERM, see :func:`signal_stop`): a job whose handler
#: fails from then on is handed back, since the stop can break it mid-call (a sandbox child ended
#: beside the worker), rather than failed and retried by this worker.
STOP_SIGNALLED = threading.Event()


def signal_stop() -> None:
    """Note that this process was asked to stop: call it from a signal handler before raising
    ``KeyboardInterrupt``."""
    STOP_SIGNALLED.set()


def run_worker(
    league: League,
    handlers: Mapping[str, Handler],
    worker_id: str | None = None,
    lease_seconds: float = 60.0,
    poll_seconds: float = 1.0,
    max_jobs: int | None = None,
    stop_event: threading.Event | None = None,
    *,
    until_idle: bool = False,
    retry_delay_seconds: float = 0.0,
    max_db_failures: int | None = None,
    parent_pid: int | None = None,
) -> WorkerReport:
    """Claim and run jobs until stopped; returns what was done.

    Only jobs whose kind has a handler are claimed. Each handler is called with a `JobContext`
    while a background thread renews the lease every `lease_seconds / 3`; its return value (JSON)
    becomes the job's result. A handler that raises fails the attempt (the traceback is kept as
    the job's error). If the lease is lost meanwhile, the job is left to its new owner.

    Args:
        league: the open league.
        handlers: job kind -> handler.
        worker_id: written to `lease_owner`; default `host:pid:random`.
        lease_seconds: how long a claim lasts without renewal; a crashed worker's job is retried
            after at most this long.
        poll_seconds: how long to wait when the queue is empty.
        max_jobs: stop after claiming this many jobs.
        stop_event: set it to stop after the current job.
        until_idle: stop as soon as no job can be claimed.
        retry_delay_seconds: how long a failed attempt waits before it can be claimed again.
        max_db_failures: stop after this many claims in a row failed on a database error (see the
            module docstring); default `DB_FAILURES_UNTIL_IDLE` with `until_idle`, else
            `DB_FAILURES_LONG_RUNNING`.
        parent_pid: the process that started this worker (``serve``): once it is no longer this
            process's parent (it ended), the worker stops, checked before each claim and at each
            lease renewal, where the running job is handed back to the queue. On Linux the worker
            also asks for SIGTERM the moment that parent ends (call this from the main thread).

    Raises:
        WorkerGaveUpError: `max_db_failures` claims in a row failed; it names the last cause.
        ReadOnlyDatabaseError, CorruptDatabaseError: at the first failure of that cause.

    Ctrl-C (KeyboardInterrupt) hands the current job back to the queue and re-raises.
    """
    worker = worker_id or default_worker_id()
    stop = stop_event or threading.Event()
    report = WorkerReport()
    kinds = sorted(handlers)
    limit = max_db_failures or (DB_FAILURES_UNTIL_IDLE if until_idle else DB_FAILURES_LONG_RUNNING)
    if limit < 1:
        raise InvalidRecordError(f"max_db_failures must be at least 1, not {limit}")
    failures = 0
    STOP_SIGNALLED.clear()
    if parent_pid is not None:
        _end_with_parent()
    while not stop.is_set() and not STOP_SIGNALLED.is_set() and (max_jobs is None or len(report.job_ids) < max_jobs):
        if _orphaned(parent_pid):
            logger.warning("worker %s stops: the process that started it (pid %d) has ended", worker, parent_pid)
            break
        try:
            job = claim_job(league, worker, lease_seconds=lease_seconds, kinds=kinds)
        except _DATABASE_ERRORS as error:  # locked, unreachable, full...: wait longer each time
            failures += 1
            if isinstance(error, _PERMANENT_ERRORS):
                raise
            if failures >= limit:
                raise WorkerGaveUpError(
                    f"worker {worker} stopped after {failures} failed attempts in a row to claim a job; "
                    f"the last: {_one_line(error)}. Jobs it held are retried by other workers once "
                    "their lease expires; start it again once the database is back"
                ) from error
            pause = min(max(poll_seconds, 0.001) * 2 ** (failures - 1), MAX_BACKOFF_SECONDS)
            logger.warning("worker %s could not claim a job (%s); attempt %d of %d, next in %.1f s",
                           worker, _one_line(error), failures, limit, pause)
            logger.debug("the failed claim's traceback", exc_info=True)
            stop.wait(pause)
            continue
        failures = 0
        if job is None:
            if until_idle:
                break
            stop.wait(poll_seconds)
            continue
        report.job_ids.append(job.id)
        logger.info("worker %s claimed job %d (%s), attempt %d", worker, job.id, job.kind, job.attempt)
        try:
            _run_one(league, handlers[job.kind], job, lease_seconds, retry_delay_seconds, report, parent_pid)
        except _DATABASE_ERRORS as error:  # could not record the outcome: retried after its lease
            if isinstance(error, _PERMANENT_ERRORS):
                raise
            report.lost += 1
            logger.warning(
                "job %d: could not record its outcome (%s); it is retried once its lease expires",
                job.id, _one_line(error),
            )
    return report


def _orphaned(parent_pid: int | None) -> bool:
    """Whether the worker's parent ended (the worker was handed to another process, often init)."""
    return parent_pid is not None and os.getppid() != parent_pid


def _end_with_parent() -> None:
    """On Linux, have the kernel send SIGTERM when the parent ends, so a job is handed back at
    once rather than at the next check (the signal is the process's only from its main thread)."""
    if not sys.platform.startswith("linux") or threading.current_thread() is not threading.main_thread():
        return
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def _one_line(error: BaseException) -> str:
    """An error as one line: a translated registry error's message, or a driver error's first line
    (without the SQL statement SQLAlchemy appends)."""
    cause = getattr(error, "orig", None) or error
    text = str(cause).strip().splitlines()
    return f"{type(error).__name__}: {text[0] if text else ''}"


def run_job_now(
    league: League,
    job_id: int,
    handlers: Mapping[str, Handler],
    *,
    worker_id: str | None = None,
    lease_seconds: float = 60.0,
) -> Any:
    """Claim the job `job_id` and run it here, in the caller's process, under a renewed lease (for
    commands that queue work and wait for it); see :func:`run_claimed_job`. Raises
    InvalidRecordError when the job cannot be claimed (another worker holds it, or it ended)."""
    job = claim_job(league, worker_id or default_worker_id(), lease_seconds=lease_seconds, job_id=job_id)
    if job is None:
        raise InvalidRecordError(f"job {job_id} cannot be claimed: it is not queued (or already taken by a worker)")
    return run_claimed_job(league, job, handlers, lease_seconds=lease_seconds)


def run_claimed_job(league: League, job: ClaimedJob, handlers: Mapping[str, Handler], *,
                    lease_seconds: float = 60.0) -> Any:
    """Run a job this process claimed, here, under a renewed lease; returns its result. A handler
    error fails the attempt and is re-raised, so the caller sees the cause. Interrupted (Ctrl-C),
    the job is cancelled rather than left queued: nobody else waits for it. Raises LeaseLostError
    when the job was taken from this process meanwhile (cancelled, or its lease ran out and another
    worker claimed it): its result, if any, is discarded."""
    if job.kind not in handlers:
        release_job(league, job)
        raise InvalidRecordError(f"job {job.id} is of kind {job.kind!r}, which has no handler here")
    try:
        result, lease_lost = _under_lease(league, handlers[job.kind], job, lease_seconds)
    except KeyboardInterrupt:
        with contextlib.suppress(LeaseLostError):  # already cancelled or taken: nothing to hand back
            _cancel_held(league, job)
        raise
    except LeaseLostError:
        raise
    except Exception:
        fail_job(league, job, traceback.format_exc())  # LeaseLostError if it was taken meanwhile
        raise
    if lease_lost.is_set():
        raise LeaseLostError(f"this process lost its lease on job {job.id} while running it; its result is discarded")
    complete_job(league, job, result)
    return result


def _run_one(
    league: League,
    handler: Handler,
    job: ClaimedJob,
    lease_seconds: float,
    retry_delay_seconds: float,
    report: WorkerReport,
    parent_pid: int | None = None,
) -> None:
    """Run one claimed job under a renewed lease, then complete or fail it."""
    try:
        result, lease_lost = _under_lease(league, handler, job, lease_seconds, parent_pid)
    except LeaseLostError:
        report.lost += 1
        logger.warning("job %d: lease lost (the job was cancelled, or another worker took it); stopped", job.id)
        return
    except KeyboardInterrupt:
        _hand_back(league, job)
        raise
    except Exception as failure:  # any handler error fails this attempt; the worker goes on
        if STOP_SIGNALLED.is_set() or _orphaned(parent_pid):
            _hand_back(league, job)  # the stop broke it: hand it back, as on KeyboardInterrupt
            raise KeyboardInterrupt from failure
        error = traceback.format_exc()
        logger.error("job %d (%s) failed on attempt %d:\n%s", job.id, job.kind, job.attempt, error)
        try:
            fail_job(league, job, error, retry_delay_seconds=retry_delay_seconds)
            report.failed += 1
        except LeaseLostError:
            report.lost += 1
        return
    if lease_lost.is_set():
        report.lost += 1
        logger.warning("job %d: lease lost while running; its result is discarded", job.id)
        if _orphaned(parent_pid):
            _hand_back(league, job)  # the lease keeper's own hand-back may have met a busy database
        return
    try:
        complete_job(league, job, result)
    except LeaseLostError:
        report.lost += 1
        logger.warning("job %d: lease lost before completion; its result is discarded", job.id)
        return
    except InvalidRecordError as error:  # a result that is not JSON
        fail_job(league, job, str(error), retry_delay_seconds=retry_delay_seconds)
        report.failed += 1
        return
    report.completed += 1
    logger.info("job %d (%s) done", job.id, job.kind)


def _hand_back(league: League, job: ClaimedJob, tries: int = 5) -> None:
    """Release a held job on a stop, trying again while the database is busy (a server killed beside
    its workers leaves them all handing back at once); after ``tries`` its lease runs out instead."""
    for attempt in range(tries):
        try:
            release_job(league, job)
            return
        except LeaseLostError:  # already handed back, cancelled or taken: nothing to do
            return
        except _DATABASE_ERRORS as error:
            if isinstance(error, _PERMANENT_ERRORS) or attempt == tries - 1:
                logger.warning("job %d: could not hand it back (%s); it is retried once its lease expires",
                               job.id, _one_line(error))
                return
            time.sleep(0.2 * 2 ** attempt)


def _under_lease(league: League, handler: Handler, job: ClaimedJob, lease_seconds: float,
                 parent_pid: int | None = None) -> tuple[Any, threading.Event]:
    """Call the handler while a background thread renews the job's lease; returns its result and
    the event that tells whether the lease was lost meanwhile (or handed back: its parent ended)."""
    context = JobContext(league=league, job=job, lease_lost=threading.Event())
    context.heartbeat()  # the claim itself: the first renewal waits for no step
    done = threading.Event()
    keeper = threading.Thread(target=_keep_lease, args=(league, job, lease_seconds, context, done, parent_pid),
                              name=f"lease-{job.id}", daemon=True)
    keeper.start()
    try:
        return handler(context), context.lease_lost
    finally:
        done.set()
        keeper.join()


def _keep_lease(
    league: League, job: ClaimedJob, lease_seconds: float, context: JobContext, done: threading.Event,
    parent_pid: int | None = None,
) -> None:
    """Every third of the lease until `done`: renew it if the handler made progress since the last
    look, else leave it to run out (logged once); stop once it is lost. A worker whose parent
    ended hands the job back to the queue instead, and its handler stops as if the lease were lost."""
    stalled = False
    while not done.wait(lease_seconds / 3):
        if _orphaned(parent_pid):
            logger.warning("job %d: the process that started this worker (pid %d) has ended; the job goes "
                           "back to the queue", job.id, parent_pid)
            _hand_back(league, job)
            context.lease_lost.set()
            return
        if not context.progressed.is_set():
            if not stalled:
                logger.warning("job %d: no progress for %.0f s; its lease is not renewed", job.id, lease_seconds / 3)
            stalled = True
            continue
        context.progressed.clear()
        stalled = False
        try:
            renew_lease(league, job, lease_seconds=lease_seconds)
        except LeaseLostError:
            context.lease_lost.set()
            return
        except Exception:  # a database hiccup: try again at the next interval
            logger.exception("job %d: could not renew the lease", job.id)


def _fenced_update(session: Session, job: ClaimedJob, action: str, **values: Any) -> None:
    """UPDATE the job only while this worker's attempt holds it; else LeaseLostError."""
    updated = session.execute(
        update(Job)
        .where(
            Job.id == job.id,
            Job.status == JobStatus.RUNNING.value,
            Job.lease_owner == job.worker_id,
            Job.attempts == job.attempt,
        )
        .values(**values)
        .returning(Job.id)
        .execution_options(synchronize_session=False)
    ).one_or_none()
    if updated is None:
        holder = session.execute(
            select(Job.status, Job.lease_owner, Job.attempts).where(Job.id == job.id)
        ).one_or_none()
        now_held = (
            "it no longer exists"
            if holder is None
            else f"it is now {holder.status}, attempt {holder.attempts}, held by {holder.lease_owner or 'nobody'}"
        )
        raise LeaseLostError(
            f"worker {job.worker_id} cannot {action} job {job.id}: its lease on attempt {job.attempt} "
            f"was lost ({now_held}); the job is retried by its new owner, and this worker's result is "
            "discarded"
        )


def _naive_utc(moment: datetime | None) -> datetime:
    """`moment` (default now) as naive UTC, the form timestamps are compared in SQL."""
    chosen = moment or utcnow()
    return chosen.astimezone(UTC).replace(tzinfo=None) if chosen.tzinfo else chosen


def _require_json(value: Any, what: str) -> None:
    try:
        json.dumps(value, allow_nan=False)
    except (TypeError, ValueError) as error:
        raise InvalidRecordError(
            f"the {what} is not JSON ({error}); use dicts, lists, strings and finite numbers"
        ) from None
