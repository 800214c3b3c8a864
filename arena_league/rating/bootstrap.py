"""Bootstrap confidence intervals for ratings, ranks, percentiles, Nash scores and alpha-Rank mass.

Efron (1979), "Bootstrap methods: another look at the jackknife", Annals of Statistics 7: the
matches are resampled with replacement, each statistic is recomputed on every replicate, and the
percentile interval of the replicates is reported. As in Chatbot Arena (Chiang et al. 2024), the
matches are resampled through their deduplicated outcome counts: one multinomial draw per round
over the (pair, outcome) cells of :class:`PairCounts`, so that a round costs the size of the count
matrix, not the number of matches. Bradley-Terry rounds are all solved at once by batched Newton
steps warm-started from the point estimate.

Ranks and their intervals are the league's one definition
(:func:`~arena_league.rating.ranks.competition_ranks`): 1 + the agents rated above the rating,
above the interval's upper end (the best place) and at or above its lower end (the worst).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from arena_league.rating.alpharank import alpha_rank
from arena_league.rating.bradley_terry import (
    DEFAULT_PRIOR_SD,
    ELO_BASE,
    ELO_SCALE,
    DrawModel,
    StrengthFitter,
    anchoring,
)
from arena_league.rating.nash import nash_averaging
from arena_league.rating.outcomes import PSEUDO_COUNT, PairCounts
from arena_league.rating.ranks import competition_ranks

__all__ = [
    "BootstrapInterval",
    "RatingIntervals",
    "alpha_rank_intervals",
    "bootstrap_ratings",
    "bootstrap_statistic",
    "nash_intervals",
]


@dataclass(frozen=True)
class RatingIntervals:
    """Bradley-Terry ratings with bootstrap intervals, ranks and percentiles."""

    agents: list[str]
    rating: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    rank: np.ndarray
    """1 + the number of other agents rated above this one (see :func:`competition_ranks`)."""
    rank_lower: np.ndarray
    """The best place: 1 + the agents rated above this one's upper end."""
    rank_upper: np.ndarray
    """The worst place: 1 + the other agents rated at or above this one's lower end."""
    percentile: np.ndarray
    """Share of the other agents rated below this one (point estimate), in percent."""
    percentile_lower: np.ndarray
    percentile_upper: np.ndarray
    samples: np.ndarray
    """Bootstrap replicates of the ratings, ``(rounds, n)``."""
    level: float
    draw_nu: float | None


@dataclass(frozen=True)
class BootstrapInterval:
    """A statistic's point estimate and bootstrap percentile interval."""

    point: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    samples: np.ndarray
    level: float


def bootstrap_ratings(
    counts: PairCounts,
    *,
    rounds: int = 100,
    level: float = 0.95,
    seed: int = 0,
    draw_model: DrawModel = "half",
    prior_sd: float = DEFAULT_PRIOR_SD,
    anchor: Sequence[str | int] | None = None,
    pin: str | int | None = None,
    base: float = ELO_BASE,
    scale: float = ELO_SCALE,
) -> RatingIntervals:
    """Bradley-Terry ratings with percentile-bootstrap intervals over resampled matches.

    Arguments are those of :func:`arena_league.rating.bradley_terry`, plus the number of bootstrap
    ``rounds``, the interval ``level`` and the ``seed``. Each replicate is anchored like the point
    estimate, so a pinned agent has a zero-width interval and the others are relative to it.
    """
    n = counts.n_agents
    if n < 2:
        raise ValueError("rating intervals need at least two agents")
    _check_level(level, rounds)
    fitter = StrengthFitter(n, draw_model, prior_sd)
    fitter.check_identifiable(counts.wins, counts.draws)
    point, _ = fitter.fit(counts.wins[None], counts.draws[None])
    wins, draws = counts.resample(np.random.default_rng(seed), rounds)
    fitter.check_identifiable(wins, draws)
    replicates, _ = fitter.fit(wins, draws, x0=np.repeat(point, rounds, axis=0))
    to_ratings = anchoring(counts.agents, anchor=anchor, pin=pin, base=base, scale=scale)
    rating = to_ratings(point[0, :n])
    samples = to_ratings(replicates[:, :n])
    lower, upper = _percentile_interval(samples, level)
    ranks = competition_ranks(rating, lower, upper)
    others = n - 1
    return RatingIntervals(
        agents=counts.agents, rating=rating, lower=lower, upper=upper, rank=ranks.rank,
        rank_lower=ranks.rank_lower, rank_upper=ranks.rank_upper,
        percentile=100.0 * (rating[None, :] < rating[:, None]).sum(axis=1) / others,
        percentile_lower=100.0 * (n - ranks.rank_upper) / others,
        percentile_upper=100.0 * (n - ranks.rank_lower) / others,
        samples=samples, level=level,
        draw_nu=float(np.exp(point[0, -1])) if draw_model == "davidson" else None)


def bootstrap_statistic(
    counts: PairCounts,
    statistic: Callable[[PairCounts], np.ndarray],
    *,
    rounds: int = 100,
    level: float = 0.95,
    seed: int = 0,
    point: np.ndarray | None = None,
) -> BootstrapInterval:
    """Percentile-bootstrap interval of any statistic of the counts (a function returning an
    array), over leagues resampled match by match.

    ``point`` is ``statistic(counts)`` when the caller has computed it already; it is then taken as
    given rather than computed again (the replicates and the interval do not depend on it).
    """
    _check_level(level, rounds)
    point = np.asarray(statistic(counts) if point is None else point, dtype=np.float64)
    wins, draws = counts.resample(np.random.default_rng(seed), rounds)
    samples = np.stack([np.asarray(statistic(PairCounts(counts.agents, w, d)), dtype=np.float64)
                        for w, d in zip(wins, draws)])
    lower, upper = _percentile_interval(samples, level)
    return BootstrapInterval(point, lower, upper, samples, level)


def nash_intervals(counts: PairCounts, *, pseudo_count: float = PSEUDO_COUNT, rounds: int = 100,
                   level: float = 0.95, seed: int = 0, point: np.ndarray | None = None) -> BootstrapInterval:
    """Bootstrap intervals of the Nash-averaged scores on A = logit(win rate) (with the
    pseudo-count, so that unbeaten pairs stay finite). ``point``: the scores of ``counts`` when
    already known (see :func:`bootstrap_statistic`)."""
    return bootstrap_statistic(counts, lambda c: nash_averaging(c.logit_payoff(pseudo_count))[1],
                               rounds=rounds, level=level, seed=seed, point=point)


def alpha_rank_intervals(counts: PairCounts, *, alpha: float = 100.0, m: int = 50,
                         pseudo_count: float = PSEUDO_COUNT, rounds: int = 100, level: float = 0.95,
                         seed: int = 0, point: np.ndarray | None = None) -> BootstrapInterval:
    """Bootstrap intervals of the single-population alpha-Rank mass on the win-rate table.
    ``point``: the mass of ``counts`` when already known (see :func:`bootstrap_statistic`)."""
    return bootstrap_statistic(counts, lambda c: alpha_rank([c.win_rate(pseudo_count)], alpha=alpha, m=m),
                               rounds=rounds, level=level, seed=seed, point=point)


def _check_level(level: float, rounds: int) -> None:
    if not 0 < level < 1:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    if rounds < 2:
        raise ValueError(f"the bootstrap needs at least 2 rounds (100 is usual), got {rounds}")


def _percentile_interval(samples: np.ndarray, level: float) -> tuple[np.ndarray, np.ndarray]:
    lower, upper = np.quantile(samples, [(1.0 - level) / 2.0, (1.0 + level) / 2.0], axis=0)
    return lower, upper
