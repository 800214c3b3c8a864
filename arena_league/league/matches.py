"""One stored match: what it was, and its replay, recorded again on demand.

A match a job played is stored with its seed and seats (key ``job:<job>:<match id>``); with the
league seed of its job that is its whole spec, and a match's result depends on nothing else. So
any such match can be watched even if nobody recorded it: :func:`queue_replay` queues a
``replay`` job that plays it again with a recorder (in a worker, with its submitted agents in the
sandbox, never in a web request), checks that it ends exactly as stored, and keeps the replay.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from arena_league import registry as reg
from arena_league.league.errors import NotFoundError
from arena_league.league.quotas import enqueue_owned, live_job_limit
from arena_league.league.tokens import Identity
from arena_league.registry import League

__all__ = ["find_match", "handle_replay", "match_page", "match_replay", "match_replay_file", "match_view",
           "queue_replay"]

_JOB_MATCH_KEY = re.compile(r"^job:(?P<job>[0-9]+):(?P<match>[0-9]+)$")


def _match(session: Any, match_id: int) -> reg.Match:
    match = reg.get_match_by_id(session, match_id)
    if match is None:
        raise NotFoundError(f"there is no match {match_id}")
    return match


def match_page(match_id: int, server: str | None = None) -> str:
    """Where the web service shows a match (the same id everywhere): its page's path, or its whole
    address on ``server`` (e.g. ``http://127.0.0.1:8000``) when given."""
    path = f"/matches/{match_id}"
    if not server:
        return path
    if not server.startswith(("http://", "https://")):
        raise ValueError(f"the server address {server!r} must start with http:// or https://, e.g. "
                         "http://127.0.0.1:8000")
    return server.rstrip("/") + path


def find_match(session: Any, match: str | int, game_id: str | None = None) -> reg.Match:
    """The match ``match``: its id (``265``, as ``arena-league matches`` and its page show it) or
    its stored key (``job:6:6291471``); of ``game_id`` when given. A miss raises with the fix."""
    text = str(match).strip()
    found = None
    if text.isdigit():
        found = reg.get_match_by_id(session, int(text))
    elif _JOB_MATCH_KEY.match(text):
        found = reg.get_match(session, text)
    else:
        raise ValueError(f"{text!r} is not a match id; give the number `arena-league matches GAME` shows in its "
                         "match column (e.g. 265)")
    if found is None:
        raise NotFoundError(f"there is no match {text}; `arena-league matches GAME` lists the stored ones")
    if game_id is not None and found.game_id != game_id:
        raise NotFoundError(f"match {text} is a match of {found.game_id}, not {game_id}; see `arena-league matches "
                            f"{game_id}`")
    return found


def match_replay_file(league: League, match: str | int, *, record: bool = False) -> tuple[int, Path]:
    """The id and replay file of the match ``match`` (see :func:`find_match`); with ``record``, a
    match without one is played again here and recorded first (as the job of :func:`queue_replay`)."""
    with league.reading() as session:
        found = find_match(session, match)
        match_id, path = found.id, _replay_paths(found)[0]
    if _recorded(path):
        return match_id, Path(path)
    if not record:
        raise NotFoundError(f"match {match_id} has no recorded replay yet; record it with `arena-league replay "
                            f"{match_id} --record` (or on its page {match_page(match_id)})")
    from arena_league.league.service import job_handlers

    job_id = queue_replay(league, match_id)
    reg.run_job_now(league, job_id, job_handlers())
    with league.reading() as session:
        return match_id, Path(_replay_paths(find_match(session, match_id))[0])


def match_view(league: League, match_id: int) -> dict[str, Any]:
    """A stored match: game, seed, job, seats (agent, team, score, outcome, forfeit), each team's
    result, and whether a replay is recorded or can be."""
    with league.reading() as session:
        match = _match(session, match_id)
        seats = [{"seat": s.seat, "agent": s.agent.name, "team": s.team, "score": s.score, "outcome": s.outcome,
                  "position": s.position, "forfeit": s.forfeit} for s in sorted(match.seats, key=lambda s: s.seat)]
        halves = list(match.halves or [])
        view = {"id": match.id, "key": match.match_key, "game_id": match.game_id, "seed": match.seed,
                "job": match.job_id, "created_at": match.created_at.isoformat(timespec="seconds"),
                "seats": seats, "paired": bool(halves),
                "replay": all(_recorded(path) for path in _replay_paths(match)),
                "replayable": _JOB_MATCH_KEY.match(match.match_key) is not None}
    view["teams"] = _teams([{**seat, "points": None} for seat in seats])
    if halves:
        # a pair: each team's total is what its agents scored toward the pair in both halves
        n = len(seats)
        totals = [halves[0]["points"][i] + halves[1]["points"][(i + n // 2) % n] for i in range(n)]
        for team in view["teams"]:
            team["points"] = next(t for t, s in zip(totals, seats) if s["team"] == team["team"])
        view["halves"] = [{"half": k, "steps": half["steps"], "replay": _recorded(half.get("replay_path")),
                           "teams": _teams([{"agent": a, "team": t, "score": sc, "outcome": o, "points": pt}
                                            for a, t, sc, o, pt in zip(half["seats"], half["teams"], half["scores"],
                                                                       half["outcomes"], half["points"])])}
                          for k, half in enumerate(halves)]
    return view


def _teams(seats: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per team: its agents, outcome, score (and pair points) from its seats."""
    teams: dict[int, dict[str, Any]] = {}
    for seat in seats:
        team = teams.setdefault(seat["team"], {"team": seat["team"], "agents": [], "outcome": seat["outcome"],
                                               "score": seat["score"], "points": seat["points"]})
        if seat["agent"] not in team["agents"]:
            team["agents"].append(seat["agent"])
    return [teams[t] for t in sorted(teams)]


def _replay_paths(match: reg.Match) -> list[str | None]:
    """The replay files of a match: one, or a pair's two halves'."""
    return [half.get("replay_path") for half in match.halves] if match.halves else [match.replay_path]


def _recorded(path: str | None) -> bool:
    return bool(path) and Path(path).is_file()


def match_replay(league: League, match_id: int, half: int | None = None) -> dict[str, Any]:
    """The replay document of a match (see :func:`arena_league.league.replays.replay_document`), of
    one ``half`` (0 or 1; default 0) of a pair; :class:`NotFoundError` when none is recorded yet."""
    from arena_league.league.replays import replay_document

    with league.reading() as session:
        match = _match(session, match_id)
        paths = _replay_paths(match)
    if half is not None and len(paths) == 1:
        raise ValueError(f"match {match_id} is not a pair, so it has no halves; leave `half` out")
    if half is not None and half not in (0, 1):
        raise ValueError(f"half must be 0 or 1 (a pair's first or second match), not {half}")
    path = paths[half or 0]
    if not _recorded(path):
        raise NotFoundError(f"match {match_id} has no recorded replay yet; POST /api/matches/{match_id}/replay "
                            "queues a job that records it")
    return replay_document(path)


def queue_replay(league: League, match_id: int, *, who: Identity | None = None) -> int:
    """Queue the recording of a stored match's replay (see the module docstring) for ``who`` (within
    their quota, :mod:`arena_league.league.quotas`; None: the league's own); the job id."""
    limit = live_job_limit(league) if who is not None else None
    with league.transaction() as session:
        match = _match(session, match_id)
        if not _JOB_MATCH_KEY.match(match.match_key):
            raise ValueError(f"match {match_id} ({match.match_key}) was not played by a league job, so it cannot "
                             "be played again; only matches of evaluations and placements have replays on demand")
        return enqueue_owned(session, who, "replay", {"match": match.id, "game_id": match.game_id}, priority=70,
                             limit=limit).id


def handle_replay(ctx: reg.JobContext, progress: Any = None) -> dict[str, Any]:
    """Job handler: play a stored match again with a recorder and keep the replay, if it ends as
    stored (else the job fails, naming the difference)."""
    from arena_league.league.service import agent_refs, match_key
    from arena_league.matchmaking import MatchSpec, play_matches
    from arena_league.replay import ReplayRecording

    match_id = int(ctx.job.payload["match"])
    with ctx.league.reading() as session:
        match = _match(session, match_id)
        key = _JOB_MATCH_KEY.match(match.match_key)
        job = reg.get_job(session, int(key["job"]))
        if job is None:
            raise ValueError(f"match {match_id}'s job {key['job']} is gone; its league seed is unknown")
        seats = sorted(match.seats, key=lambda s: s.seat)
        agents = list({s.agent.name: s.agent for s in seats}.values())
        refs = agent_refs(session, ctx.league, agents)
        spec = MatchSpec(int(key["match"]), match.game_id, tuple(s.agent.name for s in seats),
                         int((job.payload or {}).get("seed", 0)), paired=bool(match.halves))
        stored = [(s.score, s.outcome) for s in seats]
        stored_key, game_id = match.match_key, match.game_id
    if spec.seed != int(match.seed) or match_key(int(key["job"]), spec.match_id) != stored_key:
        raise ValueError(f"match {match_id} cannot be rebuilt from its job: its seed differs")
    folder = Path(ctx.league.home) / "replays" / game_id
    folder.mkdir(parents=True, exist_ok=True)
    ctx.heartbeat()
    from arena_league.league.settings import sandbox_limits

    [result] = play_matches([spec], refs, recording=ReplayRecording(folder), heartbeat=ctx.heartbeat,
                            sandbox_limits=sandbox_limits(ctx.league))
    replayed = list(zip(result.scores, result.outcomes))
    if replayed != stored:
        for half in result.halves or (result,):
            Path(half.replay_path).unlink(missing_ok=True)
        raise ValueError(f"match {match_id} played again ended {replayed}, not {stored} as stored; an agent or "
                         "the game's rules changed since (its replay is not kept)")
    with ctx.league.transaction() as session:
        reg.set_replay_path(session, _match(session, match_id), str(result.replay_path), result.halves_summary())
    return {"match": match_id, "replay": True, "steps": result.steps}
