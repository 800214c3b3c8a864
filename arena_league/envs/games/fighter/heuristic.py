"""Fighter's scripted play: the heuristic, from the observation alone. Imported by the game's rules
only.

Each seat, in its own frame, against the nearest opponent in play:

1. of the eight compass lines from the fighter, take the one passing nearest the opponent's
   centre, if it passes within 0.28 (most of a fighter's radius) ahead and no bunker tile lies on
   the way (checked every 0.25): facing along it (within about 8 degrees), fire whenever the gun
   is loaded, else hold still; not facing along it, move that way (which turns the fighter);
2. otherwise close in: every open tile's number of steps to the opponent's tile is grown out from
   that tile a ring at a time (four neighbours, through open tiles); the fighter heads for the
   centre of its tile's neighbour (eight neighbours, a diagonal one only with both tiles beside
   it open) with the fewest steps, as the nearest compass move.
"""

from __future__ import annotations

import math

import numpy as np

from arena_league.envs.games.fighter.arena import (
    COLS,
    FIGHTER_RADIUS,
    HALF_X,
    HALF_Y,
    POSITION_UNIT,
    ROWS,
    TILE,
)
from arena_league.envs.physics2d import COMPASS_MOVES

__all__ = ["heuristic"]

#: A compass line passing the opponent's centre nearer than this is a shot; the longest shot taken.
MISS, REACH = 0.8 * FIGHTER_RADIUS, 14.0
#: Facing along a line: the heading's dot product with it at least this.
FACING = 0.99
_FIRE = 9
_OWN_CELLS, _OTHER_CELLS, _SHELL_CELLS, _PLANE = 9, 8, 5, ROWS * COLS


def _tile(x: float, y: float) -> tuple[int, int]:
    return (min(max(math.floor((y + HALF_Y) / TILE), 0), ROWS - 1),
            min(max(math.floor((x + HALF_X) / TILE), 0), COLS - 1))


def _steps_to(targets: np.ndarray, open_tiles: np.ndarray) -> np.ndarray:
    """``float[N, ROWS, COLS]``: steps from every open tile to the row's target tile through open
    tiles (infinite where none leads), for all rows at once."""
    steps = np.where(targets, 0.0, np.inf)
    reached = targets.copy()
    ring = 0
    while True:
        ring += 1
        padded = np.pad(reached, ((0, 0), (1, 1), (1, 1)))
        around = padded[:, :-2, 1:-1] | padded[:, 2:, 1:-1] | padded[:, 1:-1, :-2] | padded[:, 1:-1, 2:]
        new = around & open_tiles & ~reached
        if not new.any():
            return steps
        steps[new] = ring
        reached |= new


def _clear(open_tiles: np.ndarray, x: float, y: float, ux: float, uy: float, length: float) -> bool:
    """Whether no bunker tile lies on the segment from ``(x, y)`` along ``(ux, uy)`` for ``length``."""
    for k in range(1, int(length / 0.25) + 1):
        px, py = x + ux * 0.25 * k, y + uy * 0.25 * k
        if abs(px) < HALF_X and abs(py) < HALF_Y and not open_tiles[_tile(px, py)]:
            return False
    return True


def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
    obs = np.asarray(obs, dtype=np.float64)
    widths = {_PLANE + _OWN_CELLS - _OTHER_CELLS + (_OTHER_CELLS + _SHELL_CELLS) * n: n for n in (2, 4)}
    if obs.ndim != 2 or obs.shape[1] not in widths:
        raise ValueError(f"Fighter heuristic: observations of shape {obs.shape} are not Fighter's (N, "
                         f"{' or '.join(map(str, widths))})")
    count = len(obs)
    n_agents = (obs.shape[1] - _PLANE - _OWN_CELLS + _OTHER_CELLS) // (_OTHER_CELLS + _SHELL_CELLS)
    first_rival = n_agents // 2 - 1
    open_tiles = obs[:, -_PLANE:].reshape(count, ROWS, COLS) < 0.5
    others = obs[:, _OWN_CELLS: _OWN_CELLS + _OTHER_CELLS * (n_agents - 1)].reshape(count, -1, _OTHER_CELLS)
    rivals = others[:, first_rival:]
    gap = np.hypot(rivals[:, :, 0], rivals[:, :, 1]) + np.where(rivals[:, :, 7] > 0.5, 0.0, np.inf)
    target = gap.argmin(axis=1)
    rows = np.arange(count)
    offset = rivals[rows, target, 0:2] * POSITION_UNIT
    targets = np.zeros((count, ROWS, COLS), dtype=bool)
    here = []
    for i in range(count):
        x, y = obs[i, 1] * POSITION_UNIT, obs[i, 2] * POSITION_UNIT
        here.append((x, y))
        targets[(i, *_tile(x + offset[i, 0], y + offset[i, 1]))] = True
    steps = _steps_to(targets, open_tiles)
    moves = np.zeros((count, 2))
    fire = np.zeros(count, dtype=bool)
    for i in range(count):
        if obs[i, 0] < 0.5 or not np.isfinite(gap[i, target[i]]):
            continue
        (x, y), (dx, dy) = here[i], offset[i]
        along = COMPASS_MOVES[1:] @ (dx, dy)
        miss = np.abs(COMPASS_MOVES[1:, 0] * dy - COMPASS_MOVES[1:, 1] * dx)
        miss[(along <= 0) | (along > REACH)] = np.inf
        line = int(miss.argmin())
        ux, uy = COMPASS_MOVES[1 + line]
        if miss[line] < MISS and _clear(open_tiles[i], x, y, ux, uy, along[line] - FIGHTER_RADIUS):
            if obs[i, 5] * ux + obs[i, 6] * uy >= FACING:
                fire[i] = obs[i, 8] == 0.0 and obs[i, _OWN_CELLS + _OTHER_CELLS * (n_agents - 1)] < 0.5
            else:
                moves[i] = ux, uy
            continue
        row, col = _tile(x, y)
        best, aim = steps[i, row, col], None
        for mx, my in COMPASS_MOVES[1:]:
            step_row, step_col = row + round(my), col + round(mx)
            if not (0 <= step_row < ROWS and 0 <= step_col < COLS):
                continue
            if mx and my and not (open_tiles[i, row, step_col] and open_tiles[i, step_row, col]):
                continue
            if steps[i, step_row, step_col] < best:
                best, aim = steps[i, step_row, step_col], (step_row, step_col)
        if aim is not None:
            cx, cy = -HALF_X + (aim[1] + 0.5) * TILE, -HALF_Y + (aim[0] + 0.5) * TILE
            moves[i] = cx - x, cy - y
    if action_type == "discrete":
        angle = np.round(np.arctan2(moves[:, 1], moves[:, 0]) / (np.pi / 4)).astype(np.int64) % 8
        actions = np.where((moves == 0.0).all(axis=1), 0, 1 + angle)
        return np.where(fire, _FIRE, actions).astype(np.int64)
    length = np.maximum(np.hypot(moves[:, 0], moves[:, 1]), 1e-9)[:, None]
    thrust = np.where(length > 1e-6, moves / length, 0.0)
    return np.column_stack([thrust, np.where(fire, 1.0, -1.0)]).astype(np.float32)
