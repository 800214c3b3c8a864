"""Classic online Elo ratings.

Elo (1978), "The Rating of Chessplayers, Past and Present": after each match both ratings move by
K (score - expected), with expected = 1 / (1 + base^((r_opponent - r) / scale)). The result depends
on the order of matches, which is why leaderboards use :func:`arena_league.rating.bradley_terry`;
online Elo stays for matchmaking (a rating that exists after every match) and for users who expect
it.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["elo_expected_score", "elo_online"]


def elo_expected_score(rating: ArrayLike, opponent: ArrayLike, scale: float = 400.0,
                       base: float = 10.0) -> np.ndarray:
    """Expected score of ``rating`` against ``opponent`` under the Elo model."""
    diff = (np.asarray(opponent, dtype=np.float64) - np.asarray(rating, dtype=np.float64)) / scale
    return 1.0 / (1.0 + np.power(base, diff))


def elo_online(
    first: ArrayLike,
    second: ArrayLike,
    score: ArrayLike,
    n_agents: int,
    *,
    k: float = 32.0,
    initial: float | ArrayLike = 1000.0,
    scale: float = 400.0,
    base: float = 10.0,
) -> np.ndarray:
    """Plays the matches in order and returns the final Elo ratings.

    Args:
        first, second: agent indices of each match, in the order played (for an
            :class:`OutcomeTable`, ``results = table.pairwise()`` gives ``results.first``,
            ``results.second``, ``results.score``).
        score: the first agent's score in each match: 1 win, 0.5 draw, 0 loss.
        n_agents: number of agents.
        k: the K-factor (rating points moved by a fully unexpected result).
        initial: starting rating, one for all or one per agent.
        scale, base: an opponent ``scale`` points stronger has ``base`` times the odds.
    """
    first = np.asarray(first, dtype=np.int64)
    second = np.asarray(second, dtype=np.int64)
    score = np.asarray(score, dtype=np.float64)
    if not (first.shape == second.shape == score.shape) or first.ndim != 1:
        raise ValueError("first, second and score must be 1-D arrays of equal length, one entry per match")
    if first.size and (min(first.min(), second.min()) < 0 or max(first.max(), second.max()) >= n_agents):
        raise ValueError(f"agent indices must lie in [0, {n_agents})")
    if ((score < 0) | (score > 1)).any():
        raise ValueError("scores must lie in [0, 1] (1 win, 0.5 draw, 0 loss)")
    ratings = np.broadcast_to(np.asarray(initial, dtype=np.float64), (n_agents,)).tolist()
    log_base = math.log(base) / scale
    # The recursion is sequential by definition; plain floats keep it fast.
    for a, b, s in zip(first.tolist(), second.tolist(), score.tolist()):
        expected = 1.0 / (1.0 + math.exp(log_base * (ratings[b] - ratings[a])))
        delta = k * (s - expected)
        ratings[a] += delta
        ratings[b] -= delta
    return np.array(ratings)
