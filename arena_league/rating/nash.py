"""Nash averaging: agents scored against the maximum-entropy Nash equilibrium of the meta-game.

Balduzzi, Tuyls, Perolat & Graepel (2018), "Re-evaluating Evaluation", NeurIPS. For an
antisymmetric meta-game A (A[i, j] = logit of agent i's win rate against agent j), the game between
two evaluators who each pick a distribution over agents is symmetric zero-sum with value 0. Its
maximum-entropy Nash equilibrium p is unique; an agent's Nash-averaged score is (A p)_i <= 0, with 0
for the agents in the equilibrium's support. The scores are invariant to adding copies of agents,
which mean win rate is not.

The solve is two steps. (1) One linear programme finds an equilibrium of maximal support: by
Tucker's theorem on skew-symmetric systems (1956) there is an equilibrium p with p_i > 0 or
(A p)_i < 0 for every i, and the LP maximises the smallest of p_i - (A p)_i. That support S is the
union of the supports of all equilibria, and every equilibrium q has (A q)_S = 0. (2) Maximum
entropy over the equilibrium set {q on S : A_SS q = 0, A_rest,S q <= 0, sum q = 1}: when that set
is a single point it is solved exactly; otherwise through the convex dual (log-sum-exp, solved by
L-BFGS-B and polished by Newton steps).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike
from scipy.optimize import linprog, minimize
from scipy.special import logsumexp, softmax

from arena_league.rating.outcomes import PSEUDO_COUNT

__all__ = ["check_antisymmetric", "nash_averaging", "zero_sum_value"]


def check_antisymmetric(A: ArrayLike, atol: float = 1e-8) -> np.ndarray:
    """Returns A as a float array after checking it is a finite antisymmetric square matrix; the
    result is exactly antisymmetric, (A - A^T) / 2."""
    A = np.asarray(A, dtype=np.float64)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"the meta-game must be a square matrix, got shape {A.shape}")
    if not np.isfinite(A).all():
        raise ValueError("the meta-game has infinite or NaN entries; build it with a pseudo-count, "
                         f"e.g. PairCounts.logit_payoff(pseudo_count={PSEUDO_COUNT})")
    scale = max(1.0, float(np.abs(A).max(initial=0.0)))
    if np.abs(A + A.T).max(initial=0.0) > atol * scale:
        raise ValueError("the meta-game must be antisymmetric (A[i, j] == -A[j, i]); from win rates W "
                         "use A = logit(W) with W[i, j] + W[j, i] == 1, or A = W - W.T")
    return 0.5 * (A - A.T)


def nash_averaging(A: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-entropy Nash equilibrium of the antisymmetric meta-game A and the Nash-averaged
    scores.

    Args:
        A: antisymmetric ``(n, n)`` matrix, ``A[i, j]`` the payoff of agent i against agent j
            (typically the logit of i's win rate against j).

    Returns:
        ``(p, scores)``: the equilibrium distribution over agents and ``scores = A @ p`` (all <= 0,
        exactly 0 on the support of p).
    """
    A = check_antisymmetric(A)
    n = A.shape[0]
    if n == 1:
        return np.ones(1), np.zeros(1)
    support = _maximal_support(A)
    p = np.zeros(n)
    p[support] = _max_entropy_on_support(A, support)
    return p, A @ p


def _maximal_support(A: np.ndarray) -> np.ndarray:
    """The support of an equilibrium with p_i > 0 or (A p)_i < 0 for all i (Tucker): the
    maximal support, on which the maximum-entropy equilibrium lies."""
    n = A.shape[0]
    # variables (p, t): maximise t s.t. A p <= 0, t - p_i + (A p)_i <= 0, sum p = 1, p >= 0, t <= 1
    c = np.zeros(n + 1)
    c[-1] = -1.0
    a_ub = np.block([[A, np.zeros((n, 1))], [A - np.eye(n), np.ones((n, 1))]])
    a_eq = np.r_[np.ones(n), 0.0][None, :]
    result = linprog(c, A_ub=a_ub, b_ub=np.zeros(2 * n), A_eq=a_eq, b_eq=[1.0],
                     bounds=[(0, None)] * n + [(None, 1.0)], method="highs")
    if result.status != 0:
        raise RuntimeError(f"Nash averaging LP failed: {result.message}")
    p = np.clip(result.x[:n], 0.0, None)
    p /= p.sum()
    return np.flatnonzero(p > -(A @ p))


def _max_entropy_on_support(A: np.ndarray, support: np.ndarray) -> np.ndarray:
    """Maximum-entropy q on ``support`` with A_SS q = 0, A_rest,S q <= 0, sum q = 1."""
    m = support.size
    if m == 1:
        return np.ones(1)
    A_s = A[:, support]
    equalities = np.vstack([A_s[support], np.ones((1, m))])
    rhs = np.r_[np.zeros(m), 1.0]
    singular_values = scipy.linalg.svdvals(equalities)
    if (singular_values > singular_values[0] * max(equalities.shape) * 1e-12).sum() == m:
        # The equilibrium is unique: solve the (consistent) system exactly.
        q = scipy.linalg.lstsq(equalities, rhs)[0]
        return np.clip(q, 0.0, None) / np.clip(q, 0.0, None).sum()

    # Dual of max H(q) s.t. A_s q <= 0 (rows in S are equalities): q = softmax(-A_s^T y), with y
    # free on S and y >= 0 elsewhere, minimising log-sum-exp(-A_s^T y).
    on_support = np.zeros(A.shape[0], dtype=bool)
    on_support[support] = True

    def dual(y: np.ndarray) -> tuple[float, np.ndarray]:
        z = -A_s.T @ y
        return float(logsumexp(z)), -A_s @ softmax(z)

    bounds = [(None, None) if s else (0.0, None) for s in on_support]
    y0 = np.zeros(A.shape[0])
    result = minimize(dual, y0, jac=True, method="L-BFGS-B", bounds=bounds,
                      options={"maxiter": 10_000, "ftol": 1e-15, "gtol": 1e-12})
    y = result.x
    # Newton polish on the constraints active at the dual optimum (free ones and y_k > 0).
    active = on_support | (y > 1e-12)
    B = A_s[active]
    for _ in range(50):
        q = softmax(-A_s.T @ y)
        residual = B @ q
        if np.abs(residual).max() < 1e-14:
            break
        hessian = (B * q) @ B.T - np.outer(residual, residual)
        y[active] += scipy.linalg.lstsq(hessian, residual)[0]
        y[~on_support] = np.maximum(y[~on_support], 0.0)
    q = softmax(-A_s.T @ y)
    if (A_s @ q).max() > 1e-6 or np.abs(A_s[support] @ q).max() > 1e-6:
        # The polish must not leave the equilibrium set; fall back to the first-order solution.
        q = softmax(-A_s.T @ result.x)
    return q


def zero_sum_value(M: ArrayLike) -> tuple[float, np.ndarray, np.ndarray]:
    """Value of the two-player zero-sum matrix game M (row player maximises M[i, j]) and a pair of
    optimal mixed strategies ``(value, p_row, q_col)``, by linear programming."""
    M = np.asarray(M, dtype=np.float64)
    if M.ndim != 2 or 0 in M.shape:
        raise ValueError(f"the payoff matrix must be 2-D and non-empty, got shape {M.shape}")
    n_rows, n_cols = M.shape
    # variables (p, v): maximise v s.t. v - (M^T p)_j <= 0, sum p = 1, p >= 0
    c = np.r_[np.zeros(n_rows), -1.0]
    a_ub = np.hstack([-M.T, np.ones((n_cols, 1))])
    a_eq = np.r_[np.ones(n_rows), 0.0][None, :]
    result = linprog(c, A_ub=a_ub, b_ub=np.zeros(n_cols), A_eq=a_eq, b_eq=[1.0],
                     bounds=[(0, None)] * n_rows + [(None, None)], method="highs")
    if result.status != 0:
        raise RuntimeError(f"zero-sum game LP failed: {result.message}")
    p = np.clip(result.x[:n_rows], 0.0, None)
    q = np.clip(-result.ineqlin.marginals, 0.0, None)
    return float(result.x[-1]), p / p.sum(), q / q.sum()
