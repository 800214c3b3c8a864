"""CaptureFlag's scripted player: each row of observations decided from that row alone (manual, "Heuristic")."""

from __future__ import annotations

import numpy as np

from arena_league.envs.games.captureflag.engine import (
    ACTION_COL,
    ACTION_ROW,
    AT,
    N_ACTIONS,
    N_HEADER,
    PER_OTHER,
)

_BLOCKED, _DANGER, _NEAR_DANGER = 100.0, 30.0, 8.0


def heuristic_actions(obs: np.ndarray, players_per_team: int) -> np.ndarray:
    """``int64[N]``: the heuristic's action per observation row."""
    n = len(obs)
    blocked = obs[:, AT["blocked"]:AT["blocked"] + N_ACTIONS] > 0.5
    to_enemy = obs[:, AT["to_enemy_stand"]:AT["to_enemy_stand"] + N_ACTIONS]
    to_own = obs[:, AT["to_own_stand"]:AT["to_own_stand"] + N_ACTIONS]
    danger = obs[:, AT["danger"]:AT["danger"] + N_ACTIONS]
    carrying = obs[:, AT["carrying"]] > 0.5
    own_home = obs[:, AT["own_flag_home"]] > 0.5
    in_enemy_half = obs[:, AT["in_enemy_half"]] > 0.5
    others = obs[:, N_HEADER:].reshape(n, -1, PER_OTHER)
    opponents = others[:, players_per_team - 1:]
    # a chase: the nearest exposed active opponent (the one carrying my flag first)
    intruder = (opponents[..., 2] > 0.5) & (opponents[..., 4] > 0.5)
    span = np.abs(opponents[..., 0]) + np.abs(opponents[..., 1]) - 10.0 * (opponents[..., 3] > 0.5)
    span = np.where(intruder, span, np.inf)
    chased = span.argmin(axis=1) if opponents.shape[1] else np.zeros(n, dtype=np.int64)
    chasing = np.isfinite(span.min(axis=1)) if opponents.shape[1] else np.zeros(n, dtype=bool)
    rel = opponents[np.arange(n), chased, :2] if opponents.shape[1] else np.zeros((n, 2))
    closer = ACTION_ROW[None, :] * np.sign(rel[:, :1]) + ACTION_COL[None, :] * np.sign(rel[:, 1:2])
    # my own flag taken: chase its carrier; a teammate carries theirs: defend at home
    mates = others[:, :players_per_team - 1]
    mate_carries = (mates[..., 3] > 0.5).any(axis=1) & ~carrying
    defend = ~carrying & chasing & (~own_home | mate_carries & ~in_enemy_half)
    # with a teammate, the one further back (the lower on a tie) guards the stand
    ahead = (mates[..., 2] > 0.5) & ((mates[..., 1] > 1e-6) | ((np.abs(mates[..., 1]) <= 1e-6) & (mates[..., 0] > 1e-6)))
    guard = ahead.any(axis=1) & ~carrying & ~in_enemy_half
    defend |= guard & chasing
    heading = np.where(carrying[:, None] | guard[:, None], -to_own, -to_enemy) * 40.0
    goal = heading
    goal = np.where(defend[:, None], closer.astype(np.float64), goal)
    score = goal - _BLOCKED * blocked - np.where(carrying[:, None] | ~defend[:, None],
                                                 _DANGER * (danger >= 1.0) + _NEAR_DANGER * (danger > 0.25), 0.0)
    score[:, 0] -= 1e-3  # moving beats standing on a tie
    return score.argmax(axis=1).astype(np.int64)
