"""Boomer's search agent: from a duel seat's observation, rebuild the board on the batched engine, try
each candidate action there against the heuristic's predicted answer, and play on with both heuristics
(the package docstring, "Search agent")."""

from __future__ import annotations

import numpy as np

from arena_league.envs.games.boomer.boards import (
    BOMB,
    EXTRA_BOMB,
    FLAME_STEPS,
    KICK,
    MAX_AMMO,
    MAX_STRENGTH,
    PER_AGENT,
    PLANES,
    RANGE,
    RIGID,
    STOP,
    WOOD,
    BoomerBoards,
)
from arena_league.envs.games.boomer.heuristic import heuristic_actions, split_observation

#: The options of the heuristic the search plays for its own seat, after its first action.
OWN_PLAY = {"block": 10.0, "hunt": 1.0, "wary": 1.0}
#: The candidates after the heuristic's own action, in this order.
_OTHERS = np.array([BOMB, STOP, 1, 2, 3, 4], dtype=np.int64)
#: Worth of a rollout's end: the opponent out and we alive, both out on one step, we out.
_WIN, _BOTH, _LOSS = 1.0, -0.5, -1.0
#: Only duels with the opponent this many steps away or nearer (Manhattan) are searched: farther, the
#: heuristic's own play decides nothing within the horizon that the search could change.
NEAR = 6
_ENGINES: dict[tuple[int, int], BoomerBoards] = {}


def _engine(n_boards: int, size: int) -> BoomerBoards:
    """A two-seat engine of at least ``n_boards`` boards, a multiple of 64 (built once per shape: building
    draws maps); the boards past ``n_boards`` are done."""
    key = (-(-n_boards // 64) * 64, size)
    if key not in _ENGINES:
        if len(_ENGINES) > 64:
            _ENGINES.clear()
        _ENGINES[key] = BoomerBoards(key[0], 2, size=size, n_rigid=0, n_wood=12, n_items=0)
    return _ENGINES[key]


def rebuild(obs: np.ndarray, copies: int) -> BoomerBoards:
    """An engine holding ``copies`` boards of each duel observation row (seat 0 is the observer, in its frame,
    seat 1 the opponent). What the observation does not show is guessed: a bomb is the nearer player's, at its
    blast strength, and lies still; no power-up hides under wood."""
    m = len(obs)
    size = split_observation(obs)[1]
    eng = _engine(m * copies, size)
    planes = obs[:, 2 * PER_AGENT:].reshape(m, len(PLANES), size * size)
    terrain = np.zeros((m, size * size), dtype=np.int8)
    for plane, code in ((0, RIGID), (1, WOOD), (2, EXTRA_BOMB), (3, RANGE), (4, KICK)):
        terrain[planes[:, plane] > 0.5] = code
    timer = np.where(planes[:, 5] > 0, np.rint(1.0 / np.maximum(planes[:, 5], 1e-6)), 0).astype(np.int8)
    flame = np.rint(planes[:, 7] * FLAME_STEPS).astype(np.int8)
    cells = np.stack([planes[:, 8].argmax(axis=1), planes[:, 10].argmax(axis=1)], axis=1)  # [m, 2]
    alive = np.stack([obs[:, 0], obs[:, PER_AGENT]], axis=1) > 0.5
    ammo = np.rint(np.stack([obs[:, 1], obs[:, PER_AGENT + 1]], axis=1) * MAX_AMMO).astype(np.int64)
    strength = np.rint(np.stack([obs[:, 2], obs[:, PER_AGENT + 2]], axis=1) * MAX_STRENGTH).astype(np.int64)
    kick = np.stack([obs[:, 3], obs[:, PER_AGENT + 3]], axis=1) > 0.5
    row, col = np.divmod(np.arange(size * size), size)
    r, c = np.divmod(cells, size)
    far = np.abs(row[None, :, None] - r[:, None, :]) + np.abs(col[None, :, None] - c[:, None, :])  # [m, cells, 2]
    far = np.where(alive[:, None, :], far, 1 << 20)
    owner = (far[:, :, 1] < far[:, :, 0]).astype(np.int8)
    bomb_strength = np.where(timer > 0, np.take_along_axis(strength, owner.astype(np.int64), axis=1), 0)
    rep = np.repeat(np.arange(m), copies)
    rep = np.concatenate([rep, np.zeros(eng.n_boards - len(rep), dtype=np.int64)])  # the spare boards
    inner = eng._inner
    eng.terrain[:] = RIGID
    eng.terrain[:, inner] = terrain[rep]
    eng.hidden[:] = 0
    eng.flame[:] = 0
    eng.flame[:, inner] = flame[rep]
    eng.bomb_timer[:] = 0
    eng.bomb_timer[:, inner] = timer[rep]
    eng.bomb_strength[:] = 0
    eng.bomb_strength[:, inner] = bomb_strength[rep].astype(np.int8)
    eng.bomb_owner[:] = -1
    eng.bomb_owner[:, inner] = np.where(timer > 0, owner, -1)[rep]
    eng.bomb_direction[:] = -1
    eng.position[:] = inner[cells[rep]]
    eng.alive[:] = alive[rep]
    eng.ammo[:] = ammo[rep]
    eng.strength[:] = np.maximum(strength[rep], 1)
    eng.can_kick[:] = kick[rep]
    eng.death_step[:] = np.where(alive[rep], -1, 0)
    eng.t[:] = 0
    eng.done[:] = False
    eng.done[m * copies:] = True
    eng.truncated[:] = False
    return eng


def search_moves(obs: np.ndarray, uniforms: np.ndarray, *, width: int, rollouts: int, horizon: int,
                 epsilon: float) -> np.ndarray:
    """The Boomer search agent's action per observation row (package docstring, "Search agent")."""
    if not 1 <= width <= len(_OTHERS):
        raise ValueError(f"Boomer's search has {len(_OTHERS)} actions to try: ask for W from 1 to {len(_OTHERS)}, "
                         f"not {width}")
    obs = np.asarray(obs, dtype=np.float32)
    if obs.ndim != 2:
        raise ValueError(f"Boomer search: observations must be float32[N, obs_dim], not shape {obs.shape}")
    n = len(obs)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    seats, size = split_observation(obs)
    actions = heuristic_actions(obs, **OWN_PLAY)
    if seats == 2 and width > 1:
        # only duels with both players alive are searched: the rest is the heuristic's
        live = (obs[:, 0] > 0.5) & (obs[:, PER_AGENT] > 0.5)
        cells = obs[:, 2 * PER_AGENT:].reshape(n, len(PLANES), size * size)
        (r0, c0), (r1, c1) = np.divmod(cells[:, 8].argmax(axis=1), size), np.divmod(cells[:, 10].argmax(axis=1), size)
        live = np.flatnonzero(live & (np.abs(r0 - r1) + np.abs(c0 - c1) <= NEAR))
        if len(live):
            actions[live] = _searched(obs[live], actions[live], width, horizon)
    u = np.asarray(uniforms, dtype=np.float64).reshape(-1)
    if epsilon > 0 and len(u) == n:
        wild = u < epsilon
        actions = np.where(wild, np.minimum((u / epsilon * len(_OTHERS)).astype(np.int64), len(_OTHERS) - 1),
                           actions)
    return actions


def _searched(obs: np.ndarray, own: np.ndarray, width: int, horizon: int) -> np.ndarray:
    """The best of ``width`` first actions per row (the heuristic's own first, kept on a tie), each played
    out ``horizon`` steps with both players' heuristics on the rebuilt board."""
    m = len(obs)
    later = _OTHERS[None, :] != own[:, None]
    rest = _OTHERS[None, :].repeat(m, axis=0)[later].reshape(m, len(_OTHERS) - 1)
    candidates = np.concatenate([own[:, None], rest], axis=1)[:, :width]  # [m, width]
    eng = rebuild(obs, width)
    first = candidates.reshape(-1)  # board b tries candidate b % width of row b // width
    for k in range(horizon):
        if eng.done.all():
            break
        seen = eng.observe()
        moves = np.zeros((eng.n_boards, 2), dtype=np.int64)
        going = np.flatnonzero(~eng.done)
        moves[going, 1] = heuristic_actions(seen[going, 1])
        moves[going, 0] = first[going] if k == 0 else heuristic_actions(seen[going, 0], **OWN_PLAY)
        eng.step(moves)
    # a player out later outlives the other (``death_step`` is -1 for the living)
    out = np.where(eng.alive, horizon + 1, eng.death_step)
    worth = np.where(out[:, 0] > out[:, 1], _WIN, np.where(out[:, 0] < out[:, 1], _LOSS, 0.0))
    worth[(out[:, 0] == out[:, 1]) & ~eng.alive[:, 0]] = _BOTH
    worth = worth[:m * width]
    best = worth.reshape(m, width).argmax(axis=1)
    return candidates[np.arange(m), best]
