"""Bootstrap confidence intervals for ratings, ranks, percentiles, Nash scores and alpha-Rank mass.

Efron (1979), "Bootstrap methods: another look at the jackknife", Annals of Statistics 7: the
matches are resampled with replacement, each statistic is recomputed on every replicate, and the
percentile interval of the replicates is reported. As in Chatbot Arena (Chiang et al. 2024), the
matches are resampled through their deduplicated outcome counts: one multinomial draw per round
over the (pair, outcome) cells of :class:`PairCounts`, so that a round costs the size of the count
matrix, not the number of matches. Bradley-Terry rounds are all solved at once by batched Newton
steps warm-started from the point estimate.

With :class:`SeatCounts` the fit carries a seat term (see
:func:`~arena_league.rating.bradley_terry.fit_bradley_terry`), resampled the same way over the
(side pair, pair, outcome) cells, and its interval is reported as a :class:`SeatTerm`.

Ranks and their intervals are the league's one definition
(:func:`~arena_league.rating.ranks.competition_ranks`): 1 + the agents rated above the rating,
above the interval's upper end (the best place) and at or above its lower end (the worst).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.special import expit

from arena_league.rating.alpharank import alpha_rank
from arena_league.rating.bradley_terry import (
    DEFAULT_PRIOR_SD,
    ELO_BASE,
    ELO_SCALE,
    DrawModel,
    SeatStrengthFitter,
    anchoring,
    strength_fitter,
)
from arena_league.rating.nash import nash_averaging
from arena_league.rating.outcomes import PSEUDO_COUNT, PairCounts, SeatCounts
from arena_league.rating.ranks import competition_ranks

__all__ = [
    "BootstrapInterval",
    "RatingIntervals",
    "SeatTerm",
    "alpha_rank_intervals",
    "bootstrap_ratings",
    "bootstrap_statistic",
    "nash_intervals",
]


@dataclass(frozen=True)
class SeatTerm:
    """The fitted advantage of each side, with its bootstrap percentile interval.

    ``advantage`` is in rating points per side (side 0 = 0): agent i at side a plays j at side b as
    if rated ``rating_i + advantage[a]`` against ``rating_j + advantage[b]``. ``first_share`` is the
    share of the points side 0 takes from side 1 between equally rated agents: sigmoid(h_0 - h_1)
    with draws as halves, and under Davidson the expected score (e^(d/2) + nu/2) / (e^(d/2) +
    e^(-d/2) + nu) at d = h_0 - h_1.
    """

    advantage: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    first_share: float
    first_share_lower: float
    first_share_upper: float
    level: float

    def to_dict(self) -> dict[str, float | list[float]]:
        """Plain floats and lists, for JSON."""
        return {"advantage": [float(v) for v in self.advantage], "lower": [float(v) for v in self.lower],
                "upper": [float(v) for v in self.upper], "first_share": float(self.first_share),
                "first_share_lower": float(self.first_share_lower),
                "first_share_upper": float(self.first_share_upper), "level": float(self.level)}

    def describe(self) -> str:
        """One line: the first seat's share of even matches and its edge over the second in Elo."""
        edge = self.advantage[0] - self.advantage[1]
        # side 0 is fixed at 0, so the edge's interval is the mirror of side 1's
        edge_lower, edge_upper = self.advantage[0] - self.upper[1], self.advantage[0] - self.lower[1]
        return (f"the first seat wins {100 * self.first_share:.0f}% [{100 * self.first_share_lower:.0f}, "
                f"{100 * self.first_share_upper:.0f}] of even matches ({edge:+.0f} Elo [{edge_lower:.0f}, "
                f"{edge_upper:.0f}])")


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
    seats: SeatTerm | None = None
    """The seat term and its interval, when rated from :class:`SeatCounts`; else None."""


@dataclass(frozen=True)
class BootstrapInterval:
    """A statistic's point estimate and bootstrap percentile interval."""

    point: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    samples: np.ndarray
    level: float


def bootstrap_ratings(
    counts: PairCounts | SeatCounts,
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
    estimate, so a pinned agent has a zero-width interval and the others are relative to it. With
    :class:`SeatCounts` the ratings carry a seat term and :attr:`RatingIntervals.seats` reports it.
    """
    n = counts.n_agents
    if n < 2:
        raise ValueError("rating intervals need at least two agents")
    _check_level(level, rounds)
    fitter, data = strength_fitter(counts, draw_model, prior_sd)
    fitter.check_identifiable(*data)
    point, _ = fitter.fit(*(c[None] for c in data))
    resampled = counts.resample(np.random.default_rng(seed), rounds)
    fitter.check_identifiable(*resampled)
    replicates, _ = fitter.fit(*resampled, x0=np.repeat(point, rounds, axis=0))
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
        draw_nu=float(np.exp(point[0, -1])) if draw_model == "davidson" else None,
        seats=_seat_term(fitter, point[0], replicates, level, scale)
        if isinstance(fitter, SeatStrengthFitter) else None)


def _seat_term(fitter: SeatStrengthFitter, point: np.ndarray, replicates: np.ndarray, level: float,
               scale: float) -> SeatTerm:
    """The seat term of the point estimate ``(p,)`` with the percentile interval of the replicates
    ``(rounds, p)``."""
    points = scale / math.log(10.0)
    advantage, samples = points * fitter.seat_strengths(point), points * fitter.seat_strengths(replicates)
    lower, upper = _percentile_interval(samples, level)
    davidson = fitter.draw_model == "davidson"

    def first_share(x: np.ndarray) -> np.ndarray:
        h = fitter.seat_strengths(x)
        d = h[..., 0] - h[..., 1]
        if not davidson:
            return expit(d)
        nu = np.exp(x[..., -1])
        # (e^(d/2) + nu/2) / (e^(d/2) + e^(-d/2) + nu), divided through by e^(|d|/2) to stay finite
        up, down, tie = np.exp(0.5 * (d - np.abs(d))), np.exp(-0.5 * (d + np.abs(d))), nu * np.exp(-0.5 * np.abs(d))
        return (up + 0.5 * tie) / (up + down + tie)

    share_lower, share_upper = _percentile_interval(first_share(replicates), level)
    return SeatTerm(advantage, lower, upper, float(first_share(point)), float(share_lower), float(share_upper),
                    level)


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
