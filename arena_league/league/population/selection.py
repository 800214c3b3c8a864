"""Choosing a base population among rated candidates: span the skill range, differ in behaviour.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) ranks new agents against a base population of 100 agents per game, taken
from the snapshots of several training schemes. A rank is only informative where the base has
agents, so the base must cover the skill range evenly; and agents that play alike add matches
without adding information, so among agents of similar skill the base keeps those that behave
differently.

:func:`select_spanning` does both with pure numpy, given each candidate's rating (Bradley-Terry,
Elo scale) and a behaviour descriptor (here: its row of the logit payoff matrix against every
candidate, i.e. *whom* it beats and loses to, not only how often):

1. **Eligible** candidates are those rated above ``floor`` (the build passes the uniformly random
   agent's rating plus a margin, so that random play ranks at the bottom of the base).
2. **Targets**: ``size`` ratings evenly spaced from the weakest to the strongest eligible
   candidate; the two ends are taken first (they set the spread), the others from the middle
   outwards (so that, should candidates run short, the range stays covered).
3. The two ends take the weakest and the strongest eligible candidates. Every other target takes,
   among the ``pool`` unchosen eligible candidates nearest to it in rating, the one farthest in
   behaviour from those already chosen (max-min distance, as in farthest-point sampling; Gonzalez
   1985), ties going to the one nearest the target.
4. When fewer than ``size`` candidates are eligible, the base is filled with the best of the
   others, nearest the floor first, and the caller reports the shortfall.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["behaviour_distances", "select_spanning", "target_order"]


def behaviour_distances(descriptors: ArrayLike) -> np.ndarray:
    """Root-mean-square distance between every pair of behaviour descriptors ``[n, d]``
    (NaN cells, e.g. unplayed pairs, are left out of a pair's mean). ``float64[n, n]``."""
    x = np.asarray(descriptors, dtype=np.float64)
    if x.ndim != 2:
        raise ValueError(f"descriptors must be a matrix [candidates, features], got shape {x.shape}")
    known = ~np.isnan(x)
    filled = np.where(known, x, 0.0)
    k = known.astype(np.float64)
    # sum over features both rows know of (x_i - x_j)^2, expanded so that it is three matrix products
    both = k @ k.T
    squares = (filled**2) @ k.T
    sq = squares + squares.T - 2.0 * filled @ filled.T
    with np.errstate(invalid="ignore", divide="ignore"):
        distance = np.sqrt(np.clip(sq, 0.0, None) / both)
    distance[both == 0] = 0.0
    np.fill_diagonal(distance, 0.0)
    return distance


def target_order(size: int) -> np.ndarray:
    """The order in which the ``size`` evenly spaced targets are served: both ends, then from the
    middle outwards (``[0, size-1, mid, mid-1, mid+1, ...]``)."""
    if size < 1:
        raise ValueError(f"size must be at least 1, not {size}")
    if size == 1:
        return np.array([0])
    inner = np.arange(1, size - 1)
    middle = (size - 1) / 2.0
    inner = inner[np.lexsort((inner, np.abs(inner - middle)))]
    return np.concatenate([[0, size - 1], inner]).astype(np.int64)


def select_spanning(ratings: ArrayLike, descriptors: ArrayLike, size: int, *, floor: float | None = None,
                    pool: int = 4) -> np.ndarray:
    """Indices of ``size`` candidates spanning the rating range and differing in behaviour (see the
    module docstring), sorted by rating (weakest first).

    Args:
        ratings: each candidate's rating, ``float[n]``.
        descriptors: each candidate's behaviour descriptor, ``float[n, d]`` (NaN: unknown cell).
        size: how many to choose (all candidates when there are no more than ``size``).
        floor: only candidates rated above it are eligible while there are enough of them.
        pool: candidates nearest a target in rating among which behaviour decides.
    """
    r = np.asarray(ratings, dtype=np.float64)
    n = r.size
    if r.ndim != 1 or not np.isfinite(r).all():
        raise ValueError("ratings must be a vector of finite numbers, one per candidate")
    if np.asarray(descriptors).shape[0] != n:
        raise ValueError(f"descriptors need one row per candidate ({n}), got {np.asarray(descriptors).shape[0]}")
    if size < 1:
        raise ValueError(f"size must be at least 1, not {size}")
    if pool < 1:
        raise ValueError(f"pool must be at least 1, not {pool}")
    if n <= size:
        return np.argsort(r, kind="stable")
    eligible = np.flatnonzero(r > floor) if floor is not None else np.arange(n)
    if eligible.size <= size:
        others = np.setdiff1d(np.arange(n), eligible)
        fill = others[np.argsort(-r[others], kind="stable")][: size - eligible.size]
        chosen = np.concatenate([eligible, fill])
        return chosen[np.argsort(r[chosen], kind="stable")]
    distance = behaviour_distances(descriptors)[np.ix_(eligible, eligible)]
    er = r[eligible]
    targets = np.linspace(er.min(), er.max(), size)
    taken = np.zeros(eligible.size, dtype=bool)
    nearest_chosen = np.full(eligible.size, np.inf)  # behaviour distance to the closest chosen one
    chosen_local: list[int] = []
    for k, t in enumerate(target_order(size)):
        free = np.flatnonzero(~taken)
        gap = np.abs(er[free] - targets[t])
        near = free[np.argsort(gap, kind="stable")[:pool]]
        if k >= 2:  # the two ends are the weakest and the strongest themselves: they set the spread
            # farthest in behaviour from the chosen; ties (within 1e-9) go to the nearest in rating
            spread = nearest_chosen[near]
            best = near[np.lexsort((np.abs(er[near] - targets[t]), -np.round(spread, 9)))[0]]
        else:
            best = near[0]
        taken[best] = True
        chosen_local.append(int(best))
        nearest_chosen = np.minimum(nearest_chosen, distance[best])
    chosen = eligible[np.asarray(chosen_local)]
    return chosen[np.argsort(r[chosen], kind="stable")]
