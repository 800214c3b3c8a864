"""Schedules: jobs enqueued again and again, every N seconds or on a cron expression.

A league after Arena (Song et al., AAAI 2020) keeps its rankings current: evaluation and
re-rating run on a schedule. A schedule names a job kind and payload, and either an interval in
seconds or a cron expression (five fields: minute hour day-of-month month day-of-week, read in
UTC; parsed by croniter).

`tick` is the one-shot step (for cron or a systemd timer): in one write transaction it enqueues
one job for every enabled schedule whose `next_run_at` has come, and moves `next_run_at` past
now. Runs missed while nothing ticked are coalesced into that one job, not replayed as a backlog.
Two ticks at the same moment do not both enqueue: on SQLite the write transaction is BEGIN
IMMEDIATE, so ticks run one after the other and the second finds `next_run_at` already moved; on
PostgreSQL due schedules are read `FOR UPDATE SKIP LOCKED`, so each is taken by one tick.
`run_scheduler` calls `tick` in a loop.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Mapping
from datetime import UTC, datetime, timedelta
from typing import Any

from croniter import croniter
from sqlalchemy import func, select
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session

from arena_league.registry.db import League
from arena_league.registry.errors import InvalidScheduleError, NameTakenError, RegistryError
from arena_league.registry.jobs import enqueue
from arena_league.registry.models import Schedule, utcnow

logger = logging.getLogger(__name__)

_CRON_HELP = (
    "use five fields, minute hour day-of-month month day-of-week (UTC), "
    "e.g. '0 3 * * *' for 03:00 every day or '*/15 * * * *' for every 15 minutes"
)


def add_schedule(
    session: Session,
    name: str,
    kind: str,
    payload: Mapping[str, Any] | None = None,
    *,
    interval_seconds: int | None = None,
    cron: str | None = None,
    start_at: datetime | None = None,
    priority: int = 0,
    max_attempts: int = 3,
    enabled: bool = True,
    now: datetime | None = None,
) -> Schedule:
    """Add a schedule running `kind` every `interval_seconds`, or at the times of `cron` (UTC).

    The first run is at `start_at`; by default, now for an interval and the next cron time for
    a cron expression.

    Raises:
        InvalidScheduleError: both or neither of interval and cron, a non-positive interval, or a
            cron expression croniter cannot read (the message shows the expected form).
        NameTakenError: a schedule of that name exists.
    """
    if (interval_seconds is None) == (cron is None):
        raise InvalidScheduleError(
            f"schedule {name!r} needs exactly one of interval_seconds or cron, not "
            f"{'both' if cron is not None else 'neither'}"
        )
    if interval_seconds is not None and (not isinstance(interval_seconds, int) or interval_seconds <= 0):
        raise InvalidScheduleError(
            f"schedule {name!r} has interval {interval_seconds!r}; use a whole number of seconds above 0"
        )
    if cron is not None:
        cron = " ".join(cron.split())
        _check_cron(name, cron)
    existing = get_schedule(session, name)
    if existing is not None:
        taken = session.scalars(select(Schedule.name).where(Schedule.name.startswith(f"{name}-"))).all()
        number = 2
        while f"{name}-{number}" in taken:
            number += 1
        raise NameTakenError(
            "schedule", name, f"schedule #{existing.id} running {existing.kind!r}", f"{name}-{number}"
        )
    moment = _aware(now or utcnow())
    if start_at is not None:
        first = _aware(start_at)
    elif cron is not None:
        first = _next_cron_time(cron, moment)
    else:
        first = moment
    schedule = Schedule(
        name=name,
        kind=kind,
        payload=dict(payload or {}),
        interval_seconds=interval_seconds,
        cron=cron,
        priority=priority,
        max_attempts=max_attempts,
        next_run_at=first,
        enabled=enabled,
    )
    session.add(schedule)
    session.flush()
    return schedule


def get_schedule(session: Session, name: str) -> Schedule | None:
    """The schedule with this name, or None."""
    return session.scalars(select(Schedule).where(Schedule.name == name)).one_or_none()


def list_schedules(session: Session) -> list[Schedule]:
    """Every schedule, by name."""
    return list(session.scalars(select(Schedule).order_by(Schedule.name)))


def set_schedule_enabled(session: Session, name: str, enabled: bool) -> Schedule:
    """Pause (False) or resume (True) a schedule."""
    schedule = _require_schedule(session, name)
    schedule.enabled = enabled
    session.flush()
    return schedule


def remove_schedule(session: Session, name: str) -> None:
    """Delete a schedule; the jobs it already enqueued stay (their schedule_id becomes NULL)."""
    session.delete(_require_schedule(session, name))
    session.flush()


def next_run_after(schedule: Schedule, now: datetime) -> datetime:
    """The schedule's first run time strictly after `now`, stepping from its current `next_run_at`."""
    moment = _aware(now)
    if schedule.cron is not None:
        return _next_cron_time(schedule.cron, moment)
    assert schedule.interval_seconds is not None
    due = _aware(schedule.next_run_at)
    if due > moment:
        return due
    steps = math.floor((moment - due).total_seconds() / schedule.interval_seconds) + 1
    return due + timedelta(seconds=steps * schedule.interval_seconds)


def tick(league: League, now: datetime | None = None) -> list[int]:
    """Enqueue one job for each due schedule and move its `next_run_at` past now; returns job ids."""
    moment = _aware(now or utcnow())
    enqueued = []
    with league.transaction() as session:
        due = (
            select(Schedule)
            .where(Schedule.enabled.is_(True), Schedule.next_run_at <= moment)
            .order_by(Schedule.next_run_at, Schedule.id)
        )
        if league.dialect == "postgresql":
            due = due.with_for_update(skip_locked=True)
        for schedule in session.scalars(due):
            job = enqueue(
                session,
                schedule.kind,
                schedule.payload,
                priority=schedule.priority,
                max_attempts=schedule.max_attempts,
                run_after=moment,
                schedule_id=schedule.id,
            )
            schedule.last_run_at = moment
            schedule.next_run_at = next_run_after(schedule, moment)
            enqueued.append(job.id)
            logger.info(
                "schedule %s enqueued job %d; next run %s", schedule.name, job.id, schedule.next_run_at
            )
    return enqueued


def run_scheduler(
    league: League,
    *,
    poll_seconds: float = 30.0,
    stop_event: threading.Event | None = None,
    max_ticks: int | None = None,
) -> int:
    """Tick until `stop_event` is set (or `max_ticks` ticks); returns how many jobs were enqueued.

    Between ticks it sleeps until the next schedule is due, at most `poll_seconds`, so schedules
    added meanwhile are seen.
    """
    stop = stop_event or threading.Event()
    total = 0
    ticks = 0
    while not stop.is_set():
        try:
            total += len(tick(league))
        except (RegistryError, SQLAlchemyError):
            logger.exception("scheduler tick failed; trying again")
        ticks += 1
        if max_ticks is not None and ticks >= max_ticks:
            break
        with league.reading() as session:
            soonest = session.scalar(select(func.min(Schedule.next_run_at)).where(Schedule.enabled.is_(True)))
        wait = poll_seconds if soonest is None else (soonest - utcnow()).total_seconds()
        stop.wait(min(poll_seconds, max(wait, 0.0)))
    return total


def _check_cron(name: str, cron: str) -> None:
    if len(cron.split()) != 5:
        raise InvalidScheduleError(
            f"schedule {name!r}: cron expression {cron!r} has {len(cron.split())} fields; {_CRON_HELP}"
        )
    try:
        croniter(cron)
    except (ValueError, KeyError) as error:
        raise InvalidScheduleError(
            f"schedule {name!r}: cron expression {cron!r} is not valid ({error}); {_CRON_HELP}"
        ) from None


def _next_cron_time(cron: str, after: datetime) -> datetime:
    """The first time of `cron` strictly after `after` (cron read in UTC)."""
    naive = _aware(after).replace(tzinfo=None)
    return croniter(cron, naive).get_next(datetime).replace(tzinfo=UTC)


def _require_schedule(session: Session, name: str) -> Schedule:
    schedule = get_schedule(session, name)
    if schedule is None:
        known = ", ".join(session.scalars(select(Schedule.name).order_by(Schedule.name))) or "none"
        raise RegistryError(f"no schedule named {name!r}; schedules: {known}")
    return schedule


def _aware(moment: datetime) -> datetime:
    """`moment` as aware UTC (a naive datetime is taken to be UTC)."""
    return moment.replace(tzinfo=UTC) if moment.tzinfo is None else moment.astimezone(UTC)
