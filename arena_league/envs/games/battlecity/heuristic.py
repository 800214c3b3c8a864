"""BattleCity's scripted play: the heuristic, from the observation alone. Imported by the game's
rules only.

Each seat, in its own frame (its base at the bottom, the enemy base at the top):

1. an opponent in play lies in line with the tank (its centre within 0.35 of the tank's row or
   column line, at most 8 tiles away) with no tile between them: turn to face it (one move step
   that way), then fire whenever the gun is loaded;
2. otherwise follow the cheapest way over the tiles to the enemy base: every tile's cost to the
   base is found by relaxing ``cost(tile) = min over the four neighbours of (enter(neighbour) +
   cost(neighbour))`` until nothing changes, where entering an empty tile costs 1, a brick (or the
   enemy base) 4 (a shot, the wait for it, the step in), and steel and the own base cannot be
   entered. The tank moves toward the neighbour of its tile with the least ``enter + cost``
   (ties: N, E, W, S), sliding back toward its tile's centre line on the way (a diagonal move)
   when more than 0.1 off it; when that neighbour is a brick or the base, it faces it and fires
   whenever the gun is loaded.

A tuned heuristic changes three constants: ``aim`` (how far off its line an opponent still counts
as in line, 0.35), ``brick`` (what a brick costs beyond an empty tile, 3) and ``snipe`` (0: off; S:
a tile at most S tiles below or beside the enemy base with no steel between counts as a way to the
base, at ``brick`` a shell for each brick between and for the base, and a tank whose own tile is
its cheapest way stands there, faces the base and fires whenever the gun is loaded).
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from arena_league.envs.games.battlecity.maze import BASE_TILE, GRID, HALF, TILE, maze_observation, turned
from arena_league.envs.physics2d import CellLayout

__all__ = ["heuristic"]

#: What entering a brick (or the enemy base) costs beyond an empty tile: the shot and the wait.
BRICK_COST = 3.0
#: Opponents this far off the tank's row or column line count as in line; the longest shot taken.
IN_LINE, SHOT_RANGE = 0.35, 8.0
#: Off the tile's centre line by more than this, the tank slides back toward it as it moves.
CENTRE_SLACK = 0.1
_NOOP, _FIRE = 0, 9
_ENEMY_BASE = turned(*BASE_TILE)
#: The four ways a tank goes, in the order ties are broken: (d_row, d_col).
_WAYS = ((1, 0), (0, 1), (0, -1), (-1, 0))


@cache
def _layout(n_agents: int) -> CellLayout:
    return maze_observation(n_agents)


def _compass(dx: float, dy: float) -> int:
    """The compass move (1 E .. 8 SE) along ``(dx, dy)``."""
    return 1 + round(math.atan2(dy, dx) / (math.pi / 4)) % 8


def _snipe_cost(bricks: np.ndarray, steel: np.ndarray, snipe: float, brick_cost: float) -> np.ndarray:
    """Every tile's cost to destroy the enemy base by shooting from it, for every row of ``(N, GRID,
    GRID)`` planes at once: ``brick_cost`` a shell (one per brick between, one for the base) on the
    tiles at most ``snipe`` tiles below or beside the base with no steel between; inf elsewhere."""
    shots = np.full(bricks.shape, np.inf)
    base_row, base_col = _ENEMY_BASE
    for d_row, d_col in ((-1, 0), (0, -1), (0, 1)):
        between = np.zeros(len(bricks))
        for k in range(1, GRID):
            r, c = base_row + k * d_row, base_col + k * d_col
            if k > snipe or not (0 <= r < GRID and 0 <= c < GRID):
                break
            shots[:, r, c] = between + 1.0
            between = between + np.where(steel[:, r, c], np.inf, bricks[:, r, c])
    return brick_cost * shots


def _cost_to_base(bricks: np.ndarray, steel: np.ndarray, brick_cost: float = BRICK_COST,
                  start: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(enter, reach)``: every tile's cost to enter and ``enter + cost to the base from it``,
    for every row of ``(N, GRID, GRID)`` planes at once; ``start`` (inf where none) is what the
    base costs from a tile without moving on."""
    enter = np.where(steel, np.inf, np.where(bricks, 1.0 + brick_cost, 1.0))
    own_base, enemy_base = BASE_TILE, turned(*BASE_TILE)
    enter[:, own_base[0], own_base[1]] = np.inf
    enter[:, enemy_base[0], enemy_base[1]] = 1.0 + brick_cost
    cost = np.full_like(enter, np.inf) if start is None else start.copy()
    cost[:, enemy_base[0], enemy_base[1]] = 0.0
    for _ in range(GRID * GRID):
        reach = enter + cost
        new = cost.copy()
        np.minimum(new[:, 1:, :], reach[:, :-1, :], out=new[:, 1:, :])
        np.minimum(new[:, :-1, :], reach[:, 1:, :], out=new[:, :-1, :])
        np.minimum(new[:, :, 1:], reach[:, :, :-1], out=new[:, :, 1:])
        np.minimum(new[:, :, :-1], reach[:, :, 1:], out=new[:, :, :-1])
        new[:, enemy_base[0], enemy_base[1]] = 0.0
        if np.array_equal(new, cost):
            break
        cost = new
    return enter, enter + cost


def _line_clear(solid: np.ndarray, row: int, col: int, d_row: int, d_col: int, tiles: int) -> bool:
    """Whether the ``tiles`` tiles after ``(row, col)`` along ``(d_row, d_col)`` are all empty."""
    for k in range(1, tiles):
        r, c = row + k * d_row, col + k * d_col
        if not (0 <= r < GRID and 0 <= c < GRID) or solid[r, c]:
            return False
    return True


def heuristic(obs: np.ndarray, action_type: str, *, aim: float = IN_LINE, brick: float = BRICK_COST,
              snipe: float = 0.0) -> np.ndarray:
    obs = np.asarray(obs, dtype=np.float64)
    if obs.ndim != 2 or obs.shape[1] not in (343 + 13 * 2, 343 + 13 * 4):
        raise ValueError(f"BattleCity heuristic: observations of shape {obs.shape} are not BattleCity's (N, 343 + 13 n) "
                         "for n = 2 or 4 seats")
    n_agents = (obs.shape[1] - 343) // 13
    layout = _layout(n_agents)
    mates = n_agents // 2 - 1
    planes = GRID * GRID
    bricks = obs[:, layout.at("bricks"): layout.at("bricks") + planes].reshape(-1, GRID, GRID) > 0.5
    steel = obs[:, layout.at("steel"): layout.at("steel") + planes].reshape(-1, GRID, GRID) > 0.5
    # Sniping tiles start the relaxation at their shots' cost, so the way there competes with driving in.
    shots = _snipe_cost(bricks, steel, snipe, brick) if snipe >= 1.0 else None
    enter, reach = _cost_to_base(bricks, steel, brick, shots)
    solid = bricks | steel
    moves = np.zeros((len(obs), 3))  # (dx, dy, fire) per row
    for i, row_obs in enumerate(obs):
        if row_obs[0] < 0.5:
            continue
        x, y = row_obs[1] * HALF, row_obs[2] * HALF
        hx, hy = row_obs[5], row_obs[6]
        loaded = row_obs[layout.at("reload")] == 0.0 and row_obs[layout.at("shell_0_flying")] < 0.5
        row = min(max(math.floor((y + HALF) / TILE), 0), GRID - 1)
        col = min(max(math.floor((x + HALF) / TILE), 0), GRID - 1)
        solid_i = solid[i].copy()
        solid_i[BASE_TILE] = solid_i[turned(*BASE_TILE)] = True
        way = None
        for k in range(mates, n_agents - 1):
            if row_obs[layout.at(f"other_{k}_active")] < 0.5:
                continue
            rx, ry = row_obs[layout.at(f"other_{k}")] * HALF, row_obs[layout.at(f"other_{k}") + 1] * HALF
            if abs(ry) < aim and abs(rx) < SHOT_RANGE:
                candidate = (0, 1 if rx > 0 else -1)
                tiles = round(abs(rx) / TILE)
            elif abs(rx) < aim and abs(ry) < SHOT_RANGE:
                candidate = (1 if ry > 0 else -1, 0)
                tiles = round(abs(ry) / TILE)
            else:
                continue
            if _line_clear(solid_i, row, col, *candidate, tiles):
                way = candidate
                break
        shoot = way is not None
        if way is None:
            best = math.inf
            for d_row, d_col in _WAYS:
                r, c = row + d_row, col + d_col
                if 0 <= r < GRID and 0 <= c < GRID and reach[i, r, c] < best:
                    best, way = reach[i, r, c], (d_row, d_col)
            if shots is not None and shots[i, row, col] <= best:
                way = (1, 0) if col == _ENEMY_BASE[1] else (0, 1 if col < _ENEMY_BASE[1] else -1)
                shoot = True
            elif way is None:
                continue
            else:
                shoot = enter[i, row + way[0], col + way[1]] > 1.0
        d_row, d_col = way
        facing = hx * d_col + hy * d_row > 0.95
        if shoot and facing and loaded:
            moves[i, 2] = 1.0
            continue
        cx, cy = -HALF + (col + 0.5) * TILE, -HALF + (row + 0.5) * TILE
        dx, dy = float(d_col), float(d_row)
        if d_row == 0 and abs(y - cy) > CENTRE_SLACK:
            dy = -math.copysign(1.0, y - cy)
        elif d_col == 0 and abs(x - cx) > CENTRE_SLACK:
            dx = -math.copysign(1.0, x - cx)
        if shoot and facing:
            dx, dy = (dx, dy) if (dx, dy) != (d_col, d_row) else (0.0, 0.0)  # loading: hold still
        moves[i, 0:2] = dx, dy
    if action_type == "discrete":
        actions = np.zeros(len(obs), dtype=np.int64)
        for i, (dx, dy, fire) in enumerate(moves.tolist()):
            actions[i] = _FIRE if fire else (_NOOP if dx == dy == 0.0 else _compass(dx, dy))
        return actions
    length = np.maximum(np.hypot(moves[:, 0], moves[:, 1]), 1.0)
    out = np.stack([moves[:, 0] / length, moves[:, 1] / length, 2.0 * moves[:, 2] - 1.0], axis=1)
    return out.astype(np.float32)
