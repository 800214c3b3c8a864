"""The league's jobs as a person looks them up: the queue, one job in full, and cancelling one.

Every match is played by a job (``evaluate`` or ``rank``), run at once by the command that
queued it or later by ``arena-league worker``. A cancelled job does not run (again); a worker
running it stops at its next lease renewal and discards its result, and the matches it had
already stored stay (they are real matches).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from arena_league import registry as reg
from arena_league.registry import League

__all__ = ["cancel_job", "evaluation_payload", "job_detail", "job_rows"]


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
        return f"{payload.get('agent')} against {payload.get('base_label')}, budget {payload.get('budget')}"
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
