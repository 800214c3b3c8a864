"""Boomer's scripted player: from each seat's observation alone, flee blasts, lay bombs it can
escape, and walk toward wooden walls, power-ups and opponents (the package docstring, "Heuristic")."""

from __future__ import annotations

import numpy as np

from arena_league.envs.games.boomer.boards import (
    BOMB,
    BOMB_LIFE,
    DCOL,
    DROW,
    FLAME_STEPS,
    MAX_STRENGTH,
    PER_AGENT,
    PLANES,
    STOP,
)

#: The moves the heuristic weighs, in its order of preference on a tie: stop, up, down, left, right.
MOVES = np.array([STOP, 1, 2, 3, 4], dtype=np.int64)
_MOVE_ROW = np.array([0, -1, 1, 0, 0], dtype=np.int64)
_MOVE_COL = np.array([0, 0, 0, -1, 1], dtype=np.int64)
#: Steps ahead the escape search looks: a fresh bomb's life and the flames after it.
HORIZON = BOMB_LIFE + FLAME_STEPS
_FAR = 10_000


def split_observation(obs: np.ndarray) -> tuple[int, int]:
    """``(seats, size)`` of Boomer observations of ``obs.shape[1]`` floats (``4 seats + 11 size^2``)."""
    width = obs.shape[1]
    for seats in (2, 4):
        cells = (width - PER_AGENT * seats) / len(PLANES)
        size = round(cells ** 0.5) if cells > 0 else 0
        if size >= 5 and size * size == cells:
            return seats, size
    raise ValueError(f"Boomer heuristic: observations of {width} floats are not Boomer's "
                     f"(4 seats + {len(PLANES)} size^2 with 2 or 4 seats)")


def _grow(x: np.ndarray) -> np.ndarray:
    """Each cell or one of its four neighbours set, over the last two axes."""
    out = x.copy()
    out[..., 1:, :] |= x[..., :-1, :]
    out[..., :-1, :] |= x[..., 1:, :]
    out[..., :, 1:] |= x[..., :, :-1]
    out[..., :, :-1] |= x[..., :, 1:]
    return out


def _cross(rigid: np.ndarray, wood: np.ndarray, row: np.ndarray, col: np.ndarray,
           strength: np.ndarray) -> np.ndarray:
    """``bool[N, size, size]``: the blast of a bomb at (row, col) of each row's board."""
    n, size = rigid.shape[0], rigid.shape[1]
    rows = np.arange(n)
    cross = np.zeros(rigid.shape, dtype=bool)
    cross[rows, row, col] = True
    for d in range(4):
        open_ = np.ones(n, dtype=bool)
        for k in range(1, MAX_STRENGTH):
            r, c = row + k * DROW[d], col + k * DCOL[d]
            inside = (r >= 0) & (r < size) & (c >= 0) & (c < size)
            r, c = np.clip(r, 0, size - 1), np.clip(c, 0, size - 1)
            open_ &= inside & ~rigid[rows, r, c] & (k < strength)
            if not open_.any():
                break
            cross[rows[open_], r[open_], c[open_]] = True
            open_ &= ~wood[rows, r, c]
    return cross


def _escapes(start_row: np.ndarray, start_col: np.ndarray, passable: np.ndarray, blast_step: np.ndarray,
             flame_left: np.ndarray) -> np.ndarray:
    """``bool[N, 5]``: whether each move (stop, up, down, left, right) leads, on a path that never
    stands in a flame, to a cell no blast will reach. ``blast_step`` is the step a blast first
    reaches each cell (``_FAR`` where none does), ``flame_left`` the steps a flame still burns."""
    n, size = passable.shape[0], passable.shape[1]
    rows = np.arange(n)[:, None]
    r = start_row[:, None] + _MOVE_ROW[None, :]
    c = start_col[:, None] + _MOVE_COL[None, :]
    inside = (r >= 0) & (r < size) & (c >= 0) & (c < size)
    r, c = np.clip(r, 0, size - 1), np.clip(c, 0, size - 1)
    first = inside & passable[rows, r, c]
    first[:, 0] = True  # staying is always possible
    calm = (blast_step >= _FAR) & (flame_left <= 1)
    if calm.all():
        return first  # no bomb or flame on any board: every open cell is safe
    reach = np.zeros((n, 5, size, size), dtype=bool)
    reach[rows, np.arange(5)[None, :], r, c] = first
    safe = np.zeros((n, 5), dtype=bool)
    for k in range(1, HORIZON + 1):
        if k > 1:
            reach = (_grow(reach) & passable[:, None]) | reach
        # burning at step k: a flame still alight, or a blast's flames (they burn FLAME_STEPS steps)
        deadly = (flame_left - k >= 1) | ((blast_step <= k) & (k < blast_step + FLAME_STEPS))
        reach &= ~deadly[:, None]
        safe |= (reach & calm[:, None]).any(axis=(2, 3))
        if (safe | ~reach.any(axis=(2, 3))).all():
            break  # every move is decided: safe, or with nowhere left to stand
    return safe & first


def _distances(goal: np.ndarray, passable: np.ndarray) -> np.ndarray:
    """``int64[N, size, size]``: steps from each cell to the nearest goal over passable cells (``_FAR`` where
    none is reached within ``2 size`` steps)."""
    size = goal.shape[1]
    distance = np.full(goal.shape, _FAR, dtype=np.int64)
    distance[goal] = 0
    frontier = goal
    for k in range(1, 2 * size):
        frontier = _grow(frontier) & passable & (distance == _FAR)
        if not frontier.any():
            break
        distance[frontier] = k
    return distance


def heuristic_actions(obs: np.ndarray, *, block: float = 0, hunt: float = 0, press: float = 0,
                      wary: float = 0) -> np.ndarray:
    """The Boomer heuristic's action per observation row (package docstring, "Heuristic"); ``block``,
    ``hunt``, ``press`` and ``wary`` tune it (``BoomerRules.heuristic_options_meaning``), their defaults
    the plain heuristic."""
    obs = np.asarray(obs, dtype=np.float32)
    if obs.ndim != 2:
        raise ValueError(f"Boomer heuristic: observations must be float32[N, obs_dim], not shape {obs.shape}")
    seats, size = split_observation(obs)
    n = len(obs)
    actions = np.zeros(n, dtype=np.int64)
    alive = obs[:, 0] > 0.5
    if not alive.any():
        return actions
    live = np.flatnonzero(alive)
    o = obs[live]
    m = len(o)
    planes = o[:, PER_AGENT * seats:].reshape(m, len(PLANES), size, size)
    rigid, wood = planes[:, 0] > 0.5, planes[:, 1] > 0.5
    power_up = (planes[:, 2] + planes[:, 3] + planes[:, 4]) > 0.5
    bombs = planes[:, 5] > 0
    with np.errstate(divide="ignore"):
        blast_step = np.where(planes[:, 6] > 0, np.rint(1.0 / np.maximum(planes[:, 6], 1e-6)), _FAR).astype(np.int64)
    flame_left = np.rint(planes[:, 7] * FLAME_STEPS).astype(np.int64)
    others = (planes[:, 9] + planes[:, 10]) > 0.5
    opponents = planes[:, 10] > 0.5
    own = planes[:, 8].reshape(m, -1).argmax(axis=1)
    row, col = np.divmod(own, size)
    ammo = np.rint(o[:, 1] * 10).astype(np.int64)
    strength = np.rint(o[:, 2] * 10).astype(np.int64)
    passable = ~rigid & ~wood & ~bombs & ~others
    rows = np.arange(m)
    safe = _escapes(row, col, passable, blast_step, flame_left)
    near = opponents.copy()  # the cells within ``wary`` steps of an opponent: it may step into them first
    for _ in range(int(wary)):
        near = _grow(near)
    if wary > 0:  # flee on ways that keep off them, where there are some
        strict = _escapes(row, col, passable & ~near, blast_step, flame_left)
        safe = np.where(strict.any(axis=1)[:, None], strict, safe)
    opp_board, opp_row, opp_col = np.nonzero(opponents)  # every opponent: its board, row and column
    # a bomb here: worth it when its blast reaches wood or an opponent, and only with a way out
    cross = _cross(rigid, wood, row, col, strength)
    worth = (cross & (wood | opponents)).any(axis=(1, 2)) & (ammo > 0) & ~bombs[rows, row, col]
    # walk toward the nearest cell next to wood or an opponent, or onto a power-up
    goal = (_grow(wood | opponents) & ~wood & ~opponents & passable) | (power_up & passable)
    r = np.clip(row[:, None] + _MOVE_ROW[None, :], 0, size - 1)
    c = np.clip(col[:, None] + _MOVE_COL[None, :], 0, size - 1)
    distance = _distances(goal, passable)
    score = distance[rows[:, None], r, c].astype(np.float64)
    if hunt > 0:
        # armed enough: only the cells its blast would reach an opponent from, and power-ups, draw it, not
        # wood; where none can be reached it waits for the opponent to open the way
        hunting = ammo >= hunt
        if hunting.any():
            # the cells whose blast would reach an opponent: its own cross at our strength, the arms alike
            in_line = np.zeros((m, size, size), dtype=bool)
            np.logical_or.at(in_line, opp_board, _cross(rigid[opp_board], wood[opp_board], opp_row, opp_col,
                                                        strength[opp_board]))
            prey = (in_line & ~opponents & passable) | (power_up & passable)
            distance[hunting] = _distances(prey, passable)[hunting]
            score[hunting] = distance[rows[:, None], r, c][hunting]
    score[:, 0] += 0.5  # at equal distance, keep moving
    if block > 0 and len(opp_board):
        # an opponent in a known blast: stand where it leaves the opponent fewest ways out
        hunted = blast_step[opp_board, opp_row, opp_col] < _FAR
        if hunted.any():
            b, r0, c0 = opp_board[hunted], opp_row[hunted], opp_col[hunted]
            k = len(b)
            body = np.repeat(passable[b], 5, axis=0)
            body[np.arange(5 * k), r[b].reshape(-1), c[b].reshape(-1)] = False
            body[np.arange(5 * k), np.repeat(r0, 5), np.repeat(c0, 5)] = True
            ways = _escapes(np.repeat(r0, 5), np.repeat(c0, 5), body, np.repeat(blast_step[b], 5, axis=0),
                            np.repeat(flame_left[b], 5, axis=0)).sum(axis=1).reshape(k, 5)
            np.add.at(score, b, block * ways)
    score[~safe] += 10 * _FAR
    # nowhere safe: at least avoid the cells that burn next step
    burning_next = (flame_left >= 2) | (blast_step == 1)
    score[~safe] += 5 * _FAR * burning_next[rows[:, None], r, c][~safe]
    best = score.argmin(axis=1)
    choice = MOVES[best]
    lay = worth & (distance[rows, row, col] == 0)
    if press > 0 and len(opp_board):
        # both heading for the one cell between us and an opponent, both moves fail for ever: bomb instead
        two_away = np.abs(opp_row - row[opp_board]) + np.abs(opp_col - col[opp_board]) == 2
        contested = np.zeros(m, dtype=bool)
        contested[opp_board[two_away]] = True
        contested &= (best > 0) & _grow(opponents)[rows, r[rows, best], c[rows, best]]
        lay |= contested & (ammo > 0) & ~bombs[rows, row, col]
    bomb_safe = np.zeros(m, dtype=bool)
    if lay.any():  # the way out with the bomb counted, for the rows that would lay one
        w = np.flatnonzero(lay)
        with_bomb = np.where(cross[w], np.minimum(blast_step[w], BOMB_LIFE), blast_step[w])
        passable_after = passable[w].copy()
        passable_after[np.arange(len(w)), row[w], col[w]] = False
        if wary > 0:  # an opponent may step first into a cell near it, and hold it: no way out through one
            passable_after &= ~near[w]
        bomb_safe[w] = _escapes(row[w], col[w], passable_after, with_bomb, flame_left[w])[:, 1:].any(axis=1)
    choice = np.where(bomb_safe, BOMB, choice)
    actions[live] = choice
    return actions
