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
from arena_league.league.home import did_you_mean, short_name
from arena_league.league.versions import version_rows
from arena_league.registry import League

__all__ = ["agent_detail", "agent_rows", "latest_placements", "match_result", "recent_matches", "reinstate_agent",
           "require_agent", "resolve_agent"]


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


def require_agent(session: Any, name: str, game_id: str | None = None) -> reg.Agent:
    """The agent ``name``: its full name, or the short name a board shows (``random`` for
    ``random@<game>``) when one agent (of ``game_id``, when given) carries it. A missing or
    ambiguous name raises, naming the agents it could be and the fix."""
    agent = reg.get_agent(session, name)
    if agent is not None and (game_id is None or agent.game_id == game_id):
        return agent
    every = reg.list_agents(session)
    if agent is not None:
        raise NotFoundError(f"agent {name} plays {agent.game_id}, not {game_id}; give an agent of {game_id} (see "
                            f"`arena-league agents {game_id}`)")
    same = [a for a in every if short_name(a.name, a.game_id) == name and a.name != name]
    if game_id is not None:
        mine = [a for a in same if a.game_id == game_id]
        if not mine and same:
            raise NotFoundError(f"{game_id} has no agent {name!r}; {' and '.join(a.name for a in same)} "
                                f"{'play' if len(same) > 1 else 'plays'} another game (see "
                                f"`arena-league agents {game_id}`)")
        same = mine
    if len(same) == 1:
        return same[0]
    if same:
        names = ", ".join(sorted(a.name for a in same))
        raise NotFoundError(f"{name!r} is the short name of {len(same)} agents ({names}); give the full name, or "
                            "the game with --game GAME")
    pool = [a for a in every if game_id is None or a.game_id == game_id]
    known = {a.name for a in pool} | {short_name(a.name, a.game_id) for a in pool}
    where = f" of {game_id}" if game_id else ""
    listing = f"`arena-league agents{' ' + game_id if game_id else ''}`"
    raise NotFoundError(f"there is no agent {name!r}{where}.{did_you_mean(name, known)} See {listing}")


def resolve_agent(league: League, name: str, game_id: str | None = None) -> str:
    """The full name of the agent ``name`` (see :func:`require_agent`)."""
    with league.reading() as session:
        return require_agent(session, name, game_id).name


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


def agent_detail(league: League, name: str, *, matches: int = 10, game_id: str | None = None) -> dict[str, Any]:
    """One agent in full (``name`` as :func:`require_agent` takes it): its record, validation log,
    populations, placements (newest first) and its last ``matches`` matches."""
    with league.reading() as session:
        agent = require_agent(session, name, game_id)
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


def reinstate_agent(league: League, name: str, game_id: str | None = None) -> dict[str, Any]:
    """Make a suspended agent active again (its forfeits stay counted: the next one suspends it
    again); returns its name, status and the forfeits it carries."""
    with league.transaction() as session:
        agent = require_agent(session, name, game_id)
        if agent.status != "suspended":
            raise ValueError(f"agent {agent.name} is {agent.status}, not suspended; only a suspended agent is reinstated")
        reg.set_agent_status(session, agent, "active")
        forfeited = reg.forfeit_counts(session, [agent.id]).get(agent.id, 0)
        return {"name": agent.name, "status": agent.status, "matches_forfeited": forfeited}


def recent_matches(league: League, game_id: str, *, agent: str | None = None, limit: int = 20,
                   server: str | None = None) -> list[dict[str, Any]]:
    """The last ``limit`` matches of a game (optionally those of one agent), newest first: each
    with its id (the one its page, ``/matches/<id>``, and ``arena-league replay`` take), its stored
    key, seed, replay file and seats; ``page`` is the page's path, or its address on ``server``."""
    from arena_league.envs import game_spec
    from arena_league.league.matches import match_page

    game_spec(game_id)  # an unknown id raises with the valid ones
    match_page(0, server)  # a malformed address raises before the league is read
    with league.reading() as session:
        agent_id = require_agent(session, agent, game_id).id if agent else None
        matches = reg.list_matches(session, game_id, agent_id=agent_id)[-limit:]
        rows = [{"id": m.id, "page": match_page(m.id, server), "match_key": m.match_key, "seed": m.seed,
                 "replay": m.replay_path, "paired": bool(m.halves),
                 "halves": [{"seats": h["seats"], "points": h["points"], "steps": h["steps"],
                             "replay": h.get("replay_path")} for h in m.halves or []],
                 "created_at": m.created_at.isoformat(timespec="seconds"),
                 "seats": [{"seat": s.seat, "agent": s.agent.name, "team": s.team, "score": s.score,
                            "outcome": s.outcome, "position": s.position} for s in m.seats]}
                for m in reversed(matches)]
    for row in rows:
        row["result"] = match_result(row["seats"], game_id) + (" (a pair)" if row["paired"] else "")
    return rows


def match_result(seats: list[dict[str, Any]], game_id: str) -> str:
    """A match's result in a line: each team's agents (short names, each once) and its outcome,
    e.g. ``example-mlp (loss) vs base-v1.sp-s0-sp-5120 (win)``."""
    teams: dict[int, tuple[list[str], str]] = {}
    for seat in seats:
        names, _ = teams.setdefault(seat["team"], ([], seat["outcome"] or "-"))
        name = short_name(seat["agent"], game_id)
        if name not in names:
            names.append(name)
    return " vs ".join(f"{' + '.join(names)} ({outcome})" for names, outcome in teams.values())
