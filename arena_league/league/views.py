"""What the web service shows, as plain JSON-ready documents: one function per page.

Each page of ``arena-league serve`` renders one of these documents, and its ``.json`` twin returns
it as it is, so a page never knows more than its JSON. They read the registry only: nothing here
runs agent code or imports a population: a page that needs a game's shipped base population
before the league has it queues the job that imports it (once) and says so, showing the board the
league has until the job is done.

Leaderboards are the expensive part (a bootstrap over every stored match), so
:class:`LeaderboardCache` keeps each board computed once per state of the league: a board is
computed again only when the game's matches, agents or placements changed (one small query tells).
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from arena_league import registry as reg
from arena_league.envs import game_options, game_spec, list_games
from arena_league.envs.options import options_catalog
from arena_league.league.agents import agent_detail, frozen_ratings
from arena_league.league.errors import NotFoundError
from arena_league.league.home import short_name
from arena_league.league.jobs import stamp
from arena_league.league.leaderboards import METHODS, LeaderboardError, rank_text
from arena_league.league.tokens import Identity
from arena_league.league.uploads import series_versions
from arena_league.registry import League

__all__ = ["METHODS", "LeaderboardCache", "agent_log", "agent_view", "game_view", "games_view", "home_view",
           "job_view"]

#: Agents in a game page's win-rate heatmap.
HEATMAP_AGENTS = 12
_SORTS = {"rank": ("rank", False), "rating": ("rating", True), "name": ("agent", False),
          "matches": ("matches", True), "win_rate": ("win_rate", True)}


def _require_game(game_id: str) -> None:
    if game_id not in list_games():
        raise NotFoundError(f"there is no game {game_id!r}; the games are listed at /api/games")


# --- games and the home page -------------------------------------------------------------------

def games_view(league: League) -> list[dict[str, Any]]:
    """Every game: id, layout, whether a base population is shipped and whether it is imported, and
    its options (``options_catalog`` records)."""
    from arena_league.league.populations import shipped_populations

    with league.reading() as session:
        frozen = {}
        for population in reg.list_populations(session):
            if population.frozen:
                frozen.setdefault(population.game_id, []).append(
                    {"population": f"{population.name}:{population.version}", "members": len(population.members)})
    rows = []
    for game_id in list_games():
        spec = game_spec(game_id)
        rows.append({"game_id": game_id, "teams": spec.n_teams, "players_per_team": spec.players_per_team,
                     "action_types": list(spec.rules.action_types), "summary": spec.rules.summary,
                     "base_shipped": bool(shipped_populations(game_id)),
                     "base_imported": frozen.get(game_id, []),
                     "options": options_catalog(game_options(game_id))})
    return rows


def home_view(league: League, *, latest: int = 12) -> dict[str, Any]:
    """The games, their base populations, and the latest submissions."""
    from sqlalchemy import func, select

    with league.reading() as session:
        agents = session.scalars(select(reg.Agent).where(reg.Agent.kind == "submission")
                                 .order_by(reg.Agent.id.desc()).limit(latest))
        submissions = [{"name": a.name, "game_id": a.game_id, "owner": a.owner, "status": a.status,
                        "reason": a.reject_reason, "created_at": stamp(a.created_at)} for a in agents]
        counts = dict(session.execute(select(reg.Agent.game_id, func.count(reg.Agent.id))
                                      .group_by(reg.Agent.game_id)).all())
    games = games_view(league)
    for game in games:
        game["agents"] = counts.get(game["game_id"], 0)
    return {"games": games, "latest_submissions": submissions}


# --- leaderboards ----------------------------------------------------------------------------------

class LeaderboardCache:
    """Leaderboards computed once per state of their game (see the module docstring). Thread-safe.

    The state is looked up at most every ``check_every`` seconds per board (so a board may be that
    much behind the registry); when it changed, one request computes the board again while the
    others are served the board as it was (stale while it is revalidated), so readers never queue
    behind a computation, except for the very first one of a board."""

    def __init__(self, check_every: float = 1.0) -> None:
        self.check_every = check_every
        self._boards: dict[tuple, tuple[tuple, dict[str, Any]]] = {}
        self._checked: dict[tuple, float] = {}
        self._encoded: dict[tuple, tuple[int, bytes]] = {}
        self._locks: dict[tuple, threading.Lock] = {}
        self._guard = threading.Lock()

    def board(self, league: League, game_id: str, method: str = "bt") -> dict[str, Any]:
        """The ``leaderboard --json`` document of ``game_id`` by ``method``."""
        if method not in METHODS:
            raise ValueError(f"unknown rating method {method!r}; one of {', '.join(METHODS)}")
        _require_game(game_id)
        key = (league.url, game_id, method)
        cached = self._boards.get(key)
        if cached is not None and time.monotonic() - self._checked.get(key, 0.0) < self.check_every:
            return cached[1]
        state = self._state(league, game_id)
        self._checked[key] = time.monotonic()
        if cached is not None and cached[0] == state:
            return cached[1]
        with self._guard:
            lock = self._locks.setdefault(key, threading.Lock())
        if cached is not None and not lock.acquire(blocking=False):
            return cached[1]  # another request is computing the new board: this one gets the last
        if cached is None:
            lock.acquire()
        try:
            cached = self._boards.get(key)
            if cached is not None and cached[0] == state:
                return cached[1]
            document = self._compute(league, game_id, method, state)
            self._boards[key] = (state, document)
            return document
        finally:
            lock.release()

    def _compute(self, league: League, game_id: str, method: str, state: tuple) -> dict[str, Any]:
        from arena_league.league.service import leaderboard

        if state[0] is None and not state[3]:  # no match of the game yet, and no frozen population to show
            return {"game_id": game_id, "method": method, "rows": [], "n_matches": 0, "n_agents": 0,
                    "population": None, "basis": "matches", "rating_label": "rating", "level": 0.95}
        return leaderboard(league, game_id, method, import_shipped=False).to_dict()

    def board_json(self, league: League, game_id: str, method: str = "bt") -> bytes:
        """The board of :meth:`board` as JSON bytes, encoded once per computed board (a board of a
        thousand agents takes longer to encode than to look up)."""
        document = self.board(league, game_id, method)
        key = (league.url, game_id, method)
        encoded = self._encoded.get(key)
        if encoded is None or encoded[0] != id(document):
            encoded = (id(document), json.dumps(document, separators=(",", ":"), allow_nan=False).encode())
            self._encoded[key] = encoded
        return encoded[1]

    @staticmethod
    def _state(league: League, game_id: str) -> tuple:
        """What a board depends on: the game's newest match, its agents and their statuses, the
        newest finished placement and the frozen populations."""
        from sqlalchemy import func, select

        with league.reading() as session:
            newest_match = session.scalar(select(func.max(reg.Match.id)).where(reg.Match.game_id == game_id))
            agents = tuple(session.execute(
                select(reg.Agent.status, func.count(reg.Agent.id), func.max(reg.Agent.id))
                .where(reg.Agent.game_id == game_id).group_by(reg.Agent.status).order_by(reg.Agent.status)).all())
            placed = session.scalar(select(func.max(reg.Job.id)).where(reg.Job.kind == "rank",
                                                                       reg.Job.status == "done"))
            frozen = session.scalar(select(func.count(reg.Population.id)).where(
                reg.Population.game_id == game_id, reg.Population.frozen.is_(True)))
        return newest_match, agents, placed, frozen


def game_view(league: League, cache: LeaderboardCache, game_id: str, *, method: str = "bt",
              kind: str | None = None, owner: str | None = None, sort: str | None = None,
              viewer: Identity | None = None) -> dict[str, Any]:
    """A game's page: its board by ``method`` (rows filtered by ``kind`` and ``owner``, sorted by
    ``sort``), the viewer's own agents marked, the scale of the interval bars, the win-rate
    heatmap of the top agents, and (``importing``) the import of the game's shipped base population
    while the league lacks it (:func:`~arena_league.league.populations.base_import`)."""
    from arena_league.league.populations import base_import

    _require_game(game_id)
    importing = base_import(league, game_id) if method == "bt" else None
    board = cache.board(league, game_id, method)
    with league.reading() as session:
        owners = {a.name: a.owner for a in reg.list_agents(session, game_id=game_id)}
    rows = []
    for row in board["rows"]:
        rows.append({**{k: row.get(k) for k in ("agent", "kind", "status", "rank", "rank_lower", "rank_upper", "tied",
                                                "rating", "lower", "upper", "matches", "win_rate", "percentile")},
                     "rank_text": rank_text(row.get("rank"), row.get("rank_lower"), row.get("rank_upper"),
                                            bool(row.get("tied"))),
                     "short": short_name(row["agent"], game_id), "owner": owners.get(row["agent"]),
                     "mine": viewer is not None and owners.get(row["agent"]) == viewer.owner})
    kinds = sorted({r["kind"] for r in rows if r["kind"]})
    listed_owners = sorted({r["owner"] for r in rows if r["owner"]})
    shown = [r for r in rows if (kind is None or r["kind"] == kind) and (owner is None or r["owner"] == owner)]
    if sort is not None:
        if sort not in _SORTS:
            raise ValueError(f"unknown sort {sort!r}; one of {', '.join(_SORTS)}")
        field, descending = _SORTS[sort]
        rated = [r for r in shown if r[field] is not None]
        rated.sort(key=lambda r: r[field], reverse=descending)
        shown = rated + [r for r in shown if r[field] is None]
    values = [v for r in rows for v in (r["lower"], r["upper"], r["rating"]) if v is not None]
    scale = [min(values), max(values)] if values else [0.0, 1.0]
    return {"game_id": game_id, "method": method, "methods": list(METHODS), "basis": board.get("basis"),
            "population": board.get("population"), "rating_label": board.get("rating_label"),
            "level": board.get("level"), "n_matches": board.get("n_matches"), "n_agents": len(rows),
            "rank_legend": board.get("rank_legend"), "notes": board.get("notes") or [],
            "seat_term": board.get("seat_term"), "paired": game_spec(game_id).paired,
            "filters": {"kind": kind, "owner": owner, "sort": sort, "kinds": kinds, "owners": listed_owners},
            "scale": scale, "rows": shown, "heatmap": _heatmap(league, game_id, board, rows), "importing": importing,
            "summary": game_spec(game_id).rules.summary, "options": options_catalog(game_options(game_id))}


def _heatmap(league: League, game_id: str, board: dict[str, Any], rows: Sequence[dict[str, Any]]
             ) -> dict[str, Any]:
    """Pairwise win rates (share of points, draws half) among the board's top agents by rank that
    played in this league (on a population board, the entrants and the members they met: the
    members' own matches were played when the population was built), with a note saying whom it
    shows and whether they met; a pair that never met has no win rate (None)."""
    rated = [r for r in rows if r["rating"] is not None]
    played = [r for r in rated if r["matches"]]
    pool = played if len(played) >= 2 else rated
    if board.get("basis") == "population":  # the entrants first, whatever their rank, then the members
        picked = {r["agent"] for r in sorted(pool, key=lambda r: r["status"] != "placed")[:HEATMAP_AGENTS]}
        pool = [r for r in pool if r["agent"] in picked]
    top = [r["agent"] for r in pool][:HEATMAP_AGENTS]
    short = [short_name(a, game_id) for a in top]
    if len(top) < 2:
        return {"agents": top, "short": short, "win_rate": [], "games": [],
                "note": "fewer than two rated agents: no pair to show"}
    if board.get("win_rate") is not None:
        index = {name: i for i, name in enumerate(board["agents"])}
        picks = [index[a] for a in top if a in index]
        rate = np.asarray(board["win_rate"], dtype=float)[np.ix_(picks, picks)]
        games = np.asarray(board["games"], dtype=float)[np.ix_(picks, picks)]
    else:
        from arena_league.league.leaderboards import outcome_table

        with league.reading() as session:
            seat_rows = reg.match_seat_rows(session, game_id, agents=top)
        rate = np.full((len(top), len(top)), np.nan)
        games = np.zeros((len(top), len(top)))
        if seat_rows:
            counts = outcome_table(seat_rows).pair_counts()
            table_index = {name: i for i, name in enumerate(counts.agents)}
            mine = [i for i, a in enumerate(top) if a in table_index]
            picks = [table_index[top[i]] for i in mine]
            wins, draws = counts.wins[np.ix_(picks, picks)], counts.draws[np.ix_(picks, picks)]
            played_pairs = wins + wins.T + draws
            with np.errstate(invalid="ignore", divide="ignore"):
                share = np.where(played_pairs > 0, (wins + 0.5 * draws) / played_pairs, np.nan)
            rate[np.ix_(mine, mine)], games[np.ix_(mine, mine)] = share, played_pairs
    games = np.nan_to_num(games)
    np.fill_diagonal(rate, np.nan)  # an agent against a copy of itself says nothing of its rank
    met = int(np.triu(games > 0, 1).sum())
    pairs = len(top) * (len(top) - 1) // 2
    entrants = sum(r["status"] == "placed" for r in pool)
    if board.get("basis") == "population" and len(played) >= 2:
        whom = (f"{entrants} placed entrant(s) and the {len(top) - entrants} best-ranked members with matches in "
                "this league, by rank")
    elif len(played) >= 2 and len(played) < len(rated):
        whom = f"the top {len(top)} by rank of the agents with matches in this league"
    else:
        whom = f"the top {len(top)} by rank"
    said = (f"{met} of their {pairs} pairs met" if met else
            "none of them has met another in this league: every cell is not met")
    plain = [[None if not np.isfinite(v) else round(float(v), 4) for v in line] for line in rate]
    return {"agents": top, "short": short, "win_rate": plain, "games": [[int(v) for v in line] for line in games],
            "note": f"{whom}; {said}"}


# --- agents -----------------------------------------------------------------------------------------

def agent_view(league: League, name: str, *, viewer: Identity | None = None,
               boards: LeaderboardCache | None = None) -> dict[str, Any]:
    """An agent's page: its rank on its game's board (from ``boards``: the same row the game page
    shows), its record, its versions, its placements (newest first), its win rate against each
    member of the base it was last placed against, its recent matches; the validation log and the
    forfeits only for its owner and administrators."""
    detail = agent_detail(league, name)
    private = viewer is not None and viewer.may_manage(detail["owner"])
    game_id = detail["game_id"]
    matches = [{"id": m["id"], "key": m["match_key"], "created_at": m["created_at"], "replay": m["replay"],
                "seats": [{**seat, "forfeit": seat.get("forfeit")} for seat in m["seats"]]}
               for m in detail["recent_matches"]]
    with league.reading() as session:
        frozen = {member: rating for member, (rating, _) in frozen_ratings(session, game_id).items()}
    latest = detail["placements"][0] if detail["placements"] else None
    against = []
    if latest:
        for opponent, record in (latest.get("opponents") or {}).items():
            against.append({"agent": opponent, "short": short_name(opponent, game_id),
                            "rating": frozen.get(opponent), "matches": record["matches"],
                            "win_rate": record["score"] / record["matches"] if record["matches"] else None})
        against.sort(key=lambda r: (r["rating"] is None, r["rating"] or 0.0))
    view = {key: detail[key] for key in ("name", "game_id", "kind", "status", "owner", "created_at", "reason",
                                         "matches_played", "matches_forfeited", "populations")}
    view.update(standing=_standing(league, boards, game_id, detail["name"]) if boards is not None else None,
                versions=series_versions(league, detail["name"]), placements=detail["placements"], against=against,
                recent_matches=matches, private=private, mine=viewer is not None and viewer.owner == detail["owner"])
    if private:
        view.update(validation_log=detail["validation_log"], forfeits=detail["forfeits"])
    return view


def _standing(league: League, boards: LeaderboardCache, game_id: str, name: str) -> dict[str, Any] | None:
    """The agent's row of its game's board (rank, rank interval, rating), or None when the board
    does not list it rated (or there is no board yet)."""
    try:
        board = boards.board(league, game_id)
    except (LeaderboardError, ValueError):
        return None
    row = next((r for r in board["rows"] if r["agent"] == name), None)
    if row is None or row.get("rank") is None:
        return None
    of = (board["params"]["members"] + (row["status"] != "member") if board.get("basis") == "population"
          else board["n_rated"])
    return {**{k: row.get(k) for k in ("rank", "rank_lower", "rank_upper", "tied", "rating", "lower", "upper",
                                       "status")},
            "rank_text": rank_text(row["rank"], row["rank_lower"], row["rank_upper"], bool(row.get("tied"))),
            "of": int(of), "method": board["method"], "basis": board.get("basis"),
            "population": board.get("population"), "rank_legend": board.get("rank_legend")}


def agent_log(league: League, name: str, viewer: Identity | None) -> dict[str, Any]:
    """The validation log and forfeits of ``name``, for its owner and administrators; anyone else
    gets :class:`NotFoundError`, as if there were none."""
    detail = agent_detail(league, name)
    if viewer is None or not viewer.may_manage(detail["owner"]):
        raise NotFoundError(f"there is no log of {name!r} for you: an agent's log is its owner's")
    return {"name": name, "status": detail["status"], "reason": detail["reason"],
            "validation_log": detail["validation_log"], "forfeits": detail["forfeits"],
            "matches_forfeited": detail["matches_forfeited"]}


# --- jobs ---------------------------------------------------------------------------------------------

def job_view(league: League, job_id: int) -> dict[str, Any]:
    """A job as a page shows it: state, progress (a bar that ends where the job ended, with a line
    saying so), result (the error's last line when it failed), and in words: ``summary``, what the
    job found or made, and ``links`` to it (the agent's page, the match and its replay, the board)."""
    from arena_league.league.jobs import job_detail

    try:
        detail = job_detail(league, job_id)
    except ValueError:
        raise NotFoundError(f"there is no job {job_id}") from None
    error = (detail["error"] or "").strip().splitlines()
    payload = detail["payload"] or {}
    state, result = detail["status"], detail["result"]
    finished = state in ("done", "failed", "cancelled")
    summary, links = _job_outcome(detail["id"], detail["kind"], state, payload, result if isinstance(result, dict) else {},
                                  error[-1] if error else None)
    return {"id": detail["id"], "kind": detail["kind"], "state": state,
            "progress": _job_progress(detail["kind"], state, payload, detail["progress"], result, error),
            "result": result, "error": error[-1] if error else None, "what": detail["what"],
            "game_id": detail["game_id"], "agent": payload.get("agent"), "attempts": detail["attempts"],
            "created_at": detail["created_at"], "started_at": detail["started_at"],
            "finished_at": detail["finished_at"], "matches_stored": detail["matches_stored"],
            "finished": finished, "summary": summary, "links": links}


def _job_progress(kind: str, state: str, payload: dict[str, Any], progress: dict[str, Any] | None, result: Any,
                  error: list[str]) -> dict[str, Any] | None:
    """``done`` of ``total`` and the ``label`` beside the bar; a finished job's bar is full, its
    label saying how far it got when it stopped short of its total, and why."""
    done = int((progress or {}).get("done") or 0)
    total = int((progress or {}).get("total") or 0)
    if state in ("queued", "running"):
        return None if progress is None else {"done": done, "total": total, "label": f"{done} / {total}"}
    if state == "done" and kind == "rank" and isinstance(result, dict) and result.get("matches") is not None:
        done, total = int(result["matches"]), int(payload.get("budget") or total or result["matches"])
        if done < total and result.get("stopped") == "time" and result.get("stop_reason"):
            return {"done": total, "total": total, "label": f"stopped after {done} of {total}: {result['stop_reason']}"}
        if done < total:
            width = payload.get("target_half_width")
            target = f" (±{width:g} places)" if isinstance(width, (int, float)) else ""
            return {"done": total, "total": total,
                    "label": f"stopped after {done} of {total}: the rank interval was narrow enough{target}"}
    if state == "done" and isinstance(result, dict) and result.get("not_played"):
        total = int(result.get("played", 0)) + int(result.get("skipped", 0)) + int(result["not_played"])
        return {"done": total, "total": total,
                "label": f"stopped after {result.get('played', 0)} of {total}: {result.get('stop_reason', '')}"}
    if state == "done":
        total = total or 1
        return {"done": total, "total": total, "label": f"{total} / {total}" if progress else "done"}
    why = "cancelled" if state == "cancelled" else (error[-1] if error else "failed")
    total = total or 1
    return {"done": total, "total": total, "label": f"stopped after {done} of {total}: {why}"}


def _whole(value: Any) -> str:
    return "?" if value is None else f"{float(value):.0f}"


def _job_outcome(job_id: int, kind: str, state: str, payload: dict[str, Any], result: dict[str, Any],
                 error: str | None) -> tuple[str, list[dict[str, str]]]:
    """What a job found or made, in one sentence, and links to it (``text``, ``href``, and a
    ``role`` for the agent's page)."""
    game = result.get("game_id") or payload.get("game_id")
    board = [{"text": f"the {game} board", "href": f"/games/{game}"}] if game else []
    agent = result.get("agent") or payload.get("agent")
    agent_link = [{"text": f"{agent}'s page", "href": f"/agents/{agent}", "role": "agent"}] if agent else []
    match = result.get("match") or payload.get("match")
    match_link = [{"text": f"match {match}", "href": f"/matches/{match}"}] if match else []
    if state == "failed":
        return f"The {kind} job failed: {error or 'no reason was recorded'}.", agent_link + match_link + board
    if state == "cancelled":
        return f"The {kind} job was cancelled; matches it had stored stay stored.", agent_link + match_link + board
    if state != "done":
        return f"The {kind} job is {state}.", agent_link + match_link + board
    if kind == "rank":
        lower = result.get("rank_lower", result.get("rank_best"))
        upper = result.get("rank_upper", result.get("rank_worst"))
        size = int(result.get("base_size") or 0) + 1
        rating, low, high = (_whole(result.get(key)) for key in ("rating", "lower", "upper"))
        return (f"{agent} placed against {result.get('base')}: rank {result.get('rank')} of {size} ({lower}..{upper}), "
                f"rating {rating} ({low}..{high}), after {result.get('matches')} matches.", agent_link + board)
    if kind == "validate":
        reason = f": {result['reason']}" if result.get("reason") else ""
        return f"{agent} was validated: {result.get('status')}{reason}.", agent_link + board
    if kind == "replay":
        return (f"Match {match} was played again and ended as stored ({result.get('steps')} steps); its replay is "
                "kept.", [*match_link, {"text": "its replay frames", "href": f"/api/matches/{match}/replay"}])
    if kind == "evaluate":
        agents = result.get("agents") or []
        suspended = result.get("suspended") or {}
        more = f"; suspended: {', '.join(suspended)}" if suspended else ""
        played = int(result.get("played") or 0)
        return (f"Played {played} match{'' if played == 1 else 'es'} ({result.get('stored')} new) among "
                f"{len(agents)} agents of {game}{more}.", board)
    if kind == "import":
        how = "imported" if result.get("imported") else "was already imported"
        return f"{result.get('population')} of {game} {how}.", board
    if kind == "verify":
        verdict = "every node behaves as declared" if result.get("ok") else "some nodes differ from their scheme"
        return f"The social tree of {game} was verified: {verdict}.", []
    if kind == "preview":
        return (f"A match of {game} under the social tree was recorded ({result.get('steps')} steps).",
                [{"text": "its replay frames", "href": f"/api/trees/previews/{job_id}"}])
    return f"The {kind} job is done.", board
