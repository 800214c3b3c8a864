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

Two options, off by default, make tuned heuristics (``FighterRules.heuristic_options``): ``dodge``
D puts a step 0 first: an opponent's shell that will pass within the fighter's radius and 0.15 of
its centre in at most D steps, with no bunker in between, is sidestepped by the compass move that
leaves the fighter farthest off the shell's line half a unit on (where 0.6 that way is open);
``lead`` L aims step 1 at where the opponent will be after L times the shell's flight to it, at the
opponent's present velocity.
"""

from __future__ import annotations

import math

import numpy as np

from arena_league.envs.games.fighter.arena import (
    COLS,
    DT,
    FIGHTER_RADIUS,
    HALF_X,
    HALF_Y,
    POSITION_UNIT,
    ROWS,
    SHELL_SPEED,
    TILE,
    VELOCITY_UNIT,
)
from arena_league.envs.physics2d import COMPASS_MOVES

__all__ = ["heuristic"]

#: A compass line passing the opponent's centre nearer than this is a shot; the longest shot taken.
MISS, REACH = 0.8 * FIGHTER_RADIUS, 14.0
#: Facing along a line: the heading's dot product with it at least this.
FACING = 0.99
_FIRE = 9
#: A shell's way per step; a shell passing a fighter's centre nearer than its radius and this margin
#: is dodged; a sidestep is taken only when this far that way is open.
_SHELL_STEP, _DODGE_MARGIN, _DODGE_LOOK, _DODGE_REACH = SHELL_SPEED * DT, 0.15, 0.6, 0.5
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


def _open(open_tiles: np.ndarray, x: float, y: float) -> bool:
    """Whether ``(x, y)`` lies inside the arena, a fighter's radius off the wall, on an open tile."""
    inside = abs(x) < HALF_X - FIGHTER_RADIUS and abs(y) < HALF_Y - FIGHTER_RADIUS
    return inside and bool(open_tiles[_tile(x, y)])


def _clear(open_tiles: np.ndarray, x: float, y: float, ux: float, uy: float, length: float) -> bool:
    """Whether no bunker tile lies on the segment from ``(x, y)`` along ``(ux, uy)`` for ``length``."""
    for k in range(1, int(length / 0.25) + 1):
        px, py = x + ux * 0.25 * k, y + uy * 0.25 * k
        if abs(px) < HALF_X and abs(py) < HALF_Y and not open_tiles[_tile(px, py)]:
            return False
    return True


def _dodge(open_tiles: np.ndarray, x: float, y: float, shells: np.ndarray, horizon: float) -> tuple[float, float] | None:
    """The sidestep out of the way of the opponents' shell due soonest, if one will hit within
    ``horizon`` steps with no bunker in between; None when none will."""
    due, way = np.inf, None
    for flying, cell_x, cell_y, dx, dy in shells:
        if flying < 0.5:
            continue
        sx, sy = cell_x * POSITION_UNIT, cell_y * POSITION_UNIT
        along = (x - sx) * dx + (y - sy) * dy
        side = dx * (y - sy) - dy * (x - sx)
        steps = along / _SHELL_STEP
        if along <= 0.0 or abs(side) >= FIGHTER_RADIUS + _DODGE_MARGIN or steps > horizon or steps >= due:
            continue
        if not _clear(open_tiles, sx, sy, dx, dy, along - FIGHTER_RADIUS):
            continue
        # the compass move that leaves the fighter farthest off the shell's line after a sidestep's
        # reach (pure sideways away from it unless a bunker or the wall is that way)
        best = 0.0
        for mx, my in COMPASS_MOVES[1:]:
            off = abs(side + (dx * my - dy * mx) * _DODGE_REACH)
            if off > best and _open(open_tiles, x + mx * _DODGE_LOOK, y + my * _DODGE_LOOK):
                due, way, best = steps, (mx, my), off
    return way


def heuristic(obs: np.ndarray, action_type: str, *, dodge: float = 0.0, lead: float = 0.0) -> np.ndarray:
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
    shells_at = _OWN_CELLS + _OTHER_CELLS * (n_agents - 1)
    fire = np.zeros(count, dtype=bool)
    for i in range(count):
        if obs[i, 0] < 0.5 or not np.isfinite(gap[i, target[i]]):
            continue
        (x, y), (dx, dy) = here[i], offset[i]
        if dodge > 0.0:
            shells = obs[i, shells_at + _SHELL_CELLS * n_agents // 2: shells_at + _SHELL_CELLS * n_agents]
            way = _dodge(open_tiles[i], x, y, shells.reshape(-1, _SHELL_CELLS), dodge)
            if way is not None:
                moves[i] = way
                continue
        if lead > 0.0:
            # aim where the opponent will be once a shell has flown there at its present velocity
            flight = lead * math.hypot(dx, dy) / SHELL_SPEED * VELOCITY_UNIT
            dx, dy = dx + rivals[i, target[i], 2] * flight, dy + rivals[i, target[i], 3] * flight
        along = COMPASS_MOVES[1:] @ (dx, dy)
        miss = np.abs(COMPASS_MOVES[1:, 0] * dy - COMPASS_MOVES[1:, 1] * dx)
        miss[(along <= 0) | (along > REACH)] = np.inf
        line = int(miss.argmin())
        ux, uy = COMPASS_MOVES[1 + line]
        if miss[line] < MISS and _clear(open_tiles[i], x, y, ux, uy, along[line] - FIGHTER_RADIUS):
            if obs[i, 5] * ux + obs[i, 6] * uy >= FACING:
                fire[i] = obs[i, 8] == 0.0 and obs[i, shells_at] < 0.5
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
