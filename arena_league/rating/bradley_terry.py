"""Bradley-Terry ratings on the Elo scale, by maximum likelihood with a weak Gaussian prior.

Bradley & Terry (1952), "Rank analysis of incomplete block designs: I. The method of paired
comparisons", Biometrika 39. Draws count as half a win each way (``draw_model="half"``, as in
Chatbot Arena) or follow Davidson (1970), "On extending the Bradley-Terry model to accommodate ties
in paired comparison experiments", JASA 65 (``draw_model="davidson"``).

With strengths theta (natural-log scale), P(i beats j) = sigmoid(theta_i - theta_j); a rating is
``base + scale * theta / ln(10)``, so that with ``scale=400`` a 400-point gap is 10:1 odds, as in
Elo. Under Davidson, P(i wins) : P(draw) : P(j wins) = e^(d/2) : nu : e^(-d/2), d = theta_i -
theta_j. The two draw models put ratings on different scales: with draws counted as halves a
rating predicts the expected score, which under Davidson-like draws is compressed towards 0.5; so
when draws are common, ``"davidson"`` recovers the decisive-match odds. The fit is Newton's method
on the deduplicated count matrix, batched over leading axes so that all bootstrap rounds are solved
at once (see :mod:`arena_league.rating.bootstrap`).

Where the seat matters (the first player of GoBang, two-role games), counts that keep the side each
agent held (:class:`~arena_league.rating.outcomes.SeatCounts`) get an order effect, the home
advantage of paired comparisons (Agresti (2013), "Categorical Data Analysis", 3rd ed., Wiley, on the
Bradley-Terry model with an order effect): d = theta_i - theta_j + h_a - h_b for i at side a against
j at side b, with h_0 = 0 and the other sides' h under the ratings' prior.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy
import scipy.linalg
from numpy.typing import ArrayLike
from scipy import sparse
from scipy.optimize import linprog
from scipy.sparse.csgraph import connected_components
from scipy.special import expit

from arena_league.rating.outcomes import PairCounts, SeatCounts

__all__ = [
    "DEFAULT_PRIOR_SD",
    "ELO_BASE",
    "ELO_SCALE",
    "BradleyTerryFit",
    "bradley_terry",
    "fit_bradley_terry",
]

ELO_SCALE = 400.0
"""Rating points per factor of 10 in odds."""
ELO_BASE = 1000.0
"""The mean rating (or the pinned agent's rating) after anchoring."""
DEFAULT_PRIOR_SD = 1000.0
"""Standard deviation, in rating points, of the Gaussian prior on each rating around the mean. It
only matters for agents that never lost or never won, whose maximum-likelihood rating is
infinite; against a few hundred matches per agent it moves ratings by well under a point."""

DrawModel = Literal["half", "davidson"]


@dataclass(frozen=True)
class BradleyTerryFit:
    """A fitted Bradley-Terry model."""

    agents: list[str]
    ratings: np.ndarray
    """Elo-scale ratings, anchored (see :func:`fit_bradley_terry`)."""
    draw_model: DrawModel
    draw_nu: float | None
    """Davidson's tie parameter nu (P(draw) = nu / (2 + nu) between equals); None for "half"."""
    iterations: int
    seat_advantage: np.ndarray | None = None
    """With :class:`SeatCounts`: each side's advantage in rating points (side 0 = 0), so that agent i
    at side a scores against j at side b as if rated ``ratings[i] + seat_advantage[a]`` against
    ``ratings[j] + seat_advantage[b]``; None for seat-blind counts."""


def bradley_terry(
    wins: ArrayLike,
    draws: ArrayLike | None = None,
    *,
    agents: Sequence[str] | None = None,
    draw_model: DrawModel = "half",
    prior_sd: float = DEFAULT_PRIOR_SD,
    anchor: Sequence[str | int] | None = None,
    pin: str | int | None = None,
    base: float = ELO_BASE,
    scale: float = ELO_SCALE,
) -> np.ndarray:
    """Maximum-likelihood Bradley-Terry ratings from count matrices.

    Args:
        wins: ``wins[i, j]`` is the number of matches agent i won against agent j.
        draws: symmetric ``draws[i, j]`` matches drawn between i and j (default none).
        agents: names, needed only to anchor or pin by name.
        draw_model: ``"half"`` (a draw is half a win each way) or ``"davidson"``.
        prior_sd: sd of the Gaussian prior on ratings, in rating points; ``math.inf`` for the plain
            MLE, which exists only when every agent both won and lost within a strongly connected
            league.
        anchor: agents (names or indices) whose mean rating is set to ``base``; default all.
        pin: one agent (name or index) whose rating is set to ``base`` instead.
        base: the anchored mean or pinned rating (1000).
        scale: rating points per factor of 10 in odds (400).

    Returns:
        Ratings, one per agent.
    """
    counts = PairCounts.from_matrices(wins, draws, agents)
    return fit_bradley_terry(counts, draw_model=draw_model, prior_sd=prior_sd, anchor=anchor, pin=pin,
                             base=base, scale=scale).ratings


def fit_bradley_terry(
    counts: PairCounts | SeatCounts,
    *,
    draw_model: DrawModel = "half",
    prior_sd: float = DEFAULT_PRIOR_SD,
    anchor: Sequence[str | int] | None = None,
    pin: str | int | None = None,
    base: float = ELO_BASE,
    scale: float = ELO_SCALE,
) -> BradleyTerryFit:
    """Fits Bradley-Terry to deduplicated counts; arguments as in :func:`bradley_terry`.

    With :class:`SeatCounts` the model gains a term per side: P(i at side a beats j at side b) =
    sigmoid(theta_i - theta_j + h_a - h_b) (Davidson likewise in that d), with h_0 = 0 and the other
    sides' h under the ratings' prior; :attr:`BradleyTerryFit.seat_advantage` reports h in rating
    points. Ratings are anchored as without it.
    """
    fitter, data = strength_fitter(counts, draw_model, prior_sd)
    fitter.check_identifiable(*data)
    x, iterations = fitter.fit(*(c[None] for c in data))
    to_ratings = anchoring(counts.agents, anchor=anchor, pin=pin, base=base, scale=scale)
    nu = float(np.exp(x[0, -1])) if draw_model == "davidson" else None
    seats = None
    if isinstance(fitter, SeatStrengthFitter):
        seats = scale / math.log(10.0) * fitter.seat_strengths(x)[0]
    return BradleyTerryFit(counts.agents, to_ratings(x[:, : counts.n_agents])[0], draw_model, nu, iterations,
                           seats)


def strength_fitter(
    counts: PairCounts | SeatCounts, draw_model: DrawModel, prior_sd: float
) -> tuple[StrengthFitter | SeatStrengthFitter, tuple[np.ndarray, ...]]:
    """The fitter for seat-blind or seat-keeping counts, and the count arrays its methods take:
    ``(wins, draws)`` or ``(won, lost, drawn)``, as the counts' ``resample`` returns them stacked."""
    if isinstance(counts, SeatCounts):
        return (SeatStrengthFitter(counts.n_agents, counts.n_sides, draw_model, prior_sd),
                (counts.won, counts.lost, counts.drawn))
    if isinstance(counts, PairCounts):
        return StrengthFitter(counts.n_agents, draw_model, prior_sd), (counts.wins, counts.draws)
    raise TypeError(f"counts must be PairCounts or SeatCounts, got {type(counts).__name__}")


def anchoring(
    agents: Sequence[str],
    *,
    anchor: Sequence[str | int] | None = None,
    pin: str | int | None = None,
    base: float = ELO_BASE,
    scale: float = ELO_SCALE,
) -> Callable[[np.ndarray], np.ndarray]:
    """Returns the map from strengths ``(..., n)`` to anchored ratings: the mean over ``anchor``
    (default all agents) equals ``base``, or the ``pin`` agent's rating equals ``base``."""
    if anchor is not None and pin is not None:
        raise ValueError("pass either `anchor` (a population whose mean is fixed) or `pin` (one agent), "
                         "not both")
    if pin is not None:
        members = np.array([_agent_index(agents, pin)])
    elif anchor is not None:
        members = np.unique([_agent_index(agents, a) for a in anchor])
        if members.size == 0:
            raise ValueError("`anchor` is empty; name at least one agent, or leave it unset for all")
    else:
        members = np.arange(len(agents))
    points = scale / math.log(10.0)

    def to_ratings(theta: np.ndarray) -> np.ndarray:
        ratings = points * theta
        return ratings - ratings[..., members].mean(axis=-1, keepdims=True) + base

    return to_ratings


def _agent_index(agents: Sequence[str], key: str | int) -> int:
    if isinstance(key, (int, np.integer)):
        if not 0 <= key < len(agents):
            raise ValueError(f"agent index {key} is out of range for {len(agents)} agents")
        return int(key)
    try:
        return list(agents).index(str(key))
    except ValueError:
        raise ValueError(f"unknown agent {key!r}; pass `agents` names or an index") from None


_SCIPY_BATCHES = tuple(int(v) for v in scipy.__version__.split(".")[:2]) >= (1, 16)


def solve_positive_definite(h: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Solves h x = g for a stack of symmetric positive definite matrices ``(..., n, n)``.

    scipy.linalg rather than numpy.linalg: on a loaded machine numpy's multithreaded batched LU
    took 50 times longer than this Cholesky solve (1 s against 0.02 s for 100 matrices of 100).
    """
    if _SCIPY_BATCHES or h.ndim == 2:
        return scipy.linalg.solve(h, g[..., None], assume_a="pos", check_finite=False)[..., 0]
    return np.stack([scipy.linalg.solve(a, b, assume_a="pos", check_finite=False) for a, b in zip(h, g)])


Objective = Callable[[np.ndarray, bool], tuple[np.ndarray, np.ndarray | None, np.ndarray | None]]


def newton(objective: Objective, x: np.ndarray, max_iter: int = 100, tol: float = 1e-10) -> tuple[np.ndarray, int]:
    """Minimises a strictly convex objective by Newton's method with Armijo backtracking, for a
    batch of independent problems at once.

    Args:
        objective: ``objective(x, derivatives)`` maps parameters ``(batch, p)`` to the values
            ``(batch,)`` and, when ``derivatives`` is true, the gradients ``(batch, p)`` and the
            positive definite Hessians ``(batch, p, p)`` (else None for both).
        x: the starting point ``(batch, p)``.
        max_iter, tol: at most ``max_iter`` steps; stop once every step is below ``tol``.

    Returns:
        The minimisers ``(batch, p)`` and the number of iterations.
    """
    f, g, h = objective(x, True)
    for iterations in range(1, max_iter + 1):
        step = -solve_positive_definite(h, g)
        size = np.abs(step).max(axis=-1)
        if (size < tol).all():
            return x, iterations
        slope = (g * step).sum(axis=-1)
        # Try the full Newton step first (its derivatives are needed next anyway); backtrack
        # only the batch elements whose objective did not decrease enough.
        f_new, g_new, h_new = objective(x + step, True)
        # Near the optimum rounding noise swamps the decrease; a Newton step is then exact.
        ok = (f_new <= f + 1e-4 * slope) | (size < 1e-6)
        if ok.all():
            x, f, g, h = x + step, f_new, g_new, h_new
            continue
        t = np.where(ok, 1.0, 0.5)
        for _ in range(60):
            f_new = objective(x + t[:, None] * step, False)[0]
            ok = (f_new <= f + 1e-4 * t * slope) | (t * size < 1e-6)
            if ok.all():
                break
            t = np.where(ok, t, 0.5 * t)
        x = x + t[:, None] * step
        f, g, h = objective(x, True)
    raise RuntimeError(f"Bradley-Terry Newton did not converge in {max_iter} iterations")


class StrengthFitter:
    """Penalised Newton fit of log-strengths (and Davidson's log nu), batched over leading axes.

    The negative log-posterior is strictly convex (a log-sum-exp in differences of strengths plus a
    ridge), so Newton with Armijo backtracking converges from any start; warm starts from the point
    estimate make bootstrap rounds converge in a few steps. Work is done per unordered pair (the
    upper triangle), and the pairs' counts are gathered once per fit.
    """

    def __init__(self, n_agents: int, draw_model: DrawModel = "half", prior_sd: float = DEFAULT_PRIOR_SD):
        _check_model(draw_model, prior_sd)
        self.n = n_agents
        self.draw_model = draw_model
        self.ridge = _ridge(prior_sd)
        # Davidson's log nu gets a very weak prior around nu = 1 so that it stays finite in a league
        # (or a bootstrap round) without draws.
        self.eta_ridge = 1e-2
        self.first, self.second = np.triu_indices(n_agents, 1)
        n_pairs = self.first.size
        # incidence[i, k] = +1 if agent i is pair k's first, -1 if its second: maps per-pair
        # derivatives with respect to d = theta_first - theta_second onto the agents
        columns = np.r_[np.arange(n_pairs), np.arange(n_pairs)]
        self.incidence = sparse.csr_matrix((np.r_[np.ones(n_pairs), -np.ones(n_pairs)],
                                            (np.r_[self.first, self.second], columns)),
                                           shape=(n_agents, n_pairs))
        self.degree = abs(self.incidence)

    def check_identifiable(self, wins: np.ndarray, draws: np.ndarray) -> None:
        """Without a prior the MLE exists only if the 'beat or drew' graph is strongly connected."""
        if self.ridge > 0:
            return
        beat = (wins + draws) > 0
        for w in beat.reshape(-1, self.n, self.n):
            n_parts, _ = connected_components(w, directed=True, connection="strong")
            if n_parts > 1:
                raise ValueError("with prior_sd=inf the maximum-likelihood ratings are infinite: the league "
                                 "splits into groups that never lost (or never won) against each other; "
                                 "use a finite prior_sd (the default) or play the missing pairs")

    def start(self, wins: np.ndarray, draws: np.ndarray) -> np.ndarray:
        """Starting point: equal strengths, and nu from the draw share."""
        batch = wins.shape[:-2]
        x = np.zeros((*batch, self.n + (self.draw_model == "davidson")))
        if self.draw_model == "davidson":
            n_draws = 0.5 * draws.sum(axis=(-2, -1))
            n_matches = wins.sum(axis=(-2, -1)) + n_draws
            share = np.clip(n_draws / np.maximum(n_matches, 1.0), 0.5 / np.maximum(n_matches, 1.0), 0.99)
            x[..., -1] = np.log(2.0 * share / (1.0 - share))
        return x

    def fit(self, wins: np.ndarray, draws: np.ndarray, x0: np.ndarray | None = None,
            max_iter: int = 100, tol: float = 1e-10) -> tuple[np.ndarray, int]:
        """Minimises the negative log-posterior for each batch element of ``wins``/``draws``
        ``(..., n, n)``. Returns the parameters ``(..., n [+1 for log nu])`` and the iterations."""
        batch = wins.shape[:-2]
        wins = wins.reshape((-1, self.n, self.n))
        draws = draws.reshape((-1, self.n, self.n))
        x = self.start(wins, draws) if x0 is None else np.array(x0, dtype=float).reshape(wins.shape[0], -1)
        pairs = (wins[:, self.first, self.second], wins[:, self.second, self.first],
                 draws[:, self.first, self.second])
        objective = self._half if self.draw_model == "half" else self._davidson
        x, iterations = newton(lambda y, derivatives: objective(y, *pairs, derivatives=derivatives), x,
                               max_iter, tol)
        return x.reshape((*batch, x.shape[-1])), iterations

    def _to_agents(self, per_pair: np.ndarray, matrix: sparse.csr_matrix) -> np.ndarray:
        """Sums per-pair values ``(batch, pairs)`` onto agents through ``matrix``."""
        return (matrix @ per_pair.T).T

    def _finish(self, theta: np.ndarray, f: np.ndarray, d_f: np.ndarray, d2_f: np.ndarray):
        """Adds the ridge (or the gauge fix without one) to the objective, and maps the per-pair
        first and second derivatives (in d) to the gradient and the Laplacian Hessian."""
        f = f + self._penalty(theta)
        g = self._to_agents(d_f, self.incidence) + self.ridge * theta
        h = np.zeros((theta.shape[0], self.n, self.n))
        h[:, self.first, self.second] = -d2_f
        h[:, self.second, self.first] = -d2_f
        idx = np.arange(self.n)
        h[:, idx, idx] = self._to_agents(d2_f, self.degree) + self.ridge
        if self.ridge == 0:
            # The likelihood is flat along theta + c; fixing the gauge with 1 1^T / n leaves Newton
            # steps orthogonal to it (the gradient sums to zero).
            h += 1.0 / self.n
        return f, g, h

    def _penalty(self, theta: np.ndarray) -> np.ndarray:
        return 0.5 * self.ridge * (theta**2).sum(-1)

    def _half(self, x: np.ndarray, won: np.ndarray, lost: np.ndarray, drawn: np.ndarray, derivatives: bool):
        # per pair: points scored by the first (won + drawn/2) and second agent, d = theta_1 - theta_2
        points, against = won + 0.5 * drawn, lost + 0.5 * drawn
        games = points + against
        d = x[:, self.first] - x[:, self.second]
        with np.errstate(over="ignore"):
            odds_against = np.exp(-d)  # inf only past a gap of ~300 000 rating points
        # -log L = points softplus(-d) + against softplus(d), and softplus(d) = softplus(-d) + d
        f = (games * np.log1p(odds_against) + against * d).sum(-1)
        if not derivatives:
            return f + self._penalty(x), None, None
        p = 1.0 / (1.0 + odds_against)
        games_p = games * p
        return self._finish(x, f, games_p - points, games_p * (1.0 - p))

    def _davidson(self, x: np.ndarray, won: np.ndarray, lost: np.ndarray, drawn: np.ndarray,
                  derivatives: bool):
        # per pair: -log L = -(won - lost) d/2 - drawn eta + games log(2 cosh(d/2) + nu)
        theta, eta = x[:, :-1], x[:, -1]
        games = won + lost + drawn
        d = theta[:, self.first] - theta[:, self.second]
        a = np.exp(-0.5 * np.abs(d))
        nu_a = np.exp(eta)[:, None] * a
        q = 1.0 + a * a + nu_a
        log_d = 0.5 * np.abs(d) + np.log(q)  # log(2 cosh(d/2) + nu), overflow-free
        n_draws = drawn.sum(-1)
        f = (-0.5 * ((won - lost) * d).sum(-1) - eta * n_draws + (games * log_d).sum(-1)
             + 0.5 * self.eta_ridge * eta**2)
        if not derivatives:
            return f + self._penalty(theta), None, None
        s = np.sign(d) * 0.5 * (1.0 - a * a) / q  # d log D / d d
        r = nu_a / q  # d log D / d eta
        g_eta = -n_draws + (games * r).sum(-1) + self.eta_ridge * eta
        f, g_theta, h_theta = self._finish(theta, f, -0.5 * (won - lost) + games * s,
                                           games * ((1.0 + a * a) / (4.0 * q) - s * s))
        h = np.empty((x.shape[0], self.n + 1, self.n + 1))
        h[:, :-1, :-1] = h_theta
        cross = self._to_agents(-games * s * r, self.incidence)
        h[:, :-1, -1] = cross
        h[:, -1, :-1] = cross
        h[:, -1, -1] = (games * (r - r * r)).sum(-1) + self.eta_ridge
        return f, np.concatenate([g_theta, g_eta[:, None]], axis=-1), h


class SeatStrengthFitter:
    """Penalised Newton fit of log-strengths with a seat term: side advantages h (h_0 = 0) and,
    under Davidson, log nu; batched over leading axes like :class:`StrengthFitter`.

    Parameters are laid out as ``(theta_0 .. theta_{n-1}, h_1 .. h_{S-1}[, log nu])``. The side
    advantages get the ratings' Gaussian prior, so that a league where one side always wins keeps
    a finite advantage. Work is done on the dense ``(batch, K, n, n)`` count arrays of
    :class:`SeatCounts`: each cell's first and second derivatives in d = theta_i - theta_j + h_a -
    h_b are summed onto the parameters (the theta block is the Laplacian of the summed curvatures,
    the theta-h terms are row-minus-column sums, the h-h terms total sums).
    """

    def __init__(self, n_agents: int, n_sides: int, draw_model: DrawModel = "half",
                 prior_sd: float = DEFAULT_PRIOR_SD):
        _check_model(draw_model, prior_sd)
        self.n = n_agents
        self.n_sides = n_sides
        self.draw_model = draw_model
        self.ridge = _ridge(prior_sd)
        self.eta_ridge = 1e-2  # as in StrengthFitter
        a, b = np.triu_indices(n_sides, 1)
        # sides[k, s] = +1 if side s is pair k's first side, -1 if its second; column 0 (h_0 = 0) dropped
        sides = np.zeros((a.size, n_sides))
        sides[np.arange(a.size), a] = 1.0
        sides[np.arange(a.size), b] = -1.0
        self.sides = sides[:, 1:]
        self.n_strengths = n_agents + n_sides - 1

    def seat_strengths(self, x: np.ndarray) -> np.ndarray:
        """The side advantages ``(..., n_sides)`` in strength units, h_0 = 0."""
        h = x[..., self.n:self.n_strengths]
        return np.concatenate([np.zeros((*h.shape[:-1], 1)), h], axis=-1)

    def check_identifiable(self, won: np.ndarray, lost: np.ndarray, drawn: np.ndarray) -> None:
        """Without a prior the MLE exists only if no direction of the parameters (other than a
        common shift of the strengths) raises every match's likelihood: a linear program per league
        looks for such a direction (won cells want d up, lost cells down, drawn cells d fixed)."""
        if self.ridge > 0:
            return
        shape = (-1, self.n_sides * (self.n_sides - 1) // 2, self.n, self.n)
        for w, lo, dr in zip(won.reshape(shape), lost.reshape(shape), drawn.reshape(shape)):
            k, i, j = np.nonzero(w + lo + dr)
            design = np.zeros((k.size, self.n_strengths))
            design[np.arange(k.size), i] += 1.0
            design[np.arange(k.size), j] -= 1.0
            design[:, self.n:] = self.sides[k]
            sign = np.sign(w[k, i, j] - lo[k, i, j])
            split = ((w[k, i, j] > 0) & (lo[k, i, j] > 0)) | (dr[k, i, j] > 0)
            fixed = design[split]
            one_way = design[~split] * sign[~split, None]
            gauge = np.r_[np.ones(self.n), np.zeros(self.n_sides - 1)][None, :]
            result = linprog(-one_way.sum(axis=0), A_ub=-one_way if one_way.size else None,
                             b_ub=np.zeros(one_way.shape[0]) if one_way.size else None,
                             A_eq=np.vstack([fixed, gauge]), b_eq=np.zeros(fixed.shape[0] + 1),
                             bounds=(-1.0, 1.0), method="highs")
            rank = np.linalg.matrix_rank(np.vstack([design, gauge]))
            if (result.status == 0 and -result.fun > 1e-9) or rank < self.n_strengths:
                raise ValueError("with prior_sd=inf the maximum-likelihood ratings or seat advantages are "
                                 "infinite or not unique: some agents or sides never lost (or never won) "
                                 "against the others; use a finite prior_sd (the default) or play agents "
                                 "on both sides")

    def start(self, won: np.ndarray, lost: np.ndarray, drawn: np.ndarray) -> np.ndarray:
        """Starting point: equal strengths, no seat advantage, and nu from the draw share."""
        batch = won.shape[:-3]
        x = np.zeros((*batch, self.n_strengths + (self.draw_model == "davidson")))
        if self.draw_model == "davidson":
            n_draws = drawn.sum(axis=(-3, -2, -1))
            n_matches = np.maximum(won.sum(axis=(-3, -2, -1)) + lost.sum(axis=(-3, -2, -1)) + n_draws, 1.0)
            share = np.clip(n_draws / n_matches, 0.5 / n_matches, 0.99)
            x[..., -1] = np.log(2.0 * share / (1.0 - share))
        return x

    def fit(self, won: np.ndarray, lost: np.ndarray, drawn: np.ndarray, x0: np.ndarray | None = None,
            max_iter: int = 100, tol: float = 1e-10) -> tuple[np.ndarray, int]:
        """Minimises the negative log-posterior for each batch element of the counts
        ``(..., K, n, n)``. Returns the parameters ``(..., n + n_sides - 1 [+1 for log nu])`` and
        the iterations."""
        batch = won.shape[:-3]
        cells = won.shape[-3:]
        won, lost, drawn = (c.reshape((-1, *cells)) for c in (won, lost, drawn))
        x = self.start(won, lost, drawn) if x0 is None else np.array(x0, dtype=float).reshape(won.shape[0], -1)
        objective = self._half if self.draw_model == "half" else self._davidson
        x, iterations = newton(lambda y, derivatives: objective(y, won, lost, drawn, derivatives), x,
                               max_iter, tol)
        return x.reshape((*batch, x.shape[-1])), iterations

    def _gaps(self, x: np.ndarray) -> np.ndarray:
        """d = theta_i - theta_j + h_a - h_b per cell, ``(batch, K, n, n)``."""
        theta = x[:, : self.n]
        seat = x[:, self.n:self.n_strengths] @ self.sides.T
        return theta[:, None, :, None] - theta[:, None, None, :] + seat[:, :, None, None]

    def _to_parameters(self, per_cell: np.ndarray) -> np.ndarray:
        """Sums per-cell derivatives in d ``(batch, K, n, n)`` onto theta and h."""
        theta = (per_cell.sum(-1) - per_cell.sum(-2)).sum(1)
        return np.concatenate([theta, per_cell.sum((-2, -1)) @ self.sides], axis=-1)

    def _finish(self, x: np.ndarray, f: np.ndarray, d_f: np.ndarray, d2_f: np.ndarray):
        """Adds the ridge (or the gauge fix without one) and maps per-cell first and second
        derivatives (in d) to the gradient and Hessian over (theta, h)."""
        strengths = x[:, : self.n_strengths]
        f = f + self._penalty(strengths)
        g = self._to_parameters(d_f) + self.ridge * strengths
        n = self.n
        summed = d2_f.sum(1)
        summed = summed + summed.transpose(0, 2, 1)
        h = np.empty((x.shape[0], self.n_strengths, self.n_strengths))
        h[:, :n, :n] = -summed
        idx = np.arange(n)
        h[:, idx, idx] += summed.sum(-1)
        cross = np.einsum("rki,ks->ris", d2_f.sum(-1) - d2_f.sum(-2), self.sides)
        h[:, :n, n:] = cross
        h[:, n:, :n] = cross.transpose(0, 2, 1)
        h[:, n:, n:] = np.einsum("rk,ks,kt->rst", d2_f.sum((-2, -1)), self.sides, self.sides)
        diagonal = np.arange(self.n_strengths)
        h[:, diagonal, diagonal] += self.ridge
        if self.ridge == 0:
            h[:, :n, :n] += 1.0 / n  # the gauge fix of StrengthFitter
        return f, g, h

    def _penalty(self, strengths: np.ndarray) -> np.ndarray:
        return 0.5 * self.ridge * (strengths**2).sum(-1)

    def _half(self, x: np.ndarray, won: np.ndarray, lost: np.ndarray, drawn: np.ndarray, derivatives: bool):
        points, against = won + 0.5 * drawn, lost + 0.5 * drawn
        games = points + against
        d = self._gaps(x)
        f = (games * np.logaddexp(0.0, -d) + against * d).sum((-3, -2, -1))
        if not derivatives:
            return f + self._penalty(x), None, None
        p = expit(d)
        games_p = games * p
        return self._finish(x, f, games_p - points, games_p * (1.0 - p))

    def _davidson(self, x: np.ndarray, won: np.ndarray, lost: np.ndarray, drawn: np.ndarray,
                  derivatives: bool):
        # per cell, as in StrengthFitter._davidson
        eta = x[:, -1]
        games = won + lost + drawn
        d = self._gaps(x)
        a = np.exp(-0.5 * np.abs(d))
        nu_a = np.exp(eta)[:, None, None, None] * a
        q = 1.0 + a * a + nu_a
        log_d = 0.5 * np.abs(d) + np.log(q)
        n_draws = drawn.sum((-3, -2, -1))
        f = (-0.5 * ((won - lost) * d).sum((-3, -2, -1)) - eta * n_draws + (games * log_d).sum((-3, -2, -1))
             + 0.5 * self.eta_ridge * eta**2)
        if not derivatives:
            return f + self._penalty(x[:, : self.n_strengths]), None, None
        s = np.sign(d) * 0.5 * (1.0 - a * a) / q
        r = nu_a / q
        g_eta = -n_draws + (games * r).sum((-3, -2, -1)) + self.eta_ridge * eta
        f, g_strengths, h_strengths = self._finish(x, f, -0.5 * (won - lost) + games * s,
                                                   games * ((1.0 + a * a) / (4.0 * q) - s * s))
        h = np.empty((x.shape[0], self.n_strengths + 1, self.n_strengths + 1))
        h[:, :-1, :-1] = h_strengths
        cross = self._to_parameters(-games * s * r)
        h[:, :-1, -1] = cross
        h[:, -1, :-1] = cross
        h[:, -1, -1] = (games * (r - r * r)).sum((-3, -2, -1)) + self.eta_ridge
        return f, np.concatenate([g_strengths, g_eta[:, None]], axis=-1), h


def _check_model(draw_model: str, prior_sd: float) -> None:
    if draw_model not in ("half", "davidson"):
        raise ValueError(f"draw_model must be 'half' or 'davidson', got {draw_model!r}")
    if not prior_sd > 0:
        raise ValueError(f"prior_sd must be positive (math.inf for no prior), got {prior_sd}")


def _ridge(prior_sd: float) -> float:
    """The prior's precision on strengths (natural-log units) for a prior sd in rating points."""
    return 0.0 if math.isinf(prior_sd) else (ELO_SCALE / (math.log(10.0) * prior_sd)) ** 2
