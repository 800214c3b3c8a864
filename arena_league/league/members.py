"""A population's averaged ranking among a game's base population, as the Arena paper offers.

``rank_members(league, ["alice", "bob"])`` or ``rank_members(league, ["runs/final"])`` places every
member against its game's base population (:func:`~arena_league.league.service.rank`, matches
stored like any placement) and reports the population's mean rank and mean percentile with a
bootstrap interval over its members (seeded, percentile method).

A member is named by an agent already in the league, or by a path: an ONNX file, an arena-policy
folder (one holding ``manifest.json``), a frozen population folder (``population.json``: its
members' artifacts; built-in search members have none and are left out), or a folder of such files
and folders. Paths are submitted first
(:func:`~arena_league.league.service.submit`, validated as every submission is) under the name
``<folder>.<member>``; the same bytes submitted before keep the agent they already have.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.league.agents import require_agent
from arena_league.league.errors import NotFoundError
from arena_league.rating.aggregate import stratified_bootstrap_ci

__all__ = ["MembersReport", "member_sources", "rank_members"]

_MANIFEST = "manifest.json"
_POPULATION = "population.json"


@dataclass
class MembersReport:
    """Every member's placement and the population's averages with their intervals."""

    game_id: str
    base: str
    base_size: int
    members: list[dict[str, Any]] = field(default_factory=list)
    mean_rank: float = 0.0
    mean_rank_lower: float = 0.0
    mean_rank_upper: float = 0.0
    mean_percentile: float = 0.0
    mean_percentile_lower: float = 0.0
    mean_percentile_upper: float = 0.0
    level: float = 0.95
    matches: int = 0

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _member_name(folder: str, stem: str) -> str:
    name = re.sub(r"[^A-Za-z0-9._+-]+", "-", f"{folder}.{stem}").strip("-.") or "member"
    return name[:128]


def member_sources(item: str) -> tuple[list[tuple[Path, str]], str | None]:
    """``(path, name)`` of every artifact behind the path ``item``, and the game a population
    folder names (None otherwise). Raises ValueError for a path with no agent in it."""
    path = Path(item)
    if path.is_file():
        if path.suffix != ".onnx":
            raise ValueError(f"{item} is not an agent: give an .onnx file, an arena-policy folder, a population "
                             "folder or a folder of those")
        return [(path, _member_name(path.parent.name or "members", path.stem))], None
    if (path / _POPULATION).is_file():
        manifest = json.loads((path / _POPULATION).read_text())
        # built-in members (search agents) carry no artifact and are the league's own: not entrants
        found = [(path / m["artifact"], _member_name(path.name, Path(m["artifact"]).name))
                 for m in manifest.get("members", []) if m.get("artifact")]
        return found, manifest.get("game_id")
    if (path / _MANIFEST).is_file():
        return [(path, _member_name(path.parent.name or "members", path.name))], None
    found = [(child, _member_name(path.name, child.stem)) for child in sorted(path.iterdir())
             if (child.is_dir() and (child / _MANIFEST).is_file()) or (child.is_file() and child.suffix == ".onnx")]
    if not found:
        raise ValueError(f"{item} holds no agents (no .onnx files, arena-policy folders or population.json)")
    return found, None


def rank_members(league: Any, members: Sequence[str], *, game_id: str | None = None, budget: int = 200,
                 population: str | None = None, seed: int = 0, target_half_width: float = 3.0,
                 backend: str = "inprocess", reps: int = 2000, progress: Any = None,
                 log: Callable[[str], None] | None = None) -> MembersReport:
    """Places every member (agent names or paths, see the module) against the base population of
    their game and averages their ranks and percentiles, with 95% intervals over the members."""
    from arena_league.league.service import rank, submit

    say = log or (lambda line: None)
    if not members:
        raise ValueError("name the members: agent names, or paths to .onnx files, arena-policy folders or a "
                         "population folder")
    names: list[str] = []
    sources: list[tuple[Path, str]] = []
    for item in members:
        if Path(item).exists():
            found, named_game = member_sources(item)
            if named_game and game_id and named_game != game_id:
                raise ValueError(f"{item} is a population of {named_game}, not of {game_id}")
            game_id = game_id or named_game
            sources += found
            continue
        with league.reading() as session:
            try:
                agent = require_agent(session, item, game_id)
            except NotFoundError as error:
                raise ValueError(f"{item!r} is neither a path nor an agent to rank here: {error}") from None
            game_id = agent.game_id
        names.append(agent.name)
    if sources and game_id is None:
        raise ValueError("the members' game is not known from their files; give it with --game GAME")
    for path, name in sources:
        result = submit(league, path, game_id, name)
        if result.status != "active":
            raise ValueError(f"{path} was not accepted as an agent of {game_id} ({result.reason}); see "
                             f"`arena-league agent {result.agent}`")
        names.append(result.agent)
    names = list(dict.fromkeys(names))
    rows, label, base_size = [], "", 0
    for i, name in enumerate(names):
        say(f"member {i + 1} of {len(names)}: ranking {name}")
        placed = rank(league, name, budget=budget, population=population, seed=seed,
                      target_half_width=target_half_width, backend=backend, progress=progress)
        label, base_size = placed.base, placed.base_size
        rows.append({"agent": name, "rank": placed.rank, "rank_lower": placed.rank_lower,
                     "rank_upper": placed.rank_upper, "percentile": placed.percentile,
                     "percentile_lower": placed.percentile_lower, "percentile_upper": placed.percentile_upper,
                     "rating": placed.rating, "matches": placed.matches})
    table = np.array([[r["rank"], r["percentile"]] for r in rows], dtype=np.float64)
    report = MembersReport(game_id=str(game_id), base=label, base_size=base_size, members=rows,
                           matches=int(sum(r["matches"] for r in rows)))
    rng = np.random.default_rng(seed)
    for column, key in ((0, "mean_rank"), (1, "mean_percentile")):
        values = table[:, column:column + 1]
        if len(values) > 1:
            ci = stratified_bootstrap_ci(values, lambda s: s.mean(axis=(-2, -1)), reps=reps, rng=rng)
            point, lower, upper = float(ci.point), float(ci.lower), float(ci.upper)
        else:  # one member: its own placement interval is the population's
            row = rows[0]
            point = float(values[0, 0])
            lower, upper = ((row["rank_lower"], row["rank_upper"]) if key == "mean_rank"
                            else (row["percentile_lower"], row["percentile_upper"]))
        setattr(report, key, point)
        setattr(report, f"{key}_lower", float(lower))
        setattr(report, f"{key}_upper", float(upper))
    return report
