"""The league's agents as a person looks them up: a list per game, and one agent in full.

An agent's rating here is where it stands on its game's base scale: a base member's frozen
rating from its population, or an entrant's latest placement (the result of its newest finished
``rank`` job). A rejected agent keeps its reason and validation log; a suspended one (it forfeited
too many matches in the inference sandbox) its reason and the forfeits themselves.
"""

from __future__ import annotations

from typing import Any

from arena_league import registry as reg
from arena_league.league.errors import NotFoundError
from arena_league.league.home import did_you_mean
from arena_league.league.versions import version_rows
from arena_league.registry import League

__all__ = ["agent_detail", "agent_rows", "latest_placements", "recent_matches", "reinstate_agent", "require_agent"]


def latest_placements(session: Any, game_id: str | None = None, *, base: str | None = None
                      ) -> dict[str, tuple[dict[str, Any], int]]:
    """Agent name -> (the result, the job id) of its newest finished ``rank`` job, of ``game_id``
    and against the base labelled ``base`` (e.g. ``base-v1:1``) when given."""
    placed: dict[str, tuple[dict[str, Any], int]] = {}
    for job in reg.list_jobs(session, status="done", kind="rank"):  # newest first
        payload, result = job.payload or {}, job.result or {}
        name = payload.get("agent")
        if (name and name not in placed and (game_id is None or payload.get("game_id") == game_id)
                and (base is None or payload.get("base_label") == base)):
            placed[name] = (placement_result(result), job.id)
    return placed


_LEGACY_RANK_KEYS = {"rank_best": "rank_lower", "rank_worst": "rank_upper"}


def placement_result(result: dict[str, Any]) -> dict[str, Any]:
    """A stored ``rank`` job's result with today's field names: placements stored before the rank
    interval's ends were named ``rank_lower``/``rank_upper`` carry ``rank_best``/``rank_worst``."""
    if not any(key in result for key in _LEGACY_RANK_KEYS):
        return result
    return {_LEGACY_RANK_KEYS.get(key, key): value for key, value in result.items()}


def frozen_ratings(session: Any, game_id: str | None) -> dict[str, tuple[float, str]]:
    """Base member name -> (frozen rating, ``population:version``), newest population first."""
    ratings: dict[str, tuple[float, str]] = {}
    populations = sorted(reg.list_populations(session, game_id=game_id), key=lambda p: (p.created_at, p.id),
                         reverse=True)
    for population in populations:
        if not population.frozen:
            continue
        for member in population.members:
            rating = (member.meta or {}).get("rating")
            if rating is not None and member.agent.name not in ratings:
                ratings[member.agent.name] = (float(rating), f"{population.name}:{population.version}")
    return ratings


def require_agent(session: Any, name: str) -> reg.Agent:
    """The agent ``name``; a missing one raises with the closest names."""
    agent = reg.get_agent(session, name)
    if agent is None:
        every = [a.name for a in reg.list_agents(session)]
        raise NotFoundError(f"there is no agent {name!r}.{did_you_mean(name, every)} See `arena-league agents`")
    return agent


def agent_rows(league: League, game_id: str | None = None) -> list[dict[str, Any]]:
    """Every agent (of ``game_id``): name, game, kind, status, owner, rating and where it comes from,
    and the reason of a rejected one; oldest first."""
    with league.reading() as session:
        if game_id is not None and reg.get_game(session, game_id) is None:
            from arena_league.envs import game_spec

            game_spec(game_id)  # an unknown id raises with the valid ones
            return []
        placed = latest_placements(session, game_id)
        frozen = frozen_ratings(session, game_id)
        rows = []
        for agent in reg.list_agents(session, game_id=game_id):
            row: dict[str, Any] = {"name": agent.name, "game_id": agent.game_id, "kind": agent.kind,
                                   "status": agent.status, "owner": agent.owner, "rating": None, "rated_by": None,
                                   "reason": agent.reject_reason}
            if agent.name in placed:
                result = placed[agent.name][0]
                row.update(rating=result.get("rating"), lower=result.get("lower"), upper=result.get("upper"),
                           rated_by=f"placement against {result.get('base')}")
            elif agent.name in frozen:
                row.update(rating=frozen[agent.name][0], rated_by=f"member of {frozen[agent.name][1]}")
            rows.append(row)
        return rows


def agent_detail(league: League, name: str, *, matches: int = 10) -> dict[str, Any]:
    """One agent in full: its record, validation log, populations, placements (newest first) and
    its last ``matches`` matches."""
    with league.reading() as session:
        agent = require_agent(session, name)
        placements = [placement_result(job.result) for job in reg.list_jobs(session, status="done", kind="rank")
                      if (job.result or {}).get("agent") == agent.name]
        populations = [f"{p.name}:{p.version}" for p in reg.list_populations(session, game_id=agent.game_id)
                       if any(m.agent_id == agent.id for m in p.members)]
        recent = reg.list_matches(session, agent.game_id, agent_id=agent.id)[-matches:]
        played = reg.count_matches(session, agent_id=agent.id)
        forfeited = reg.forfeit_counts(session, [agent.id]).get(agent.id, 0)
        forfeits = reg.agent_forfeits(session, agent, limit=matches)
        return {
            "name": agent.name, "game_id": agent.game_id, "kind": agent.kind, "status": agent.status,
            "owner": agent.owner, "created_at": agent.created_at.isoformat(timespec="seconds"),
            "artifact": agent.artifact_sha256, "metadata": agent.meta or {}, "reason": agent.reject_reason,
            "validation_log": agent.validation_log or "", "populations": populations, "placements": placements,
            "matches_played": played, "matches_forfeited": forfeited, "versions": version_rows(session, agent.name),
            "forfeits": [{**f, "at": f["at"].isoformat(timespec="seconds")} for f in forfeits],
            "recent_matches": [{"id": m.id, "match_key": m.match_key, "replay": bool(m.replay_path),
                                "created_at": m.created_at.isoformat(timespec="seconds"),
                                "seats": [{"agent": s.agent.name, "team": s.team, "outcome": s.outcome,
                                           **({"forfeit": s.forfeit} if s.forfeit else {})}
                                          for s in m.seats]} for m in reversed(recent)],
        }


def reinstate_agent(league: League, name: str) -> dict[str, Any]:
    """Make a suspended agent active again (its forfeits stay counted: the next one suspends it
    again); returns its name, status and the forfeits it carries."""
    with league.transaction() as session:
        agent = require_agent(session, name)
        if agent.status != "suspended":
            raise ValueError(f"agent {name} is {agent.status}, not suspended; only a suspended agent is reinstated")
        reg.set_agent_status(session, agent, "active")
        forfeited = reg.forfeit_counts(session, [agent.id]).get(agent.id, 0)
        return {"name": agent.name, "status": agent.status, "matches_forfeited": forfeited}


def recent_matches(league: League, game_id: str, *, agent: str | None = None, limit: int = 20) -> list[dict[str, Any]]:
    """The last ``limit`` matches of a game (optionally those of one agent), newest first."""
    with league.reading() as session:
        agent_id = reg.require_agent(session, agent).id if agent else None
        matches = reg.list_matches(session, game_id, agent_id=agent_id)[-limit:]
        return [{"match_key": m.match_key, "seed": m.seed, "replay": m.replay_path,
                 "created_at": m.created_at.isoformat(timespec="seconds"),
                 "seats": [{"seat": s.seat, "agent": s.agent.name, "team": s.team, "score": s.score,
                            "outcome": s.outcome, "position": s.position} for s in m.seats]}
                for m in reversed(matches)]
