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
_OFF_LIMITS = 100.0  # a tuned keeper's penalty for a move that would leave its stand open


def heuristic_actions(obs: np.ndarray, players_per_team: int, *, commit: float = 0.0, hunt: float = 0.0,
                      keep: float = 0.0, sortie: float = 0.0) -> np.ndarray:
    """``int64[N]``: the heuristic's action per observation row; ``commit``, ``hunt``, ``keep`` and
    ``sortie`` tune it (manual, "Heuristic"), their defaults (0) are the heuristic's own."""
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
    if commit > 0 or hunt > 0 or keep > 0 or sortie > 0:
        goal = _keeper(obs, players_per_team, goal, guard, carrying, own_home, opponents,
                       commit=commit, hunt=hunt, keep=keep, sortie=sortie)
    score = goal - _BLOCKED * blocked - np.where(carrying[:, None] | ~defend[:, None],
                                                 _DANGER * (danger >= 1.0) + _NEAR_DANGER * (danger > 0.25), 0.0)
    score[:, 0] -= 1e-3  # moving beats standing on a tie
    return score.argmax(axis=1).astype(np.int64)


def _keeper(obs, players_per_team, goal, guard, carrying, own_home, opponents, *, commit, hunt, keep, sortie):
    """The tuned goals ``float64[N, A]`` of the seat that keeps the stand (the lone seat, or the guard).

    An exposed seat never steps within 2 steps of an active opponent if it can help it, so a keeper that
    can be back within 2 steps of its stand before any opponent could reach it never loses its flag:
    with ``keep`` it stays that near (``keep`` - 1 steps to spare) and hunts an exposed opponent within
    ``hunt`` steps by the moves that keep it so, cornering it. With ``commit`` it raids whenever it is
    that many steps nearer the opponents' stand than any opponent is to its own (an opponent back from a
    tag starts far away), a race it wins. Otherwise it waits on its stand, which draws a raider deep
    into its half where it can be cornered, but with ``sortie`` it walks out (as far as ``keep`` lets
    it) while every opponent is farther than ``sortie`` times the field's length from its stand: one
    that stays far off is then raided, as the heuristic would.
    """
    n = len(obs)
    to_own = obs[:, AT["to_own_stand"]:AT["to_own_stand"] + N_ACTIONS].astype(np.float64)
    blocked = obs[:, AT["blocked"]:AT["blocked"] + N_ACTIONS] > 0.5
    # the grid's size from what a seat sees: the stand distances of neighbouring cells differ by one step,
    # and the own stand (while home) is column 1
    step = np.where(blocked, 0.0, np.abs(to_own - to_own[:, :1])).max(axis=1)
    perimeter = np.where(step > 1e-6, 1.0 / np.maximum(step, 1e-6), 62.0)  # 2 (rows + cols)
    stand = obs[:, AT["own_flag"]:AT["own_flag"] + 2].astype(np.float64)
    col_unit = stand[:, 1] + 0.5 * (obs[:, AT["position"] + 1] + 1.0)  # 1 / (cols - 1)
    cols = np.rint(np.where(col_unit > 1e-6, 1.0 + 1.0 / np.maximum(col_unit, 1e-6), 20.0))
    rows = np.maximum(np.rint(perimeter) / 2.0 - cols, 2.0)
    mine = np.rint(to_own * perimeter[:, None])  # steps from each move's cell to the own stand
    theirs = np.rint(obs[:, AT["to_enemy_stand"]].astype(np.float64) * perimeter)
    up = opponents[..., 2] > 0.5
    rel = opponents[..., :2].astype(np.float64)
    gap = np.abs(rel[..., 0]) * (rows[:, None] - 1.0) + np.abs(rel[..., 1]) * (cols[:, None] - 1.0)
    # an opponent waiting to respawn stands on its start cell and may move the step it is back
    reach = (np.abs(rel[..., 0] - stand[:, None, 0]) * (rows[:, None] - 1.0)
             + np.abs(rel[..., 1] - stand[:, None, 1]) * (cols[:, None] - 1.0))
    nearest = reach.min(axis=1) if opponents.shape[1] else np.full(n, np.inf)
    keeper = (guard | (players_per_team == 1)) & ~carrying & own_home
    if commit > 0:
        keeper &= theirs + commit > nearest  # else it races, as the heuristic raids
    allowed = mine <= np.maximum(2.0, nearest - keep + 1.0)[:, None] if keep > 0 else np.ones_like(blocked)
    rest = -to_own * 40.0
    if sortie > 0:
        out_there = (nearest > sortie * (cols - 1.0))[:, None]
        rest = np.where(out_there, -obs[:, AT["to_enemy_stand"]:AT["to_enemy_stand"] + N_ACTIONS] * 40.0, rest)
    prey = up & (opponents[..., 4] > 0.5) & (gap <= hunt)
    target = np.where(prey, gap, np.inf).argmin(axis=1) if opponents.shape[1] else np.zeros(n, dtype=np.int64)
    hunting = keeper & prey.any(axis=1)
    out = np.where(keeper[:, None], rest, goal)
    if hunt > 0:
        out = np.where(hunting[:, None], _hunt_moves(obs, rel[np.arange(n), target],
                                                     opponents[np.arange(n), target, 3] > 0.5, rows, cols, blocked),
                       out)
    home = keeper & ~allowed.any(axis=1)  # out of room: straight home
    out = np.where(home[:, None], -to_own * 40.0, out - _OFF_LIMITS * (keeper[:, None] & ~allowed))
    return out


def _hunt_moves(obs, rel, prey_carries, rows, cols, blocked):
    """``float64[N, A]``: how good each move is for tagging the prey at ``rel`` (relative, as observed).
    The prey is taken to play the heuristic: it keeps off cells within 2 steps of this seat where it would
    be exposed and otherwise heads for this seat's stand (its own while it carries), walls as far as this
    seat sees them. A move that lands next to where the prey will stand tags it; else the fewer safe
    moves the prey has left, the better, then the nearer."""
    n = len(obs)
    r1, c1 = rows - 1.0, cols - 1.0
    me = np.stack([np.rint((obs[:, AT["position"]] + 1.0) * 0.5 * r1),
                   np.rint((obs[:, AT["position"] + 1] + 1.0) * 0.5 * c1)], axis=1)
    prey = me + np.rint(rel * np.stack([r1, c1], axis=1))
    aim = np.where(prey_carries[:, None], np.stack([rows // 2, cols - 2.0], axis=1),
                   np.stack([rows // 2, np.ones(n)], axis=1))
    moves = np.stack([ACTION_ROW, ACTION_COL], axis=1).astype(np.float64)  # [A, 2]
    window = obs[:, AT["walls"]:AT["walls"] + 25].reshape(n, 5, 5) > 0.5

    def options(at):  # [N, A, 2]: the cell each move leads to, and whether it is a wall
        cell = at[:, None, :] + moves[None]
        off = (cell[..., 0] < 0) | (cell[..., 0] > r1[:, None]) | (cell[..., 1] < 0) | (cell[..., 1] > c1[:, None])
        d = (cell - me[:, None, :]).astype(np.int64) + 2
        inside = (d >= 0).all(axis=2) & (d <= 4).all(axis=2)
        wall = off | inside & window[np.arange(n)[:, None], np.clip(d[..., 0], 0, 4), np.clip(d[..., 1], 0, 4)]
        return np.where(wall[..., None], at[:, None, :], cell), wall

    def exposed(cell):
        return prey_carries.reshape((n,) + (1,) * (cell.ndim - 2)) | (
            cell[..., 1] < (cols / 2.0).reshape((n,) + (1,) * (cell.ndim - 2)))

    def gap(a, b):
        return np.abs(a - b).sum(axis=-1)

    cells, wall = options(prey)
    near = gap(cells, me[:, None, :])
    value = (-gap(cells, aim[:, None, :]) * (40.0 / (2.0 * (rows + cols)))[:, None]
             - exposed(cells) * (_DANGER * (near <= 1) + _NEAR_DANGER * (near == 2)) - _BLOCKED * wall)
    value[:, 0] -= 1e-3
    then = cells[np.arange(n), value.argmax(axis=1)]
    mine, _ = options(me)
    mine = np.where(blocked[..., None], me[:, None, :], mine)
    tag = (gap(mine, then[:, None, :]) <= 1) & exposed(then[:, None, :])
    later, later_wall = options(then)
    free = (~later_wall[:, None, :] & ((gap(later[:, None, :, :], mine[:, :, None, :]) >= 3)
                                       | ~exposed(later)[:, None, :])).sum(axis=2)
    return np.where(tag, 100.0, -3.0 * free - 0.5 * gap(mine, then[:, None, :]))
