"""Per-owner quotas on the work a request can queue, checked and queued in one step.

Every job a request queues (an upload's validation, a placement, a tree's verification or
preview, a replay, a population's import) records its owner, and counts against the league's
``jobs.live_per_owner``: the jobs one owner may hold queued or running at once. The check and the
insert happen in one transaction under the owner's lock (:func:`arena_league.registry.lock_owner`),
so concurrent requests, on one server or many, cannot together pass the limit. Administrators run
the league (imports, re-ranks) and can cancel any job, so they are not limited; the fair claim
still keeps their jobs from starving anyone. Jobs the league queues itself (schedules, the
command line) have no owner and no quota.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from arena_league import registry as reg
from arena_league.league.errors import RateLimitedError
from arena_league.league.tokens import Identity
from arena_league.registry import League

__all__ = ["enqueue_owned", "live_job_limit"]


def live_job_limit(league: League) -> int:
    """The jobs one owner may hold queued or running (the setting ``jobs.live_per_owner``)."""
    from arena_league.league.settings import league_settings

    return int(league_settings(league)["jobs.live_per_owner"]["value"])


def enqueue_owned(session: Session, who: Identity | None, kind: str, payload: dict[str, Any], *, priority: int,
                  limit: int | None) -> reg.Job:
    """Queue a job for ``who`` in the caller's transaction, under the owner's lock, once the owner's
    live jobs are under ``limit`` (None, or an administrator: no limit); ``who`` None queues it as
    the league's own. Raises :class:`RateLimitedError` at the limit."""
    if who is None:
        return reg.enqueue(session, kind, payload, priority=priority)
    reg.lock_owner(session, who.owner)
    if limit is not None and not who.admin:
        live = reg.count_live_jobs(session, who.owner)
        if live >= limit:
            raise RateLimitedError(
                f"{who.owner} already has {live} jobs queued or running, the most this league allows (the "
                "setting jobs.live_per_owner); try again once some have finished (an operator can cancel "
                "them with `arena-league jobs cancel`)")
    return reg.enqueue(session, kind, payload, priority=priority, owner=who.owner)
