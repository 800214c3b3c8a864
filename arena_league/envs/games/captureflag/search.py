"""CaptureFlag's search agent: in a duel (2T1P), with the opponent near, the seat plays every sequence of
its next moves against the heuristic opponent's predicted answers on the map rebuilt from its observation:
it tags the opponent where a sequence corners it and, raiding, passes it without being tagged (the package
docstring, "Search agent")."""

from __future__ import annotations

import itertools

import numpy as np

from arena_league.envs.boards import grow
from arena_league.envs.games.captureflag.engine import (
    ACTION_COL,
    ACTION_ROW,
    AT,
    N_ACTIONS,
    N_HEADER,
    PER_OTHER,
)
from arena_league.envs.games.captureflag.heuristic import heuristic_actions

#: The options of the tuned heuristic the search plays wherever it does not search.
OWN_PLAY = {"commit": 0.5, "hunt": 6.0, "keep": 0.5, "sortie": 0.9}
#: Bounds of the budget: the opponent's distance searched (``W``) and the plies (``H``; 5 ** H sequences).
MAX_NEAR, MAX_PLIES = 16, 4
_PAD = 2  # the rebuilt map's wall border: a move off the grid is a move into a wall
#: The heuristic's own weights (heuristic.py), for predicting its moves exactly where the map is known.
_BLOCKED, _DANGER, _NEAR_DANGER = 100.0, 30.0, 8.0
# the opponent's actions in its own frame (mirrored: its "right" is this seat's left), in its tie order
_THEIR_ROW, _THEIR_COL = ACTION_ROW, -ACTION_COL
#: Worth of a sequence: the opponent tagged, the opponents' flag picked up, this seat tagged or its flag lost
#: (each a little less the later it comes); a raid's other sequences are worth minus the steps still to go,
#: less ``_CLOSE`` where they end within 2 steps of the opponent (its next move is not certain).
_TAG, _PICK, _LOST, _CLOSE = 1000.0, 900.0, -1000.0, 3.0
_SEQUENCES: dict[int, np.ndarray] = {}


def _sequences(horizon: int) -> np.ndarray:
    """``int64[5 ** horizon, horizon]``: every sequence of ``horizon`` actions (built once per horizon)."""
    if horizon not in _SEQUENCES:
        _SEQUENCES[horizon] = np.array(list(itertools.product(range(N_ACTIONS), repeat=horizon)), dtype=np.int64)
    return _SEQUENCES[horizon]


def search_moves(obs: np.ndarray, players_per_team: int, *, near: int, horizon: int) -> np.ndarray:
    """``int64[N]``: the search agent's action per observation row (package docstring, "Search agent"): the
    tuned heuristic's (:data:`OWN_PLAY`) but in a duel with the opponent within ``near`` steps, where every
    sequence of ``horizon`` moves is played out against the heuristic's predicted answers."""
    if not 1 <= near <= MAX_NEAR or not 1 <= horizon <= MAX_PLIES:
        raise ValueError(f"CaptureFlag's search takes W (the opponent's distance searched) from 1 to {MAX_NEAR} "
                         f"and H (plies) from 1 to {MAX_PLIES}, not W = {near}, H = {horizon}: try search-w8-r1-h3")
    obs = np.asarray(obs, dtype=np.float32)
    if not len(obs):
        return np.zeros(0, dtype=np.int64)
    actions = heuristic_actions(obs, players_per_team, **OWN_PLAY)
    if players_per_team != 1:
        return actions
    rows, cols = grid_size(obs)
    opp = obs[:, N_HEADER:N_HEADER + PER_OTHER]
    me_r = np.rint((obs[:, AT["position"]] + 1.0) * 0.5 * (rows - 1)).astype(np.int64)
    me_c = np.rint((obs[:, AT["position"] + 1] + 1.0) * 0.5 * (cols - 1)).astype(np.int64)
    h_r = me_r + np.rint(opp[:, 0] * (rows - 1)).astype(np.int64)
    h_c = me_c + np.rint(opp[:, 1] * (cols - 1)).astype(np.int64)
    carrying = obs[:, AT["carrying"]] > 0.5
    own_home = obs[:, AT["own_flag_home"]] > 0.5
    their_carry = opp[:, 3] > 0.5
    live = ((rows >= 3) & (cols >= 4) & (obs[:, AT["active"]] > 0.5) & (opp[:, 2] > 0.5) & ~carrying
            & (np.abs(h_r - me_r) + np.abs(h_c - me_c) <= near))
    # hunting an exposed opponent (one carrying this seat's flag too), or raiding past one in its own half
    hunt = live & (opp[:, 4] > 0.5) & (own_home | their_carry)
    to_enemy = obs[:, AT["to_enemy_stand"]:AT["to_enemy_stand"] + N_ACTIONS]
    out = np.take_along_axis(to_enemy, actions[:, None], axis=1)[:, 0] < to_enemy[:, 0] - 1e-6
    raid = live & (opp[:, 4] < 0.5) & own_home & out
    search = hunt | raid
    for size in set(zip(rows[search].tolist(), cols[search].tolist())):
        rows_of = np.flatnonzero(search & (rows == size[0]) & (cols == size[1]))
        actions[rows_of] = _searched(obs[rows_of], actions[rows_of], *size, me_r[rows_of], me_c[rows_of],
                                     h_r[rows_of], h_c[rows_of], their_carry[rows_of], raid[rows_of], horizon)
    return actions


def grid_size(obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``int64[N]`` rows and columns of the grid, from what each seat sees: neighbouring cells' stand
    distances differ by one step (1 / (2 (rows + cols))), and a flag at home stands at column 1 (own) or
    ``cols - 2`` (the opponents'); 0 where neither flag is home."""
    to_own = obs[:, AT["to_own_stand"]:AT["to_own_stand"] + N_ACTIONS].astype(np.float64)
    blocked = obs[:, AT["blocked"]:AT["blocked"] + N_ACTIONS] > 0.5
    step = np.where(blocked, 0.0, np.abs(to_own - to_own[:, :1])).max(axis=1)
    perimeter = np.rint(1.0 / np.maximum(step, 1e-6))
    at = 0.5 * (obs[:, AT["position"] + 1].astype(np.float64) + 1.0)
    unit = np.where(obs[:, AT["own_flag_home"]] > 0.5, at + obs[:, AT["own_flag"] + 1],
                    np.where(obs[:, AT["enemy_flag_home"]] > 0.5, 1.0 - at - obs[:, AT["enemy_flag"] + 1], 0.0))
    cols = np.where(unit > 1e-3, np.rint(1.0 + 1.0 / np.maximum(unit, 1e-3)), 0.0)
    rows = np.where((cols > 0) & (step > 1e-6), perimeter / 2.0 - cols, 0.0)
    return rows.astype(np.int64), cols.astype(np.int64)


def _model_map(obs: np.ndarray, rows: int, cols: int, me_r: np.ndarray, me_c: np.ndarray) -> np.ndarray:
    """``bool[M, rows + 4, cols + 4]``: the walls as far as the seat sees them (its window and, the map
    being mirrored, the window's mirror image), everything else open, a border of walls round the grid."""
    m = len(obs)
    walls = np.ones((m, rows + 2 * _PAD, cols + 2 * _PAD), dtype=bool)
    walls[:, _PAD:-_PAD, _PAD:-_PAD] = False
    window = obs[:, AT["walls"]:AT["walls"] + 25].reshape(m, 5, 5) > 0.5
    dr, dc = np.divmod(np.arange(25), 5)
    r = me_r[:, None] + dr[None, :] - 2
    c = me_c[:, None] + dc[None, :] - 2
    inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols) & window.reshape(m, 25)
    board = np.broadcast_to(np.arange(m)[:, None], r.shape)
    walls[board[inside], r[inside] + _PAD, c[inside] + _PAD] = True
    walls[board[inside], r[inside] + _PAD, cols - 1 - c[inside] + _PAD] = True
    return walls


def _distances(walls: np.ndarray, row: int, col: int) -> np.ndarray:
    """``float64[M, R, C]``: steps over open cells from (``row``, ``col``) (padded), large where unreached."""
    m, rr, cc = walls.shape
    dist = np.full((m, rr, cc), 4.0 * rr * cc)
    reached = np.zeros((m, rr, cc), dtype=bool)
    reached[:, row, col] = True
    dist[:, row, col] = 0.0
    open_ = ~walls
    for wave in range(1, rr * cc):
        grown = grow(reached, open_)
        new = grown & ~reached
        if not new.any():
            break
        dist[new] = wave
        reached = grown
    return dist


def _searched(obs, own, rows, cols, me_r, me_c, h_r, h_c, their_carry, raid, horizon):
    """The first move of the best sequence of ``horizon`` moves per row: a raid's, or a hunt's where a
    sequence tags the opponent (else the tuned heuristic's own, ``own``)."""
    m = len(obs)
    walls = _model_map(obs, rows, cols, me_r, me_c)
    cc = walls.shape[2]
    mid = rows // 2
    scale = np.float32(1.0 / (2 * (rows + cols)))
    # the raider heads for this seat's stand, or, carrying, for its own
    to_mine = _distances(walls, mid + _PAD, 1 + _PAD)
    to_theirs = _distances(walls, mid + _PAD, cols - 2 + _PAD)
    aim = np.where(their_carry[:, None, None], to_theirs, to_mine)
    aim = np.minimum(aim.astype(np.float32) * scale, np.float32(1.0)).astype(np.float64) * 40.0
    seqs = _sequences(horizon)
    s = len(seqs)
    flat_walls = walls.reshape(m, -1)
    flat_aim = aim.reshape(m, -1)
    p = np.stack([np.repeat(me_r[:, None] + _PAD, s, axis=1), np.repeat(me_c[:, None] + _PAD, s, axis=1)], axis=-1)
    h = np.stack([np.repeat(h_r[:, None] + _PAD, s, axis=1), np.repeat(h_c[:, None] + _PAD, s, axis=1)], axis=-1)
    value = np.zeros((m, s))
    over = np.zeros((m, s), dtype=bool)
    half = cols // 2 + _PAD  # padded columns at or past it are the raider's own half
    stand_mine = np.array([mid + _PAD, 1 + _PAD])
    stand_theirs = np.array([mid + _PAD, cols - 2 + _PAD])
    carry = their_carry[:, None]
    for k in range(horizon):
        # the raider's move, judged on where this seat stands now
        cell = h[:, :, None, :] + np.stack([_THEIR_ROW, _THEIR_COL], axis=1)[None, None]  # [m, s, A, 2]
        index = cell[..., 0] * cc + cell[..., 1]
        blocked = np.take_along_axis(flat_walls, index.reshape(m, -1), axis=1).reshape(index.shape)
        cell = np.where(blocked[..., None], h[:, :, None, :], cell)
        index = cell[..., 0] * cc + cell[..., 1]
        goal = np.take_along_axis(flat_aim, index.reshape(m, -1), axis=1).reshape(index.shape)
        gap = np.abs(cell - p[:, :, None, :]).sum(axis=-1)
        exposed = carry[..., None] | (cell[..., 1] < half)
        score = -goal - _BLOCKED * blocked - exposed * (_DANGER * (gap <= 1) + _NEAR_DANGER * (gap == 2))
        score[..., 0] -= 1e-3
        h_next = np.take_along_axis(cell, score.argmax(axis=2)[:, :, None, None], axis=2)[:, :, 0]
        # this seat's move
        move = seqs[:, k]
        target = p + np.stack([ACTION_ROW[move], ACTION_COL[move]], axis=1)[None]
        hit = np.take_along_axis(flat_walls, (target[..., 0] * cc + target[..., 1]), axis=1)
        p_next = np.where(hit[..., None], p, target)
        near = np.abs(h_next - p_next).sum(axis=-1) <= 1
        tagged = near & (carry | (h_next[..., 1] < half))
        caught = near & (p_next[..., 1] >= half)  # this seat exposed next to the raider
        home = np.where(carry, (h_next == stand_theirs).all(axis=-1), (h_next == stand_mine).all(axis=-1))
        lost = ~tagged & (caught | home)
        picked = raid[:, None] & ~lost & (p_next == stand_theirs).all(axis=-1)
        value = np.where(~over & picked, _PICK - 10.0 * k, value)
        over |= picked
        value = np.where(~over & tagged, _TAG - 10.0 * k, value)
        value = np.where(~over & lost, _LOST + 10.0 * k, value)
        over |= tagged | lost
        p, h = np.where(over[..., None], p, p_next), np.where(over[..., None], h, h_next)
    ahead = np.take_along_axis(to_theirs.reshape(m, -1), p[..., 0] * cc + p[..., 1], axis=1)
    close = np.abs(h - p).sum(axis=-1) <= 2
    value = np.where(over, value, np.where(raid[:, None], -ahead - _CLOSE * close, 0.0))
    first = seqs[:, 0]
    best = np.full((m, N_ACTIONS), -np.inf)
    for a in range(N_ACTIONS):
        best[:, a] = value[:, first == a].max(axis=1)
    best[np.arange(m), own] += 1e-6
    choice = best.argmax(axis=1)
    return np.where(raid | (best.max(axis=1) >= _TAG - 10.0 * horizon), choice, own)
