"""alpha-Rank: agents ranked by the stationary distribution of an evolutionary Markov chain.

Omidshafiei, Papadimitriou, Piliouras, Tuyls, Rowland, Lespiau, Czarnecki, Lanctot, Perolat &
Munos (2019), "alpha-Rank: Multi-Agent Evaluation by Evolution", Scientific Reports 9 (arXiv
1903.01373). Payoff tables follow OpenSpiel's ``open_spiel.python.egt.alpharank`` convention: one
square table ``[M]`` is a symmetric two-player game in one population (``M[r, s]`` is the payoff of
strategy r against s); K tables of shape ``(n_1, ..., n_K)`` are a K-population game, table k giving
population k's payoff at each pure profile, and the result is over profiles in C (row-major) order.

The chain moves between monomorphic states: a mutant strategy r invades a population of s with
probability eta * rho(r, s), eta = 1 / sum_k (n_k - 1), and the fixation probability of the Fermi
(logit) selection with intensity alpha in a population of m individuals is

    rho = (1 - exp(-u)) / (1 - exp(-m u)),  u = alpha (f_r - f_s),

where f is the payoff the mutant and the resident earn ("local selection", OpenSpiel's default: in
one population f_r = M[r, s] and f_s = M[s, r]). With ``use_local_selection_model=False`` one
population follows the Moran process with fitness averaged over the population state (Eq. 6 of the
paper). The infinite-alpha limit replaces rho by 1 - eps (better), eps (worse) or 1/2 (tied)
relative to the neutral 1/m. The transition matrix is built with array operations and the
stationary distribution comes from one linear solve.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve

__all__ = ["AlphaRankSweep", "ReducibleChainError", "alpha_rank", "alpha_rank_sweep", "fixation_probability"]

_DENSE_LIMIT = 2000
"""Chains with more states than this are solved as sparse matrices."""


class ReducibleChainError(ValueError):
    """The Markov chain has several closed classes, hence no unique stationary distribution."""


def fixation_probability(u: ArrayLike, m: int) -> np.ndarray:
    """(1 - e^-u) / (1 - e^-mu), evaluated without overflow; 1/m at u = 0 (the neutral drift)."""
    u = np.asarray(u, dtype=np.float64)
    rho = np.full(u.shape, 1.0 / m)
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        pos = u > 1e-14
        neg = u < -1e-14
        rho[pos] = np.expm1(-u[pos]) / np.expm1(-m * u[pos])
        # multiply through by e^(mu) so that nothing overflows for strongly deleterious mutants
        un = u[neg]
        rho[neg] = np.exp((m - 1) * un) * np.expm1(un) / np.expm1(m * un)
    return np.nan_to_num(rho, nan=0.0)


def alpha_rank(
    payoff_tables: Sequence[ArrayLike] | np.ndarray,
    alpha: float = 100.0,
    m: int = 50,
    use_inf_alpha: bool = False,
    inf_alpha_eps: float = 0.01,
    use_local_selection_model: bool = True,
) -> np.ndarray:
    """alpha-Rank stationary distribution over strategies (one population) or joint profiles.

    Args:
        payoff_tables: ``[M]`` for a symmetric game (a bare square array is read as ``[M]``), or K
            arrays of shape ``(n_1, ..., n_K)`` for K populations.
        alpha: selection intensity; large values rank by the sink of the response graph. See
            :func:`alpha_rank_sweep` for the automatic choice.
        m: population size of the evolutionary model (>= 2).
        use_inf_alpha: the alpha -> infinity limit, with transition noise ``inf_alpha_eps``.
        inf_alpha_eps: in [0, 1); 0 gives the bare response graph, which has a unique stationary
            distribution only if it has one sink component.
        use_local_selection_model: fitness against the current opponent only (OpenSpiel's
            default); False uses the single-population Moran process over population states.

    Returns:
        pi, summing to 1: over strategies, or over profiles in C order for K populations.

    Raises:
        ReducibleChainError: the chain has several closed classes (alpha too large for floating
            point, or ``inf_alpha_eps=0`` with several sinks).
    """
    tables = _check_tables(payoff_tables)
    if int(m) != m or m < 2:
        raise ValueError(f"the population size m must be an integer >= 2, got {m}")
    if not 0.0 <= inf_alpha_eps < 1.0:
        raise ValueError(f"inf_alpha_eps must lie in [0, 1), got {inf_alpha_eps}")
    if not use_inf_alpha and not alpha >= 0:
        raise ValueError(f"alpha must be non-negative, got {alpha}")
    rows, cols, rates, n_states = _transitions(tables, float(alpha), int(m), use_inf_alpha, inf_alpha_eps,
                                               use_local_selection_model)
    return _stationary_distribution(rows, cols, rates, n_states)


@dataclass(frozen=True)
class AlphaRankSweep:
    """The result of :func:`alpha_rank_sweep`: ``pi`` at the chosen ``alpha``, and the path."""

    pi: np.ndarray
    alpha: float
    alphas: np.ndarray
    pis: np.ndarray


def alpha_rank_sweep(
    payoff_tables: Sequence[ArrayLike] | np.ndarray,
    m: int = 50,
    alpha_start: float = 1e-4,
    factor: float = 2.0,
    max_alpha: float = 1e6,
    rtol: float = 1e-5,
    atol: float = 1e-8,
    use_local_selection_model: bool = True,
) -> AlphaRankSweep:
    """Chooses alpha automatically, as the paper recommends: as large as possible.

    Multiplies alpha by ``factor`` from ``alpha_start`` until pi stops changing (``np.allclose``
    with ``rtol``/``atol``), the chain turns reducible in floating point, or ``max_alpha`` is
    passed; returns the last pi computed (as OpenSpiel's ``sweep_pi_vs_alpha``).
    """
    tables = _check_tables(payoff_tables)
    if factor <= 1.0 or alpha_start <= 0:
        raise ValueError("alpha_start must be positive and factor > 1")
    alphas, pis = [], []
    alpha = alpha_start
    while alpha <= max_alpha:
        try:
            pi = alpha_rank(tables, alpha=alpha, m=m, use_local_selection_model=use_local_selection_model)
        except ReducibleChainError:
            if not pis:
                raise
            break
        alphas.append(alpha)
        pis.append(pi)
        if len(pis) > 1 and np.allclose(pis[-1], pis[-2], rtol=rtol, atol=atol):
            break
        alpha *= factor
    return AlphaRankSweep(pis[-1], alphas[-1], np.array(alphas), np.array(pis))


def _check_tables(payoff_tables: Sequence[ArrayLike] | np.ndarray) -> list[np.ndarray]:
    if isinstance(payoff_tables, np.ndarray) and payoff_tables.ndim == 2:
        payoff_tables = [payoff_tables]
    tables = [np.asarray(t, dtype=np.float64) for t in payoff_tables]
    if not tables:
        raise ValueError("payoff_tables is empty; pass [M] for a symmetric game or one table per population")
    if any(not np.isfinite(t).all() for t in tables):
        raise ValueError("payoff tables contain NaN or infinite payoffs; every profile needs a payoff "
                         "(for win rates, play every pair or use a pseudo-count)")
    if len(tables) == 1:
        if tables[0].ndim != 2 or tables[0].shape[0] != tables[0].shape[1]:
            raise ValueError(f"a single payoff table is a symmetric game and must be square, got shape "
                             f"{tables[0].shape}; pass one table per population for asymmetric games")
        return tables
    shape = tables[0].shape
    if any(t.shape != shape for t in tables) or len(shape) != len(tables):
        raise ValueError(f"K = {len(tables)} populations need K tables of K dimensions, all of one shape; "
                         f"got shapes {[t.shape for t in tables]}")
    return tables


def _transitions(tables: list[np.ndarray], alpha: float, m: int, use_inf_alpha: bool, eps: float,
                 local: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Off-diagonal transition probabilities of the chain as (row, col, probability) triplets."""
    if len(tables) == 1:
        payoff = tables[0]
        n = payoff.shape[0]
        if n == 1:
            return np.zeros(0, int), np.zeros(0, int), np.zeros(0), 1
        s, r = np.nonzero(~np.eye(n, dtype=bool))  # resident s, mutant r
        eta = 1.0 / (n - 1)
        if use_inf_alpha:
            rates = eta * _inf_alpha_rates(payoff[r, s], payoff[s, r], eps)
        elif local:
            rates = eta * fixation_probability(alpha * (payoff[r, s] - payoff[s, r]), m)
        else:
            rates = eta * _moran_fixation(payoff, alpha, m)[s, r]
        return s, r, rates, n

    shape = tables[0].shape
    n_states = int(np.prod(shape))
    if n_states == 1:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0), 1
    eta = 1.0 / sum(n_k - 1 for n_k in shape)
    state = np.arange(n_states).reshape(shape)
    rows, cols, rates = [], [], []
    for k, (payoff, n_k) in enumerate(zip(tables, shape)):
        stride = int(np.prod(shape[k + 1:]))
        # deviant[s, j]: population k's payoff at profile s with its own strategy replaced by j
        deviant = np.broadcast_to(np.expand_dims(np.moveaxis(payoff, k, -1), k), (*shape, n_k))
        deviant = deviant.reshape(n_states, n_k)
        resident = payoff.reshape(n_states)
        own = (state // stride % n_k).reshape(n_states)
        target = (state.reshape(n_states, 1) + (np.arange(n_k)[None, :] - own[:, None]) * stride)
        moves = np.arange(n_k)[None, :] != own[:, None]
        s_idx = np.broadcast_to(np.arange(n_states)[:, None], moves.shape)[moves]
        f_r, f_s = deviant[moves], resident[s_idx]
        if use_inf_alpha:
            rho = _inf_alpha_rates(f_r, f_s, eps)
        else:
            rho = fixation_probability(alpha * (f_r - f_s), m)
        rows.append(s_idx)
        cols.append(target[moves])
        rates.append(eta * rho)
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(rates), n_states


def _inf_alpha_rates(f_mutant: np.ndarray, f_resident: np.ndarray, eps: float) -> np.ndarray:
    return np.where(np.isclose(f_mutant, f_resident, rtol=0.0, atol=1e-14), 0.5,
                    np.where(f_mutant > f_resident, 1.0 - eps, eps))


def _moran_fixation(payoff: np.ndarray, alpha: float, m: int) -> np.ndarray:
    """rho[s, r] of mutant r in residents s, fitness averaged over the population (paper Eq. 6):
    rho = 1 / (1 + sum_l prod_{p<=l} exp(-alpha (f_r(p) - f_s(m - p)))), p the number of mutants."""
    mutants = np.arange(1, m)[None, None, :]
    self_r = np.diag(payoff)[None, :, None]  # indexed [s, r, p]
    self_s = np.diag(payoff)[:, None, None]
    r_vs_s = payoff.T[:, :, None]  # payoff[r, s]
    s_vs_r = payoff[:, :, None]  # payoff[s, r]
    f_r = ((mutants - 1) * self_r + (m - mutants) * r_vs_s) / (m - 1)
    f_s = ((m - mutants - 1) * self_s + mutants * s_vs_r) / (m - 1)
    log_terms = np.cumsum(-alpha * (f_r - f_s), axis=-1)
    log_sum = np.logaddexp(0.0, np.logaddexp.reduce(log_terms, axis=-1))
    return np.exp(-log_sum)


def _stationary_distribution(rows: np.ndarray, cols: np.ndarray, rates: np.ndarray, n: int) -> np.ndarray:
    """pi with pi C = pi for the chain with the given off-diagonal rates, by one linear solve."""
    if n == 1:
        return np.ones(1)
    keep = rates > 0
    rows, cols, rates = rows[keep], cols[keep], rates[keep]
    graph = sparse.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n))
    n_parts, part = connected_components(graph, directed=True, connection="strong")
    if n_parts > 1:
        leaves = np.ones(n_parts, dtype=bool)
        leaves[np.unique(part[rows[part[rows] != part[cols]]])] = False
        if leaves.sum() > 1:
            classes = [np.flatnonzero(part == c).tolist() for c in np.flatnonzero(leaves)[:4]]
            raise ReducibleChainError(
                f"the alpha-Rank chain has {leaves.sum()} closed classes (e.g. states {classes}), so no "
                "unique stationary distribution: lower alpha, or use use_inf_alpha=True with "
                "inf_alpha_eps > 0 (or alpha_rank_sweep to pick alpha)")
    # Generator Q = C - I: the diagonal is minus the total outflow, summed rather than taken as
    # 1 - C[s, s], so that tiny escape rates do not cancel.
    outflow = np.bincount(rows, weights=rates, minlength=n)
    # Solve Q^T pi = 0 with the last equation replaced by sum(pi) = 1.
    if n <= _DENSE_LIMIT:
        q_t = np.zeros((n, n))
        q_t[cols, rows] = rates
        q_t[np.arange(n), np.arange(n)] = -outflow
        q_t[-1, :] = 1.0
        rhs = np.zeros(n)
        rhs[-1] = 1.0
        pi = scipy.linalg.solve(q_t, rhs, check_finite=False)
    else:
        last = cols == n - 1
        q_t = sparse.csr_matrix(
            (np.r_[rates[~last], -outflow[:-1], np.ones(n)],
             (np.r_[cols[~last], np.arange(n - 1), np.full(n, n - 1)],
              np.r_[rows[~last], np.arange(n - 1), np.arange(n)])), shape=(n, n))
        rhs = np.zeros(n)
        rhs[-1] = 1.0
        pi = spsolve(q_t.tocsc(), rhs)
    pi = np.clip(pi, 0.0, None)
    return pi / pi.sum()
