"""Recurring evaluations, the scheduler that queues them, and the worker that runs queued jobs.

A schedule queues an ``evaluate`` job (the same payload :func:`~arena_league.league.service.queue_evaluation`
queues, naming no agents: every agent active when it runs) every ``interval_seconds`` or on a
five-field UTC cron expression; ``arena-league scheduler`` queues due ones, ``arena-league worker``
runs them with the league's job handlers.
"""

from __future__ import annotations

import importlib
import threading
from dataclasses import asdict, dataclass
from typing import Any

from arena_league import registry as reg
from arena_league.league.home import register_game
from arena_league.league.jobs import evaluation_payload
from arena_league.registry import League

__all__ = ["WorkerSummary", "add_evaluation_schedule", "list_schedules", "remove_schedule", "run_scheduler",
           "run_worker", "tick", "waiting_jobs"]


def _schedule_row(schedule: reg.Schedule) -> dict[str, Any]:
    return {"name": schedule.name, "kind": schedule.kind, "payload": schedule.payload,
            "interval_seconds": schedule.interval_seconds, "cron": schedule.cron,
            "next_run_at": schedule.next_run_at.isoformat(timespec="seconds"), "enabled": schedule.enabled}


def add_evaluation_schedule(league: League, name: str, game_id: str, *, every: int | None = None,
                            cron: str | None = None, matches_per_pair: int = 10, seed: int = 0,
                            backend: str = "inprocess") -> dict[str, Any]:
    """A schedule named ``name`` that evaluates every active agent of ``game_id`` every ``every``
    seconds or on ``cron`` (exactly one of them); returns its row."""
    if not name:
        raise ValueError("a schedule needs a name: `arena-league schedule add NAME --game GAME --every SECONDS`")
    if not game_id:
        raise ValueError(f"schedule {name!r} needs --game GAME (see `arena-league games`)")
    if (every is None) == (cron is None):
        raise ValueError("give exactly one of --every SECONDS or --cron 'MIN HOUR DOM MON DOW'")
    payload = evaluation_payload(game_id, None, matches_per_pair=matches_per_pair, seed=seed, backend=backend)
    register_game(league, game_id)
    with league.transaction() as session:
        schedule = reg.add_schedule(session, name, "evaluate", payload, interval_seconds=every, cron=cron)
        return _schedule_row(schedule)


def list_schedules(league: League) -> list[dict[str, Any]]:
    """Every schedule's row, by name."""
    with league.reading() as session:
        return [_schedule_row(s) for s in reg.list_schedules(session)]


def remove_schedule(league: League, name: str | None) -> None:
    """Delete the schedule ``name``; the jobs it already queued stay."""
    if not name:
        raise ValueError("name the schedule to remove: `arena-league schedule remove NAME`")
    with league.transaction() as session:
        reg.remove_schedule(session, name)


def tick(league: League) -> list[int]:
    """Queue one job for each due schedule, once; the queued job ids."""
    return reg.tick(league)


def run_scheduler(league: League, *, poll_seconds: float = 30.0, max_ticks: int | None = None,
                  stop_event: threading.Event | None = None) -> int:
    """Queue due jobs every ``poll_seconds`` until stopped; the number of ticks made."""
    return reg.run_scheduler(league, poll_seconds=poll_seconds, max_ticks=max_ticks, stop_event=stop_event)


@dataclass(frozen=True)
class WorkerSummary:
    """What a worker did before it stopped."""

    completed: int
    failed: int
    lost: int
    jobs: list[int]

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def signal_stop() -> None:
    """Note, from a signal handler, that this worker process was asked to stop: a job its stop
    breaks mid-call is handed back rather than failed (see ``registry.jobs.signal_stop``)."""
    reg.jobs.signal_stop()


def release_jobs_of_process(league: League, pid: int) -> list[int]:
    """Hand back every job still held by the ended worker process ``pid`` of this machine (see
    ``registry.jobs.release_jobs_of_process``); returns the jobs' ids."""
    return reg.release_jobs_of_process(league, pid)


def run_worker(league: League, *, worker_id: str | None = None, lease_seconds: float = 60.0,
               poll_seconds: float = 1.0, max_jobs: int | None = None, until_idle: bool = False,
               stop_event: threading.Event | None = None, parent_pid: int | None = None,
               backend: str = "inprocess", address: str | None = None, workers: int | None = None
               ) -> WorkerSummary:
    """Claim and run queued jobs (evaluations, rankings) with the league's handlers until stopped,
    ``max_jobs`` ran, with ``until_idle``, the queue is empty or, given ``parent_pid``, the process
    that started the worker has ended (the job it ran goes back to the queue). ``backend``,
    ``address`` and ``workers`` say where the jobs' matches are played
    (:class:`~arena_league.league.service.MatchBackend`: ``"ray"`` fans each job's matches out over a
    Ray cluster); several workers, on one PostgreSQL league, share its queue whatever their backend."""
    # the match engine: loaded only to run jobs
    from arena_league.league.service import MatchBackend, job_handlers

    play = MatchBackend(backend, address, workers)  # a wrong backend is refused before a job is claimed

    # load what a job runs (onnxruntime, torch, the sandbox) before claiming one: a stop signal that
    # lands in a native module's import becomes an ImportError the job fails with, not a hand-back
    importlib.import_module("arena_league.policies.onnx_policy")
    importlib.import_module("arena_league.policies.validation")

    report = reg.run_worker(league, job_handlers(play=play), worker_id=worker_id, lease_seconds=lease_seconds,
                            poll_seconds=poll_seconds, max_jobs=max_jobs, stop_event=stop_event,
                            until_idle=until_idle, parent_pid=parent_pid)
    return WorkerSummary(report.completed, report.failed, report.lost, list(report.job_ids))


def waiting_jobs(league: League) -> dict[str, int]:
    """How many jobs wait for a worker (``queued``) and how many workers hold (``running``)."""
    with league.reading() as session:
        counts = reg.queue_counts(session)
    return {"queued": counts["queued"], "running": counts["running"]}
