"""Population-level measures of a league: performance against a base population, population
versus population, effective diversity and intransitivity.

- Song et al. (2020), "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
  Intelligence", AAAI: an agent's population performance is its mean win rate against the base
  population.
- Balduzzi, Garnelo, Bachrach, Czarnecki, Perolat, Jaderberg & Graepel (2019), "Open-ended
  Learning in Symmetric Zero-sum Games", ICML: the relative population performance v(P, Q) is the
  value of the zero-sum game between populations P and Q under the antisymmetric payoff A (so
  v(P, Q) = -v(Q, P)); the effective diversity of P is sum_ij p_i p_j [A_ij]_+ with p the Nash
  equilibrium of P's own meta-game.
- Balduzzi et al. (2018), "Re-evaluating Evaluation": the combinatorial Hodge decomposition of A
  on the complete graph, A = grad(r) + rot(A), with r = div(A) = row means of A (the transitive
  part; r_i - r_j) and the rest cyclic. The cyclic part's real Schur form is 2 x 2 blocks
  [[0, s_k], [-s_k, 0]], one rock-paper-scissors-like cycle of strength s_k each.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from arena_league.rating.nash import check_antisymmetric, nash_averaging, zero_sum_value

__all__ = [
    "Intransitivity",
    "effective_diversity",
    "intransitivity",
    "population_performance",
    "population_vs_population",
]


def population_performance(win_rate: ArrayLike, base: Sequence[int] | None = None) -> np.ndarray:
    """Arena's population performance: each agent's mean win rate against the base population.

    Args:
        win_rate: square league matrix, ``win_rate[i, j]`` the share of points (draws half) agent i
            took from agent j (e.g. :meth:`PairCounts.win_rate`).
        base: indices of the base population (default all agents); an agent in the base is averaged
            over the other base agents.

    Returns:
        One mean win rate per agent.
    """
    W = np.asarray(win_rate, dtype=np.float64)
    if W.ndim != 2 or W.shape[0] != W.shape[1]:
        raise ValueError(f"win_rate must be a square league matrix, got shape {W.shape}")
    members = np.zeros(W.shape[0], dtype=bool)
    members[np.arange(W.shape[0]) if base is None else np.asarray(base, dtype=int)] = True
    opponents = members[None, :] & ~np.eye(W.shape[0], dtype=bool)
    if np.isnan(W[opponents]).any():
        raise ValueError("some agents never played some base agents (NaN win rates); play them, or pass "
                         "PairCounts.win_rate(pseudo_count=...) to shrink unplayed pairs to 0.5")
    n_opponents = opponents.sum(axis=1)
    if (n_opponents == 0).any():
        raise ValueError("the base population needs at least two agents (or one agent not in it)")
    return np.where(opponents, W, 0.0).sum(axis=1) / n_opponents


def population_vs_population(A: ArrayLike, P: Sequence[int], Q: Sequence[int]) -> float:
    """Relative population performance v(P, Q): the value of the zero-sum game in which one side
    picks a mixture over P and the other over Q, with payoff A[P][:, Q]. Antisymmetric:
    v(P, Q) = -v(Q, P), and v(P, P) = 0."""
    A = check_antisymmetric(A)
    P, Q = np.asarray(P, dtype=int), np.asarray(Q, dtype=int)
    if P.size == 0 or Q.size == 0:
        raise ValueError("both populations need at least one agent")
    return zero_sum_value(A[np.ix_(P, Q)])[0]


def effective_diversity(A: ArrayLike, P: Sequence[int] | None = None) -> float:
    """Effective diversity of population P: sum_ij p_i p_j [A_ij]_+, with p the maximum-entropy
    Nash equilibrium of P's meta-game; 0 for a transitive population, large when the agents the
    equilibrium keeps beat each other in cycles."""
    A = check_antisymmetric(A)
    members = np.arange(A.shape[0]) if P is None else np.asarray(P, dtype=int)
    sub = A[np.ix_(members, members)]
    p, _ = nash_averaging(sub)
    return float(p @ np.clip(sub, 0.0, None) @ p)


@dataclass(frozen=True)
class Intransitivity:
    """Hodge decomposition of an antisymmetric meta-game, ``A = transitive + cyclic``."""

    ratings: np.ndarray
    """div(A): each agent's mean payoff; the transitive part is ratings[i] - ratings[j]."""
    transitive: np.ndarray
    cyclic: np.ndarray
    cyclic_share: float
    """||cyclic||^2 / ||A||^2 (Frobenius), in [0, 1]: 0 transitive, 1 purely cyclic."""
    cycle_strengths: np.ndarray
    """The s_k of the cyclic part's Schur blocks, descending."""

    @property
    def transitive_share(self) -> float:
        return 1.0 - self.cyclic_share


def intransitivity(A: ArrayLike) -> Intransitivity:
    """Splits A into its transitive and cyclic parts (see the module docstring)."""
    A = check_antisymmetric(A)
    ratings = A.mean(axis=1)
    transitive = ratings[:, None] - ratings[None, :]
    cyclic = A - transitive
    total = float((A**2).sum())
    share = float((cyclic**2).sum()) / total if total > 0 else 0.0
    # eigenvalues of a real antisymmetric matrix are +-i s_k; the positive s_k are the block strengths
    strengths = np.sort(scipy.linalg.eigvals(cyclic).imag)[::-1]
    strengths = strengths[strengths > 1e-12 * max(1.0, np.abs(A).max())]
    return Intransitivity(ratings, transitive, cyclic, share, strengths)
