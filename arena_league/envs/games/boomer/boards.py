"""Boomer's whole-array engine: many boards stepped together (the manual is the package docstring).

Every board is padded with one ring of rigid wall, so a move, a kick or a blast arm never needs a
bounds check; cells are numbered ``row * side + col`` on the padded board (``side = size + 2``)
inside the engine and ``row * size + col`` on the board a player sees. Bombs live in per-cell
arrays (timer, strength, owner, sliding direction), so a chain reaction is a loop over the bombs
that explode, not over the boards.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import numpy as np

from arena_league.envs.boards import grow, reset_keys

#: Terrain codes of a cell.
PASSAGE, RIGID, WOOD, EXTRA_BOMB, RANGE, KICK = 0, 1, 2, 3, 4, 5
POWER_UPS: tuple[int, ...] = (EXTRA_BOMB, RANGE, KICK)
#: Pommerman's action numbers: stop, the four moves, lay a bomb.
ACTIONS: tuple[str, ...] = ("stop", "up", "down", "left", "right", "bomb")
STOP, BOMB = 0, 5
#: The compass direction (0 up, 1 right, 2 down, 3 left) of each action, -1 for stop and bomb.
ACTION_DIRECTION = np.array([-1, 0, 2, 3, 1, -1], dtype=np.int64)
DROW = np.array([-1, 0, 1, 0], dtype=np.int64)
DCOL = np.array([0, 1, 0, -1], dtype=np.int64)
#: Steps from laying a bomb to its explosion (Pommerman's bomb life 9 + 1).
BOMB_LIFE = 10
#: A flame burns on the step of its explosion and the two after (Pommerman's flame life 2).
FLAME_STEPS = 3
#: Ammo and blast strength never grow past this (Pommerman's caps).
MAX_AMMO = 10
MAX_STRENGTH = 10
#: Observation planes, in order (each ``size * size`` cells of the seat's frame).
PLANES: tuple[str, ...] = ("rigid wall", "wooden wall", "extra-bomb power-up", "range power-up", "kick power-up",
                           "bomb: 1 / steps to its explosion", "blast: 1 / steps until a blast reaches the cell",
                           "flame: steps it still burns / 3", "own position", "teammates", "opponents")
N_BOARD_PLANES = 8  # the planes every seat shares (turned into its frame)
_TERRAIN_PLANES = np.array([RIGID, WOOD, EXTRA_BOMB, RANGE, KICK], dtype=np.int8)  # the first five planes
PER_AGENT = 4  # alive, ammo / 10, blast strength / 10, can kick
STATE_PER_AGENT = 6  # the same, then row and column / (size - 1)


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_SHIFT30, _SHIFT27, _SHIFT31 = np.uint64(30), np.uint64(27), np.uint64(31)
_ITEM_SALT = 1 << 20  # the power-up draws' counters, far from the wall draws' attempts


def _splitmix64(x: np.ndarray) -> np.ndarray:
    """The SplitMix64 finaliser, element-wise on ``uint64`` arrays (wrapping arithmetic)."""
    z = x + _GOLDEN
    z ^= z >> _SHIFT30  # in place: a fresh array each step costs more than the arithmetic on small ones
    z *= _MIX1
    z ^= z >> _SHIFT27
    z *= _MIX2
    z ^= z >> _SHIFT31
    return z


@functools.lru_cache(maxsize=256)
def _hash_columns(counter: int, count: int) -> np.ndarray:
    """``uint64[count]``: the key-free half of :func:`_hashes` (read-only: the draws of every map share it)."""
    columns = np.uint64(counter) * np.uint64(1 << 12) + np.arange(count, dtype=np.uint64)
    hashed = _splitmix64(columns)
    hashed.flags.writeable = False
    return hashed


def _hashes(keys: np.ndarray, counter: int, count: int) -> np.ndarray:
    """``uint64[len(keys), count]``: random numbers that are a function of (key, counter, column)."""
    return _splitmix64(keys[:, None] ^ _hash_columns(counter, count)[None, :])


def quarter_turn_orbits(size: int) -> np.ndarray:
    """``int64[k, 4]``: the board cells (``row * size + col``) grouped into orbits of the quarter
    turn ``(r, c) -> (c, size - 1 - r)`` (clockwise), each orbit listed turn by turn; the centre of
    an odd board, its own orbit, is left out."""
    seen = np.zeros(size * size, dtype=bool)
    orbits = []
    for r in range(size):
        for c in range(size):
            if seen[r * size + c]:
                continue
            orbit, (rr, cc) = [], (r, c)
            for _ in range(4):
                orbit.append(rr * size + cc)
                rr, cc = cc, size - 1 - rr
            seen[orbit] = True
            if len(set(orbit)) == 4:
                orbits.append(orbit)
    return np.array(orbits, dtype=np.int64)


def turned_cells(size: int, quarter_turns: int) -> np.ndarray:
    """``int64[size * size]``: for every cell of a frame turned back by ``quarter_turns``, the board
    cell it shows (the board cell reached by turning it ``quarter_turns`` times clockwise)."""
    rows, cols = np.divmod(np.arange(size * size), size)
    for _ in range(quarter_turns % 4):
        rows, cols = cols, size - 1 - rows
    return rows * size + cols


class BoomerBoards:
    """``n_boards`` Boomer matches stepped together; see the package docstring for the rules.

    State (``B`` boards, ``S`` seats, padded cells): ``terrain``, ``hidden`` (the power-up under a
    wooden wall), ``flame`` (steps a flame still burns), ``bomb_timer`` (0: no bomb), ``bomb_strength``,
    ``bomb_owner``, ``bomb_direction`` (-1 still, else sliding) as ``int8[B, side * side]``;
    ``position`` (padded cell), ``alive``, ``ammo``, ``strength``, ``can_kick``, ``death_step`` as
    ``[B, S]``; ``t int64[B]``. This step's ``picked`` (a power-up taken), ``died``, ``laid``,
    ``kicked``; ``done``, ``truncated``, ``final_scores``.
    """

    def __init__(self, n_boards: int, n_seats: int = 2, size: int = 11, n_rigid: int = 36, n_wood: int = 36,
                 n_items: int = 20, blast_strength: int = 2, team_of: Any = None, quarter_turns: Any = None,
                 autoreset: bool = False, max_steps: int | None = None, seed: int = 0) -> None:
        if n_seats not in (2, 4):
            raise ValueError(f"Boomer seats 2 or 4 players (one to a corner), not {n_seats}")
        self.n_boards, self.n_seats, self.size = int(n_boards), int(n_seats), int(size)
        self.n_rigid, self.n_wood, self.n_items = int(n_rigid), int(n_wood), int(n_items)
        self.blast_strength = int(blast_strength)
        self.max_steps = None if max_steps is None else int(max_steps)
        self.autoreset = bool(autoreset)
        self.rng = np.random.default_rng(seed)
        s, n = self.n_seats, self.size
        self.team_of = np.arange(s, dtype=np.int64) if team_of is None else np.asarray(team_of, dtype=np.int64)
        self.n_teams = int(self.team_of.max()) + 1
        default_turns = (0, 2) if s == 2 else (0, 1, 2, 3)
        self.quarter_turns = np.asarray(default_turns if quarter_turns is None else quarter_turns, dtype=np.int64)
        self.n_cells = n * n
        self.side = n + 2
        side = self.side
        rows, cols = np.divmod(np.arange(self.n_cells), n)
        self._inner = (rows + 1) * side + (cols + 1)  # board cell -> padded cell
        self._delta = DROW * side + DCOL
        self._orbits = quarter_turn_orbits(n)
        self._layout_tables()
        self._frame_cells = np.stack([turned_cells(n, int(q)) for q in self.quarter_turns])  # [S, N*N]
        self._frame_of = np.argsort(self._frame_cells, axis=1)  # board cell -> frame cell, per seat
        same_team = self.team_of[:, None] == self.team_of[None, :]
        others = [[j for j in range(s) if j != i and same_team[i, j]] + [j for j in range(s) if not same_team[i, j]]
                  for i in range(s)]
        self._others = np.array(others, dtype=np.int64).reshape(s, s - 1)
        # which position plane (own 8, teammates 9, opponents 10) seat j fills in seat i's view
        self._team_onehot = self.team_of[:, None] == np.arange(self.n_teams)[None, :]  # [S, teams]
        self._position_plane = np.where(np.eye(s, dtype=bool), 8, np.where(same_team, 9, 10))
        self.header = PER_AGENT * s
        self.obs_dim = self.header + len(PLANES) * self.n_cells
        self.state_dim = N_BOARD_PLANES * self.n_cells + STATE_PER_AGENT * s
        b, c = self.n_boards, side * side
        self._boards = np.arange(b)
        self.terrain = np.zeros((b, c), dtype=np.int8)
        self.hidden = np.zeros((b, c), dtype=np.int8)
        self.flame = np.zeros((b, c), dtype=np.int8)
        self.bomb_timer = np.zeros((b, c), dtype=np.int8)
        self.bomb_strength = np.zeros((b, c), dtype=np.int8)
        self.bomb_owner = np.full((b, c), -1, dtype=np.int8)
        self.bomb_direction = np.full((b, c), -1, dtype=np.int8)
        self.position = np.zeros((b, s), dtype=np.int64)
        self.alive = np.zeros((b, s), dtype=bool)
        self.ammo = np.zeros((b, s), dtype=np.int64)
        self.strength = np.zeros((b, s), dtype=np.int64)
        self.can_kick = np.zeros((b, s), dtype=bool)
        self.death_step = np.full((b, s), -1, dtype=np.int64)
        self.picked = np.zeros((b, s), dtype=bool)
        self.died = np.zeros((b, s), dtype=bool)
        self.laid = np.zeros((b, s), dtype=bool)
        self.kicked = np.zeros((b, s), dtype=bool)
        self.t = np.zeros(b, dtype=np.int64)
        self.keys = np.zeros(b, dtype=np.uint64)
        self.done = np.zeros(b, dtype=bool)
        self.truncated = np.zeros(b, dtype=bool)
        self.final_scores = np.full((b, self.n_teams), np.nan)
        self.reset()

    # --- the map -------------------------------------------------------------------------------
    def _layout_tables(self) -> None:
        """The start cells, the cells kept clear around them and the wooden lanes between corners
        (as in Pommerman's boards), each a set of whole orbits of the quarter turn."""
        n = self.size
        orbit_of = np.full(self.n_cells, -1, dtype=np.int64)
        for k, orbit in enumerate(self._orbits):
            orbit_of[orbit] = k
        clear = [(1, 1), (1, 2), (1, 3), (2, 1), (3, 1)]
        self._clear_orbits = np.unique([orbit_of[r * n + c] for r, c in clear])
        self._lane_orbits = np.unique([orbit_of[1 * n + i] for i in range(4, n - 4)]).astype(np.int64)
        self._start_cells = np.array([self._turn_cell(n + 1, int(q)) for q in self.quarter_turns], dtype=np.int64)
        taken = np.zeros(len(self._orbits), dtype=bool)
        taken[self._clear_orbits] = True
        taken[self._lane_orbits] = True
        self._free_orbits = np.flatnonzero(~taken)
        lanes = 4 * len(self._lane_orbits)
        problems = []
        if self.n_rigid % 4 or self.n_wood % 4 or self.n_items % 4:
            problems.append("n_rigid, n_wood and n_items must be multiples of 4 (the board is the same turned by a "
                            "quarter)")
        if self.n_wood < lanes:
            problems.append(f"n_wood must be at least {lanes} on a {n}-board (the wooden lanes between corners)")
        if (self.n_rigid + self.n_wood - lanes) // 4 > len(self._free_orbits):
            problems.append(f"n_rigid + n_wood must be at most {4 * len(self._free_orbits) + lanes} on a {n}-board")
        if self.n_items > self.n_wood:
            problems.append("n_items must be at most n_wood (power-ups hide under wooden walls)")
        if problems:
            raise ValueError("Boomer board: " + "; ".join(problems) + f" (got n_rigid={self.n_rigid}, "
                             f"n_wood={self.n_wood}, n_items={self.n_items})")

    def _turn_cell(self, cell: int, quarter_turns: int) -> int:
        r, c = divmod(cell, self.size)
        for _ in range(quarter_turns % 4):
            r, c = c, self.size - 1 - r
        return r * self.size + c

    def generate(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The ``terrain`` and ``hidden`` (``int8[len(keys), size * size]``, board cells) of boards
        drawn from ``keys`` (``uint64``): whole quarter-turn orbits of rigid walls (drawn again until
        every other cell is reachable from the corners), the wooden lanes between the corners plus
        drawn wooden orbits, and one power-up kind per drawn orbit of walls hiding ``n_items``
        power-ups. Every draw is a hash of (key, what is drawn, attempt), so a board's map does
        not depend on the boards drawn with it."""
        keys = np.asarray(keys, dtype=np.uint64).reshape(-1)
        k, orbits, n_cells = len(keys), self._orbits, self.n_cells
        n_rigid, n_wood = self.n_rigid // 4, (self.n_wood - 4 * len(self._lane_orbits)) // 4
        free = self._free_orbits
        drawn = np.zeros((k, len(free)), dtype=np.int64)
        terrain = np.zeros((k, n_cells), dtype=np.int8)
        pending = np.arange(k)
        attempt = 0
        while len(pending):
            order = np.argsort(_hashes(keys[pending], attempt, len(free)), axis=1, kind="stable")
            drawn[pending] = free[order]
            rigid = np.zeros((len(pending), n_cells), dtype=np.int8)
            rows = np.arange(len(pending))[:, None]
            rigid[rows, orbits[drawn[pending, :n_rigid]].reshape(len(pending), -1)] = RIGID
            terrain[pending] = rigid
            pending = pending[~self._all_reachable(rigid)]
            attempt += 1
        wooden = np.concatenate([np.broadcast_to(self._lane_orbits, (k, len(self._lane_orbits))),
                                 drawn[:, n_rigid:n_rigid + n_wood]], axis=1)
        rows = np.arange(k)[:, None]
        terrain[rows, orbits[wooden].reshape(k, -1)] = WOOD
        hidden = np.zeros((k, n_cells), dtype=np.int8)
        n_item_orbits = self.n_items // 4
        if n_item_orbits:
            salt = _ITEM_SALT
            pick = np.argsort(_hashes(keys, salt, wooden.shape[1]), axis=1, kind="stable")[:, :n_item_orbits]
            with_items = np.take_along_axis(wooden, pick, axis=1)
            kinds = np.array(POWER_UPS, dtype=np.int8)[_hashes(keys, salt + 1, n_item_orbits) % np.uint64(3)]
            hidden[rows, orbits[with_items].reshape(k, -1)] = np.repeat(kinds, 4, axis=1)
        return terrain, hidden

    def _all_reachable(self, terrain: np.ndarray) -> np.ndarray:
        """``bool[k]``: on each board, every cell that is not rigid wall is reachable from the
        first corner's start."""
        n = self.size
        open_ = (terrain != RIGID).reshape(-1, n, n)
        reach = np.zeros(open_.shape, dtype=bool)
        reach.reshape(len(reach), -1)[:, self._start_cells[0]] = True
        while True:
            grown = grow(reach, open_)
            if (grown == reach).all():
                return (reach == open_).all(axis=(1, 2))
            reach = grown

    # --- matches -------------------------------------------------------------------------------
    def reset(self, boards: Any = None, keys: Any = None) -> None:
        """New matches on every board or on those indexed; each board's map comes from its key
        (drawn from the engine's generator unless ``keys``, ``uint64``, are given)."""
        sel, keys = reset_keys(self._boards, self.rng, boards, keys)
        terrain, hidden = self.generate(keys)
        self.terrain[sel] = RIGID
        self.terrain[sel[:, None], self._inner] = terrain
        self.hidden[sel] = 0
        self.hidden[sel[:, None], self._inner] = hidden
        self.keys[sel] = keys
        for name in ("flame", "bomb_timer", "bomb_strength"):
            getattr(self, name)[sel] = 0
        self.bomb_owner[sel] = -1
        self.bomb_direction[sel] = -1
        self.position[sel] = self._inner[self._start_cells]
        self.alive[sel] = True
        self.ammo[sel] = 1
        self.strength[sel] = self.blast_strength
        self.can_kick[sel] = False
        self.death_step[sel] = -1
        for name in ("picked", "died", "laid", "kicked"):
            getattr(self, name)[sel] = False
        self.t[sel] = 0
        self.done[sel] = False
        self.truncated[sel] = False
        self.final_scores[sel] = np.nan

    def set_board(self, board: int, picture: Sequence[str], hidden: dict[int, int] | None = None) -> None:
        """Put a position on one board (puzzles, tests) from a picture of ``size`` rows of ``size``
        characters: ``.`` passage, ``#`` rigid, ``+`` wood, ``e`` ``r`` ``k`` power-ups (extra bomb,
        range, kick), a digit the seat standing there (a seat not drawn is dead). ``hidden`` maps
        board cells of wooden walls to the power-up under them. No bombs or flames; every seat has
        ammo 1, the starting blast strength and no kick; the step counter restarts at 0."""
        b, n = int(board), self.size
        if not 0 <= b < self.n_boards:
            raise ValueError(f"board {board!r} is not one of 0..{self.n_boards - 1}")
        if len(picture) != n or any(len(row) != n for row in picture):
            raise ValueError(f"a Boomer picture has {n} rows of {n} characters")
        codes = {".": PASSAGE, "#": RIGID, "+": WOOD, "e": EXTRA_BOMB, "r": RANGE, "k": KICK}
        terrain = np.zeros(self.n_cells, dtype=np.int8)
        self.alive[b] = False
        for cell, char in enumerate("".join(picture)):
            if char.isdigit() and int(char) < self.n_seats:
                self.position[b, int(char)] = self._inner[cell]
                self.alive[b, int(char)] = True
            elif char in codes:
                terrain[cell] = codes[char]
            else:
                raise ValueError(f"{char!r} is not a Boomer picture character (. # + e r k or a seat digit "
                                 f"0..{self.n_seats - 1})")
        self.terrain[b] = RIGID
        self.terrain[b, self._inner] = terrain
        self.hidden[b] = 0
        for cell, kind in (hidden or {}).items():
            self.hidden[b, self._inner[cell]] = kind
        for name in ("flame", "bomb_timer", "bomb_strength"):
            getattr(self, name)[b] = 0
        self.bomb_owner[b] = -1
        self.bomb_direction[b] = -1
        self.ammo[b] = 1
        self.strength[b] = self.blast_strength
        self.can_kick[b] = False
        self.death_step[b] = np.where(self.alive[b], -1, 0)
        self.t[b] = 0
        self.done[b] = self.truncated[b] = False

    def lay_bomb(self, board: int, cell: int, owner: int, timer: int = BOMB_LIFE, strength: int | None = None) -> None:
        """Put a bomb of ``owner`` on board cell ``cell`` (puzzles, tests); it takes none of the owner's ammo."""
        padded = self._inner[int(cell)]
        self.bomb_timer[board, padded] = timer
        self.bomb_strength[board, padded] = self.strength[board, owner] if strength is None else strength
        self.bomb_owner[board, padded] = owner
        self.bomb_direction[board, padded] = -1

    def random_actions(self) -> np.ndarray:
        """Uniform random actions (every action is legal), from the engine's generator."""
        return self.rng.integers(len(ACTIONS), size=(self.n_boards, self.n_seats))

    def step(self, actions: np.ndarray) -> None:
        """One step of every unfinished board; ``actions[b, s]`` is in seat ``s``'s own frame."""
        actions = np.asarray(actions)
        if actions.shape != (self.n_boards, self.n_seats) or actions.dtype.kind not in "iu":
            raise ValueError(f"BoomerBoards.step takes integer actions of shape ({self.n_boards}, {self.n_seats}); "
                             f"got shape {actions.shape} dtype {actions.dtype}")
        if actions.size and (actions.min() < 0 or actions.max() >= len(ACTIONS)):
            raise ValueError("Boomer actions are 0 stop, 1 up, 2 down, 3 left, 4 right, 5 bomb (in the seat's frame)")
        if self.autoreset:
            self.done[:] = False
            self.truncated[:] = False
        live = ~self.done
        self.picked[:] = False
        self.died[:] = False
        self.laid[:] = False
        self.kicked[:] = False
        self._burn_down(live)
        self._slide_bombs(live)
        acting = self.alive & live[:, None]
        self._lay_bombs(actions, acting)
        self._move_agents(actions, acting)
        self._explode(live)
        self._burn_agents(live)
        self.t += live
        self._judge(live)

    def _burn_down(self, live: np.ndarray) -> None:
        """Flames burn one step shorter; a wooden wall's power-up appears where its flame goes out."""
        flame = self.flame
        burning = (flame > 0) & live[:, None]
        if not burning.any():
            return
        out = burning & (flame == 1)
        flame -= burning.astype(np.int8)
        revealed = out & (self.hidden > 0)
        if revealed.any():
            self.terrain[revealed] = self.hidden[revealed]
            self.hidden[revealed] = 0

    def _slide_bombs(self, live: np.ndarray) -> None:
        """Kicked bombs slide one cell; one that would enter a wall, a power-up, a bomb, a player or a
        cell another bomb enters stops where it is."""
        moving = (self.bomb_direction >= 0) & live[:, None]
        if not moving.any():
            return
        b, cell = np.nonzero(moving)
        d = self.bomb_direction[b, cell].astype(np.int64)
        target = cell + self._delta[d]
        blocked = (self.terrain[b, target] != PASSAGE) | (self.bomb_timer[b, target] > 0)
        on_target = (self.position[b] == target[:, None]) & self.alive[b]
        blocked |= on_target.any(axis=1)
        flat = b * self.terrain.shape[1] + target
        _, inverse, counts = np.unique(flat, return_inverse=True, return_counts=True)
        blocked |= counts[inverse] > 1
        self.bomb_direction[b[blocked], cell[blocked]] = -1
        go = ~blocked
        if go.any():
            self._move_bombs(b[go], cell[go], target[go])

    def _move_bombs(self, b: np.ndarray, source: np.ndarray, target: np.ndarray) -> None:
        """Bombs from ``source`` to ``target`` cells (every source is cleared before any target is written)."""
        arrays = (self.bomb_timer, self.bomb_strength, self.bomb_owner, self.bomb_direction)
        values = [a[b, source].copy() for a in arrays]
        for a, empty in zip(arrays, (0, 0, -1, -1), strict=True):
            a[b, source] = empty
        for a, value in zip(arrays, values, strict=True):
            a[b, target] = value

    def _lay_bombs(self, actions: np.ndarray, acting: np.ndarray) -> None:
        lay = acting & (actions == BOMB) & (self.ammo > 0)
        if not lay.any():
            return
        b, s = np.nonzero(lay)
        cell = self.position[b, s]
        free = self.bomb_timer[b, cell] == 0
        b, s, cell = b[free], s[free], cell[free]
        self.bomb_timer[b, cell] = BOMB_LIFE
        self.bomb_strength[b, cell] = self.strength[b, s]
        self.bomb_owner[b, cell] = s
        self.bomb_direction[b, cell] = -1
        self.ammo[b, s] -= 1
        self.laid[b, s] = True

    def _move_agents(self, actions: np.ndarray, acting: np.ndarray) -> None:
        """Simultaneous moves: a move into a wall fails; into a bomb it kicks the bomb when the player
        can kick and the cell past the bomb is clear, else fails; then every move that meets another
        (the same cell, a swap, a cell a kicked bomb enters, a player who stays) fails, until none does."""
        frame_direction = ACTION_DIRECTION[actions]
        moving = acting & (frame_direction >= 0)
        if not moving.any():
            return
        s_count = self.n_seats
        direction = (frame_direction + self.quarter_turns) % 4
        step = self._delta[direction]
        pos = self.position
        rows = self._boards[:, None]
        target = pos + step
        terrain = self.terrain[rows, target]
        moving &= (terrain != RIGID) & (terrain != WOOD)
        bomb_ahead = moving & (self.bomb_timer[rows, target] > 0)
        kick = bomb_ahead & self.can_kick
        beyond = np.where(kick, target + step, target)  # past the board's ring only where nobody kicks
        if kick.any():
            somebody = (pos[:, None, :] == beyond[:, :, None]) & self.alive[:, None, :]
            kick &= (self.terrain[rows, beyond] == PASSAGE) & (self.bomb_timer[rows, beyond] == 0) & \
                ~somebody.any(axis=2)
        moving &= ~bomb_ahead | kick
        # cells nobody can match: a dead or staying seat's "want" is its own cell, a seat without a
        # kick lands its bomb nowhere
        nowhere = -1 - np.arange(s_count)
        here = np.where(self.alive, pos, nowhere)
        want = np.where(moving, target, here)
        landing = np.where(kick & moving, beyond, nowhere - s_count)
        other = ~np.eye(s_count, dtype=bool)
        while True:
            same = (want[:, :, None] == want[:, None, :]) & other
            swap = (want[:, :, None] == here[:, None, :]) & (want[:, None, :] == here[:, :, None]) & other
            onto_kick = (want[:, :, None] == landing[:, None, :]) & other
            kick_clash = ((landing[:, :, None] == landing[:, None, :]) | (landing[:, :, None] == want[:, None, :])) \
                & other
            fails = moving & (same | swap | onto_kick | kick_clash).any(axis=2)
            if not fails.any():
                break
            moving &= ~fails
            want = np.where(moving, want, here)
            landing = np.where(moving, landing, nowhere - s_count)
        kicked = moving & (landing >= 0)
        if kicked.any():
            b, s = np.nonzero(kicked)
            self._move_bombs(b, target[b, s], beyond[b, s])
            self.bomb_direction[b, beyond[b, s]] = direction[b, s]
            self.kicked[b, s] = True
        np.copyto(self.position, want, where=moving)
        found = self.terrain[rows, self.position]
        picked = moving & (found >= EXTRA_BOMB)
        if picked.any():
            b, s = np.nonzero(picked)
            kind = found[b, s]
            self.ammo[b, s] = np.minimum(self.ammo[b, s] + (kind == EXTRA_BOMB), MAX_AMMO)
            self.strength[b, s] = np.minimum(self.strength[b, s] + (kind == RANGE), MAX_STRENGTH)
            self.can_kick[b, s] |= kind == KICK
            self.terrain[b, self.position[b, s]] = PASSAGE
            self.picked[b, s] = True

    def blast_cells(self, b: np.ndarray, cell: np.ndarray, strength: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The cells the blasts of bombs at ``(b, cell)`` with ``strength`` reach: ``(index into the
        bombs, padded cell)`` pairs, the bombs' own cells first; an arm runs ``strength - 1`` cells,
        stops before a rigid wall and at a wooden one."""
        index = np.arange(len(b))
        which, cells = [index], [cell]
        longest = int(strength.max(initial=0))
        # the four arms side by side: [bombs, 4] arrays, one pass per cell of reach
        arm_of = np.broadcast_to(index[:, None], (len(b), 4))
        rows, longer = b[:, None], strength[:, None]
        reach = np.broadcast_to(cell[:, None], (len(b), 4))
        open_ = np.ones((len(b), 4), dtype=bool)
        for k in range(1, longest):
            reach = np.where(open_, reach + self._delta, reach)  # a stopped arm stays inside the ring
            terrain = self.terrain[rows, reach]
            open_ &= (terrain != RIGID) & (k < longer)
            if not open_.any():
                break
            which.append(arm_of[open_])
            cells.append(reach[open_])
            open_ &= terrain != WOOD
        return np.concatenate(which), np.concatenate(cells)

    def _explode(self, live: np.ndarray) -> None:
        """Bombs count down; one at 0 or in a flame explodes, and so does every bomb its blast
        reaches, in the same step. Each returns its ammo; the blasts become flames."""
        timer = self.bomb_timer
        has_bomb = (timer > 0) & live[:, None]
        if not has_bomb.any():
            return
        timer -= has_bomb.astype(np.int8)
        going = has_bomb & ((timer == 0) | (self.flame > 0))
        if not going.any():
            return
        marked = np.zeros(timer.shape, dtype=bool)
        b, cell = np.nonzero(going)
        while len(b):
            strength = self.bomb_strength[b, cell].astype(np.int64)
            owner = self.bomb_owner[b, cell].astype(np.int64)
            np.add.at(self.ammo, (b, owner), 1)
            timer[b, cell] = 0
            self.bomb_owner[b, cell] = -1
            self.bomb_direction[b, cell] = -1
            which, reached = self.blast_cells(b, cell, strength)
            rb = b[which]
            marked[rb, reached] = True
            chained = timer[rb, reached] > 0
            pairs = np.unique(rb[chained] * timer.shape[1] + reached[chained])
            b, cell = np.divmod(pairs, timer.shape[1])
        np.minimum(self.ammo, MAX_AMMO, out=self.ammo)
        self.terrain[marked] = PASSAGE  # wooden walls burn down, power-ups in a blast are lost
        self.flame[marked] = FLAME_STEPS

    def _burn_agents(self, live: np.ndarray) -> None:
        on_flame = self.alive & live[:, None] & (self.flame[self._boards[:, None], self.position] > 0)
        if on_flame.any():
            self.alive &= ~on_flame
            self.died |= on_flame
            self.death_step[on_flame] = np.broadcast_to(self.t[:, None] + 1, on_flame.shape)[on_flame]

    def _judge(self, live: np.ndarray) -> None:
        """End the boards where at most one team has a player left (or at ``max_steps``)."""
        teams_left = (self.alive[:, :, None] & self._team_onehot).any(axis=1)  # [B, teams]
        ended = live & (teams_left.sum(axis=1) <= 1)
        if self.max_steps is not None:
            cut = live & ~ended & (self.t >= self.max_steps)
            self.truncated |= cut
            ended |= cut
        if not ended.any():
            return
        self.done |= ended
        finished = np.flatnonzero(ended)
        self.final_scores[finished] = self.team_scores(finished)
        if self.autoreset:
            truncated = self.truncated[finished]
            self.reset(finished)
            self.done[finished] = True
            self.truncated[finished] = truncated

    def team_scores(self, boards: Any = None) -> np.ndarray:
        """``float64[len(boards), n_teams]``: each team beats the teams eliminated before it (a team
        with a player left outlives every eliminated one) and ties with those out on the same step:
        1 per team beaten, 0.5 per team tied."""
        sel = self._boards if boards is None else np.asarray(boards, dtype=np.int64).reshape(-1)
        last = np.zeros((len(sel), self.n_teams), dtype=np.int64)
        big = np.iinfo(np.int64).max
        for team in range(self.n_teams):
            members = self.team_of == team
            out = np.where(self.alive[sel][:, members], big, self.death_step[sel][:, members])
            last[:, team] = out.max(axis=1)
        beats = (last[:, :, None] > last[:, None, :]).sum(axis=2)
        ties = (last[:, :, None] == last[:, None, :]).sum(axis=2) - 1
        return beats + 0.5 * ties

    # --- what seats see --------------------------------------------------------------------------
    def _bomb_times(self) -> tuple[np.ndarray, np.ndarray]:
        """``(bomb, blast)``: ``float32[B, size * size]`` board planes of 1 / steps to each bomb's
        explosion and of 1 / steps until a blast reaches each cell, chains included (the blast of
        a bomb caught in another's goes off with the earlier one)."""
        n_cells = self.n_cells
        bomb = np.zeros((self.n_boards, n_cells), dtype=np.float32)
        blast = np.zeros((self.n_boards, n_cells), dtype=np.float32)
        timer = self.bomb_timer[:, self._inner]
        b, inner = np.nonzero(timer > 0)
        if not len(b):
            return bomb, blast
        padded = self._inner[inner]
        steps = timer[b, inner].astype(np.int64)
        bomb[b, inner] = 1.0 / steps
        which, reached = self.blast_cells(b, padded, self.bomb_strength[b, padded].astype(np.int64))
        side = self.side
        flat_reached = b[which] * side * side + reached
        flat_bombs = b * side * side + padded
        # a bomb reached by an earlier blast goes off with it: relax until nothing changes
        while True:
            earliest = np.full(self.n_boards * side * side, BOMB_LIFE + 1, dtype=np.int64)
            np.minimum.at(earliest, flat_reached, steps[which])
            sooner = np.minimum(steps, earliest[flat_bombs])
            if (sooner == steps).all():
                break
            steps = sooner
        # settled: ``earliest`` holds, per cell, the step the first blast reaches it
        earliest = earliest.reshape(self.n_boards, side * side)[:, self._inner]
        reached = earliest <= BOMB_LIFE
        blast[reached] = 1.0 / earliest[reached]
        return bomb, blast

    def board_planes(self) -> np.ndarray:
        """``float32[B, 8, size * size]``: the planes every seat sees, in the board's frame."""
        planes = np.zeros((self.n_boards, N_BOARD_PLANES, self.n_cells), dtype=np.float32)
        terrain = self.terrain[:, self._inner]
        planes[:, :5] = terrain[:, None, :] == _TERRAIN_PLANES[None, :, None]
        planes[:, 5], planes[:, 6] = self._bomb_times()
        planes[:, 7] = self.flame[:, self._inner] * np.float32(1.0 / FLAME_STEPS)
        return planes

    def _agent_scalars(self) -> np.ndarray:
        """``float32[B, S, 4]``: alive, ammo / 10, blast strength / 10, can kick (zeros for the dead)."""
        scalars = np.stack([self.alive, self.ammo / MAX_AMMO, self.strength / MAX_STRENGTH, self.can_kick],
                           axis=2).astype(np.float32)
        scalars[~self.alive] = 0.0
        return scalars

    def board_cell(self, padded: np.ndarray) -> np.ndarray:
        """Board cells (``row * size + col``) of padded cells."""
        row, col = np.divmod(padded, self.side)
        return (row - 1) * self.size + (col - 1)

    def observe(self) -> np.ndarray:
        """``float32[B, S, obs_dim]``: every seat's observation in its own frame (package docstring)."""
        b_count, s_count, n_cells = self.n_boards, self.n_seats, self.n_cells
        obs = np.zeros((b_count, s_count, self.obs_dim), dtype=np.float32)
        scalars = self._agent_scalars()
        obs[:, :, :PER_AGENT] = scalars
        obs[:, :, PER_AGENT:self.header] = scalars[:, self._others].reshape(b_count, s_count, -1)
        planes = self.board_planes()
        body = obs[:, :, self.header:].reshape(b_count, s_count, len(PLANES), n_cells)
        body[:, :, :N_BOARD_PLANES] = planes[:, :, self._frame_cells].transpose(0, 2, 1, 3)  # [B, S, 8, cells]
        cell = self.board_cell(self.position)  # [B, S]
        b, viewer, seen = np.nonzero(self.alive[:, :, None] & self.alive[:, None, :])
        body[b, viewer, self._position_plane[viewer, seen], self._frame_of[viewer, cell[b, seen]]] = 1.0
        dead = ~self.alive
        if dead.any():
            obs[dead] = 0.0
        return obs

    def state(self) -> np.ndarray:
        """``float32[B, state_dim]``: the board planes (board frame), then per seat alive, ammo / 10,
        blast strength / 10, can kick, row and column / (size - 1)."""
        state = np.zeros((self.n_boards, self.state_dim), dtype=np.float32)
        state[:, :N_BOARD_PLANES * self.n_cells] = self.board_planes().reshape(self.n_boards, -1)
        per = np.zeros((self.n_boards, self.n_seats, STATE_PER_AGENT), dtype=np.float32)
        per[:, :, :PER_AGENT] = self._agent_scalars()
        row, col = np.divmod(self.board_cell(self.position), self.size)
        per[:, :, 4] = np.where(self.alive, row / (self.size - 1), 0.0)
        per[:, :, 5] = np.where(self.alive, col / (self.size - 1), 0.0)
        state[:, N_BOARD_PLANES * self.n_cells:] = per.reshape(self.n_boards, -1)
        return state

    def grid(self, board: int = 0) -> np.ndarray:
        """``int64[size, size]`` terrain codes of one board (0 passage, 1 rigid, 2 wood, 3..5 power-ups)."""
        return self.terrain[int(board), self._inner].astype(np.int64).reshape(self.size, self.size)
