"""The one definition of an agent's rank and its rank interval, shared by every view of the league.

An agent's **rank** is 1 + the number of agents of a reference set whose rating (the point
estimate, the score a board is sorted by) is strictly above its own: standard competition
ranking, so that equal ratings share a rank ("1224" ranking). Its rank interval runs from
**rank_lower**, the best place its rating interval allows (1 + the number of reference agents
rated strictly above the upper end of the interval), to **rank_upper**, the worst (1 + the number
rated at or above its lower end). An agent never counts itself.

The reference set is whoever the rank is among: the other rated agents of a board re-rated from
matches, or a frozen base population (an entrant's place among its members, as a placement
reports it: ``53`` of 101, and a member's place among the other members).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Ranks", "competition_ranks"]


@dataclass(frozen=True)
class Ranks:
    """Ranks and rank intervals of some agents among a reference set (see the module docstring)."""

    rank: np.ndarray
    rank_lower: np.ndarray
    """The best place: 1 + reference agents rated strictly above the upper end of the interval."""
    rank_upper: np.ndarray
    """The worst place: 1 + reference agents (other than the agent) rated at or above its lower end."""
    tied: np.ndarray
    """Whether another reference agent has exactly this agent's rating (so shares its rank)."""


def competition_ranks(
    rating: ArrayLike,
    lower: ArrayLike | None = None,
    upper: ArrayLike | None = None,
    *,
    reference: ArrayLike | None = None,
    self_index: ArrayLike | None = None,
) -> Ranks:
    """Rank, rank interval and ties of agents rated ``rating`` among the ``reference`` ratings.

    Args:
        rating: the agents' point ratings (any scale where higher is better), shape ``(n,)``.
        lower, upper: the ends of each agent's rating interval, same shape; None (or NaN on a row)
            for an agent without an interval: its rank interval then spans only the agents tied
            with it. An interval that does not hold its point (a percentile bootstrap need not) is
            widened to hold it, so that ``rank_lower <= rank <= rank_upper`` always.
        reference: the ratings the agents are ranked among, shape ``(m,)``; by default ``rating``
            itself (every agent among the others).
        self_index: for each agent, its index in ``reference`` (so that it does not count
            itself), or -1 for an agent outside it; by default ``0 .. n - 1`` when ``reference``
            is None and all -1 otherwise.

    Equal ratings share a rank; a NaN rating has no place and is an error. Vectorised: sorts the
    reference once, O((n + m) log m).
    """
    rating = np.asarray(rating, dtype=np.float64)
    if rating.ndim != 1:
        raise ValueError(f"rating must be a 1-D array, got shape {rating.shape}")
    if np.isnan(rating).any():
        raise ValueError("a NaN rating has no rank")
    low = _end(lower, rating, np.minimum)
    high = _end(upper, rating, np.maximum)
    if reference is None:
        ref = rating
        own = np.arange(rating.size) if self_index is None else np.asarray(self_index, dtype=np.int64)
    else:
        ref = np.asarray(reference, dtype=np.float64)
        own = np.full(rating.size, -1) if self_index is None else np.asarray(self_index, dtype=np.int64)
    if ref.ndim != 1 or np.isnan(ref).any():
        raise ValueError("reference must be a 1-D array of ratings without NaN")
    if own.shape != rating.shape or (own >= ref.size).any():
        raise ValueError("self_index needs one index into the reference (or -1) per agent")
    ordered = np.sort(ref)
    m = ordered.size

    def above(values: np.ndarray) -> np.ndarray:
        return m - np.searchsorted(ordered, values, side="right")

    def at_or_above(values: np.ndarray) -> np.ndarray:
        return m - np.searchsorted(ordered, values, side="left")

    member = own >= 0
    own_rating = np.where(member, ref[np.clip(own, 0, None)] if m else 0.0, np.nan)
    # the agent's own entry is never strictly above its own rating or its upper end (which holds
    # the rating), but it is at or above its lower end and at its own rating
    itself_at_low = member & (own_rating >= low)
    itself_at = member & (own_rating == rating)
    rank = 1 + above(rating)
    return Ranks(rank=rank, rank_lower=1 + above(high),
                 rank_upper=1 + at_or_above(low) - itself_at_low.astype(np.int64),
                 tied=(at_or_above(rating) - above(rating) - itself_at.astype(np.int64)) > 0)


def _end(end: ArrayLike | None, rating: np.ndarray, widen) -> np.ndarray:
    if end is None:
        return rating.copy()
    values = np.asarray(end, dtype=np.float64)
    if values.shape != rating.shape:
        raise ValueError(f"interval ends need one value per rating ({rating.size}), got shape {values.shape}")
    return widen(np.where(np.isnan(values), rating, values), rating)
