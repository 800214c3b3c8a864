"""The records a population build passes between its stages and writes: candidates, members, figures,
the build's report, and the criteria a shipped population is judged by."""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import torch

from arena_league.policies.architecture import Architecture

__all__ = [
    "CRITERIA",
    "HEADROOM",
    "PAIRED_CRITERIA",
    "REFERENCES",
    "SCRIPTED_SCHEME",
    "TUNED_SCHEME",
    "BuildReport",
    "Candidate",
    "MemberRecord",
    "PopulationFigures",
    "check_criteria",
    "criteria_for",
    "member_name",
]

#: The issue's must-show criteria for a shipped population, as (figure, comparison, threshold).
CRITERIA: dict[str, tuple[str, str, float]] = {
    "best_beats_worst": ("best_vs_worst_win_rate", ">=", 0.90),
    "bradley_terry_spread": ("spread", ">=", 800.0),
    "random_in_bottom_5_percent": ("random_bottom_share", "<=", 0.05),
    "three_schemes": ("n_schemes", ">=", 3),
}
#: The criteria of a game played in pairs (a runner and a blocker), in pair terms: the figures above
#: come from pairs (ratings fitted on pairs, best over worst in pairs), and besides, the random agent
#: is last and the scripted heuristic is not on top.
PAIRED_CRITERIA: dict[str, tuple[str, str, float]] = {
    **CRITERIA,
    "random_last": ("members_below_random", "<=", 0),
    "heuristic_not_on_top": ("heuristic_rank", ">=", 2),
}
#: A population with headroom: its best member beats the scripted heuristic in this share of matches
#: at least (the newest population of every game must; ``base-v1`` of a game that ships a newer one
#: is kept for comparability).
HEADROOM: tuple[str, str, float] = ("best_vs_heuristic_win_rate", ">=", 0.60)
#: The scheme recorded for a built-in search agent member.
SCRIPTED_SCHEME = "search"
#: The scheme recorded for a built-in tuned heuristic member (the game's heuristic with other constants).
TUNED_SCHEME = "tuned"
#: Members are rated at least this far above the random agent (Elo) unless a recipe says otherwise.
#: The scripted agents every round robin holds, as references for the ratings.
REFERENCES = ("random", "heuristic")


@dataclass
class Candidate:
    """A snapshot that may join the population."""

    key: str
    """Its name within the build: ``<scheme>-s<seed>-<learner>-<steps>``."""
    scheme: str
    steps: int
    seed: int
    learner: str
    architecture: Architecture
    params: dict[str, torch.Tensor]
    warm_start: str | None = None
    """The agent its run imitated before RL (``scripted:heuristic``), or None (from scratch)."""
    scripted: str | None = None
    """A built-in agent's name (``search-w8-r4-h30``; no architecture, no weights), or None."""


@dataclass
class MemberRecord:
    """One member of a built population."""

    name: str
    """Its agent name in a league: ``<population>.<key>@<game>``."""
    key: str
    scheme: str
    steps: int
    seed: int
    learner: str
    rating: float
    rating_lower: float
    rating_upper: float
    rank: int
    """1 = strongest member."""
    artifact: str
    """Its arena-policy folder, relative to the population folder."""
    bundle: str
    bundle_index: int
    warm_start: str | None = None
    """The agent its run imitated before RL, or None (trained from scratch)."""
    scripted: str | None = None
    """A built-in member's agent name (it has no artifact), or None."""


@dataclass
class PopulationFigures:
    """The figures a shipped population is judged by (see :data:`CRITERIA`)."""

    size: int
    spread: float
    """Bradley-Terry rating of the best member minus that of the worst (Elo points)."""
    best: str
    worst: str
    best_vs_worst_matches: int
    best_vs_worst_win_rate: float
    """Share of those matches the best member won (draws not counted as wins)."""
    best_vs_worst_score: float
    """Its points share (draws count half)."""
    random_rating: float
    random_rank: int
    """Rank of the random agent among the members and itself (1 = strongest)."""
    random_bottom_share: float
    """(members rated below random + 1) / (members + 1): the random agent's place from the bottom."""
    members_below_random: int
    heuristic_rating: float
    heuristic_rank: int
    schemes: dict[str, int]
    """Members per training scheme."""
    n_schemes: int
    effective_diversity: float
    """Of the members' logit payoff meta-game (Balduzzi et al. 2018): 0 when transitive."""
    round_robin_matches: int
    """Matches among members and references the ratings come from."""
    best_vs_heuristic_matches: int = 0
    best_vs_heuristic_win_rate: float = float("nan")
    """Share of those matches the best member won against the scripted heuristic (:data:`HEADROOM`)."""
    best_vs_heuristic_score: float = float("nan")
    seat_term: dict[str, Any] | None = None
    """Bradley-Terry's seat term the ratings were fitted with (:class:`~arena_league.rating.SeatTerm`
    as a dict, its sentence under ``"text"``); placements against the population use it."""


@dataclass
class BuildReport:
    """What :func:`build_population` did and made."""

    game_id: str
    name: str
    out_dir: str | None
    work_dir: str
    schemes: list[str]
    steps_per_scheme: dict[str, int]
    seed: int
    candidates: int
    members: list[MemberRecord]
    figures: PopulationFigures | None
    criteria: dict[str, bool]
    passed: bool
    trained: list[str]
    """Schemes trained by this call."""
    reused_runs: list[str]
    """Schemes whose finished runs were read back from ``work_dir``."""
    matches_played: int
    """Round-robin and verification matches played by this call."""
    matches_reused: int
    """Matches read back from ``work_dir``."""
    stage: str
    """The last stage completed ("train", "round_robin", ..., "register")."""
    population: str | None = None
    """``name:version`` in the league, when registered."""
    seconds: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def criteria_for(game_id: str) -> dict[str, tuple[str, str, float]]:
    """The shipped-population criteria of ``game_id``: :data:`PAIRED_CRITERIA` for a game played in
    pairs, else :data:`CRITERIA`."""
    from arena_league.envs import game_spec

    return PAIRED_CRITERIA if game_spec(game_id).paired else CRITERIA


def check_criteria(figures: PopulationFigures, game_id: str) -> dict[str, bool]:
    """Each criterion of ``game_id`` (:func:`criteria_for`) checked against ``figures``."""
    result = {}
    for criterion, (figure, comparison, threshold) in criteria_for(game_id).items():
        value = float(getattr(figures, figure))
        result[criterion] = value >= threshold if comparison == ">=" else value <= threshold
    return result


def member_name(population: str, key: str, game_id: str) -> str:
    """A member's agent name in a league: ``<population>.<key>@<game_id>``."""
    return f"{population}.{key}@{game_id}"


def write_json(path: Path, document: Any) -> None:
    """Write JSON atomically (a reader never sees half a file; an interrupted write leaves none)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(document, indent=1, sort_keys=False) + "\n")
    os.replace(tmp, path)


def jsonable(value: Any) -> Any:
    """``value`` as JSON holds it (tuples as lists, non-finite floats as None)."""
    from arena_league.training.schemes import json_safe

    return json_safe(value)
