"""Snake: several snakes on one grid eat food and grow; on a collision the shorter snake dies.

One of the grid games of Song et al., "Arena: A General Evaluation Platform and Building Toolkit
for Multi-Agent Intelligence" (AAAI 2020), built as a batched numpy engine. Ids:
``Snake-2T1P-v1``, ``Snake-4T1P-v1`` and ``Snake-2T2P-v1`` (teams of two snakes).

Board and start
---------------
A ``size x size`` grid (default 20) walled all round. Snakes start ``start_length`` cells long
(default 3) in rotationally symmetric places: snake 0's head at row ``size // 2``, column
``size // 4``, heading up with its body below; every other snake holds the same place on the
board turned by a number of quarter turns (2 snakes: 0 and 2 quarter turns; 4 snakes: 0, 1, 2, 3; in 2T2P
teammates face each other across the centre: seats 0, 1, 2, 3 turned by 0, 2, 1, 3).
``n_food`` food items (default: snakes + 1) lie on random empty cells.

Each seat's frame
-----------------
Every seat sees and acts in *its own frame*: the board turned back by its quarter turns, so that
each seat starts where seat 0 starts, heading "up". One policy can play any seat.

Actions
-------
Discrete 4, in the seat's own frame: 0 up, 1 right, 2 down, 3 left. A reversal (the direction
opposite to the current heading, i.e. into one's own neck) continues straight instead. Every
action is always legal (``action_mask()`` is ``None``); dead seats' actions are ignored.

One step, exactly
-----------------
1. Every living snake turns (or not) and moves its head one cell.
2. A head that leaves the board dies (``wall``).
3. A snake whose head enters food grows: its tail stays this step.
4. Collisions are judged against everyone's position *after* the move (tails that move away free
   their cell; tails of growing snakes do not; snakes dying this step still count as obstacles):
   * a head in one's own body dies (``self``);
   * a head in another snake's body or head (including two heads on one cell, and two heads that
     swap cells) is a collision between the two snakes: the *shorter* one dies, both die when
     they are equally long (``collision``). Lengths are those at the start of the step. With more
     than two snakes in one cell every pair is judged and every loser dies.
5. A surviving snake that entered food eats it (it is one longer); eaten food reappears at once on
   a random empty cell (positions drawn from the match seed, so a match replays exactly).
   Food entered by a snake that dies stays where it is.
6. Dead snakes leave the board at once.

The match ends when at most one team has a living snake, or at ``max_cycles`` (default 500).

Observation (``float32``, per seat, in its own frame; ``W = 2 * view_radius + 1`` = 7)
------------------------------------------------------------------------------------
====================================  ============================================================
index                                 content
====================================  ============================================================
``0``                                 alive (active) flag; a dead seat's whole row is 0
``1, 2``                              head row, column in the seat's frame, scaled to [-1, 1]
``3 .. 6``                            heading one-hot (up, right, down, left)
``7``                                 length / size
``8, 9``                              nearest food (Manhattan) relative to the head: rows, columns
                                      (down and right positive) / (size - 1); 0, 0 without food
``10``                                distance to that food / (2 (size - 1)); 1 without food
``11 .. 14``                          per action: the cell it leads to is a wall or a body now
``15 .. 18``                          per action: another living snake's head is next to that cell
``19 .. 22``                          per action: room past that cell, the free cells among its
                                      other three neighbours / 3 (0: a dead end)
``23 ..`` (``6 W^2`` values)          local window centred on the head, ``W x W`` row-major per
                                      channel (row 0 is the seat's "up"): wall (off-board), own body,
                                      teammates' bodies, opponents' bodies, other snakes' heads,
                                      food; the head itself is the window's centre
then, for each other snake            head position relative to mine (rows, columns) / (size - 1),
(teammates first, then opponents,     length / size, alive flag; all 0 for a dead snake
both in seat order), 4 values
====================================  ============================================================

Size: ``23 + 6 W^2 + 4 (snakes - 1)``: 321 for two snakes, 329 for four (W = 7).

Bounds (the observation space): every cell lies in [0, 1] but the positions (cells 1, 2, 8, 9 and
each other snake's relative head), in [-1, 1], and the lengths / size (cell 7 and each other
snake's length), in [0, size]: a snake is at most ``size * size`` cells long. The board bounds all
of them; nothing is clipped.

Global state: per snake a plane of ``size * size`` (1.0 head, 0.5 body), a food plane, then per
snake alive, length / size, heading one-hot, head row and column scaled to [-1, 1] (board frame);
bounds [0, 1], length / size in [0, size] and head row and column in [-1, 1].

Measures: ``active`` and ``alive`` (the snake lives), ``resource_gain`` (food eaten this step,
0 or 1), ``target_distance`` (Manhattan distance from the head to the nearest food after the
step; frozen when the snake dies), ``velocity_to_target`` (+1 / -1 when this step's move brought
the head nearer to / farther from the nearest food *as it lay before the move*, so eating counts
+1 and the food reappearing elsewhere costs nothing; 0 for dead snakes), ``outcome`` (at the end:
``2 * team_result / (teams - 1) - 1``: +1 win, 0 draw, -1 loss with two teams).

``team_result()`` ranks teams by survival: teams with a living snake first, the others by the
step their last snake died (later is better), ties broken by the team's total length (at death
for dead snakes); a team scores the number of teams it beats plus 0.5 per team tied with it
(two teams: 1 / 0.5 / 0).

Default social tree: a CP ``ranking`` root with order ``"survive"`` (scale 10) over the teams
(the agents in 1P layouts, NL nodes of two agents in 2T2P), and on every agent an IS
``velocity_to_target`` leaf (scale 0.02): heading for food is one's own affair, outliving the
others is the competition.

Heuristic (deterministic, from the observation's first 23 values): among the 4 actions, avoid
any whose cell is a wall or a body, then a dead end (no free cell past it), then any next to
another snake's head, then prefer a move toward the nearest food (along the axis with the larger
offset first), then going straight. It outlives uniformly random play in about 19 of 20 matches.

Search agent (``scripted:search-wW-r1-hH[-eE]``, :func:`search_moves`): a search over the seat's
own moves in its window, from the observation alone (the others held still). Its candidates are the
``W`` distinct moves the heuristic likes best (``W`` = 1 is the heuristic; 3 or more, every move).
From each it searches ``H`` moves deep, breadth first, for the free window cells it can reach (a
reach to the window's edge counts as enough room), and scores the move by that room (up to ``2 H``
cells), by a kill (+40: an opponent's body cell entered while longer than every other living snake,
which the collision rule decides for the mover), against a threat (-50: a head of a snake at least as
long next to the cell; a seen head is told apart by the direction of the others' relative positions)
and toward the nearest food (+1 closer, 0 across, -1 away); a blocked cell is never entered but for a
kill. Ties go to the heuristic's order. With probability ``E`` (the seat's uniform) it plays the
heuristic's move instead. It has no rollouts (``R`` must be 1): the window holds no one else's moves.
In 400 matches of 2T2P (teams swapped halfway) ``search-w3-r1-h4`` scores 0.87 against the heuristic.

Game kwargs: ``size`` (default 20, at least 8), ``n_food`` (default snakes + 1),
``start_length`` (default 3, 1 .. size // 4), ``view_radius`` (default 3: a 7 x 7 window, at most
``size``), declared in ``SnakeRules.options`` (listed by ``arena-league games``).

Batched engine
--------------
:class:`SnakeBoards` steps many boards at once with whole-array numpy operations: every body
cell stores the step its snake's head entered it, so a cell belongs to snake ``o`` while
``t - stamp < length[o]``; growing, moving tails and removing dead snakes touch no grid at all::

    boards = SnakeBoards(n_boards=4096, n_snakes=2, seed=0, autoreset=True)
    while True:
        boards.step(boards.random_actions())   # int64[B, n_snakes], each in its snake's frame
        boards.done, boards.final_scores       # boards that ended on this step, their team scores

* ``SnakeBoards(n_boards, n_snakes=2, size=20, n_food=None, start_length=3, view_radius=3,
  team_of=None, rotations=None, autoreset=False, max_steps=None, seed=0)``; ``team_of[s]`` is
  snake ``s``'s team (default: one team each), ``rotations[s]`` its quarter turns.
* ``reset(boards=None, keys=None)``: new matches on every board (or those indexed); each board's
  random key comes from the engine's generator unless ``keys`` (``uint64``) are given. A board's
  whole match is a function of its key and the actions, whatever else is in the batch.
* ``set_board(board, bodies, food=(), directions=None)``: put a position on one board (bodies
  as lists of board cells, head first).
* ``step(actions: int64[B, n_snakes])``: one step of every unfinished board (finished boards
  ignore their actions unless ``autoreset``).
* ``observe() -> float32[B, n_snakes, obs_dim]``; ``state() -> float32[B, state_dim]``;
  ``team_scores(boards=None) -> float64[B, n_teams]``; ``random_actions() -> int64[B, n_snakes]``.
* State: ``head``, ``direction`` (board frame), ``length``, ``alive`` (all ``[B, n_snakes]``),
  ``food int64[B, n_food]`` (cell or -1), ``t int64[B]``; this step's ``ate``, ``died``,
  ``death_cause`` (0 none, 1 wall, 2 self, 3 collision), ``toward_food`` (the
  ``velocity_to_target`` measure), ``food_distance``; ``done``, ``truncated`` (``max_steps``).
* ``autoreset=True``: a board whose match ends is started afresh at the end of that ``step``;
  ``done``, ``truncated`` and ``final_scores`` report the finished match until the next ``step``.

:class:`SnakeMatches` is the match engine's whole-array path (``SnakeRules.batched_matches``):
many matches of one layout on one ``SnakeBoards`` built like the rules' own one-board engine, each
match's board key drawn from its seed exactly as ``SnakeRules.reset`` draws it.

Playing it (``arena-league play``)
----------------------------------
The board is drawn in text: ``#`` wall, ``*`` food, your snake ``@`` (head) and ``o`` (body), the
others ``A``/``a``, ``B``/``b``, ... with every snake's length. A move is ``w``, ``a``, ``s`` or
``d`` (or ``up``, ``left``, ``down``, ``right``) on the board *as drawn*, turned into the seat's own
frame for you; Enter keeps going straight. Once your snake is dead you watch the others finish.

Rendering
---------
A top-down picture of the board (``320 // size`` pixels a cell, at least 4) in a dark frame: every
snake's body in its team's colour, a living snake's head darker, the food in magenta.
``render_mode="rgb_array"`` returns it; ``"human"`` shows it in a window.

Replay scene
------------
The walled grid, every snake's body cells (cubes in its team's colour, the head taller) and the
food (spheres): entities ``grid``, ``snake/<seat>`` and ``food``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from arena_league.envs import scene
from arena_league.envs.boards import BoardSlots, OneBoard, reset_keys
from arena_league.envs.controls import Controls, arrow_keys, key_controls
from arena_league.envs.core import GameRules, Measures, cell_bounds
from arena_league.envs.options import Option
from arena_league.envs.rendering import TEAM_COLOURS, grid_picture
from arena_league.envs.social import team_groups

#: Action meanings, in each seat's own frame; the board direction is (action + quarter turns) % 4.
DIRECTIONS: tuple[str, ...] = ("up", "right", "down", "left")
DROW = np.array([-1, 0, 1, 0], dtype=np.int64)
DCOL = np.array([0, 1, 0, -1], dtype=np.int64)
#: R^q as matrices acting on (row, col) vectors: R turns "up" into "right" (a clockwise quarter).
ROTATIONS = np.array([[[1, 0], [0, 1]], [[0, 1], [-1, 0]], [[-1, 0], [0, -1]], [[0, -1], [1, 0]]], dtype=np.int64)
N_HEADER = 23
N_CHANNELS = 6
PER_OTHER = 4
CHANNELS: tuple[str, ...] = ("wall", "own body", "teammates' bodies", "opponents' bodies", "other heads", "food")
DEATH_CAUSES: dict[int, str] = {1: "wall", 2: "self", 3: "collision"}
#: Default quarter turns of the snakes' starting places, by number of snakes.
DEFAULT_ROTATIONS: dict[int, tuple[int, ...]] = {1: (0,), 2: (0, 2), 3: (0, 1, 2), 4: (0, 1, 2, 3)}
_SPAWN_TRIES = 16
#: Game options bounded above by the board's side (the others are declared on the rules).
START_LENGTH = Option("start_length", int, 3, "cells of each snake at the start; at most size // 4", low=1)
VIEW_RADIUS = Option("view_radius", int, 3, "cells each seat sees around its head, 3 for a 7 x 7 "
                     "window; at most size", low=1)
_WALL, _EMPTY = -2, -1  # owner codes of cells without a snake
_NEVER = np.iinfo(np.int64).max  # a body threshold no stamp exceeds
_NEVER32 = np.iinfo(np.int32).max

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


def _splitmix64(x: np.ndarray) -> np.ndarray:
    """The SplitMix64 finaliser, element-wise on ``uint64`` arrays (wrapping arithmetic)."""
    z = x + _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


def _draw(keys: np.ndarray, counter: np.ndarray, attempt: int) -> np.ndarray:
    """Counter-based random ``uint64`` per board: a function of (key, counter, attempt) only, so a
    board's food falls the same whether it is stepped alone or among thousands."""
    mixed = counter.astype(np.uint64) * np.uint64(_SPAWN_TRIES + 1) + np.uint64(attempt)
    return _splitmix64(keys ^ _splitmix64(mixed))


def _turn_cells(q: np.ndarray, rows: np.ndarray, cols: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Cells turned by ``q`` quarter turns about the board centre."""
    x, y = 2 * rows - (size - 1), 2 * cols - (size - 1)
    m = ROTATIONS[q % 4]
    xr = m[..., 0, 0] * x + m[..., 0, 1] * y
    yr = m[..., 1, 0] * x + m[..., 1, 1] * y
    return (xr + size - 1) // 2, (yr + size - 1) // 2


def _any_of(flags: list[np.ndarray], shape: tuple[int, ...]) -> np.ndarray:
    """Element-wise OR of a few same-shaped bool arrays (numpy's reduce over a short trailing axis
    is much slower than a handful of whole-array ORs)."""
    out = np.zeros(shape, dtype=bool)
    for flag in flags:
        out |= flag
    return out


def _positive_int(name: str, value: Any, low: int, high: int | None = None, hint: str = "") -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low or (
            high is not None and value > high):
        span = f">= {low}" if high is None else f"in {low}..{high}"
        raise ValueError(f"{name} must be an integer {span}, not {value!r}{hint}")
    return int(value)


class SnakeBoards:
    """``n_boards`` Snake matches stepped together (see the module docstring for the API).

    Internally each board is padded with a wall border ``max(view_radius, 2)`` cells wide (``owner`` -2),
    so moves and observation windows never need a bounds check; ``head`` and ``food`` are given
    in board cells (``row * size + col``).
    """

    def __init__(self, n_boards: int, n_snakes: int = 2, size: int = 20, n_food: int | None = None,
                 start_length: int = 3, view_radius: int = 3, team_of: Any = None, rotations: Any = None,
                 autoreset: bool = False, max_steps: int | None = None, seed: int = 0) -> None:
        self.n_boards = _positive_int("n_boards", n_boards, 1)
        self.n_snakes = _positive_int("n_snakes", n_snakes, 1, 4, " (snakes start in the 4 quarter-turned places)")
        self.size = _positive_int("size", size, 8)
        self.n_food = self.n_snakes + 1 if n_food is None else _positive_int("n_food", n_food, 0)
        self.start_length = _positive_int("start_length", start_length, 1, self.size // 4,
                                          f" (at most size // 4 = {self.size // 4} on a {self.size}-board)")
        self.view_radius = _positive_int("view_radius", view_radius, 1, self.size)
        self.max_steps = None if max_steps is None else _positive_int("max_steps", max_steps, 1)
        self.autoreset = bool(autoreset)
        self.rng = np.random.default_rng(seed)
        s = self.n_snakes
        self.team_of = np.arange(s, dtype=np.int64) if team_of is None else np.asarray(team_of, dtype=np.int64)
        if self.team_of.shape != (s,) or self.team_of.min() < 0:
            raise ValueError(f"team_of must give a team index >= 0 for each of the {s} snakes, not {team_of!r}")
        self.n_teams = int(self.team_of.max()) + 1
        self.rotations = np.asarray(DEFAULT_ROTATIONS[s] if rotations is None else rotations, dtype=np.int64)
        if self.rotations.shape != (s,) or len(set(self.rotations.tolist())) != s or not np.isin(
                self.rotations, np.arange(4)).all():
            raise ValueError(f"rotations must give distinct quarter turns 0..3 for each of the {s} snakes, "
                             f"not {rotations!r}")
        self.n_cells = self.size * self.size
        self.window = 2 * self.view_radius + 1
        self.obs_dim = N_HEADER + N_CHANNELS * self.window ** 2 + PER_OTHER * (s - 1)
        self.state_dim = (s + 1) * self.n_cells + 8 * s
        self._pad = max(self.view_radius, 2)  # moves and the room look-ahead reach 2 cells out
        self._side = self.size + 2 * self._pad  # padded side
        self._build_tables()
        b, f, cells = self.n_boards, self.n_food, self._side ** 2
        self._boards = np.arange(b)
        self._snakes = np.arange(s)
        self._cell_offset = self._boards * cells
        self._snake_offset = self._boards * s
        self.owner = np.empty((b, cells), dtype=np.int8)  # -2 wall, -1 empty, else the snake
        self.stamp = np.zeros((b, cells), dtype=np.int32)  # the step a head entered the cell
        self._bind_grid_views()
        self._head = np.zeros((b, s), dtype=np.int64)  # padded cells
        self._food = np.full((b, f), -1, dtype=np.int64)  # padded cells, -1 for none
        self.direction = np.zeros((b, s), dtype=np.int64)
        self.length = np.zeros((b, s), dtype=np.int64)
        self.alive = np.zeros((b, s), dtype=bool)
        self.t = np.zeros(b, dtype=np.int64)
        self.keys = np.zeros(b, dtype=np.uint64)
        self.spawns = np.zeros(b, dtype=np.int64)
        self.done = np.zeros(b, dtype=bool)
        self.truncated = np.zeros(b, dtype=bool)
        self.ate = np.zeros((b, s), dtype=bool)
        self.died = np.zeros((b, s), dtype=bool)
        self.death_cause = np.zeros((b, s), dtype=np.int8)
        self.death_step = np.full((b, s), -1, dtype=np.int64)
        self.toward_food = np.zeros((b, s), dtype=np.int64)
        self.food_distance = np.zeros((b, s), dtype=np.int64)
        self.final_scores = np.full((b, self.n_teams), np.nan)
        self.reset()

    #: Views of ``owner`` and ``stamp``: made again on unpickling, so that they share the grids' memory.
    _GRID_VIEWS = ("_owner_flat", "_stamp_flat", "_owner_windows", "_stamp_windows")

    def _bind_grid_views(self) -> None:
        b, w, side = self.n_boards, self.window, self._side
        self._owner_flat = self.owner.reshape(-1)
        self._stamp_flat = self.stamp.reshape(-1)
        # every W x W block of the grids, as views (the grids are only ever updated in place)
        self._owner_windows = sliding_window_view(self.owner.reshape(b, side, side), (w, w), axis=(1, 2))
        self._stamp_windows = sliding_window_view(self.stamp.reshape(b, side, side), (w, w), axis=(1, 2))

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        for name in self._GRID_VIEWS:
            del state[name]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._bind_grid_views()

    def _build_tables(self) -> None:
        n, s, q, pad, side = self.size, self.n_snakes, self.rotations, self._pad, self._side
        rows, cols = np.divmod(np.arange(self.n_cells), n)
        self._inner = (rows + pad) * side + (cols + pad)  # board cell -> padded cell
        template = np.full((side, side), _WALL, dtype=np.int8)
        template[pad:pad + n, pad:pad + n] = _EMPTY
        self._owner_template = template.reshape(-1)
        self._delta = DROW * side + DCOL  # padded-cell step of each direction
        # snake 0's starting body (head first), turned for each snake
        rows0 = n // 2 + np.arange(self.start_length)
        cols0 = np.full(self.start_length, n // 4)
        r, c = _turn_cells(q[:, None], rows0[None, :], cols0[None, :], n)
        self._start_cells = (r + pad) * side + (c + pad)  # [S, L]
        self._start_direction = q.copy()
        self._frame_turn = (4 - q) % 4  # board -> own frame
        self._frame_matrix = ROTATIONS[self._frame_turn].reshape(s, 4).T.copy()  # m00, m01, m10, m11 per snake
        # window cell order of each snake's frame: its block turned by its quarter turns
        square = np.arange(self.window ** 2).reshape(self.window, self.window)
        self._window_turn = np.concatenate([s * square.size + np.rot90(square, int(k)).reshape(-1)
                                            for s, k in enumerate(q)])  # [S * W^2], into [S, W^2] blocks
        same_team = self.team_of[:, None] == self.team_of[None, :]
        # the others in each snake's observation: teammates first, then opponents, in seat order
        others = []
        for i in range(s):
            mates = [j for j in range(s) if j != i and same_team[i, j]]
            rivals = [j for j in range(s) if not same_team[i, j]]
            others.append(mates + rivals)
        self._others = np.array(others, dtype=np.int64).reshape(s, s - 1)
        self._team_onehot = self.team_of[:, None] == np.arange(self.n_teams)[None, :]  # [S, T]
        self._team_members = [np.flatnonzero(self.team_of == t) for t in range(self.n_teams)]

    # --- board cells ----------------------------------------------------------------------------
    def _to_frame(self, drow: np.ndarray, dcol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(row, col) vectors ``[B, S, ...]`` of each snake turned into its own frame."""
        shape = (1, self.n_snakes) + (1,) * (drow.ndim - 2)
        m = self._frame_matrix
        return (m[0].reshape(shape) * drow + m[1].reshape(shape) * dcol,
                m[2].reshape(shape) * drow + m[3].reshape(shape) * dcol)

    def _to_board(self, padded: np.ndarray) -> np.ndarray:
        row, col = np.divmod(padded, self._side)
        return (row - self._pad) * self.size + (col - self._pad)

    @property
    def head(self) -> np.ndarray:
        """``int64[B, n_snakes]``: each head's board cell ``row * size + col`` (board frame)."""
        return self._to_board(self._head)

    @property
    def food(self) -> np.ndarray:
        """``int64[B, n_food]``: each food item's board cell, -1 for none."""
        return np.where(self._food >= 0, self._to_board(self._food), -1)

    # --- matches -----------------------------------------------------------------------------
    def reset(self, boards: Any = None, keys: Any = None) -> None:
        """Start new matches on every board, or on the boards indexed by ``boards``."""
        sel, keys = reset_keys(self._boards, self.rng, boards, keys)
        length = self.start_length
        self.owner[sel] = self._owner_template
        self.stamp[sel] = 0
        for i in range(self.n_snakes):
            self.owner[sel[:, None], self._start_cells[i][None, :]] = i
            self.stamp[sel[:, None], self._start_cells[i][None, :]] = -np.arange(length)[None, :]
        self._head[sel] = self._start_cells[:, 0]
        self.direction[sel] = self._start_direction
        self.length[sel] = length
        self.alive[sel] = True
        self.t[sel] = 0
        self.keys[sel] = keys
        self.spawns[sel] = 0
        self.done[sel] = False
        self.truncated[sel] = False
        self.ate[sel] = False
        self.died[sel] = False
        self.death_cause[sel] = 0
        self.death_step[sel] = -1
        self.toward_food[sel] = 0
        self.final_scores[sel] = np.nan
        self._food[sel] = -1
        self._fill_food(sel)
        food_row, food_col = self._food_rows_cols()
        row, col = np.divmod(self._head[sel], self._side)
        self.food_distance[sel] = self._nearest_food(row, col, food_row[sel], food_col[sel])

    def set_board(self, board: int, bodies: Sequence[Sequence[int]], food: Sequence[int] = (),
                  directions: Sequence[int] | None = None) -> None:
        """Set up a position on one board (puzzles, tests): ``bodies[s]`` lists snake ``s``'s
        board cells (``row * size + col``) head first, each next to the one before; an empty list
        leaves that snake dead. ``food`` lists food cells (remaining slots are filled at random);
        ``directions[s]`` is a heading in the board frame (default: from the neck to the head,
        up for a one-cell snake). The board's step counter restarts at 0."""
        b = int(board)
        if not 0 <= b < self.n_boards:
            raise ValueError(f"board {board!r} is not one of 0..{self.n_boards - 1}")
        if len(bodies) != self.n_snakes:
            raise ValueError(f"set_board needs one body (a list of cells, head first) for each of the "
                             f"{self.n_snakes} snakes, got {len(bodies)}")
        n = self.size
        seen: set[int] = set()
        for s, body in enumerate(bodies):
            previous = None
            for cell in map(int, body):
                if not 0 <= cell < self.n_cells:
                    raise ValueError(f"snake {s}: cell {cell} is off the board (cells are 0..{self.n_cells - 1})")
                if cell in seen:
                    raise ValueError(f"snake {s}: cell {cell} is already taken; bodies cannot overlap")
                seen.add(cell)
                if previous is not None and abs(cell // n - previous // n) + abs(cell % n - previous % n) != 1:
                    raise ValueError(f"snake {s}: cells {previous} and {cell} are not neighbours")
                previous = cell
        if len(food) > self.n_food or any(int(f) in seen or not 0 <= int(f) < self.n_cells for f in food):
            raise ValueError(f"food must be at most {self.n_food} free board cells, not {list(food)}")
        self.owner[b] = self._owner_template
        self.stamp[b] = 0
        self.t[b] = 0
        for s, body in enumerate(bodies):
            cells = self._inner[np.asarray(body, dtype=np.int64)]
            self.owner[b, cells] = s
            self.stamp[b, cells] = -np.arange(len(body))
            self.length[b, s] = len(body)
            self.alive[b, s] = len(body) > 0
            self.death_step[b, s] = -1 if len(body) else 0
            if len(body):
                self._head[b, s] = cells[0]
                if directions is not None:
                    self.direction[b, s] = int(directions[s]) % 4
                elif len(body) > 1:
                    dr, dc = body[0] // n - body[1] // n, body[0] % n - body[1] % n
                    self.direction[b, s] = int(np.flatnonzero((dr == DROW) & (dc == DCOL))[0])
                else:
                    self.direction[b, s] = 0
        self._food[b] = -1
        self._food[b, :len(food)] = self._inner[np.asarray(food, dtype=np.int64)]
        self._fill_food(np.array([b]))
        self.done[b] = self.truncated[b] = False
        self.ate[b] = self.died[b] = False
        self.death_cause[b] = 0
        self.toward_food[b] = 0
        food_row, food_col = self._food_rows_cols(np.array([b]))
        row, col = np.divmod(self._head[b:b + 1], self._side)
        self.food_distance[b] = self._nearest_food(row, col, food_row, food_col)[0]

    def random_actions(self) -> np.ndarray:
        """Uniform random actions (every action is legal), from the engine's generator."""
        return self.rng.integers(4, size=(self.n_boards, self.n_snakes))

    def step(self, actions: np.ndarray) -> None:
        """One step of every unfinished board; ``actions[b, s]`` is in snake ``s``'s own frame."""
        actions = np.asarray(actions)
        if actions.shape != (self.n_boards, self.n_snakes) or actions.dtype.kind not in "iu":
            raise ValueError(f"SnakeBoards.step takes integer actions of shape ({self.n_boards}, {self.n_snakes}); "
                             f"got shape {actions.shape} dtype {actions.dtype}")
        if actions.size and (actions.min() < 0 or actions.max() > 3):
            raise ValueError("Snake actions are 0 up, 1 right, 2 down, 3 left (in the snake's own frame); "
                             f"got {int(actions.min()) if actions.min() < 0 else int(actions.max())}")
        if self.autoreset:
            self.done[:] = False
            self.truncated[:] = False
        n_snakes, n_boards = self.n_snakes, self.n_boards
        live = ~self.done
        moving = self.alive & live[:, None]
        # 1. turn (a reversal continues straight) and move the heads
        wanted = (actions + self.rotations) % 4
        direction = np.where(moving & (wanted != (self.direction + 2) % 4), wanted, self.direction)
        new_head = np.where(moving, self._head + self._delta[direction], self._head)
        flat = self._cell_offset[:, None] + new_head
        owner = self._owner_flat[flat].astype(np.int64)
        # 2. walls
        wall = moving & (owner == _WALL)
        moved = moving & ~wall
        new_row, new_col = np.divmod(new_head, self._side)
        before = self.food_distance  # kept up to date for living snakes
        after = self._nearest_food(new_row, new_col, *self._food_rows_cols())
        # 3. growth: a head entering food keeps its tail this step
        on_food = [new_head == self._food[:, j, None] for j in range(self.n_food)]
        grows = moved & _any_of(on_food, moved.shape)
        grown_length = self.length + grows
        t1 = self.t + 1
        # 4. collisions against the bodies after everyone's move
        occupied = moved & (self._stamp_flat[flat] > self._body_threshold(t1, grown_length, owner))
        other = np.maximum(owner, 0)
        own_body = occupied & (other == self._snakes)
        hit = occupied & ~own_body
        start_length = self.length
        their_length = np.take(start_length, self._snake_offset[:, None] + other)
        dies = wall | own_body | (hit & (start_length <= their_length))
        beaten = hit & (start_length >= their_length)  # the snake whose body was entered dies
        if beaten.any():
            bumped = np.flatnonzero(beaten.any(axis=1))
            for k in range(n_snakes):
                dies[bumped, k] |= (beaten[bumped] & (other[bumped] == k)).any(axis=1)
        for i in range(n_snakes):
            for k in range(i + 1, n_snakes):
                same_cell = moved[:, i] & moved[:, k] & (new_head[:, i] == new_head[:, k])
                dies[:, i] |= same_cell & (start_length[:, i] <= start_length[:, k])
                dies[:, k] |= same_cell & (start_length[:, k] <= start_length[:, i])
        died = moving & dies
        survive = moving & ~dies
        # 5. survivors move in and eat
        ate = survive & grows
        boards, snakes = np.nonzero(survive)
        self._owner_flat[flat[boards, snakes]] = snakes
        self._stamp_flat[flat[boards, snakes]] = t1[boards]
        self._head = np.where(survive, new_head, self._head)
        self.direction = np.where(survive, direction, self.direction)
        self.length = self.length + ate
        self.alive = self.alive & ~died
        self.t = np.where(live, t1, self.t)
        self.ate = ate
        self.died = died
        self.death_cause = np.where(died, np.where(wall, 1, np.where(own_body, 2, 3)), 0).astype(np.int8)
        self.death_step = np.where(died, t1[:, None], self.death_step)
        self.toward_food = np.where(survive & (before < self._no_food), before - after, 0)
        distance = after
        if ate.any():
            fed = np.flatnonzero(ate.any(axis=1))
            food = self._food[fed]
            food[((food[:, None, :] == new_head[fed][:, :, None]) & ate[fed][:, :, None]).any(axis=1)] = -1
            self._food[fed] = food
            self._fill_food(fed)
            distance = after.copy()
            distance[fed] = self._nearest_food(new_row[fed], new_col[fed], *self._food_rows_cols(fed))
        self.food_distance = np.where(self.alive, distance, self.food_distance)
        # the end: at most one team left (none, when playing alone), or out of steps
        teams_alive = np.zeros(n_boards, dtype=np.int64)
        for members in self._team_members:
            teams_alive += _any_of([self.alive[:, i] for i in members], (n_boards,))
        ended = live & (teams_alive <= (1 if self.n_teams > 1 else 0))
        truncated = live & ~ended & (self.t >= self.max_steps) if self.max_steps else np.zeros_like(ended)
        self.truncated = truncated
        self.done = self.done | ended | truncated
        finished = np.flatnonzero(ended | truncated)
        if finished.size:
            self.final_scores[finished] = self.team_scores(finished)
            if self.autoreset:
                saved = (self.done.copy(), self.truncated.copy(), self.died.copy(), self.ate.copy(),
                         self.final_scores.copy())
                self.reset(finished)
                self.done, self.truncated, self.died, self.ate, self.final_scores = saved

    # --- queries --------------------------------------------------------------------------------
    def _body_threshold(self, t: np.ndarray, length: np.ndarray, owner: np.ndarray) -> np.ndarray:
        """Per cell (``owner`` gathered from the grid): the stamp a body cell must exceed at time
        ``t`` given snake lengths ``length``. A cell holds snake ``o``'s body while
        ``stamp > t - length[o]``; dead snakes, empty cells and walls get a threshold no stamp
        exceeds."""
        width = self.n_snakes + 2
        threshold = np.empty((self.n_boards, width), dtype=np.int64)
        threshold[:, :-2] = np.where(self.alive, t[:, None] - length, _NEVER)
        threshold[:, -2:] = _NEVER
        # owner -1 / -2 land on the previous row's two trailing "never" columns (row 0 wraps to the last)
        rows = (self._boards * width).reshape((-1,) + (1,) * (owner.ndim - 1))
        return np.take(threshold, rows + owner)

    def _window_blocks(self, windows: np.ndarray, corner: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
        """``[B, S, W*W]``: each snake's ``W x W`` block of a grid (``windows``: its sliding-window
        view) whose top-left cell is ``corner``, turned by the snake's quarter turns into its own
        frame (frame offset ``(i, j)`` shows the board offset ``R^q (i, j)``: ``np.rot90`` by ``q``)."""
        blocks = windows[corner].reshape(self.n_boards, -1)  # [B, S * W*W], a copy
        return np.take(blocks, self._window_turn, axis=1).reshape(self.n_boards, self.n_snakes, -1)

    def _body_at(self, boards: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """Whether each padded cell (on its board; arrays broadcast) holds a living snake's body now."""
        flat = boards * self._side ** 2 + cells
        owner = self._owner_flat[flat].astype(np.int64)
        other = np.maximum(owner, 0)
        return (owner >= 0) & self.alive[boards, other] & (
            self.t[boards] - self._stamp_flat[flat] < self.length[boards, other])

    def _fill_food(self, boards: np.ndarray) -> None:
        """Put food on every empty food slot of ``boards``, each on a random empty cell (slots of
        one board in slot order, each draw numbered by the board's spawn counter)."""
        pending_board, pending_slot = np.nonzero(self._food[boards] < 0)
        pending_board = boards[pending_board]
        while pending_board.size:
            # one slot per board per round, so that no two draws of a round share a board
            first = np.ones(pending_board.size, dtype=bool)
            first[1:] = pending_board[1:] != pending_board[:-1]
            need, slot = pending_board[first], pending_slot[first]
            pending_board, pending_slot = pending_board[~first], pending_slot[~first]
            for attempt in range(_SPAWN_TRIES):
                draw = _draw(self.keys[need], self.spawns[need], attempt) % np.uint64(self.n_cells)
                cells = self._inner[draw.astype(np.int64)]
                taken = self._body_at(need, cells) | _any_of(
                    [self._food[need, j] == cells for j in range(self.n_food)], cells.shape)
                placed = ~taken
                self._food[need[placed], slot[placed]] = cells[placed]
                self.spawns[need[placed]] += 1
                need, slot = need[taken], slot[taken]
                if not need.size:
                    break
            for b, j in zip(need.tolist(), slot.tolist()):  # nearly full boards: pick among the free cells
                free = ~self._body_at(np.full(self.n_cells, b), self._inner)
                free &= ~np.isin(self._inner, self._food[b])
                choices = self._inner[free]
                if choices.size:
                    pick = _draw(self.keys[b:b + 1], self.spawns[b:b + 1], _SPAWN_TRIES) % np.uint64(choices.size)
                    self._food[b, j] = choices[int(pick[0])]
                    self.spawns[b] += 1

    def _food_rows_cols(self, boards: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Padded rows and columns of the food slots (of all boards, or of ``boards``); empty
        slots sit far off the board."""
        food = self._food if boards is None else self._food[boards]
        food_row, food_col = np.divmod(food, self._side)
        far = food < 0
        food_row[far] = -4 * self._side
        food_col[far] = -4 * self._side
        return food_row, food_col

    @property
    def _no_food(self) -> int:
        """The food distance reported when a board has no food."""
        return 2 * (self.size - 1)

    def _nearest_food(self, rows: np.ndarray, cols: np.ndarray, food_row: np.ndarray,
                      food_col: np.ndarray) -> np.ndarray:
        """Manhattan distance from each (row, col) ``[B, S]`` to its board's nearest food
        (``2 (size - 1)`` without food)."""
        nearest = np.full(rows.shape, self._no_food, dtype=np.int64)
        for j in range(self.n_food):
            d = np.abs(rows - food_row[:, j, None]) + np.abs(cols - food_col[:, j, None])
            np.minimum(nearest, d, out=nearest)
        return nearest

    def team_scores(self, boards: Any = None) -> np.ndarray:
        """``float64[B, n_teams]``: teams ranked by survival, then total length (module docstring)."""
        sel = self._boards if boards is None else np.asarray(boards, dtype=np.int64).reshape(-1)
        end = np.where(self.alive[sel], np.iinfo(np.int64).max, self.death_step[sel])
        team_end = np.where(self._team_onehot[None], end[:, :, None], -1).max(axis=1)
        team_length = (self.length[sel][:, :, None] * self._team_onehot[None]).sum(axis=1)
        same_end = team_end[:, :, None] == team_end[:, None, :]
        beats = (team_end[:, :, None] > team_end[:, None, :]) | (
            same_end & (team_length[:, :, None] > team_length[:, None, :]))
        ties = same_end & (team_length[:, :, None] == team_length[:, None, :])
        return beats.sum(axis=2) + 0.5 * (ties.sum(axis=2) - 1)

    def observe(self) -> np.ndarray:
        """``float32[B, n_snakes, obs_dim]``: every snake's observation in its own frame."""
        n, n_snakes, n_boards = self.size, self.n_snakes, self.n_boards
        obs = np.zeros((n_boards, n_snakes, self.obs_dim), dtype=np.float32)
        row, col = np.divmod(self._head, self._side)  # padded
        scale = 1.0 / (n - 1)
        obs[:, :, 0] = self.alive
        # the head in the own frame: the board centre-relative position turned
        frame_row, frame_col = self._to_frame(2 * (row - self._pad) - (n - 1), 2 * (col - self._pad) - (n - 1))
        frame_row, frame_col = (frame_row + n - 1) // 2, (frame_col + n - 1) // 2
        obs[:, :, 1] = frame_row * (2.0 * scale) - 1.0
        obs[:, :, 2] = frame_col * (2.0 * scale) - 1.0
        heading = (self.direction + self._frame_turn) % 4
        for d in range(4):
            obs[:, :, 3 + d] = heading == d
        obs[:, :, 7] = self.length * (1.0 / n)
        # nearest food (first slot on ties), relative, in the own frame
        food_row, food_col = self._food_rows_cols()
        best = np.full(row.shape, self._no_food + 1, dtype=np.int64)
        best_dr = np.zeros_like(row)
        best_dc = np.zeros_like(row)
        for j in range(self.n_food):
            dr = food_row[:, j, None] - row
            dc = food_col[:, j, None] - col
            d = np.abs(dr) + np.abs(dc)
            closer = d < best
            best = np.where(closer, d, best)
            best_dr = np.where(closer, dr, best_dr)
            best_dc = np.where(closer, dc, best_dc)
        found = best <= self._no_food
        vr, vc = self._to_frame(best_dr, best_dc)
        obs[:, :, 8] = vr * scale
        obs[:, :, 9] = vc * scale
        obs[:, :, 10] = np.where(found, best * (0.5 * scale), 1.0)
        # per action: the cell it leads to (a reversal goes straight) is blocked / contested
        action_dir = (np.arange(4) + self.rotations[:, None]) % 4  # [S, 4]
        action_dir = np.where(action_dir == ((self.direction + 2) % 4)[:, :, None],
                              self.direction[:, :, None], action_dir)  # [B, S, 4]
        flat = (self._cell_offset[:, None] + self._head)[:, :, None] + self._delta[action_dir]
        owner = self._owner_flat[flat].astype(np.int64)
        threshold = self._body_threshold(self.t, self.length, owner)
        obs[:, :, 11:15] = (owner == _WALL) | (self._stamp_flat[flat] > threshold)
        # room: free cells around each target, its way in (the head) excluded
        beyond = flat[:, :, :, None] + self._delta
        owner = self._owner_flat[beyond].astype(np.int64)
        free = (owner != _WALL) & (self._stamp_flat[beyond] <= self._body_threshold(self.t, self.length, owner))
        free &= beyond != (self._cell_offset[:, None] + self._head)[:, :, None, None]
        obs[:, :, 19:23] = free.sum(axis=3) * (1.0 / 3.0)
        target_row = row[:, :, None] + DROW[action_dir]
        target_col = col[:, :, None] + DCOL[action_dir]
        contested = np.zeros(target_row.shape, dtype=bool)
        for k in range(n_snakes):
            rival = (self.alive[:, k, None] & (self._snakes != k))[:, :, None]
            near = np.abs(target_row - row[:, k, None, None]) + np.abs(target_col - col[:, k, None, None]) == 1
            contested |= rival & near
        obs[:, :, 15:19] = contested
        # local window: each head's W x W block of the padded grid, turned into the own frame
        v, w = self.view_radius, self.window
        w2 = w * w
        window = obs[:, :, N_HEADER:N_HEADER + N_CHANNELS * w2].reshape(n_boards, n_snakes, N_CHANNELS, w2)
        corner = (self._boards[:, None], row - v, col - v)
        owner = self._window_blocks(self._owner_windows, corner)
        stamp = self._window_blocks(self._stamp_windows, corner)
        threshold = np.where(self.alive, self.t[:, None] - self.length, _NEVER32).astype(np.int32)
        body = np.zeros(owner.shape, dtype=bool)
        mate = np.zeros(owner.shape, dtype=bool)  # a cell of my team (me included)
        for k in range(n_snakes):
            of_k = owner == k
            body |= of_k & (stamp > threshold[:, k, None, None])
            mate |= of_k & (self.team_of[k] == self.team_of)[None, :, None]
        mine = owner == self._snakes[:, None].astype(np.int8)
        window[:, :, 0] = owner == _WALL
        window[:, :, 1] = body & mine
        window[:, :, 2] = body & ~mine & mate
        window[:, :, 3] = body & ~mate
        window[:, :, 4] = body & ~mine & (stamp == self.t[:, None, None])
        if self.n_food:
            fr, fc = self._to_frame(food_row[:, None, :] - row[:, :, None],
                                    food_col[:, None, :] - col[:, :, None])  # [B, S, F], own frame
            b, k, j = np.nonzero((np.abs(fr) <= v) & (np.abs(fc) <= v))
            window[b, k, 5, (fr[b, k, j] + v) * w + fc[b, k, j] + v] = 1.0
        # the others: teammates first, then opponents
        if n_snakes > 1:
            o = self._others  # [S, S-1]
            vr, vc = self._to_frame(row[:, o] - row[:, :, None], col[:, o] - col[:, :, None])
            others = obs[:, :, N_HEADER + N_CHANNELS * w2:].reshape(n_boards, n_snakes, n_snakes - 1, PER_OTHER)
            others[..., 0] = vr * scale
            others[..., 1] = vc * scale
            others[..., 2] = self.length[:, o] * (1.0 / n)
            others[..., 3] = 1.0
            dead_other = ~self.alive[:, o]
            if dead_other.any():
                others[dead_other] = 0.0
        dead = ~self.alive
        if dead.any():
            obs[dead] = 0.0
        return obs

    def state(self) -> np.ndarray:
        """``float32[B, state_dim]``: body planes per snake, the food plane, per-snake scalars."""
        n, s, nc = self.size, self.n_snakes, self.n_cells
        state = np.zeros((self.n_boards, self.state_dim), dtype=np.float32)
        body = self._body_at(self._boards[:, None], self._inner[None, :])
        owner = self.owner[:, self._inner]
        head = body & (self.stamp[:, self._inner] == self.t[:, None])
        for i in range(s):
            mine = owner == i
            state[:, i * nc:(i + 1) * nc] = np.where(mine & head, 1.0, np.where(mine & body, 0.5, 0.0))
        food = self.food
        has = food >= 0
        boards = np.repeat(self._boards, self.n_food).reshape(food.shape)
        state[boards[has], s * nc + food[has]] = 1.0
        board_head = self.head
        row, col = np.divmod(board_head, n)
        scalars = np.zeros((self.n_boards, s, 8), dtype=np.float32)
        scalars[:, :, 0] = self.alive
        scalars[:, :, 1] = self.length / n
        for d in range(4):
            scalars[:, :, 2 + d] = self.direction == d
        scalars[:, :, 6] = 2.0 * row / (n - 1) - 1.0
        scalars[:, :, 7] = 2.0 * col / (n - 1) - 1.0
        state[:, (s + 1) * nc:] = scalars.reshape(self.n_boards, -1)
        return state

    def grid(self, board: int = 0) -> np.ndarray:
        """``int64[size, size]`` of one board: -1 empty, -2 food, ``s`` snake s's body."""
        b = int(board)
        body = self._body_at(np.full(self.n_cells, b), self._inner)
        grid = np.where(body, self.owner[b, self._inner].astype(np.int64), -1)
        food = self.food[b]
        grid[food[food >= 0]] = -2
        return grid.reshape(self.size, self.size)


class SnakeMatches(BoardSlots):
    """Snake matches stepped together on a ``SnakeBoards`` engine built like ``SnakeRules``' own
    one-board engine (same size, food, start length, view, teams and quarter turns); each match's
    board key is drawn from its seed exactly as ``SnakeRules.reset`` draws it.

    ``measures`` holds every match's measures as ``SnakeRules`` sets them (``[n_slots, n_agents]``
    arrays, kept current by ``start`` and ``step``; ``outcome`` set when a match ends, by the rules
    or cut at ``max_cycles``), and ``state()`` every match's global state: what a training batch
    (``arena_league.training.engine_batch``) computes rewards from."""

    def __init__(self, rules: SnakeRules, n_slots: int, max_cycles: int) -> None:
        one = rules.engine
        self.n_slots = n_slots
        self.max_cycles = max_cycles
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.n_teams = rules.n_teams
        self.boards = SnakeBoards(n_slots, one.n_snakes, size=one.size, n_food=one.n_food,
                                  start_length=one.start_length, view_radius=one.view_radius,
                                  team_of=one.team_of, rotations=one.rotations)
        self.boards.done[:] = True  # idle slots: the engine leaves finished boards alone
        self._steps = np.zeros(n_slots, dtype=np.int64)
        self.measures = Measures.allocate(rules.n_agents, rules.measures_provided, n_slots)

    def start(self, slot: int, seed: int) -> None:
        key = np.random.default_rng(seed).integers(0, 2**64, size=1, dtype=np.uint64)
        self.boards.reset(np.array([slot]), keys=key)
        self._steps[slot] = 0
        m = self.measures
        m.active[slot] = True
        m.alive[slot] = True
        m.resource_gain[slot] = 0.0
        m.velocity_to_target[slot] = 0.0
        m.target_distance[slot] = self.boards.food_distance[slot]
        m.outcome[slot] = 0.0

    def acting(self) -> np.ndarray:
        return self.boards.alive & ~self.boards.done[:, None]

    def step(self, actions: np.ndarray) -> np.ndarray:
        boards = self.boards
        live = ~boards.done
        boards.step(actions.astype(np.int64, copy=False))
        self._steps += live
        cut = live & ~boards.done & (self._steps >= self.max_cycles)  # the env's max_cycles
        boards.done[cut] = True
        ended = live & boards.done
        self._update_measures(live, ended)
        return ended

    def _update_measures(self, live: np.ndarray, ended: np.ndarray) -> None:
        """The measures of the matches just stepped, as ``SnakeRules.step`` (and ``finish``) set them."""
        m, boards, rows = self.measures, self.boards, live[:, None]
        np.copyto(m.alive, boards.alive, where=rows)
        np.copyto(m.active, boards.alive, where=rows)
        np.copyto(m.resource_gain, boards.ate, where=rows)
        np.copyto(m.velocity_to_target, boards.toward_food, where=rows)
        np.copyto(m.target_distance, boards.food_distance, where=rows)
        if ended.any():
            finished = np.flatnonzero(ended)
            scores = boards.team_scores(finished)
            m.outcome[finished] = 2.0 * scores[:, self.team_of] / (self.n_teams - 1) - 1.0

    def steps(self, slot: int) -> int:
        return int(self._steps[slot])


#: What a person types for each move on the board as drawn (board frame: 0 up, 1 right, 2 down, 3 left).
HUMAN_KEYS: dict[str, int] = {"w": 0, "up": 0, "u": 0, "d": 1, "right": 1, "r": 1, "s": 2, "down": 2, "a": 3,
                              "left": 3, "l": 3}


class SnakeControls(Controls):
    """A person steers a snake on the board as drawn (w/a/s/d), turned into the seat's own frame;
    Enter keeps going straight."""

    rules: SnakeRules

    def view(self) -> str:
        rules = self.rules
        engine = rules.engine
        grid = engine.grid(0)
        size = grid.shape[0]
        others = [s for s in range(rules.n_agents) if s != self.seat]
        chars = np.full(grid.shape, ".", dtype="<U1")
        chars[grid == -2] = "*"
        for s in range(rules.n_agents):
            body = "o" if s == self.seat else chr(ord("a") + others.index(s))
            chars[grid == s] = body
            if engine.alive[0, s]:
                head = int(engine.head[0, s])
                chars.reshape(-1)[head] = "@" if s == self.seat else body.upper()
        border = "#" * (size + 2)
        lines = [border] + ["#" + "".join(row) + "#" for row in chars] + [border]
        lengths = ", ".join(f"{'you' if s == self.seat else chr(ord('A') + others.index(s))}: length "
                            f"{int(engine.length[0, s])}{'' if engine.alive[0, s] else ' (dead)'}"
                            for s in range(rules.n_agents))
        return "\n".join(lines) + f"\nYou are @ (body o). {lengths}"

    def prompt(self, step: int) -> str:
        return f"step {step}: w up, a left, s down, d right (Enter: straight on) > "

    def parse(self, text: str) -> tuple[int | None, str | None]:
        engine = self.rules.engine
        rotation = int(engine.rotations[self.seat])
        if text == "":
            heading = int(engine.direction[0, self.seat])  # board frame
            return (heading - rotation) % 4, None
        if text not in HUMAN_KEYS:
            return None, f"{text!r} is not a move: type w (up), a (left), s (down) or d (right), or Enter to go on"
        return (HUMAN_KEYS[text] - rotation) % 4, None

    def web(self) -> dict[str, Any]:
        return key_controls(arrow_keys("w", "a", "s", "d"), 6.0,
                            "Arrow keys or W A S D turn your snake on the board as drawn; it keeps going.")


def heuristic_actions(obs: np.ndarray) -> np.ndarray:
    """The Snake heuristic's action per observation row (module docstring), from the header only."""
    return heuristic_scores(np.asarray(obs, dtype=np.float32)).argmax(axis=1).astype(np.int64)


def heuristic_scores(obs: np.ndarray) -> np.ndarray:
    """``float64[N, 4]``: how much the heuristic likes each action (it plays the highest)."""
    heading = obs[:, 3:7].argmax(axis=1)
    actions = np.arange(4)[None, :]
    effective = np.where(actions == ((heading + 2) % 4)[:, None], heading[:, None], actions)  # [N, 4]
    food_r, food_c = obs[:, 8:9], obs[:, 9:10]
    move_r, move_c = DROW[effective], DCOL[effective]
    along = np.where(move_r != 0, food_r * move_r, food_c * move_c)  # > 0: the move closes in
    offset = np.where(move_r != 0, np.abs(food_r), np.abs(food_c))
    gain = np.where(offset > 1e-6, np.sign(along), -1.0)
    has_food = (np.abs(food_r) + np.abs(food_c)) > 1e-6
    gain = np.where(has_food, gain + 0.01 * offset, 0.0)
    room = obs[:, 19:23]
    return (-100.0 * (obs[:, 11:15] > 0.5) - 10.0 * (obs[:, 15:19] > 0.5) - 20.0 * (room < 0.1)
            - 3.0 * (room < 0.5) + gain + 0.001 * (effective == heading[:, None]))


#: What a Snake search agent's budget means (the population provenance quotes it).
SEARCH_BUDGET_MEANING = ("the W moves the heuristic likes best searched H moves deep in the seat's window "
                         "(R must be 1), the heuristic's move played instead with probability E")
_SEARCH_ROOM, _SEARCH_THREAT, _SEARCH_KILL = 30.0, 50.0, 40.0  # weights of the search's score


def _window_parts(obs: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """The window side, the window's channels ``bool[N, 6, W, W]`` and the other snakes' rows
    ``float32[N, snakes - 1, 4]`` of Snake observations (the layout of the module docstring)."""
    rest = obs.shape[1] - N_HEADER
    w = 3
    while N_CHANNELS * w * w <= rest:
        others = rest - N_CHANNELS * w * w
        if others % PER_OTHER == 0 and others // PER_OTHER <= 3:
            window = obs[:, N_HEADER:N_HEADER + N_CHANNELS * w * w].reshape(len(obs), N_CHANNELS, w, w) > 0.5
            return w, window, obs[:, N_HEADER + N_CHANNELS * w * w:].reshape(len(obs), others // PER_OTHER,
                                                                              PER_OTHER)
        w += 2
    raise ValueError(f"Snake search: observations of {obs.shape[1]} floats are not Snake's "
                     f"({N_HEADER} + {N_CHANNELS} W^2 + 4 (snakes - 1))")


def _shifted(a: np.ndarray, dr: int, dc: int) -> np.ndarray:
    """``a`` moved by ``(dr, dc)`` over its last two axes, zeros shifted in."""
    out = np.zeros_like(a)
    h, w = a.shape[-2:]
    out[..., max(dr, 0):h + min(dr, 0), max(dc, 0):w + min(dc, 0)] = \
        a[..., max(-dr, 0):h + min(-dr, 0), max(-dc, 0):w + min(-dc, 0)]
    return out


def search_moves(obs: np.ndarray, uniforms: np.ndarray, *, width: int, rollouts: int, horizon: int,
                 epsilon: float) -> np.ndarray:
    """The Snake search agent's action per observation row (module docstring, "Search agent")."""
    obs = np.asarray(obs, dtype=np.float32)
    n = len(obs)
    w, window, others = _window_parts(obs)
    v = w // 2
    rows = np.arange(n)[:, None]
    heading = obs[:, 3:7].argmax(axis=1)
    reversal = np.arange(4)[None, :] == ((heading + 2) % 4)[:, None]
    effective = np.where(reversal, heading[:, None], np.arange(4)[None, :])
    target_row, target_col = v + DROW[effective], v + DCOL[effective]  # [N, 4] window cells
    free = ~window[:, :5].any(axis=1)  # no wall, body or head
    # a kill: an opponent's body cell, entered by a snake longer than every other living one
    alive_lengths = np.where(others[..., 3] > 0.5, others[..., 2], 0.0)
    longest = obs[:, 7] > (alive_lengths.max(axis=1) if others.shape[1] else 0.0) + 1e-6
    kill = window[:, 3][rows, target_row, target_col] & longest[:, None]
    enter = free[rows, target_row, target_col] | kill
    # room: the free window cells reachable within `horizon` moves (the others held still); a
    # reach to the window's edge counts as room enough
    reach = np.zeros((n, 4, w, w), dtype=bool)
    reach[rows, np.arange(4)[None, :], target_row, target_col] = enter
    for _ in range(horizon):
        reach |= _shifted(reach, 1, 0) | _shifted(reach, -1, 0) | _shifted(reach, 0, 1) | _shifted(reach, 0, -1)
        reach &= free[:, None]
        reach[rows, np.arange(4)[None, :], target_row, target_col] = enter
    edge = np.ones((w, w), dtype=bool)
    edge[1:-1, 1:-1] = False
    enough = 2 * horizon
    room = np.minimum(reach.sum(axis=(2, 3)) + enough * (reach & edge).any(axis=(2, 3)), enough) / enough
    # +1 a move that closes in on the nearest food, -1 one that moves away, 0 one across
    closer = np.sign(np.where(DROW[effective] != 0, obs[:, 8:9] * DROW[effective], obs[:, 9:10] * DCOL[effective]))
    score = (_SEARCH_ROOM * room + _SEARCH_KILL * kill - 1000.0 * ~enter + closer
             - _SEARCH_THREAT * _threatened(obs, window[:, 4], others, target_row, target_col))
    liked = heuristic_scores(obs)
    liked[reversal] = -np.inf  # the reversal goes straight: the same move twice
    order = np.argsort(-liked, axis=1, kind="stable")
    candidate = np.zeros((n, 4), dtype=bool)
    candidate[rows, order[:, :min(width, 3)]] = True
    rank_bonus = np.empty((n, 4))
    rank_bonus[rows, order] = -1e-3 * np.arange(4)  # ties go to the heuristic's order
    chosen = np.where(candidate, score + rank_bonus, -np.inf).argmax(axis=1)
    lapse = np.asarray(uniforms, dtype=np.float64).reshape(n) < epsilon
    return np.where(lapse, order[:, 0], chosen).astype(np.int64)


def _threatened(obs: np.ndarray, heads: np.ndarray, others: np.ndarray, target_row: np.ndarray,
                target_col: np.ndarray) -> np.ndarray:
    """``bool[N, 4]``: a head of a snake at least as long (or of one not told apart) is next to the
    cell the action leads to. A head seen at window offset ``(dr, dc)`` is the living snake whose
    relative position (``/ (size - 1)``) points the same way."""
    n, w = len(obs), heads.shape[-1]
    v = w // 2
    rows = np.broadcast_to(np.arange(n)[:, None], target_row.shape)
    threatened = np.zeros(target_row.shape, dtype=bool)
    rel_row, rel_col, length = others[..., 0], others[..., 1], others[..., 2]
    alive = others[..., 3] > 0.5
    for dr, dc in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        head_row, head_col = target_row + dr, target_col + dc
        inside = (head_row >= 0) & (head_row < w) & (head_col >= 0) & (head_col < w) & \
            ((head_row != v) | (head_col != v))
        seen = np.zeros(target_row.shape, dtype=bool)
        seen[inside] = heads[rows[inside], head_row[inside], head_col[inside]]
        if not seen.any():
            continue
        off_row, off_col = (head_row - v)[:, :, None], (head_col - v)[:, :, None]
        span = np.abs(rel_row) + np.abs(rel_col)
        scale = (np.abs(off_row) + np.abs(off_col)) / np.maximum(span, 1e-9)[:, None, :]
        miss = np.abs(rel_row[:, None, :] * scale - off_row) + np.abs(rel_col[:, None, :] * scale - off_col)
        match = (alive & (span > 0))[:, None, :] & (miss < 0.25)
        theirs = np.where(match, length[:, None, :], -1.0).max(axis=2)
        threatened |= seen & ((theirs >= obs[:, 7:8] - 1e-6) | ~match.any(axis=2))
    return threatened


class SnakeRules(OneBoard, GameRules):
    """One Snake match (the batched engine with one board); the module docstring is its manual."""

    name: ClassVar[str] = "Snake"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (4, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete",)
    turn_based: ClassVar[bool] = False
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "alive", "resource_gain", "target_distance", "velocity_to_target", "outcome"})
    default_max_cycles: ClassVar[int] = 500
    summary: ClassVar[str] = "grid snakes eat food and grow; on a collision the shorter snake dies"
    batched_matches: ClassVar[type[SnakeMatches]] = SnakeMatches
    options: ClassVar[tuple[Option, ...]] = (
        Option("size", int, 20, "the board's side, in cells", low=8),
        Option("n_food", int, None, "food items on the board at once", low=0, default_text="snakes + 1"),
        START_LENGTH, VIEW_RADIUS)

    def __init__(self, n_teams: int, players_per_team: int, action_type: str, **options: Any) -> None:
        settings = self.checked_options(options)
        size = settings["size"]
        for option, high, words in ((START_LENGTH, size // 4, f"size // 4 = {size // 4}"),
                                    (VIEW_RADIUS, size, f"size = {size}")):
            if settings[option.name] > high:
                raise ValueError(f"Snake option {option.name} must be an integer in [{option.low:g}, {words}] "
                                 f"(default {option.default_words()}: {option.meaning}), not {settings[option.name]!r}")
        if action_type != "discrete":
            raise ValueError(f"Snake has only the 'discrete' action variant, not {action_type!r}")
        if n_teams * players_per_team > 4 or n_teams < 2:
            raise ValueError(f"Snake seats 2 to 4 snakes in at least 2 teams; layouts: 2T1P, 4T1P, 2T2P "
                             f"(got {n_teams}T{players_per_team}P)")
        super().__init__(n_teams, players_per_team, action_type)
        # teammates face each other across the centre: turns 0, 2 for team 0; 1, 3 for team 1
        rotations = DEFAULT_ROTATIONS[self.n_agents] if players_per_team == 1 else (0, 2, 1, 3)
        n_food = self.n_agents + 1 if settings["n_food"] is None else settings["n_food"]
        self.engine = SnakeBoards(1, self.n_agents, size=size, n_food=n_food, start_length=settings["start_length"],
                                  view_radius=settings["view_radius"], team_of=self.team_of, rotations=rotations)
        self.size = self.engine.size
        self.obs_dim = self.engine.obs_dim
        self.state_dim = self.engine.state_dim
        self.n_actions = 4
        self.act_dim = 0
        self.action_meanings = DIRECTIONS
        self._events: list[dict] = []

    # --- the match -------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.engine.reset(keys=self.rng.integers(0, 2**64, size=1, dtype=np.uint64))
        m = self.measures
        m.active[:] = True
        m.alive[:] = True
        m.resource_gain[:] = 0.0
        m.velocity_to_target[:] = 0.0
        m.target_distance[:] = self.engine.food_distance[0]
        m.outcome[:] = 0.0
        self.game_over = False
        self._events = []

    def step(self, actions: np.ndarray) -> None:
        if self.game_over:
            raise RuntimeError("Snake: the match is over; call reset() before step()")
        engine = self.engine
        engine.step(np.asarray(actions, dtype=np.int64).reshape(1, -1))
        m = self.measures
        m.alive[:] = engine.alive[0]
        m.active[:] = engine.alive[0]
        m.resource_gain[:] = engine.ate[0]
        m.velocity_to_target[:] = engine.toward_food[0]
        m.target_distance[:] = engine.food_distance[0]
        self._events = [{"kind": "eat", "seat": int(i)} for i in np.flatnonzero(engine.ate[0])]
        self._events += [{"kind": "death", "seat": int(i), "cause": DEATH_CAUSES[int(engine.death_cause[0, i])]}
                         for i in np.flatnonzero(engine.died[0])]
        if engine.done[0]:
            self.game_over = True
            self._set_outcome()

    def _set_outcome(self) -> None:
        scores = self.team_result()
        self.measures.outcome[:] = 2.0 * scores[self.team_of] / (self.n_teams - 1) - 1.0

    def finish(self) -> None:
        self._set_outcome()

    # --- what seats see ----------------------------------------------------------------------
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        size, window = self.size, self.engine.window
        return cell_bounds((0, 1, 1), (-1, 1, 2), (0, 1, 4), (0, size, 1), (-1, 1, 2), (0, 1, 13),
                           (0, 1, N_CHANNELS * window * window),
                           *[run for _ in range(self.n_agents - 1) for run in ((-1, 1, 2), (0, size, 1), (0, 1, 1))])

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        cells = self.size * self.size
        return cell_bounds((0, 1, (self.n_agents + 1) * cells),
                           *[run for _ in range(self.n_agents) for run in ((0, 1, 1), (0, self.size, 1), (0, 1, 4),
                                                                           (-1, 1, 2))])

    def render_topdown(self) -> np.ndarray:
        engine = self.engine
        grid = engine.grid(0)
        codes = np.zeros(grid.shape, dtype=np.int64)
        codes[grid == -2] = 1
        palette = {0: (240, 240, 235), 1: (255, 0, 200)}
        for seat in range(self.n_agents):
            colour = TEAM_COLOURS[int(self.team_of[seat]) % len(TEAM_COLOURS)]
            codes[grid == seat] = 2 + 2 * seat
            palette[2 + 2 * seat] = colour
            palette[3 + 2 * seat] = tuple(int(0.55 * x) for x in colour)
            if engine.alive[0, seat]:
                codes.reshape(-1)[engine.head[0, seat]] = 3 + 2 * seat
        cell_px = max(4, 320 // self.size)
        picture = grid_picture(codes, palette, cell_px)
        framed = np.full((picture.shape[0] + 4, picture.shape[1] + 4, 3), 60, dtype=np.uint8)
        framed[2:-2, 2:-2] = picture
        return framed

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        size, n, ts = self.size, self.n_agents, timestamp_ns
        state = self.state().astype(np.float64)
        cells = size * size
        wall = (0.3, 0.3, 0.3, 1.0)
        out = [scene.entity("grid", ts, cubes=[
            scene.cube(size / 2, size / 2, -0.05, (size, size, 0.1), (0.94, 0.94, 0.92, 1.0)),
            scene.cube(size / 2, -0.1, 0.25, (size + 0.4, 0.2, 0.5), wall),
            scene.cube(size / 2, size + 0.1, 0.25, (size + 0.4, 0.2, 0.5), wall),
            scene.cube(-0.1, size / 2, 0.25, (0.2, size, 0.5), wall),
            scene.cube(size + 0.1, size / 2, 0.25, (0.2, size, 0.5), wall)])]
        for seat in range(n):
            plane = state[seat * cells:(seat + 1) * cells]
            colour = scene.team_colour(int(self.team_of[seat]))
            body = []
            for cell in np.flatnonzero(plane):
                x, y = scene.board_xy(int(cell), size)
                height = 0.9 if plane[cell] > 0.75 else 0.6
                body.append(scene.cube(x, y, height / 2, (0.9, 0.9, height), colour))
            out.append(scene.entity(f"snake/{seat}", ts, cubes=body))
        food = state[n * cells:(n + 1) * cells]
        out.append(scene.entity("food", ts, spheres=[
            scene.sphere(*scene.board_xy(int(c), size), 0.35, (0.7, 0.7, 0.7), (1.0, 0.0, 0.78, 1.0))
            for c in np.flatnonzero(food)]))
        return out

    def human_controls(self, seat: int) -> SnakeControls:
        return SnakeControls(self, seat)

    # --- the social tree and the scripted player ----------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        def leaf(seat: int) -> dict:
            return {"agent": f"player_{seat}", "scheme": "IS", "reward": "velocity_to_target", "scale": 0.02}

        children = team_groups(n_teams, players_per_team, leaf)
        return {"scheme": "CP", "reward": "ranking", "scale": 10, "params": {"order": "survive"},
                "children": children}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] < N_HEADER + N_CHANNELS:
            raise ValueError(f"Snake heuristic: observations of shape {obs.shape} are not Snake's "
                             f"(N, {N_HEADER} + {N_CHANNELS} W^2 + 4 (snakes - 1))")
        return heuristic_actions(obs)

    search_budget_meaning: ClassVar[str] = SEARCH_BUDGET_MEANING
    search_without_rollouts: ClassVar[str | None] = "its window holds no one else's moves"

    @staticmethod
    def search(obs: np.ndarray, uniforms: np.ndarray, *, action_type: str, width: int, rollouts: int, horizon: int,
               epsilon: float) -> np.ndarray:
        """:func:`search_moves` for living seats (dead ones go up; the rules ignore them)."""
        obs = np.asarray(obs, dtype=np.float32)
        actions = search_moves(obs, uniforms, width=width, rollouts=rollouts, horizon=horizon, epsilon=epsilon)
        return np.where(obs[:, 0] > 0.5, actions, 0)


RULES = SnakeRules
