"""Boomer's one-board engine: the rules of :class:`~arena_league.envs.games.boomer.boards.BoomerBoards`
for a single match, stepped in plain Python (the manual is the package docstring).

A one-board batch pays numpy's per-call overhead on every one of its whole-array operations, while a
match has a few seats, bombs and flames: here the bombs and flames are sets of cells, the per-cell
state is ``bytearray`` s on the padded board (so a move, a kick or a blast arm never needs a bounds
check), and all seats' observations are one gather from a source vector (the eight shared planes,
the seats' scalars and each viewer's position planes) that the engine brings up to date cell by
cell. ``BoomerBoards`` stays the reference: the two agree exactly, step by step, on every array,
observation and state (``tests/test_game_boomer_board.py``); :meth:`BoomerBoard.load` takes over a
board of it (set-up positions).

Numpy arrays with ``BoomerBoards``' names and shapes (one board) serve the picture, the scene, the
text view and tests: the cells ``terrain``, ``hidden``, ``flame``, ``bomb_timer``, ``bomb_strength``,
``bomb_owner``, ``bomb_direction`` are views of the engine's memory (read them; only ``terrain`` may
be written, which the next observation shows), the seats' ``position``, ``alive``, ``ammo``,
``strength``, ``can_kick``, ``death_step``, ``picked``, ``died``, ``laid``, ``kicked`` and ``t``,
``done``, ``truncated``, ``final_scores`` are copies.
"""

from __future__ import annotations

from array import array
from typing import Any

import numpy as np

from arena_league.envs.games.boomer.boards import (
    _ITEM_SALT,
    ACTION_DIRECTION,
    ACTIONS,
    BOMB,
    BOMB_LIFE,
    EXTRA_BOMB,
    FLAME_STEPS,
    KICK,
    MAX_AMMO,
    MAX_STRENGTH,
    N_BOARD_PLANES,
    PASSAGE,
    PER_AGENT,
    PLANES,
    POWER_UPS,
    RANGE,
    RIGID,
    STATE_PER_AGENT,
    WOOD,
    BoomerBoards,
    _hash_columns,
    _splitmix64,
)

_ATTEMPTS = 4  # draws of the rigid walls hashed at once (most maps need one to three)
_POWER_UP_CODES = np.array(POWER_UPS, dtype=np.int8)
_NONE = 255  # "no owner" and "lying still" in the unsigned cells (-1 through the int8 views)
_TERRAIN_CODES = np.array([RIGID, WOOD, EXTRA_BOMB, RANGE, KICK], dtype=np.int8)[:, None]  # the first five planes
_TERRAIN_VALUES = [tuple(float(code == plane) for plane in _TERRAIN_CODES[:, 0].tolist()) for code in range(6)]
# a flame's plane value, computed as the batched engine computes it (int8 times float32)
_FLAME_VALUES = (np.arange(FLAME_STEPS + 1, dtype=np.int8) * np.float32(1.0 / FLAME_STEPS)).tolist()
_INVERSE = [0.0] + [1.0 / steps for steps in range(1, BOMB_LIFE + 2)]  # 1 / steps, as the planes show it


def _one_board(attr: str, dtype: Any) -> property:
    """A read-only ``BoomerBoards``-shaped view (``[1, ...]``, a copy) of the Python value ``attr``."""
    return property(lambda self: np.array([getattr(self, attr)], dtype=dtype))


class BoomerBoard:
    """One Boomer match, the rules of ``BoomerBoards`` with ``n_boards=1`` (same arguments but
    ``autoreset``; ``reset(keys=...)`` draws the same map from the same key)."""

    n_boards = 1

    def __init__(self, n_seats: int = 2, size: int = 11, n_rigid: int = 36, n_wood: int = 36, n_items: int = 20,
                 blast_strength: int = 2, team_of: Any = None, quarter_turns: Any = None,
                 max_steps: int | None = None, seed: int = 0) -> None:
        # the batched engine checks the arguments and lays out the map tables, frames and seat orders
        layout = BoomerBoards(1, n_seats, size=size, n_rigid=n_rigid, n_wood=n_wood, n_items=n_items,
                              blast_strength=blast_strength, team_of=team_of, quarter_turns=quarter_turns,
                              max_steps=max_steps)
        self._layout = layout
        for name in ("n_seats", "size", "n_rigid", "n_wood", "n_items", "blast_strength", "max_steps", "team_of",
                     "n_teams", "quarter_turns", "n_cells", "side", "_inner", "header", "obs_dim", "state_dim"):
            setattr(self, name, getattr(layout, name))
        self.rng = np.random.default_rng(seed)
        s, n, side = self.n_seats, self.size, self.side
        cells = side * side
        self._cells = cells
        self._delta = (-side, 1, side, -1)  # compass: up, right, down, left
        # per seat, the padded step of each action in the seat's frame (None: stop or bomb)
        self._step_of = [[None if d < 0 else self._delta[(int(d) + int(q)) % 4] for d in ACTION_DIRECTION]
                         for q in self.quarter_turns]
        self._direction_of = [[-1 if d < 0 else (int(d) + int(q)) % 4 for d in ACTION_DIRECTION]
                              for q in self.quarter_turns]
        self._team = [int(t) for t in self.team_of]
        self._orbit_bits = [sum(1 << int(c) for c in orbit) for orbit in layout._orbits]
        self._orbit_padded = layout._inner[layout._orbits]  # [orbits, 4] padded cells
        self._start_bit = 1 << int(layout._start_cells[0])
        blank = bytearray([RIGID]) * cells
        for cell in layout._inner:
            blank[cell] = PASSAGE
        self._blank = bytes(blank)
        self._free = layout._free_orbits
        self._lanes = layout._lane_orbits
        n_wooden = len(self._lanes) + (self.n_wood - 4 * len(self._lanes)) // 4
        self._columns = np.concatenate([_hash_columns(attempt, len(self._free)) for attempt in range(_ATTEMPTS)]
                                       + [_hash_columns(_ITEM_SALT, n_wooden),
                                          _hash_columns(_ITEM_SALT + 1, self.n_items // 4)])
        self._start = [int(layout._inner[c]) for c in layout._start_cells]
        full = (1 << (n * n)) - 1
        col0 = sum(1 << (r * n) for r in range(n))
        self._bits = (full, full & ~col0, full & ~(col0 << (n - 1)))  # all, not column 0, not the last column
        # the observations are one gather from a source vector that the engine keeps up to date cell by
        # cell: the eight shared planes (padded cells), the seats' four scalars, one zero, then each
        # viewer's three position planes (own, teammates, opponents; padded cells)
        planes_end = N_BOARD_PLANES * cells
        self._scalar_base = planes_end
        zero = planes_end + PER_AGENT * s
        marks = zero + 1
        index = np.full((1, s, self.obs_dim), zero, dtype=np.int64)
        for i in range(s):
            for m, j in enumerate([i, *layout._others[i].tolist()]):
                index[0, i, PER_AGENT * m:PER_AGENT * (m + 1)] = planes_end + PER_AGENT * j + np.arange(PER_AGENT)
            shown = layout._inner[layout._frame_cells[i]]  # frame cell -> padded cell
            for p in range(len(PLANES)):
                base = p * cells if p < N_BOARD_PLANES else marks + (3 * i + p - N_BOARD_PLANES) * cells
                start = self.header + p * self.n_cells
                index[0, i, start:start + self.n_cells] = base + shown
        self._index = index
        self._zero = zero
        self._mark = [[marks + (3 * i + int(layout._position_plane[i, j]) - N_BOARD_PLANES) * cells
                       for j in range(s)] for i in range(s)]
        self._src = array("f", bytes(4 * (marks + 3 * s * cells)))
        self._state_index = (np.arange(N_BOARD_PLANES)[:, None] * cells + layout._inner[None, :]).reshape(-1)
        self._row_col = [((c // side - 1) / (n - 1), (c % side - 1) / (n - 1)) for c in range(cells)]
        self._T = bytearray(cells)
        self._H = bytearray(cells)
        self._F = bytearray(cells)
        self._BT = bytearray(cells)
        self._BS = bytearray(cells)
        self._BO = bytearray(cells)
        self._BD = bytearray(cells)
        self._views()
        # what the source vector shows: no terrain yet, no flames, bombs or positions
        self._shown_terrain = bytearray([_NONE]) * cells
        self._shown_flames: set[int] = set()
        self._shown_bombs: list[int] = []
        self._shown_alive: list[bool] = []
        self._shown_pos: list[int] = []
        self._obs_index = index.copy()  # a dead viewer's row points at the zero
        self._reach: dict[int, list[int]] = {}  # blast cells by bomb cell and strength, for the terrain shown
        self.reset()

    _VIEWS = ("terrain", "hidden", "flame", "bomb_timer", "bomb_strength", "bomb_owner", "bomb_direction",
              "_values", "_planes")

    def _views(self) -> None:
        for name, cells in (("terrain", self._T), ("hidden", self._H), ("flame", self._F), ("bomb_timer", self._BT),
                            ("bomb_strength", self._BS), ("bomb_owner", self._BO), ("bomb_direction", self._BD)):
            setattr(self, name, np.frombuffer(cells, dtype=np.int8).reshape(1, -1))
        self._values = np.frombuffer(self._src, dtype=np.float32)
        self._planes = self._values[:N_BOARD_PLANES * self._cells].reshape(N_BOARD_PLANES, self._cells)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        for name in self._VIEWS:
            del state[name]  # views of the engine's buffers: a copy makes its own
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._views()

    # --- the map -------------------------------------------------------------------------------
    def _reachable(self, rigid: int) -> bool:
        """Every cell that is not rigid (a bit of ``rigid`` for board cell ``row * size + col``) is
        reachable from the first corner's start (a bitboard flood fill)."""
        n = self.size
        full, not_first, not_last = self._bits
        open_ = full & ~rigid
        # a cell walled in on all four sides fails at once, without the flood
        if open_ & ~(((open_ << 1) & not_first) | ((open_ >> 1) & not_last) | (open_ << n) | (open_ >> n)):
            return False
        reach = self._start_bit
        while True:
            grown = (reach | ((reach << 1) & not_first) | ((reach >> 1) & not_last) | (reach << n) | (reach >> n)) \
                & open_
            if grown == reach:
                return reach == open_
            reach = grown

    def _generate(self, key: int) -> None:
        """``BoomerBoards.generate`` for one key, written into the padded terrain and hidden cells."""
        key = np.uint64(key)
        free, n_free, orbit_bits = self._free, len(self._free), self._orbit_bits
        n_rigid, n_wood = self.n_rigid // 4, (self.n_wood - 4 * len(self._lanes)) // 4
        hashes = _splitmix64(key ^ self._columns)  # every draw of a usual map in one pass
        attempt = 0
        while True:
            if attempt < _ATTEMPTS:
                draw = hashes[attempt * n_free:(attempt + 1) * n_free]
            else:
                draw = _splitmix64(key ^ _hash_columns(attempt, n_free))
            drawn = free[np.argsort(draw, kind="stable")]
            attempt += 1
            rigid = 0
            for k in drawn[:n_rigid].tolist():
                rigid |= orbit_bits[k]
            if self._reachable(rigid):
                break
        padded = self._orbit_padded
        self._T[:] = self._blank
        self._H[:] = bytes(self._cells)
        terrain, hidden = self.terrain[0], self.hidden[0]
        terrain[padded[drawn[:n_rigid]]] = RIGID
        wooden = np.concatenate([self._lanes, drawn[n_rigid:n_rigid + n_wood]])
        terrain[padded[wooden]] = WOOD
        n_item_orbits = self.n_items // 4
        if n_item_orbits:
            start = _ATTEMPTS * n_free
            pick = np.argsort(hashes[start:start + len(wooden)], kind="stable")[:n_item_orbits]
            kinds = _POWER_UP_CODES[hashes[start + len(wooden):] % np.uint64(3)]
            hidden[padded[wooden[pick]]] = kinds[:, None]

    # --- matches -------------------------------------------------------------------------------
    def reset(self, boards: Any = None, keys: Any = None) -> None:
        """A new match; its map comes from its key (one ``uint64``, drawn from the engine's generator
        unless given), as ``BoomerBoards.reset`` draws it."""
        if boards is not None and np.asarray(boards).reshape(-1).tolist() != [0]:
            raise ValueError(f"a one-board Boomer engine resets board 0 only, not {boards!r}")
        if keys is None:
            keys = self.rng.integers(0, 2**64, size=1, dtype=np.uint64)
        keys = np.asarray(keys, dtype=np.uint64).reshape(-1)
        if keys.shape != (1,):
            raise ValueError(f"reset got {keys.size} keys for 1 board; give one uint64 key")
        self.keys = keys.copy()
        self._generate(int(keys[0]))
        self._changed: list[int] = []  # terrain cells changed since the source vector was brought up to date
        empty, none = bytes(self._cells), bytes([_NONE]) * self._cells
        self._F[:] = self._BT[:] = self._BS[:] = empty
        self._BO[:] = self._BD[:] = none
        self._bombs: set[int] = set()
        self._flames: set[int] = set()
        s = self.n_seats
        self._pos = list(self._start)
        self._alive = [True] * s
        self._ammo = [1] * s
        self._strength = [self.blast_strength] * s
        self._kick = [False] * s
        self._death = [-1] * s
        self._picked = [False] * s
        self._died = [False] * s
        self._laid = [False] * s
        self._kicked = [False] * s
        self._t = 0
        self._judged = False
        self.eventful = False
        self._scalars_stale = True  # the seats' scalars in the source vector
        self._done = False
        self._truncated = False
        self._final: list[float] | None = None

    def load(self, boards: BoomerBoards, board: int = 0) -> None:
        """Take over board ``board`` of a batched engine built alike, as it stands (puzzles, tests:
        ``BoomerBoards.set_board`` and ``lay_bomb`` set positions up)."""
        b = int(board)
        for cells, name in ((self._T, "terrain"), (self._H, "hidden"), (self._F, "flame"), (self._BT, "bomb_timer"),
                            (self._BS, "bomb_strength"), (self._BO, "bomb_owner"), (self._BD, "bomb_direction")):
            cells[:] = getattr(boards, name)[b].view(np.uint8).tobytes()
        self._bombs = {int(c) for c in np.flatnonzero(boards.bomb_timer[b])}
        self._flames = {int(c) for c in np.flatnonzero(boards.flame[b])}
        self._changed = []
        self._pos = boards.position[b].tolist()
        self._alive = boards.alive[b].tolist()
        self._ammo = boards.ammo[b].tolist()
        self._strength = boards.strength[b].tolist()
        self._kick = boards.can_kick[b].tolist()
        self._death = boards.death_step[b].tolist()
        for name in ("picked", "died", "laid", "kicked"):
            setattr(self, f"_{name}", getattr(boards, name)[b].tolist())
        self.keys = boards.keys[b:b + 1].copy()
        self._t = int(boards.t[b])
        self._done, self._truncated = bool(boards.done[b]), bool(boards.truncated[b])
        self._final = boards.final_scores[b].tolist() if self._done else None
        self.eventful = False
        self._scalars_stale = True
        self._judged = False

    def step(self, actions: Any) -> None:
        """``BoomerBoards.step`` with ``actions`` of shape ``(1, seats)``."""
        actions = np.asarray(actions)
        if actions.shape != (1, self.n_seats) or actions.dtype.kind not in "iu":
            raise ValueError(f"BoomerBoard.step takes integer actions of shape (1, {self.n_seats}); "
                             f"got shape {actions.shape} dtype {actions.dtype}")
        self.play(actions[0].tolist())

    def play(self, actions: list[int]) -> None:
        """One step, ``actions`` a list of one action per seat in its own frame (0..5)."""
        if min(actions) < 0 or max(actions) >= len(ACTIONS):
            raise ValueError("Boomer actions are 0 stop, 1 up, 2 down, 3 left, 4 right, 5 bomb (in the seat's frame)")
        s = self.n_seats
        self._picked = [False] * s
        self._died = [False] * s
        self._laid = [False] * s
        self._kicked = [False] * s
        self.eventful = False  # whether any seat laid, kicked, took or died on this step
        if self._done:
            return
        if self._flames:
            self._burn_down()
        if self._bombs:
            self._slide_bombs()
        self._lay_bombs(actions)
        self._move_agents(actions)
        if self._bombs:
            self._explode()
        flame, alive, pos = self._F, self._alive, self._pos
        for seat in range(s):
            if alive[seat] and flame[pos[seat]]:
                alive[seat] = False
                self._died[seat] = self.eventful = self._scalars_stale = True
                self._death[seat] = self._t + 1
        self._t += 1
        # the teams left change only with a death: judge on one, on a match's first step and near max_steps
        if not self._judged or any(self._died) or self.max_steps is not None:
            self._judged = True
            self._judge()

    def _burn_down(self) -> None:
        flame, hidden, terrain = self._F, self._H, self._T
        out = []
        for cell in self._flames:
            left = flame[cell] - 1
            flame[cell] = left
            if not left:
                out.append(cell)
                if hidden[cell]:
                    terrain[cell] = hidden[cell]
                    self._changed.append(cell)
                    hidden[cell] = 0
        self._flames.difference_update(out)

    def _slide_bombs(self) -> None:
        direction = self._BD
        sliding = [cell for cell in self._bombs if direction[cell] != _NONE]
        if not sliding:
            return
        delta, terrain, timer = self._delta, self._T, self._BT
        targets = [cell + delta[direction[cell]] for cell in sliding]
        players = {p for p, a in zip(self._pos, self._alive, strict=True) if a}
        moves = []
        for cell, target in zip(sliding, targets, strict=True):
            if terrain[target] != PASSAGE or timer[target] or target in players or targets.count(target) > 1:
                direction[cell] = _NONE
            else:
                moves.append((cell, target))
        if moves:
            self._move_bombs(moves)

    def _move_bombs(self, moves: list[tuple[int, int]]) -> None:
        """Bombs from each source to its target (every source is cleared before any target is written)."""
        arrays = (self._BT, self._BS, self._BO, self._BD)
        values = [[a[source] for a in arrays] for source, _ in moves]
        bombs = self._bombs
        for source, _ in moves:
            for a, empty in zip(arrays, (0, 0, _NONE, _NONE), strict=True):
                a[source] = empty
            bombs.discard(source)
        for (_, target), value in zip(moves, values, strict=True):
            for a, v in zip(arrays, value, strict=True):
                a[target] = v
            bombs.add(target)

    def _lay_bombs(self, actions: list[int]) -> None:
        timer, pos, ammo = self._BT, self._pos, self._ammo
        layers = [seat for seat in range(self.n_seats)
                  if actions[seat] == BOMB and self._alive[seat] and ammo[seat] > 0 and not timer[pos[seat]]]
        for seat in layers:
            cell = pos[seat]
            timer[cell] = BOMB_LIFE
            self._BS[cell] = self._strength[seat]
            self._BO[cell] = seat
            self._BD[cell] = _NONE
            ammo[seat] -= 1
            self._laid[seat] = self.eventful = self._scalars_stale = True
            self._bombs.add(cell)

    def _move_agents(self, actions: list[int]) -> None:
        """Simultaneous moves, settled as ``BoomerBoards._move_agents`` settles them."""
        alive, pos, terrain, timer = self._alive, self._pos, self._T, self._BT
        movers = []  # (seat, target, where its kick lands the bomb or None)
        for seat, steps in enumerate(self._step_of):
            step = steps[actions[seat]]
            if step is None or not alive[seat]:
                continue
            target = pos[seat] + step
            kind = terrain[target]
            if kind in (RIGID, WOOD):
                continue
            beyond = None
            if timer[target]:
                beyond = target + step
                if not (self._kick[seat] and terrain[beyond] == PASSAGE and not timer[beyond]
                        and not any(a and p == beyond for p, a in zip(pos, alive, strict=True))):
                    continue
            movers.append((seat, target, beyond))
        if not movers:
            return
        s_count = self.n_seats
        here = [pos[seat] if alive[seat] else -1 - seat for seat in range(s_count)]
        want = list(here)
        landing = [-1 - s_count - seat for seat in range(s_count)]
        moving = [False] * s_count
        claimed = list(here)
        for seat, target, beyond in movers:
            moving[seat] = True
            want[seat] = claimed[seat] = target
            if beyond is not None:
                landing[seat] = beyond
                claimed.append(beyond)
        # no cell wanted or landed on twice and no move into a cell a mover leaves: no move fails
        left = {here[seat] for seat, _, _ in movers}
        clear = len(set(claimed)) == len(claimed) and not any(target in left for _, target, _ in movers)
        while not clear:  # a move that meets another fails, until none does
            fails = [i for i in range(s_count) if moving[i] and any(
                want[i] == want[j] or (want[i] == here[j] and want[j] == here[i]) or want[i] == landing[j]
                or landing[i] == landing[j] or landing[i] == want[j] for j in range(s_count) if j != i)]
            if not fails:
                break
            for i in fails:
                moving[i] = False
                want[i] = here[i]
                landing[i] = -1 - s_count - i
        kicks = [seat for seat, _, beyond in movers if beyond is not None and moving[seat]]
        if kicks:
            self._move_bombs([(want[seat], landing[seat]) for seat in kicks])
            for seat in kicks:
                self._BD[landing[seat]] = self._direction_of[seat][actions[seat]]
                self._kicked[seat] = self.eventful = True
        for seat, _, _ in movers:
            if not moving[seat]:
                continue
            cell = pos[seat] = want[seat]
            kind = terrain[cell]
            if kind >= EXTRA_BOMB:
                self._ammo[seat] = min(self._ammo[seat] + (kind == EXTRA_BOMB), MAX_AMMO)
                self._strength[seat] = min(self._strength[seat] + (kind == RANGE), MAX_STRENGTH)
                self._kick[seat] = self._kick[seat] or kind == KICK
                terrain[cell] = PASSAGE
                self._changed.append(cell)
                self._picked[seat] = self.eventful = self._scalars_stale = True

    def blast_cells(self, cell: int, strength: int) -> list[int]:
        """The padded cells a blast of ``strength`` from ``cell`` reaches, the bomb's own first; an arm
        runs ``strength - 1`` cells, stops before a rigid wall and at a wooden one."""
        terrain = self._T
        reached = [cell]
        for delta in self._delta:
            at = cell
            for _ in range(strength - 1):
                at += delta
                kind = terrain[at]
                if kind == RIGID:
                    break
                reached.append(at)
                if kind == WOOD:
                    break
        return reached

    def _explode(self) -> None:
        timer, flame, bombs = self._BT, self._F, self._bombs
        wave = []
        for cell in bombs:
            left = timer[cell] - 1
            timer[cell] = left
            if not left or flame[cell]:
                wave.append(cell)
        if not wave:
            return
        strength, owner, direction, ammo = self._BS, self._BO, self._BD, self._ammo
        marked: set[int] = set()
        while wave:
            for cell in wave:
                ammo[owner[cell]] += 1
                timer[cell] = 0
                owner[cell] = _NONE
                direction[cell] = _NONE
                bombs.discard(cell)
            reached = set()
            for cell in wave:
                reached.update(self.blast_cells(cell, strength[cell]))
            marked |= reached
            wave = [cell for cell in reached if timer[cell]]
        self._ammo = [min(a, MAX_AMMO) for a in ammo]
        self._scalars_stale = True
        terrain = self._T
        changed = self._changed
        for cell in marked:
            if terrain[cell] != PASSAGE:
                terrain[cell] = PASSAGE  # wooden walls burn down, power-ups in a blast are lost
                changed.append(cell)
            flame[cell] = FLAME_STEPS
        self._flames |= marked

    def _judge(self) -> None:
        """End the match when at most one team has a player left (or at ``max_steps``)."""
        ended = len({team for team, a in zip(self._team, self._alive, strict=True) if a}) <= 1
        if not ended and self.max_steps is not None and self._t >= self.max_steps:
            self._truncated = ended = True
        if ended:
            self._done = True
            self._final = self.team_scores()[0].tolist()

    def team_scores(self, boards: Any = None) -> np.ndarray:
        """``float64[1, n_teams]``: as ``BoomerBoards.team_scores``."""
        big = np.iinfo(np.int64).max
        last = [-(2**63)] * self.n_teams
        for team, a, death in zip(self._team, self._alive, self._death, strict=True):
            last[team] = max(last[team], big if a else death)
        return np.array([[sum(x > y for y in last) + 0.5 * (sum(x == y for y in last) - 1) for x in last]],
                        dtype=np.float64)

    # --- what seats see --------------------------------------------------------------------------
    def _refresh(self) -> None:
        """Bring the source vector up to the board: the terrain planes when a cell changed, the
        flames, bombs and blasts, the seats' scalars, and the positions when a seat moved or died."""
        src, cells = self._src, self._cells
        if self._changed:
            terrain, shown = self._T, self._shown_terrain
            for cell in self._changed:
                shown[cell] = code = terrain[cell]
                for slot, value in zip(range(cell, 5 * cells, cells), _TERRAIN_VALUES[code], strict=True):
                    src[slot] = value
            self._changed = []
            self._reach.clear()
        if self._shown_terrain != self._T:  # a new map, or cells written from outside
            self._planes[:5] = self.terrain[0] == _TERRAIN_CODES
            self._shown_terrain[:] = self._T
            self._reach.clear()
        flames = self._flames
        if flames or self._shown_flames:
            base = 7 * cells
            for cell in self._shown_flames - flames:
                src[base + cell] = 0.0
            flame = self._F
            for cell in flames:
                src[base + cell] = _FLAME_VALUES[flame[cell]]
            self._shown_flames = set(flames)
        for slot in self._shown_bombs:
            src[slot] = 0.0
        self._shown_bombs = self._bomb_planes() if self._bombs else []
        if self._scalars_stale:
            self._write_scalars()
        alive, pos = self._alive, self._pos
        if alive != self._shown_alive:
            mark, shown = self._mark, self._shown_pos
            seen = [seat for seat, a in enumerate(self._shown_alive) if a]
            for i in seen:
                for j in seen:
                    src[mark[i][j] + shown[j]] = 0.0
            seen = [seat for seat in range(self.n_seats) if alive[seat]]
            for i in seen:
                for j in seen:
                    src[mark[i][j] + pos[j]] = 1.0
            for i, a in enumerate(alive):
                self._obs_index[0, i] = self._index[0, i] if a else self._zero
            self._shown_alive, self._shown_pos = list(alive), list(pos)
        elif pos != self._shown_pos:
            # the seats that moved: every viewer's mark leaves the old cell, then lands on the new one
            mark, shown, seen = self._mark, self._shown_pos, [seat for seat in range(self.n_seats) if alive[seat]]
            moved = [j for j in seen if pos[j] != shown[j]]
            for j in moved:
                for i in seen:
                    src[mark[i][j] + shown[j]] = 0.0
            for j in moved:
                for i in seen:
                    src[mark[i][j] + pos[j]] = 1.0
            self._shown_pos = list(pos)

    def _write_scalars(self) -> None:
        """The seats' alive flag, ammo / 10, blast strength / 10 and kick (zeros for the dead)."""
        src, base = self._src, self._scalar_base
        for alive, ammo, strength, kick in zip(self._alive, self._ammo, self._strength, self._kick, strict=True):
            if alive:
                src[base] = 1.0
                src[base + 1] = ammo / MAX_AMMO
                src[base + 2] = strength / MAX_STRENGTH
                src[base + 3] = kick
            else:
                src[base] = src[base + 1] = src[base + 2] = src[base + 3] = 0.0
            base += PER_AGENT
        self._scalars_stale = False

    def _blast_slots(self, cell: int) -> tuple[list[int], frozenset[int]]:
        """The blast plane's slots of the blast of the bomb on ``cell`` and the cells its arms reach (kept
        until the terrain changes)."""
        key = cell * 16 + self._BS[cell]
        found = self._reach.get(key)
        if found is None:
            cells = self.blast_cells(cell, self._BS[cell])
            found = self._reach[key] = ([6 * self._cells + x for x in cells], frozenset(cells[1:]))
        return found

    def _bomb_planes(self) -> list[int]:
        """Write the bomb and blast planes; return the slots written."""
        src, timer = self._src, self._BT
        bombs = self._bombs
        if len(bombs) == 1:
            (cell,) = bombs
            slots = self._blast_slots(cell)[0]
            value = _INVERSE[timer[cell]]
            for slot in slots:
                src[slot] = value
            src[5 * self._cells + cell] = value
            return [*slots, 5 * self._cells + cell]
        blasts = {cell: self._blast_slots(cell) for cell in bombs}
        at = {cell: timer[cell] for cell in bombs}
        if not all(bombs.isdisjoint(arms) for _, arms in blasts.values()):
            # a bomb in another's blast goes off with it: the bombs in order of their timers, each setting
            # off the bombs its blast reaches (and theirs) before the next goes off on its own
            went: set[int] = set()
            for source in sorted(bombs, key=timer.__getitem__):
                if source in went:
                    continue
                went.add(source)
                chain = [source]
                while chain:
                    for other in blasts[chain.pop()][1] & bombs:
                        if other not in went:
                            went.add(other)
                            at[other] = at[source]
                            chain.append(other)
        # the blast plane holds each cell's earliest blast: written latest first, the earliest write stays
        slots = []
        for cell in sorted(bombs, key=at.__getitem__, reverse=True):
            value = _INVERSE[at[cell]]
            blast = blasts[cell][0]
            for slot in blast:
                src[slot] = value
            slots += blast
        base = 5 * self._cells
        for cell in bombs:
            src[base + cell] = _INVERSE[timer[cell]]
            slots.append(base + cell)
        return slots

    def observe(self) -> np.ndarray:
        """``float32[1, S, obs_dim]``: as ``BoomerBoards.observe``."""
        self._refresh()
        return self._values.take(self._obs_index)

    def state(self) -> np.ndarray:
        """``float32[1, state_dim]``: as ``BoomerBoards.state``."""
        self._refresh()
        state = np.empty((1, self.state_dim), dtype=np.float32)
        split = N_BOARD_PLANES * self.n_cells
        np.take(self._values, self._state_index, out=state[0, :split])
        per: list[float] = []
        for a, ammo, strength, kick, cell in zip(self._alive, self._ammo, self._strength, self._kick, self._pos,
                                                 strict=True):
            per += (1.0, ammo / MAX_AMMO, strength / MAX_STRENGTH, float(kick), *self._row_col[cell]) if a \
                else (0.0,) * STATE_PER_AGENT
        state[0, split:] = per
        return state

    def board_cell(self, padded: Any) -> np.ndarray:
        """Board cells (``row * size + col``) of padded cells."""
        row, col = np.divmod(np.asarray(padded), self.side)
        return (row - 1) * self.size + (col - 1)

    def grid(self, board: int = 0) -> np.ndarray:
        """``int64[size, size]`` terrain codes (0 passage, 1 rigid, 2 wood, 3..5 power-ups)."""
        return self.terrain[int(board), self._inner].astype(np.int64).reshape(self.size, self.size)

    # --- the seats, as BoomerBoards' one-board arrays (copies) --------------------------------
    position = _one_board("_pos", np.int64)
    alive = _one_board("_alive", bool)
    ammo = _one_board("_ammo", np.int64)
    strength = _one_board("_strength", np.int64)
    can_kick = _one_board("_kick", bool)
    death_step = _one_board("_death", np.int64)
    picked = _one_board("_picked", bool)
    died = _one_board("_died", bool)
    laid = _one_board("_laid", bool)
    kicked = _one_board("_kicked", bool)
    t = _one_board("_t", np.int64)
    done = _one_board("_done", bool)
    truncated = _one_board("_truncated", bool)

    @property
    def final_scores(self) -> np.ndarray:
        return np.array([self._final if self._final is not None else [np.nan] * self.n_teams], dtype=np.float64)
