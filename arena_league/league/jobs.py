"""The league's jobs as a person looks them up: the queue, one job in full, and cancelling one.

Every match is played by a job (``evaluate`` or ``rank``), run at once by the command that
queued it or later by ``arena-league worker``. A command that queues a job follows it wherever it
runs (:func:`follow_job`): here when it can claim it, else in the worker that took it (a server's,
say), reading the progress that worker stores. A cancelled job does not run (again); a worker
running it stops at its next progress report (within :data:`PROGRESS_EVERY` seconds and a match)
or lease renewal and discards its result, and the matches it had already stored stay (they are
real matches).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Mapping, Sequence
from datetime import UTC, datetime
from typing import Any

from arena_league import registry as reg
from arena_league.league.errors import JobCancelledError, JobFailedError, JobInterrupted
from arena_league.registry import League

__all__ = ["PROGRESS_EVERY", "cancel_job", "evaluation_payload", "follow_job", "job_detail", "job_rows"]

#: Seconds between two writes of a running job's progress to its row, and between two looks at the
#: row of a job another worker runs.
PROGRESS_EVERY = 0.5


def evaluation_payload(game_id: str, agents: Sequence[str] | None, *, matches_per_pair: int = 10, seed: int = 0,
                       backend: str = "inprocess", workers: int | None = None, record: bool = False,
                       max_matches: int | None = None) -> dict[str, Any]:
    """The payload of an ``evaluate`` job, queued now or by a schedule (``agents`` None: every agent
    active when the job runs). :func:`arena_league.league.service.handle_evaluate` reads it."""
    if matches_per_pair < 1:
        raise ValueError(f"matches_per_pair must be at least 1, not {matches_per_pair}")
    if max_matches is not None and max_matches < 1:
        raise ValueError(f"max_matches must be at least 1, not {max_matches}")
    payload = {"game_id": game_id, "agents": None if agents is None else list(agents),
               "matches_per_pair": int(matches_per_pair), "seed": int(seed), "backend": backend, "workers": workers,
               "record": bool(record)}
    if max_matches is not None:  # absent rather than None, so that earlier payloads read the same
        payload["max_matches"] = int(max_matches)
    return payload


def stamp(moment: Any) -> str | None:
    return moment.isoformat(timespec="seconds") if moment is not None else None


def _summary(job: reg.Job) -> str:
    payload = job.payload or {}
    if job.kind == "rank":
        base = payload.get("base_label") or payload.get("population") or "its game's base population"
        plays = f"{payload['more']} more matches" if payload.get("more") else f"budget {payload.get('budget')}"
        return f"{payload.get('agent')} against {base}, {plays}, seed {payload.get('seed', 0)}"
    if job.kind == "evaluate":
        agents = payload.get("agents")
        who = f"{len(agents)} agents" if agents else "every active agent"
        cap = f", at most {payload['max_matches']}" if payload.get("max_matches") else ""
        return f"{who}, {payload.get('matches_per_pair')} per pair{cap}"
    if job.kind == "verify":
        return f"a social tree of {payload.get('game_id')}, {payload.get('samples')} sampled pairs"
    if job.kind == "preview":
        return f"one match of {payload.get('game_id')} under a social tree"
    if job.kind == "import":
        return f"{payload.get('population')} of {payload.get('game_id')}, shipped with arena-league"
    if job.kind == "replay":
        return f"match {payload.get('match')} played again and recorded"
    if job.kind == "validate":
        return f"{payload.get('agent')}, uploaded"
    return ""


def _row(job: reg.Job) -> dict[str, Any]:
    return {"id": job.id, "kind": job.kind, "status": job.status, "game_id": (job.payload or {}).get("game_id"),
            "what": _summary(job), "attempts": job.attempts, "created_at": stamp(job.created_at),
            "finished_at": stamp(job.finished_at), "worker": job.lease_owner}


def job_rows(league: League, *, status: str | None = None, kind: str | None = None, limit: int = 50
             ) -> list[dict[str, Any]]:
    """The newest ``limit`` jobs (of one status or kind), newest first."""
    if status is not None and status not in {s.value for s in reg.JobStatus}:
        raise ValueError(f"unknown job status {status!r}; one of {', '.join(s.value for s in reg.JobStatus)}")
    with league.reading() as session:
        return [_row(job) for job in reg.list_jobs(session, status=status, kind=kind, limit=limit)]


def job_detail(league: League, job_id: int) -> dict[str, Any]:
    """One job in full: its row, payload, result or error, its progress, and how many matches it stored."""
    with league.reading() as session:
        job = reg.get_job(session, job_id)
        if job is None:
            raise ValueError(f"there is no job {job_id}; see `arena-league jobs list`")
        stored = len(reg.match_keys_of_job(session, job.id))
        return {**_row(job), "payload": job.payload, "result": job.result, "error": job.error,
                "progress": job.progress, "matches_stored": stored, "started_at": stamp(job.started_at)}


def cancel_job(league: League, job_id: int) -> dict[str, Any]:
    """Cancel a queued or running job; its row afterwards."""
    try:
        reg.cancel_job(league, job_id)
    except reg.InvalidRecordError as error:
        raise ValueError(str(error)) from None
    with league.reading() as session:
        return _row(reg.get_job(session, job_id))


def follow_job(league: League, job_id: int, handlers: Mapping[str, Callable[[reg.JobContext], Any]], *,
               progress: Callable[[int, int], None] | None = None, log: Callable[[str], None] | None = None,
               poll_seconds: float = PROGRESS_EVERY, sleep: Callable[[float], None] = time.sleep) -> Any:
    """Wait for the job ``job_id`` and return its result, wherever it runs: here (claimed, run
    with ``handlers``, reporting to ``progress``) whenever it can be claimed (queued, or its
    worker's lease ran out), else in the worker that holds it, whose stored progress
    (``done``/``total``) goes to ``progress`` every ``poll_seconds`` (slept with ``sleep``).

    Raises :class:`JobFailedError` (its error's last line) when the job failed,
    :class:`JobCancelledError` when someone cancelled it, and, on Ctrl-C, cancels the job (here:
    stops it; in another worker: that worker stops at its next progress report) and raises
    :class:`JobInterrupted` saying so. ``log`` hears once that another worker runs the job."""
    say = log or (lambda line: None)
    worker = reg.default_worker_id()
    elsewhere: str | None = None
    try:
        while True:
            with league.reading() as session:
                job = reg.get_job(session, job_id)
                if job is None:
                    raise ValueError(f"there is no job {job_id}; see `arena-league jobs list`")
                status, owner, result = job.status, job.lease_owner, job.result
                error, done = job.error, job.progress or {}
                claimable = _claimable(job)
            if status == reg.JobStatus.DONE.value:
                if progress is not None and done.get("total"):
                    progress(int(done["total"]), int(done["total"]))
                return result
            if status == reg.JobStatus.FAILED.value:
                raise JobFailedError(f"job {job_id} failed: {_last_line(error)}; see `arena-league jobs show {job_id}`")
            if status == reg.JobStatus.CANCELLED.value:
                raise JobCancelledError(f"job {job_id} was cancelled (`arena-league jobs cancel`, or on the web) "
                                        "before it finished; the matches it played stay stored")
            if claimable:
                claimed = reg.claim_job(league, worker, job_id=job_id)
                if claimed is not None:
                    elsewhere = None
                    try:
                        return reg.run_claimed_job(league, claimed, handlers)
                    except reg.LeaseLostError:
                        continue  # cancelled or taken meanwhile: the row says which
            if status == reg.JobStatus.RUNNING.value and owner and owner != elsewhere:
                elsewhere = owner
                say(f"job {job_id} is run by worker {owner}; following it here (Ctrl-C cancels it)")
            if progress is not None and done.get("total"):
                progress(int(done.get("done", 0)), int(done["total"]))
            sleep(poll_seconds)
    except KeyboardInterrupt:
        with contextlib.suppress(reg.InvalidRecordError):  # it ended meanwhile: nothing to cancel
            reg.cancel_job(league, job_id)
        where = f" in worker {elsewhere}, which stops at its next progress report" if elsewhere else ""
        raise JobInterrupted(f"job {job_id} was cancelled (Ctrl-C){where}; the matches it already played stay "
                             f"stored. See `arena-league jobs show {job_id}`") from None


def _claimable(job: reg.Job) -> bool:
    """Whether a claim could take the job now: queued and due, or running on an expired lease."""
    now = datetime.now(UTC)  # the registry returns its timestamps as aware UTC
    if job.status == reg.JobStatus.QUEUED.value:
        return job.run_after is None or job.run_after <= now
    return (job.status == reg.JobStatus.RUNNING.value and job.lease_expires_at is not None
            and job.lease_expires_at < now)


def _last_line(error: str | None) -> str:
    """A job's stored error (a traceback) as one line: its last, which names the exception."""
    lines = [line.strip() for line in (error or "").splitlines() if line.strip()]
    return lines[-1] if lines else "no error was stored"
