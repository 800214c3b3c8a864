"""Rating, selection and figures of a population build: Bradley-Terry over the round robin, the
members chosen to span the ratings, and the figures the population is judged by."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.league.population.records import (
    REFERENCES,
    BuildReport,
    Candidate,
    MemberRecord,
    PopulationFigures,
    member_name,
    write_json,
)
from arena_league.league.population.round_robin import play_seatings, tally
from arena_league.league.population.selection import select_spanning


@dataclass
class Selection:
    """The rating and selection stage's result."""

    counts: Any
    """The round robin's :class:`~arena_league.rating.SeatCounts` over every candidate and reference
    (each result with the side each agent held, for the seat term of the ratings)."""
    chosen: list[int]
    """Indices of the members among the candidates."""
    margin: float
    """The floor above the random agent's rating that the selection used (Elo)."""


def rate_and_select(table: np.ndarray, keys: list[str], n_candidates: int, size: int, margin: float,
                    say: Callable[[str], None]) -> Selection:
    """Bradley-Terry with a seat term over the round robin ``table`` (rows: team 0's agent index, team
    1's, team 0's score), then ``size`` candidates spanning the ratings from ``margin`` Elo above the
    random agent."""
    from arena_league.rating import PSEUDO_COUNT, SeatCounts, fit_bradley_terry

    first, second = table[:, 0].astype(np.int64), table[:, 1].astype(np.int64)
    seats = SeatCounts.from_results(first, second, np.zeros_like(first), np.ones_like(second), table[:, 2], keys)
    ratings = fit_bradley_terry(seats).ratings
    counts = seats.pair_counts()
    payoff = counts.logit_payoff(pseudo_count=PSEUDO_COUNT)
    payoff[counts.games == 0] = np.nan
    np.fill_diagonal(payoff, np.nan)
    random_index = keys.index("random")
    chosen = select_spanning(ratings[:n_candidates], payoff[:n_candidates], size,
                             floor=float(ratings[random_index]) + margin)
    say(f"selected {len(chosen)} of {n_candidates} candidates (random agent rated {ratings[random_index]:.0f}, "
        f"candidates {ratings[:n_candidates].min():.0f} .. {ratings[:n_candidates].max():.0f})")
    return Selection(seats, list(chosen), margin)


def population_figures(game_id: str, members: list[Candidate], keys: list[str], counts: Any,
                       policies: Mapping[str, Any], seed: int, rounds: int, verify_matches: int, batch_size: int,
                       work: Path, digest: str, report: BuildReport) -> tuple[PopulationFigures, Any]:
    """The figures of ``members`` (:class:`PopulationFigures`) and their bootstrap rating fit."""
    from arena_league.rating import (
        PSEUDO_COUNT,
        PairCounts,
        SeatCounts,
        bootstrap_ratings,
        effective_diversity,
    )

    names = [m.key for m in members] + list(REFERENCES)
    index = np.asarray([keys.index(n) for n in names])
    seats = SeatCounts(names, counts.n_sides, *(c[:, index][:, :, index] for c in (counts.won, counts.lost,
                                                                                    counts.drawn)))
    sub = seats.pair_counts()
    fit = bootstrap_ratings(seats, rounds=rounds, seed=seed, anchor=[m.key for m in members])
    n = len(members)
    member_ratings = fit.rating[:n]
    best, worst = int(np.argmax(member_ratings)), int(np.argmin(member_ratings))
    wins, draws, played = _duel(game_id, members[best].key, members[worst].key, policies, seed, verify_matches,
                                batch_size, work, digest, report, 1 << 40)
    h_wins, h_draws, h_played = _duel(game_id, members[best].key, "heuristic", policies, seed, verify_matches,
                                      batch_size, work, digest, report, 1 << 41)
    random_rating, heuristic_rating = float(fit.rating[n]), float(fit.rating[n + 1])
    below_random = int((member_ratings < random_rating).sum())
    schemes: dict[str, int] = {}
    for m in members:
        schemes[m.scheme] = schemes.get(m.scheme, 0) + 1
    member_payoff = PairCounts(names[:n], sub.wins[:n, :n], sub.draws[:n, :n]).logit_payoff(pseudo_count=PSEUDO_COUNT)
    figures = PopulationFigures(
        size=n, spread=round(float(member_ratings.max() - member_ratings.min()), 1),
        best=members[best].key, worst=members[worst].key, best_vs_worst_matches=played,
        best_vs_worst_win_rate=round(wins / played, 4), best_vs_worst_score=round((wins + 0.5 * draws) / played, 4),
        random_rating=round(random_rating, 1), random_rank=1 + int((member_ratings > random_rating).sum()),
        random_bottom_share=round((below_random + 1) / (n + 1), 4), members_below_random=below_random,
        heuristic_rating=round(heuristic_rating, 1),
        heuristic_rank=1 + int((member_ratings > heuristic_rating).sum()), schemes=dict(sorted(schemes.items())),
        n_schemes=len(schemes), effective_diversity=round(effective_diversity(member_payoff), 4),
        round_robin_matches=round(sub.n_matches), best_vs_heuristic_matches=h_played,
        best_vs_heuristic_win_rate=round(h_wins / h_played, 4),
        best_vs_heuristic_score=round((h_wins + 0.5 * h_draws) / h_played, 4),
        seat_term={**fit.seats.to_dict(), "text": fit.seats.describe()})
    return figures, fit


def _duel(game_id: str, best: str, worst: str, policies: Mapping[str, Any], seed: int, n: int, batch_size: int,
          work: Path, digest: str, report: BuildReport, first_match_id: int) -> tuple[int, int, int]:
    """(wins, draws, matches) of ``best`` against ``worst`` over ``n`` matches, seats alternating,
    with match ids from ``first_match_id`` (past any round robin's, so they never share its seeds)."""
    tag = hashlib.sha256(f"{best}|{worst}|{n}".encode()).hexdigest()[:12]
    path = work / "matches" / digest / f"verify-{tag}.json"
    seatings = [(best, worst) if k % 2 == 0 else (worst, best) for k in range(n)]
    if path.exists():
        scores = json.loads(path.read_text())["scores"]
        report.matches_reused += len(scores)
    else:
        scores = play_seatings(game_id, seatings, policies, seed, first_match_id, batch_size)
        write_json(path, {"best": best, "worst": worst, "scores": scores})
        report.matches_played += len(scores)
    return (*tally(scores), n)


def member_records(name: str, game_id: str, members: list[Candidate], fit: Any) -> list[MemberRecord]:
    """The members' records: names, provenance, ratings with their intervals and ranks (1 = strongest)."""
    n = len(members)
    rating = fit.rating[:n]
    order = np.argsort(-rating, kind="stable")
    rank = np.empty(n, dtype=int)
    rank[order] = np.arange(1, n + 1)
    records = []
    for i, m in enumerate(members):
        records.append(MemberRecord(
            name=member_name(name, m.key, game_id), key=m.key, scheme=m.scheme, steps=m.steps, seed=m.seed,
            learner=m.learner, rating=round(float(rating[i]), 1), rating_lower=round(float(fit.lower[i]), 1),
            rating_upper=round(float(fit.upper[i]), 1), rank=int(rank[i]),
            artifact="" if m.scripted else f"agents/{m.key}", bundle="", bundle_index=-1, warm_start=m.warm_start,
            scripted=m.scripted))
    return records
