"""Placing an entrant against a frozen, already-rated base population.

The Arena paper (Song et al., AAAI 2020) ranks a new agent among a fixed base population. Here the
entrant's Bradley-Terry rating x is fitted with the base ratings held fixed (Bradley & Terry 1952;
Elo scale, see :mod:`arena_league.rating.bradley_terry`): a one-dimensional penalised maximum
likelihood with a weak Gaussian prior around the base mean. Its interval is the likelihood-ratio
interval {x : 2 (l(x_hat) - l(x)) <= chi2_1(level)} of the penalised log-likelihood l, found by
Newton's method on each side; the rank and its interval follow from where the base ratings fall
around it (:func:`~arena_league.rating.ranks.competition_ranks` with the base as reference: rank =
1 + the number of base agents rated above, so 1 .. n + 1).

In games where the seat matters the base fit's seat term (see
:func:`~arena_league.rating.bradley_terry.fit_bradley_terry`) is held fixed too: a match the
entrant played at side s against a base agent j at the other side has d = x - base_j + h_s -
h_other, so results are recorded per entrant side.

The adaptive chooser picks the next opponent with the largest expected Fisher information about x,
E[p (1 - p)] under the current normal approximation of x (the sequential design of optimal
experiments, Chernoff 1959), preferring, among the near-best opponents, the one met least often, so
that games spread over the base agents around the entrant's rank boundaries. Playing an opponent
far from x wastes matches: a win against a much weaker agent tells little.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import expit
from scipy.stats import chi2

from arena_league.rating.bradley_terry import ELO_SCALE
from arena_league.rating.ranks import competition_ranks

__all__ = [
    "MIN_PLACEMENT_MATCHES",
    "PLACEMENT_PRIOR_SD",
    "AdaptivePlacement",
    "Placement",
    "PlacementSimulation",
    "place_entrant",
    "simulate_placement",
]

PLACEMENT_PRIOR_SD = 1000.0
"""Prior sd of the entrant's rating (rating points) around the base mean: weak against any real
number of matches, but keeps an unbeaten entrant's rating and interval finite."""

MIN_PLACEMENT_MATCHES = 20
"""Matches before the stopping rule is consulted. Checking an interval after every match and
stopping at the first narrow one is optional stopping: with fewer matches, a short lucky streak
against top agents stops placements early with the wrong rank (coverage fell to ~0.89 without it in
simulation)."""

_NEAR_BEST = 0.98
"""Opponents within this share of the best expected information count as equally good."""
_HERMITE_X, _HERMITE_W = np.polynomial.hermite_e.hermegauss(9)
_HERMITE_W = _HERMITE_W / _HERMITE_W.sum()


@dataclass(frozen=True)
class Placement:
    """An entrant's rating against a frozen base population, with its intervals."""

    rating: float
    lower: float
    upper: float
    rank: int
    """1 + the number of base agents rated above the entrant's estimate (1 .. n + 1)."""
    rank_lower: int
    """The best place: 1 + the base agents rated above the interval's upper end."""
    rank_upper: int
    """The worst place: 1 + the base agents rated at or above the interval's lower end."""
    percentile: float
    """Share of the base population rated below the entrant, in percent."""
    percentile_lower: float
    percentile_upper: float
    matches: float
    level: float

    @property
    def rank_half_width(self) -> float:
        return 0.5 * (self.rank_upper - self.rank_lower)


class _EntrantPosterior:
    """Penalised likelihood of E entrants' ratings against one base population, vectorised over
    entrants; strengths are on the natural-log scale (theta = rating * ln 10 / scale)."""

    def __init__(self, base_ratings: ArrayLike, n_entrants: int, level: float, prior_sd: float,
                 prior_mean: float | None, scale: float, seat_advantage: ArrayLike | None = None):
        ratings = np.asarray(base_ratings, dtype=np.float64)
        if ratings.ndim != 1 or ratings.size < 1 or not np.isfinite(ratings).all():
            raise ValueError("base_ratings must be a non-empty 1-D array of finite ratings")
        if not 0 < level < 1:
            raise ValueError(f"level must lie in (0, 1), got {level}")
        if not prior_sd > 0 or math.isinf(prior_sd):
            raise ValueError("prior_sd must be positive and finite: an unbeaten entrant needs it")
        self.points_per_theta = scale / math.log(10.0)
        self.base_ratings = ratings
        self.base = ratings / self.points_per_theta
        self.sorted_base = np.sort(self.base)
        self.prior_mean = (ratings.mean() if prior_mean is None else prior_mean) / self.points_per_theta
        self.prior_precision = (self.points_per_theta / prior_sd) ** 2
        self.level = level
        self.drop = 0.5 * chi2.ppf(level, 1)
        # Results are kept per (entrant side, opponent) cell, side-major; without a seat term there
        # is one side, and each cell's opponent strength is the base strength less the entrant
        # side's edge over the other.
        if seat_advantage is None:
            self.n_sides = 1
            self.cell_base = self.base
        else:
            edge = _seat_edges(seat_advantage) / self.points_per_theta
            self.n_sides = 2
            self.cell_base = (self.base[None, :] - edge[:, None]).reshape(-1)
        shape = (n_entrants, self.n_sides * ratings.size)
        self.points = np.zeros(shape)
        self.games = np.zeros(shape)
        self.mode = np.full(n_entrants, self.prior_mean)
        self.lower = np.full(n_entrants, np.nan)
        self.upper = np.full(n_entrants, np.nan)
        self.refit(np.arange(n_entrants))

    def record(self, entrants: np.ndarray, opponents: np.ndarray, scores: np.ndarray,
               sides: np.ndarray | None = None) -> None:
        cells = opponents if sides is None or self.n_sides == 1 else sides * self.base.size + opponents
        np.add.at(self.points, (entrants, cells), scores)
        np.add.at(self.games, (entrants, cells), 1.0)

    def opponent_games(self, rows: np.ndarray) -> np.ndarray:
        """Matches of each entrant against each base agent, over both sides ``(E, n)``."""
        return self.games[rows].reshape(rows.size, self.n_sides, self.base.size).sum(axis=1)

    def _log_lik(self, x: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Penalised log-likelihood, its first and second derivatives at x[e] for entrants rows."""
        d = x[:, None] - self.cell_base[None, :]
        points, games = self.points[rows], self.games[rows]
        surprise = np.logaddexp(0.0, -d)  # -log P(win)
        p = np.exp(-surprise)
        value = -(games * surprise + (games - points) * d).sum(-1)
        grad = (points - games * p).sum(-1)
        curv = -(games * (p - p * p)).sum(-1)
        offset = x - self.prior_mean
        return (value - 0.5 * self.prior_precision * offset**2, grad - self.prior_precision * offset,
                curv - self.prior_precision)

    def refit(self, rows: np.ndarray) -> None:
        """Newton's method for the mode (the log-likelihood is concave), then both interval ends."""
        x = self.mode[rows].copy()
        todo = np.arange(rows.size)
        for _ in range(100):
            _, grad, curv = self._log_lik(x[todo], rows[todo])
            step = np.clip(-grad / curv, -1.0, 1.0)
            x[todo] += step
            todo = todo[np.abs(step) >= 1e-8]
            if todo.size == 0:
                break
        self.mode[rows] = x
        top, _, curv = self._log_lik(x, rows)
        half = np.sqrt(2.0 * self.drop / -curv)
        # Start each end from its previous value when that lies well outside the new mode (it
        # moves little per match), else from the Wald end.
        lower, upper = self.lower[rows], self.upper[rows]
        lower = np.where(np.isfinite(lower) & (lower < x - 0.5 * half), lower, x - half)
        upper = np.where(np.isfinite(upper) & (upper > x + 0.5 * half), upper, x + half)
        self.lower[rows] = self._crossing(rows, top, lower)
        self.upper[rows] = self._crossing(rows, top, upper)

    def _crossing(self, rows: np.ndarray, top: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Where the log-likelihood falls ``drop`` below its maximum, on the side of the start ``x``
        (away from the mode, where the slope is not flat). The log-likelihood is concave, so Newton
        iterates overshoot outwards at most once and then approach the crossing monotonically."""
        x = x.copy()
        target = top - self.drop
        todo = np.arange(rows.size)
        for _ in range(100):
            value, grad, _ = self._log_lik(x[todo], rows[todo])
            step = np.clip(-(value - target[todo]) / grad, -2.0, 2.0)
            x[todo] += step
            todo = todo[np.abs(step) >= 1e-8]
            if todo.size == 0:
                break
        return x

    def placements(self, rows: np.ndarray) -> list[Placement]:
        scale = self.points_per_theta
        sorted_base = self.sorted_base * scale
        n = sorted_base.size
        x, lo, hi = self.mode[rows] * scale, self.lower[rows] * scale, self.upper[rows] * scale
        ranks = competition_ranks(x, lo, hi, reference=sorted_base)
        out = []
        for k, e in enumerate(rows.tolist()):
            below = np.searchsorted(sorted_base, [x[k], lo[k], hi[k]], side="left")
            out.append(Placement(
                rating=float(x[k]), lower=float(lo[k]), upper=float(hi[k]), rank=int(ranks.rank[k]),
                rank_lower=int(ranks.rank_lower[k]), rank_upper=int(ranks.rank_upper[k]),
                percentile=float(100.0 * below[0] / n), percentile_lower=float(100.0 * below[1] / n),
                percentile_upper=float(100.0 * below[2] / n), matches=float(self.games[e].sum()), level=self.level))
        return out

    def rank_half_width(self, rows: np.ndarray) -> np.ndarray:
        """Half the number of base agents rated inside each entrant's interval, ends included (half
        of rank_upper - rank_lower)."""
        inside = (np.searchsorted(self.sorted_base, self.upper[rows], side="right")
                  - np.searchsorted(self.sorted_base, self.lower[rows], side="left"))
        return 0.5 * inside

    def most_informative(self, rows: np.ndarray) -> np.ndarray:
        """Per entrant, the opponent with the largest expected Fisher information (ties within
        ``_NEAR_BEST`` go to the opponent met least often, then to the more informative). The seat
        term is left out: which side the entrant takes is the caller's to choose."""
        sd = (self.upper[rows] - self.lower[rows]) / (2.0 * math.sqrt(2.0 * self.drop))
        x = self.mode[rows, None] + sd[:, None] * _HERMITE_X[None, :]
        p = expit(x[:, None, :] - self.base[None, :, None])
        info = (p * (1.0 - p) * _HERMITE_W).sum(axis=-1)
        near = info >= _NEAR_BEST * info.max(axis=1, keepdims=True)
        games = np.where(near, self.opponent_games(rows), np.inf)
        fewest = games == games.min(axis=1, keepdims=True)
        return np.argmax(np.where(fewest, info, -1.0), axis=1)


def place_entrant(
    base_ratings: ArrayLike,
    wins: ArrayLike,
    losses: ArrayLike,
    draws: ArrayLike | None = None,
    *,
    level: float = 0.95,
    prior_sd: float = PLACEMENT_PRIOR_SD,
    prior_mean: float | None = None,
    scale: float = ELO_SCALE,
    seat_advantage: ArrayLike | None = None,
) -> Placement:
    """The entrant's rating, interval, rank interval and percentile interval against a frozen base.

    Args:
        base_ratings: the base population's ratings (Elo scale), held fixed.
        wins, losses, draws: the entrant's results against each base agent: arrays of length n
            (sides unknown), or ``(2, n)`` with row s the matches the entrant played at side s (the
            opponent at the other side of a two-team match).
        level: coverage of the intervals (0.95).
        prior_sd, prior_mean: the weak Gaussian prior on the entrant's rating (default: sd 1000
            around the base mean).
        scale: rating points per factor of 10 in odds (400).
        seat_advantage: the base fit's advantage of each of the two sides in rating points
            (:attr:`~arena_league.rating.bradley_terry.BradleyTerryFit.seat_advantage`), held fixed;
            used with per-side results. None (or results of length n) leaves the seat term out.
    """
    base = np.asarray(base_ratings, dtype=np.float64)
    counts = [np.asarray(c, dtype=np.float64) for c in (wins, losses, np.zeros_like(wins, dtype=np.float64)
                                                          if draws is None else draws)]
    per_side = counts[0].ndim == 2
    shape = (2, base.size) if per_side else base.shape
    if any(c.shape != shape for c in counts):
        raise ValueError(f"wins, losses and draws need one count per base agent ({base.size}), or one row "
                         f"of such counts for each of the two sides; got {[c.shape for c in counts]}")
    if any((c < 0).any() for c in counts):
        raise ValueError("result counts must be non-negative")
    if per_side and seat_advantage is None:
        # no seat term: the sides do not matter
        counts = [c.sum(axis=0) for c in counts]
        per_side = False
    posterior = _EntrantPosterior(base, 1, level, prior_sd, prior_mean, scale,
                                  seat_advantage if per_side else None)
    won, lost, drawn = (c.reshape(-1) for c in counts)
    posterior.points[0] = won + 0.5 * drawn
    posterior.games[0] = won + lost + drawn
    rows = np.zeros(1, dtype=np.int64)
    posterior.refit(rows)
    return posterior.placements(rows)[0]


class AdaptivePlacement:
    """Chooses an entrant's opponents one match at a time until its rank interval is narrow.

    Call :meth:`next_opponent`, play the match, :meth:`record` the entrant's score, and repeat
    while not :attr:`done`; :attr:`placement` is the current estimate. Stops when the rank interval's
    half-width is at most ``target_half_width`` places (checked from ``min_matches`` on, since a
    few lucky results can make an early interval look narrow), or after ``budget`` matches.

    With ``seat_advantage`` (the base fit's advantage of each of the two sides, in rating points)
    the seat term is held fixed and each match is recorded with the side the entrant held.
    """

    def __init__(
        self,
        base_ratings: ArrayLike,
        *,
        target_half_width: float = 3.0,
        budget: int = 200,
        min_matches: int = MIN_PLACEMENT_MATCHES,
        level: float = 0.95,
        prior_sd: float = PLACEMENT_PRIOR_SD,
        prior_mean: float | None = None,
        scale: float = ELO_SCALE,
        seat_advantage: ArrayLike | None = None,
    ):
        if budget < 1:
            raise ValueError(f"budget must be at least one match, got {budget}")
        self.target_half_width = target_half_width
        self.budget = budget
        self.min_matches = min_matches
        self._posterior = _EntrantPosterior(base_ratings, 1, level, prior_sd, prior_mean, scale,
                                            seat_advantage)
        self._rows = np.zeros(1, dtype=np.int64)
        self.matches = 0

    def next_opponent(self) -> int:
        """Index of the base agent to play next."""
        return int(self._posterior.most_informative(self._rows)[0])

    def record(self, opponent: int, score: float, side: int = 0) -> None:
        """Records a match: the entrant scored ``score`` (1 win, 0.5 draw, 0 loss) against
        base agent ``opponent``, holding ``side`` (0 or 1; the opponent held the other). The side
        matters only with a seat term."""
        if not 0 <= opponent < self._posterior.base.size:
            raise ValueError(f"opponent must be a base agent index in [0, {self._posterior.base.size})")
        if not 0.0 <= score <= 1.0:
            raise ValueError("score must be 1 (win), 0.5 (draw) or 0 (loss)")
        if side not in (0, 1):
            raise ValueError(f"side must be 0 or 1 (the entrant's team in a two-team match), got {side!r}")
        self._posterior.record(self._rows, np.array([opponent]), np.array([float(score)]), np.array([side]))
        self._posterior.refit(self._rows)
        self.matches += 1

    @property
    def done(self) -> bool:
        return self.matches >= self.budget or (
            self.matches >= self.min_matches
            and self._posterior.rank_half_width(self._rows)[0] <= self.target_half_width)

    @property
    def rank_half_width(self) -> float:
        """Half the number of base agents rated inside the interval: what :attr:`done` compares with
        ``target_half_width``."""
        return float(self._posterior.rank_half_width(self._rows)[0])

    @property
    def placement(self) -> Placement:
        return self._posterior.placements(self._rows)[0]


def _seat_edges(seat_advantage: ArrayLike) -> np.ndarray:
    """Each side's edge over the other, ``h_s - h_(1-s)`` in rating points, of a two-side advantage."""
    advantage = np.asarray(seat_advantage, dtype=np.float64)
    if advantage.shape != (2,) or not np.isfinite(advantage).all():
        raise ValueError(f"seat_advantage needs one finite value per side of a two-team game (shape (2,)), "
                         f"got shape {advantage.shape}; pass BradleyTerryFit.seat_advantage of a two-side fit")
    return advantage - advantage[::-1]


@dataclass(frozen=True)
class PlacementSimulation:
    """Outcome of :func:`simulate_placement`, one entry per simulated entrant."""

    matches: np.ndarray
    """Matches played when the rank interval first reached the target (the budget if never)."""
    reached: np.ndarray
    covered: np.ndarray
    """Whether the final rank interval holds the entrant's true rank."""
    final_half_width: np.ndarray

    @property
    def median_matches(self) -> float:
        return float(np.median(self.matches))


def simulate_placement(
    base_ratings: ArrayLike,
    entrant_ratings: ArrayLike,
    *,
    chooser: Literal["adaptive", "uniform"] = "adaptive",
    target_half_width: float = 3.0,
    budget: int = 1000,
    min_matches: int = MIN_PLACEMENT_MATCHES,
    level: float = 0.95,
    prior_sd: float = PLACEMENT_PRIOR_SD,
    scale: float = ELO_SCALE,
    seed: int = 0,
) -> PlacementSimulation:
    """Simulates placing entrants of known true rating (Bradley-Terry outcomes, no draws), all at
    once, with the adaptive chooser of :class:`AdaptivePlacement` or uniformly random opponents;
    for planning how many matches a placement takes."""
    if chooser not in ("adaptive", "uniform"):
        raise ValueError(f"chooser must be 'adaptive' or 'uniform', got {chooser!r}")
    rng = np.random.default_rng(seed)
    truth = np.asarray(entrant_ratings, dtype=np.float64)
    posterior = _EntrantPosterior(base_ratings, truth.size, level, prior_sd, None, scale)
    true_theta = truth / posterior.points_per_theta
    n_base = posterior.base.size
    matches = np.full(truth.size, budget)
    active = np.arange(truth.size)
    for played in range(1, budget + 1):
        if chooser == "adaptive":
            opponents = posterior.most_informative(active)
        else:
            opponents = rng.integers(n_base, size=active.size)
        wins = rng.random(active.size) < expit(true_theta[active] - posterior.base[opponents])
        posterior.record(active, opponents, wins.astype(np.float64))
        posterior.refit(active)
        finished = (posterior.rank_half_width(active) <= target_half_width) & (played >= min_matches)
        matches[active[finished]] = played
        active = active[~finished]
        if active.size == 0:
            break
    everyone = np.arange(truth.size)
    half_width = posterior.rank_half_width(everyone)
    true_rank = 1 + (posterior.base_ratings[None, :] > truth[:, None]).sum(axis=1)
    placements = posterior.placements(everyone)
    covered = np.array([p.rank_lower <= r <= p.rank_upper for p, r in zip(placements, true_rank)])
    return PlacementSimulation(matches, half_width <= target_half_width, covered, half_width)
