"""GoBang: five in a row on a 15x15 board, turn-based, as a batched numpy engine.

One of the board games of Song et al., "Arena: A General Evaluation Platform and Building Toolkit
for Multi-Agent Intelligence" (AAAI 2020). Ids: ``GoBang-2T1P-v1`` (two players) and
``GoBang-2T2P-v1`` (two teams of two whose members alternate turns).

Rules
-----
* Team 0 plays black and moves first, team 1 plays white; one stone per turn on an empty cell.
* **Freestyle win**: a line of *five or more* stones of one colour (an overline of six or more
  also wins) in any of the 4 directions (row, column, both diagonals). Only the 4 lines through
  the stone just placed are counted, so a move is checked in constant time.
* **Illegal move loses**: a seat to move that picks an occupied cell loses the game at once.
* **Draw** when the board is full, or when the episode is cut at ``max_cycles`` (default: the
  number of cells, so the board fills first).
* **Turn order** with two players per team (2T2P): team 0's first player, team 1's first player,
  team 0's second player, team 1's second player, and so on: seat
  ``team * players_per_team + (moves_of_that_team % players_per_team)``. Teammates share a colour.
* In the parallel API every seat sends an action each step; only the seat to move is played and
  the others' (any in-range action) are ignored. The native AEC env (``make_aec``) asks only the
  seat to move.

Actions
-------
Discrete ``size * size`` (225): ``row * size + col``, row 0 at the top.
``action_mask()`` marks the empty cells, for *every* seat (the seat not to move sees the same legal
cells, so a masked sampler never meets an empty row; its action is ignored anyway). The mask is
all False only once the board is full.

Observation in the PettingZoo API: GoBang has illegal moves, so, in PettingZoo's classic
convention, each seat's observation from ``reset``, ``step`` (and the AEC env's ``observe``) is a
dict ``{"observation": float32[455], "action_mask": int8[225]}`` under a ``Dict`` observation
space: ``observation`` is the vector below (boards and the global state appended as ``make``
asks) and ``action_mask`` is the seat's row of ``action_mask()`` (1 an empty cell). PettingZoo's
tests and samplers (``action_space(agent).sample(mask)``) and RLlib's action masking read it and
play legal moves; ``infos`` are empty. The array API (``reset_arrays``, ``step_arrays``) and an
exported agent see the vector alone.

Observation (``float32[2 * size * size + 5]`` = 455 per seat, from the seat's own perspective)
---------------------------------------------------------------------------------------------
====================  ===========================================================================
index                 content
====================  ===========================================================================
``0 .. 224``          own team's stones: 1.0 at ``row * 15 + col`` where my colour stands, else 0
``225 .. 449``        opponent's stones, same layout
``450``               my turn: 1.0 when this seat is the one to move
``451``               my team's turn: 1.0 when a seat of my team moves (differs from 450 in 2T2P)
``452``               I play black (my team moved first)
``453``               stones on the board / cells (0 .. 1)
``454``               active: 1.0 (both seats play until the game ends)
====================  ===========================================================================

Bounds: every cell lies in [0, 1] (flags, and a fraction of the cells); these are the
``observation`` space's bounds.

Global state (``float32[size * size + 2]``): the board from black's side (+1 black, -1 white,
0 empty), then the colour to move (+1 black, -1 white) and stones / cells; bounds [-1, 1], and
[0, 1] for the last cell.

Measures: ``active`` (True throughout) and ``outcome`` (+1 / -1 for the winning / losing team's
seats, 0 for a draw; set when the game ends). ``team_result()``: 1 / 0 for a win / loss, 0.5 each
for a draw.

Default social tree: a CP ``win_loss`` root (scale 1) over the two agents (2T1P), or over two NL
nodes holding each team (2T2P): the zero-sum game result, paid when the game ends.

Heuristic (deterministic): for every empty cell it scores the line each player would form through
that cell in each of the 4 directions (length and open ends); a five of its own wins outright,
blocking the opponent's five comes next, then open and closed fours, threes, and so on, with the
opponent's lines weighted 0.9 (blocking) and a small pull toward the centre. It beats uniformly
random play essentially always. It reads only the observation and assumes five in a row.

Search agent (``scripted:search-wW-rR-hH[-eE]``, :func:`rollout_moves`): a Monte-Carlo rollout
search over these rules. The ``W`` cells the heuristic scores highest are its candidates (a winning
cell is played at once); from each it plays ``R`` games on, both sides the heuristic but for a
random empty cell with probability ``E``, for at most ``H`` more stones, and plays the candidate
whose rollouts the side to move wins most (1 a win, 0.5 undecided, 0 a loss). ``R=1, E=0`` sees
exactly how the heuristic would answer, so it beats the heuristic every time; larger ``R`` and
``E`` > 0 average over less predictable opponents. Its draws come from a generator seeded by the
seat's uniform, so a match replays exactly.

Game kwargs: ``size`` (the board's side, default 15, at least ``n_in_row``) and ``n_in_row`` (stones in a
line that win, default 5), declared in ``GoBangRules.options`` (listed by ``arena-league games``).

Batched engine
--------------
:class:`GoBangBoards` steps many boards at once with a few whole-array numpy operations (the
throughput benchmark and the single-match :class:`GoBangRules` both use it)::

    boards = GoBangBoards(n_boards=4096, seed=0, autoreset=True)
    while True:
        boards.step(boards.random_actions())   # int64[B]: the cell played by the side to move
        boards.done, boards.winner             # games that ended on this step, winning colour

* ``GoBangBoards(n_boards, size=15, n_in_row=5, autoreset=False, seed=0)``
* ``reset(boards=None)``: clear all boards, or those indexed by ``boards``.
* ``step(actions: int64[B])``: each board's side to move plays its cell. Boards that are done
  (without autoreset) ignore their action.
* ``legal_mask() -> bool[B, size*size]`` (empty cells); ``random_actions() -> int64[B]``
  (uniform over each board's empty cells, from the engine's own generator).
* ``observe() -> float32[B, 2, obs_dim]``: each colour's observation (the 2T1P layout above).
* State: ``cells int8[B, size*size]`` (0 empty, 1 black, 2 white), ``to_move int64[B]`` (0 black,
  1 white), ``n_stones int64[B]``, ``done bool[B]``, ``winner int64[B]`` (0 black, 1 white,
  -1 none or draw), ``illegal bool[B]`` (the game ended by an illegal move), ``last_action``.
* ``autoreset=True``: a board whose game ends is cleared at the end of that same ``step`` while
  ``done`` and ``winner`` still report the finished game until the next ``step``.

:class:`GoBangMatches` is the match engine's whole-array path (``GoBangRules.batched_matches``):
many matches of one layout on one ``GoBangBoards``, seat turns and team observations as the rules
give them, a match cut at ``max_cycles`` a draw.

Playing it (``arena-league play``)
----------------------------------
The board is drawn in text, ``X`` black, ``O`` white, the last stone in lower case, columns
lettered ``A`` onward and rows numbered from 1 at the top. A move is a cell: a column letter and
a row number such as ``H8``, or two numbers (row, column) such as ``8 8``. An occupied cell, a
cell off the board or something that is not a cell is refused with the reason, and asked again.

Rendering
---------
A top-down picture of the board (20 pixels a cell): the grid on wood, black and white stones, a red
dot on the last stone. ``render_mode="rgb_array"`` returns it; ``"human"`` shows it in a window.

Replay scene
------------
The board (a wooden slab with its grid lines), the stones (flat spheres, black and white) and a
red mark on the last stone: entities ``board``, ``stones`` and ``last_move``.
"""

from __future__ import annotations

import math
import re
from functools import cache
from typing import Any, ClassVar

import numpy as np

from arena_league.envs import scene
from arena_league.envs.controls import Controls
from arena_league.envs.core import GameRules, Measures, cell_bounds
from arena_league.envs.options import Option
from arena_league.envs.rendering import Canvas
from arena_league.envs.social import team_groups

EMPTY, BLACK, WHITE = 0, 1, 2
#: (row step, col step) of the four lines: row, column, diagonal, anti-diagonal.
LINES: tuple[tuple[int, int], ...] = ((0, 1), (1, 0), (1, 1), (1, -1))
#: Observation scalars after the two stone planes.
N_SCALARS = 5

# Heuristic line values by (stones in the line through the cell, open ends 0/1/2); five wins.
WIN_VALUE = 1.0e6
_LINE_VALUE = np.array([
    [0.0, 0.0, 0.0],        # 0 stones (unused)
    [0.0, 2.0, 10.0],       # 1
    [0.0, 30.0, 200.0],     # 2
    [0.0, 300.0, 5000.0],   # 3
    [0.0, 10000.0, 50000.0],  # 4
])
_BLOCK_WEIGHT = 0.9


def _ray_table(size: int, reach: int) -> np.ndarray:
    """``int64[size*size, reach, 8]``: for each cell, the cells 1..reach steps away along each line
    (sides ``+`` for lines 0..3, ``-`` for lines 4..7); ``size*size`` (an always-empty sentinel)
    past the edge."""
    n_cells = size * size
    rows, cols = np.divmod(np.arange(n_cells), size)
    steps = np.arange(1, reach + 1)
    table = np.empty((n_cells, reach, 8), dtype=np.int64)
    for k, (dr, dc) in enumerate(LINES):
        for side, sign in ((0, 1), (1, -1)):
            r = rows[:, None] + sign * dr * steps[None, :]
            c = cols[:, None] + sign * dc * steps[None, :]
            inside = (r >= 0) & (r < size) & (c >= 0) & (c < size)
            table[:, :, k + 4 * side] = np.where(inside, r * size + c, n_cells)
    return table


class GoBangBoards:
    """``n_boards`` GoBang games stepped together (see the module docstring for the API)."""

    def __init__(self, n_boards: int, size: int = 15, n_in_row: int = 5, autoreset: bool = False,
                 seed: int = 0) -> None:
        if int(n_boards) < 1:
            raise ValueError(f"n_boards must be a positive integer, not {n_boards!r}")
        _check_geometry(size, n_in_row)
        self.n_boards = int(n_boards)
        self.size = int(size)
        self.n_in_row = int(n_in_row)
        self.n_cells = self.size * self.size
        self.autoreset = bool(autoreset)
        self.rng = np.random.default_rng(seed)
        self.obs_dim = 2 * self.n_cells + N_SCALARS
        self._rays = _ray_table(self.size, self.n_in_row - 1)
        self._arange = np.arange(self.n_boards)
        # one extra always-empty column: the sentinel the rays point to past the edge
        self._padded = np.zeros((self.n_boards, self.n_cells + 1), dtype=np.int8)
        self._flat = self._padded.reshape(-1)
        self._row_offset = self._arange * (self.n_cells + 1)
        self.to_move = np.zeros(self.n_boards, dtype=np.int64)
        self.n_stones = np.zeros(self.n_boards, dtype=np.int64)
        self.done = np.zeros(self.n_boards, dtype=bool)
        self.winner = np.full(self.n_boards, -1, dtype=np.int64)
        self.illegal = np.zeros(self.n_boards, dtype=bool)
        self.last_action = np.full(self.n_boards, -1, dtype=np.int64)

    def __getstate__(self) -> dict[str, Any]:
        # the flat view of the boards is made again on unpickling, so that it shares their memory
        state = self.__dict__.copy()
        del state["_flat"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._flat = self._padded.reshape(-1)

    @property
    def cells(self) -> np.ndarray:
        """``int8[B, size*size]`` view of the boards: 0 empty, 1 black, 2 white."""
        return self._padded[:, : self.n_cells]

    def reset(self, boards: np.ndarray | None = None) -> None:
        """Clear every board, or the boards indexed by ``boards``."""
        sel = slice(None) if boards is None else np.asarray(boards)
        self._padded[sel] = EMPTY
        self.to_move[sel] = 0
        self.n_stones[sel] = 0
        self.done[sel] = False
        self.winner[sel] = -1
        self.illegal[sel] = False
        self.last_action[sel] = -1

    def step(self, actions: np.ndarray) -> None:
        """Play ``actions[b]`` (a cell) for the side to move on every unfinished board."""
        actions = np.asarray(actions)
        if actions.shape != (self.n_boards,) or actions.dtype.kind not in "iu":
            raise ValueError(f"GoBangBoards.step takes one integer cell per board, shape ({self.n_boards},); "
                             f"got shape {actions.shape} dtype {actions.dtype}")
        if actions.size and (actions.min() < 0 or actions.max() >= self.n_cells):
            raise ValueError(f"GoBang cells are 0..{self.n_cells - 1} (row * {self.size} + col); got "
                             f"{int(actions.min()) if actions.min() < 0 else int(actions.max())}")
        actions = actions.astype(np.int64, copy=False)
        if self.autoreset:
            self.done[:] = False
            self.winner[:] = -1
            self.illegal[:] = False
        live = ~self.done
        colour = (self.to_move + 1).astype(np.int8)
        flat_cell = self._row_offset + actions
        before = self._flat[flat_cell]
        place = live & (before == EMPTY)
        illegal = live & (before != EMPTY)
        self._flat[flat_cell] = np.where(place, colour, before)
        # the 4 lines through the new stone: runs of the mover's colour on both sides
        same = self._flat[self._row_offset[:, None, None] + self._rays[actions]] == colour[:, None, None]
        unbroken = same[:, 0]
        run = unbroken.astype(np.int8)
        for k in range(1, self.n_in_row - 1):
            unbroken = unbroken & same[:, k]
            run += unbroken
        longest = (run[:, :4] + run[:, 4:]).max(axis=1) + 1
        five = place & (longest >= self.n_in_row)
        self.n_stones += place
        full = place & ~five & (self.n_stones == self.n_cells)
        ended = five | illegal | full
        self.winner = np.where(five, self.to_move, np.where(illegal, 1 - self.to_move, self.winner))
        self.illegal |= illegal
        self.last_action = np.where(live, actions, self.last_action)
        self.to_move = np.where(place & ~ended, 1 - self.to_move, self.to_move)
        self.done |= ended
        if self.autoreset and ended.any():
            finished = np.flatnonzero(ended)
            self._padded[finished] = EMPTY
            self.to_move[finished] = 0
            self.n_stones[finished] = 0

    def legal_mask(self) -> np.ndarray:
        """``bool[B, size*size]``: the empty cells of each board."""
        return self.cells == EMPTY

    def random_actions(self) -> np.ndarray:
        """A uniformly random empty cell per board (cell 0 on a full board), drawn from ``self.rng``."""
        actions = self.rng.integers(self.n_cells, size=self.n_boards)
        retry = np.flatnonzero(self._flat[self._row_offset + actions] != EMPTY)
        for _ in range(8):  # rejection sampling stays uniform; few boards need a second draw
            if not retry.size:
                return actions
            actions[retry] = self.rng.integers(self.n_cells, size=retry.size)
            retry = retry[self._flat[self._row_offset[retry] + actions[retry]] != EMPTY]
        if retry.size:  # nearly full boards: draw among the empty cells directly
            keys = self.rng.random((retry.size, self.n_cells))
            keys[self.cells[retry] != EMPTY] = -1.0
            actions[retry] = keys.argmax(axis=1)
        return actions

    def observe(self) -> np.ndarray:
        """``float32[B, 2, obs_dim]``: black's and white's observations (2T1P layout)."""
        obs = np.zeros((self.n_boards, 2, self.obs_dim), dtype=np.float32)
        cells = self.cells
        n = self.n_cells
        for colour in (0, 1):
            obs[:, colour, :n] = cells == colour + 1
            obs[:, colour, n:2 * n] = cells == 2 - colour
            obs[:, colour, 2 * n] = self.to_move == colour
            obs[:, colour, 2 * n + 1] = self.to_move == colour
            obs[:, colour, 2 * n + 2] = colour == 0
        obs[:, :, 2 * n + 3] = (self.n_stones / n)[:, None]
        obs[:, :, 2 * n + 4] = 1.0
        return obs


class GoBangMatches:
    """GoBang matches stepped together on a ``GoBangBoards`` engine: the match engine's whole-array
    path (turn order, observation layout, illegal moves and draws as in the module docstring).

    ``measures`` holds every match's measures as ``GoBangRules`` sets them (``[n_slots, n_agents]``
    arrays: ``active`` always, ``outcome`` set when a match ends), ``state()`` every match's global
    state and ``current_player()`` every match's seat to move: what a training batch
    (``arena_league.training.engine_batch``) reads."""

    def __init__(self, rules: GoBangRules, n_slots: int, max_cycles: int) -> None:
        self.n_slots = n_slots
        self.n_agents = rules.n_agents
        self.players_per_team = rules.players_per_team
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.max_cycles = max_cycles
        self.boards = GoBangBoards(n_slots, rules.size, rules.n_in_row)
        self.n_cells = self.boards.n_cells
        self.boards.done[:] = True  # idle slots: the engine leaves finished boards alone
        self._steps = np.zeros(n_slots, dtype=np.int64)
        self._seats = np.arange(self.n_agents)
        self.measures = Measures.allocate(self.n_agents, rules.measures_provided, n_slots)

    def start(self, slot: int, seed: int) -> None:
        # GoBang draws nothing at random: the seed is not needed, the board starts empty
        self.boards.reset(np.array([slot]))
        self._steps[slot] = 0
        self.measures.outcome[slot] = 0.0

    def current_player(self) -> np.ndarray:
        """The seat to move on each board (GoBangRules.current_player, for every board at once)."""
        boards = self.boards
        return boards.to_move * self.players_per_team + (boards.n_stones // 2) % self.players_per_team

    def observe(self) -> np.ndarray:
        by_colour = self.boards.observe()  # [B, 2, obs_dim], 2T1P layout
        if self.players_per_team == 1:
            obs = by_colour
        else:
            obs = by_colour[:, self.team_of]  # teammates share a colour; "my turn" is per seat
            obs[:, :, 2 * self.n_cells] = self.current_player()[:, None] == self._seats[None, :]
        over = self._game_over()
        if over.any():  # nobody's turn once the rules ended the game, as the rules observe it
            obs[over, :, 2 * self.n_cells: 2 * self.n_cells + 2] = 0.0
        return obs

    def _game_over(self) -> np.ndarray:
        """``bool[n_slots]``: the rules ended the match (a five, an illegal move, a full board);
        a match cut at ``max_cycles`` is not over for the rules."""
        boards = self.boards
        return boards.done & ((boards.winner >= 0) | (boards.n_stones == self.n_cells))

    def action_mask(self) -> np.ndarray:
        legal = self.boards.legal_mask()
        return np.broadcast_to(legal[:, None, :], (self.n_slots, self.n_agents, self.n_cells))

    def acting(self) -> np.ndarray:
        return (self.current_player()[:, None] == self._seats[None, :]) & ~self.boards.done[:, None]

    def step(self, actions: np.ndarray) -> np.ndarray:
        boards = self.boards
        live = ~boards.done
        moves = actions[np.arange(self.n_slots), self.current_player()]
        boards.step(np.where(live, moves, 0).astype(np.int64))
        self._steps += live
        # the env cuts a match at max_cycles: a draw (no winner yet, or the board would have ended it)
        cut = live & ~boards.done & (self._steps >= self.max_cycles)
        boards.done |= cut
        ended = live & boards.done
        if ended.any():  # +1 / -1 for the winning / losing team, 0 for a draw or a cut
            winner = boards.winner[ended][:, None]
            self.measures.outcome[ended] = np.where(winner < 0, 0.0,
                                                    np.where(self.team_of[None, :] == winner, 1.0, -1.0))
        return ended

    def state(self) -> np.ndarray:
        """``float32[n_slots, state_dim]``: every match's global state (``GoBangRules.state``)."""
        boards = self.boards
        state = np.empty((self.n_slots, self.n_cells + 2))
        cells = boards.cells
        state[:, : self.n_cells] = np.where(cells == BLACK, 1.0, np.where(cells == WHITE, -1.0, 0.0))
        state[:, self.n_cells] = np.where(boards.to_move == 0, 1.0, -1.0)
        state[:, self.n_cells + 1] = boards.n_stones / self.n_cells
        return state.astype(np.float32)

    def steps(self, slot: int) -> int:
        return int(self._steps[slot])

    def team_result(self, slot: int) -> np.ndarray:
        winner = int(self.boards.winner[slot])
        if winner < 0:
            return np.full(2, 0.5)
        return (np.arange(2) == winner).astype(np.float64)

    def pair_points(self, slot: int) -> np.ndarray:
        """What each team scored toward its pair: the team result, as ``GoBangRules.pair_points``."""
        return self.team_result(slot)


class GoBangControls(Controls):
    """A person places stones by cell: ``H8`` (column letter, row number) or ``8 8`` (row,
    column), 1-based, on the board drawn in text."""

    rules: GoBangRules

    def view(self) -> str:
        rules = self.rules
        size = rules.size
        cells = rules.engine.cells[0]
        last = int(rules.engine.last_action[0])
        letters = [chr(ord("A") + c) for c in range(size)]
        lines = ["    " + " ".join(letters)]
        for r in range(size):
            marks = []
            for c in range(size):
                cell = r * size + c
                mark = ".XO"[int(cells[cell])]
                marks.append(mark.lower() if cell == last and mark != "." else mark)
            lines.append(f"{r + 1:>3} " + " ".join(marks))
        colour = "X (black, first)" if int(rules.team_of[self.seat]) == 0 else "O (white)"
        lines.append(f"You play {colour}.")
        return "\n".join(lines)

    def prompt(self, step: int) -> str:
        return "your move (e.g. H8, or row col: 8 8) > "

    def parse(self, text: str) -> tuple[int | None, str | None]:
        rules = self.rules
        size = rules.size
        letter = re.fullmatch(r"([a-z])\s*(-?\d+)", text)
        numbers = re.fullmatch(r"(-?\d+)[\s,]+(-?\d+)", text)
        if letter:
            row, col = int(letter.group(2)) - 1, ord(letter.group(1)) - ord("a")
        elif numbers:
            row, col = int(numbers.group(1)) - 1, int(numbers.group(2)) - 1
        else:
            return None, (f"{text!r} is not a cell: type a column letter and a row number such as H8, or two numbers "
                          "(row, column) such as 8 8")
        if not (0 <= row < size and 0 <= col < size):
            return None, (f"row {row + 1}, column {col + 1} is off the board: rows and columns run from 1 to {size} "
                          f"(columns A to {chr(ord('A') + size - 1)})")
        cell = row * size + col
        if rules.engine.cells[0, cell] != 0:
            return None, f"{chr(ord('A') + col)}{row + 1} is occupied: choose an empty cell (shown as .)"
        return cell, None

    def web(self) -> dict[str, Any]:
        colour = "black (first)" if int(self.rules.team_of[self.seat]) == 0 else "white (second)"
        return {"input": "cells", "pace": None, "hint": f"Click an empty cell to place a stone; you play {colour}."}

    def point(self, x: float, y: float) -> str | None:
        """The cell under (x, y): cells are unit squares, row 1 at the top (see ``scene.board_xy``)."""
        size = self.rules.size
        return f"{size - math.floor(y)} {math.floor(x) + 1}"


def _check_geometry(size: Any, n_in_row: Any) -> None:
    if isinstance(n_in_row, bool) or not isinstance(n_in_row, (int, np.integer)) or n_in_row < 2:
        raise ValueError(f"n_in_row must be an integer >= 2 (5 for GoBang), not {n_in_row!r}")
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < n_in_row:
        raise ValueError(f"size must be an integer >= n_in_row ({n_in_row}), not {size!r}; GoBang uses 15")


#: The board's side: a game option, bounded below by the other option, ``n_in_row``.
SIZE = Option("size", int, 15, "the board's side, in cells; at least n_in_row", low=2)


@cache
def _rays(size: int, reach: int) -> np.ndarray:
    return _ray_table(size, reach)


def line_values(own: np.ndarray, opponent: np.ndarray, n_in_row: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """``(attack, threat)``, each ``float64[N, size * size]`` for N boards given ``bool[N, size * size]``
    stone planes: over the 4 lines through each empty cell, the value of the line the side's own
    stone there would make (``attack``, five or more :data:`WIN_VALUE`) and the value of the line the
    opponent's would make (``threat``); ``-inf`` on occupied cells."""
    n, n_cells = own.shape
    size = round(float(np.sqrt(n_cells)))
    rays = _rays(size, n_in_row - 1)  # [cells, reach, 8], the sentinel past the edge
    stones = np.zeros((n, 2, n_cells + 1), dtype=bool)
    stones[:, 0, :n_cells] = own
    stones[:, 1, :n_cells] = opponent
    empty = np.zeros((n, n_cells + 1), dtype=bool)
    empty[:, :n_cells] = ~(own | opponent)
    stone_rays = stones[:, :, rays]  # [N, 2, cells, reach, 8]
    empty_rays = empty[:, None, rays]  # [N, 1, cells, reach, 8]
    running = np.ones((n, 2, n_cells, 8), dtype=bool)  # still on an unbroken run of stones
    open_end = np.zeros((n, 2, n_cells, 8), dtype=bool)  # the run ends on an empty cell
    run = np.zeros((n, 2, n_cells, 8), dtype=np.int64)
    for k in range(n_in_row - 1):
        open_end |= running & empty_rays[:, :, :, k]
        running &= stone_rays[:, :, :, k]
        run += running
    length = 1 + run[..., :4] + run[..., 4:]  # [N, 2, cells, 4 lines]
    value = _LINE_VALUE[np.minimum(length, 4), open_end[..., :4].astype(np.int64) + open_end[..., 4:]]
    value[length >= n_in_row] = WIN_VALUE
    value = value.sum(axis=3)  # [N, 2, cells]
    value[np.broadcast_to(~empty[:, None, :n_cells], value.shape)] = -np.inf
    return value[:, 0], value[:, 1]


@cache
def _centre_pull(n_cells: int) -> np.ndarray:
    size = round(float(np.sqrt(n_cells)))
    rows, cols = np.divmod(np.arange(n_cells), size)
    centre = (size - 1) / 2.0
    return 1e-3 * np.maximum(np.abs(rows - centre), np.abs(cols - centre))


def heuristic_scores(own: np.ndarray, opponent: np.ndarray, n_in_row: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """``(score, attack)``: the heuristic's score of every cell (``attack + 0.9 * threat`` of
    :func:`line_values`, less a tiny pull toward the centre; ``-inf`` on occupied cells) and the
    attack values (a cell of value :data:`WIN_VALUE` or more wins at once)."""
    attack, threat = line_values(own, opponent, n_in_row)
    return attack + _BLOCK_WEIGHT * threat - _centre_pull(own.shape[1]), attack


def heuristic_moves(own: np.ndarray, opponent: np.ndarray, n_in_row: int = 5) -> np.ndarray:
    """The heuristic's cell for each of N boards given ``bool[N, size * size]`` stone planes.

    Every empty cell scores, over the 4 lines through it, the value of the line its own stone
    would make plus 0.9 times the value of the line the opponent's would make (what a block
    denies), with a tiny pull toward the centre; the best cell wins (lowest index on ties).
    """
    return heuristic_scores(own, opponent, n_in_row)[0].argmax(axis=1).astype(np.int64)


def rollout_moves(own: np.ndarray, opponent: np.ndarray, uniforms: np.ndarray, *, width: int, rollouts: int,
                  horizon: int, epsilon: float, n_in_row: int = 5) -> np.ndarray:
    """A Monte-Carlo rollout search for each of N boards (the side to move owns ``own``).

    The ``width`` cells the heuristic scores highest are the candidates (a winning cell is played
    at once). From each, ``rollouts`` games are played on, both sides following the heuristic but
    for a uniformly random empty cell with probability ``epsilon``, for at most ``horizon`` more
    stones; a rollout scores 1 when the side to move wins it, 0 when it loses, 0.5 when it is
    undecided. The candidate with the best mean is played (the heuristic's order breaks ties).
    With ``rollouts=1, epsilon=0`` the search sees exactly how the heuristic would answer. All the
    rollouts of a board step together (one scoring per stone played); their random draws come from
    a generator seeded by the board's first uniform, so a match replays exactly.
    """
    own = np.asarray(own, dtype=bool)
    opponent = np.asarray(opponent, dtype=bool)
    moves = np.zeros(len(own), dtype=np.int64)
    for b in range(len(own)):
        score, attack = heuristic_scores(own[b:b + 1], opponent[b:b + 1], n_in_row)
        legal = int(np.isfinite(score[0]).sum())
        candidates = np.argsort(-score[0], kind="stable")[:min(width, legal)]
        if candidates.size == 0 or attack[0, candidates[0]] >= WIN_VALUE or candidates.size == 1:
            moves[b] = candidates[0] if candidates.size else 0
            continue
        rng = np.random.default_rng(int(float(uniforms[b]) * 2 ** 53))
        n = candidates.size * rollouts
        planes = np.zeros((n, 2, own.shape[1]), dtype=bool)  # [rollout, side to move now / the other]
        planes[:, 0] = opponent[b]
        planes[:, 1] = own[b]
        planes[np.arange(n), 1, np.repeat(candidates, rollouts)] = True
        result = np.full(n, 0.5)
        live = np.arange(n)
        mover_is_us = False
        for _ in range(horizon):
            if live.size == 0:
                break
            score, attack = heuristic_scores(planes[live, 0], planes[live, 1], n_in_row)
            rows = np.arange(live.size)
            cells = score.argmax(axis=1)
            if epsilon > 0:
                wild = np.flatnonzero(rng.random(live.size) < epsilon)
                for j in wild:
                    empty = np.flatnonzero(np.isfinite(score[j]))
                    if empty.size:  # a full board has none: the rollout ends undecided below
                        cells[j] = empty[rng.integers(empty.size)]
            playable = np.isfinite(score[rows, cells])
            wins = playable & (attack[rows, cells] >= WIN_VALUE)
            planes[live[playable], 0, cells[playable]] = True
            result[live[wins]] = 1.0 if mover_is_us else 0.0
            live = live[~wins & playable]
            planes[live] = planes[live, ::-1]
            mover_is_us = not mover_is_us
        value = result.reshape(candidates.size, rollouts).mean(axis=1)
        moves[b] = candidates[int(np.argmax(value))]
    return moves


class GoBangRules(GameRules):
    """One GoBang match (the batched engine with one board); the module docstring is its manual."""

    name: ClassVar[str] = "GoBang"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete",)
    turn_based: ClassVar[bool] = True
    measures_provided: ClassVar[frozenset[str]] = frozenset({"active", "outcome"})
    default_max_cycles: ClassVar[int] = 225
    summary: ClassVar[str] = "15x15 five in a row (freestyle), turn-based; an illegal move loses"
    batched_matches: ClassVar[type[GoBangMatches]] = GoBangMatches

    options: ClassVar[tuple[Option, ...]] = (SIZE, Option("n_in_row", int, 5, "stones in a line that win", low=2))

    def __init__(self, n_teams: int, players_per_team: int, action_type: str, **options: Any) -> None:
        settings = self.checked_options(options)
        if settings["size"] < settings["n_in_row"]:
            raise ValueError(f"GoBang option size must be an integer in [n_in_row = {settings['n_in_row']}, inf] "
                             f"(default {SIZE.default_words()}: {SIZE.meaning}), not {settings['size']!r}")
        if n_teams != 2:
            raise ValueError(f"GoBang is played by 2 teams, not {n_teams}; layouts: 2T1P, 2T2P")
        if action_type != "discrete":
            raise ValueError(f"GoBang has only the 'discrete' action variant, not {action_type!r}")
        super().__init__(n_teams, players_per_team, action_type)
        self.size = settings["size"]
        self.n_in_row = settings["n_in_row"]
        self.n_cells = self.size * self.size
        self.obs_dim = 2 * self.n_cells + N_SCALARS
        self.state_dim = self.n_cells + 2
        self.n_actions = self.n_cells
        self.act_dim = 0
        self.action_meanings = (f"place a stone at row * {self.size} + col",)
        self.default_max_cycles = self.n_cells  # type: ignore[misc]  # the board fills first
        self.engine = GoBangBoards(1, self.size, self.n_in_row)
        self._events: list[dict] = []

    # --- the match -------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.engine.reset()
        self.measures.active[:] = True
        self.measures.outcome[:] = 0.0
        self.game_over = False
        self._events = []

    def current_player(self) -> int:
        """The seat to move: the colour to move, and within a team the players in turn."""
        team = int(self.engine.to_move[0])
        moves_of_team = int(self.engine.n_stones[0]) // 2
        return team * self.players_per_team + moves_of_team % self.players_per_team

    def step(self, actions: np.ndarray) -> None:
        if self.game_over:
            raise RuntimeError("GoBang: the game is over; call reset() before step()")
        seat = self.current_player()
        cell = int(actions[seat])
        engine = self.engine
        engine.step(np.array([cell], dtype=np.int64))
        self._events = [{"kind": "move", "seat": seat, "cell": cell}]
        if engine.done[0]:
            self.game_over = True
            winner = int(engine.winner[0])
            if engine.illegal[0]:
                self._events.append({"kind": "illegal_move", "seat": seat, "cell": cell})
            if winner >= 0:
                self.measures.outcome[:] = np.where(self.team_of == winner, 1.0, -1.0)
                if not engine.illegal[0]:
                    self._events.append({"kind": "five", "team": winner})
            else:
                self._events.append({"kind": "draw", "reason": "board full"})

    def finish(self) -> None:
        self.measures.outcome[:] = 0.0  # cut at max_cycles: a draw

    def team_result(self) -> np.ndarray:
        winner = int(self.engine.winner[0])
        if winner < 0:
            return np.full(2, 0.5)
        return (np.arange(2) == winner).astype(np.float64)

    def events(self) -> list[dict]:
        return list(self._events)

    # --- what seats see ----------------------------------------------------------------------
    def observe(self) -> np.ndarray:
        engine = self.engine
        n = self.n_cells
        cells = engine.cells[0]
        mover = self.current_player()
        obs = np.zeros((self.n_agents, self.obs_dim), dtype=np.float32)
        for seat in range(self.n_agents):
            team = int(self.team_of[seat])
            obs[seat, :n] = cells == team + 1
            obs[seat, n:2 * n] = cells == 2 - team
            obs[seat, 2 * n] = seat == mover and not self.game_over
            obs[seat, 2 * n + 1] = team == engine.to_move[0] and not self.game_over
            obs[seat, 2 * n + 2] = team == 0
        obs[:, 2 * n + 3] = engine.n_stones[0] / n
        obs[:, 2 * n + 4] = self.measures.active
        return obs

    def action_mask(self) -> np.ndarray:
        return np.repeat(self.engine.legal_mask(), self.n_agents, axis=0)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return cell_bounds((0, 1, self.obs_dim))

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return cell_bounds((-1, 1, self.n_cells + 1), (0, 1, 1))

    def state(self) -> np.ndarray:
        cells = self.engine.cells[0]
        board = np.where(cells == BLACK, 1.0, np.where(cells == WHITE, -1.0, 0.0))
        to_move = 1.0 if self.engine.to_move[0] == 0 else -1.0
        return np.concatenate([board, [to_move, self.engine.n_stones[0] / self.n_cells]]).astype(np.float32)

    def render_topdown(self) -> np.ndarray:
        size = self.size
        canvas = Canvas(0.0, float(size), 0.0, float(size), size=max(240, 20 * size), background=(222, 184, 110))
        for k in range(size):
            canvas.line(0.5, k + 0.5, size - 0.5, k + 0.5, fill=(90, 60, 30))
            canvas.line(k + 0.5, 0.5, k + 0.5, size - 0.5, fill=(90, 60, 30))
        cells = self.engine.cells[0]
        for cell in np.flatnonzero(cells):
            row, col = divmod(int(cell), size)
            colour = (25, 25, 25) if cells[cell] == BLACK else (245, 245, 245)
            canvas.circle(col + 0.5, size - row - 0.5, 0.44, fill=colour, outline=(60, 60, 60))
        last = int(self.engine.last_action[0])
        if last >= 0 and cells[last] != EMPTY:
            row, col = divmod(last, size)
            canvas.circle(col + 0.5, size - row - 0.5, 0.12, fill=(220, 40, 40))
        return canvas.array()

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        size, ts = self.size, timestamp_ns
        board = self.state()[: size * size].astype(np.float64)
        grid = [p for k in range(size) for p in ((0.5, k + 0.5, 0.001), (size - 0.5, k + 0.5, 0.001),
                                                (k + 0.5, 0.5, 0.001), (k + 0.5, size - 0.5, 0.001))]
        out = [scene.entity("board", ts,
                            cubes=[scene.cube(size / 2, size / 2, -0.05, (size, size, 0.1), (0.87, 0.72, 0.43, 1.0))],
                            lines=[scene.lines(grid, (0.35, 0.24, 0.12, 1.0), 0.03)])]
        stones = []
        for cell in np.flatnonzero(board):
            x, y = scene.board_xy(int(cell), size)
            colour = (0.1, 0.1, 0.1, 1.0) if board[cell] > 0 else (0.96, 0.96, 0.96, 1.0)
            stones.append(scene.sphere(x, y, 0.1, (0.88, 0.88, 0.25), colour))
        out.append(scene.entity("stones", ts, spheres=stones))
        last = int(self.engine.last_action[0])
        marks = []
        if 0 <= last < size * size and board[last] != 0:
            x, y = scene.board_xy(last, size)
            marks.append(scene.sphere(x, y, 0.25, (0.25, 0.25, 0.1), (0.86, 0.16, 0.16, 1.0)))
        out.append(scene.entity("last_move", ts, spheres=marks))
        return out

    def human_controls(self, seat: int) -> GoBangControls:
        return GoBangControls(self, seat)

    # --- the social tree and the scripted player ----------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        children = team_groups(n_teams, players_per_team)
        return {"scheme": "CP", "reward": "win_loss", "scale": 1, "children": children}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        own, opponent, movers = _planes(obs, "heuristic")
        # seats not to move get the first empty cell (legal, and ignored by the rules)
        actions = (~(own | opponent)).argmax(axis=1).astype(np.int64)
        if movers.size:
            actions[movers] = heuristic_moves(own[movers], opponent[movers])
        return actions

    search_budget_meaning: ClassVar[str] = ("W candidate moves, R rollouts of at most H moves each, random moves "
                                            "in them with probability E")

    @staticmethod
    def search(obs: np.ndarray, uniforms: np.ndarray, *, action_type: str, width: int, rollouts: int, horizon: int,
               epsilon: float) -> np.ndarray:
        """:func:`rollout_moves` for the seats to move (the others get the first empty cell)."""
        own, opponent, movers = _planes(obs, "search")
        actions = (~(own | opponent)).argmax(axis=1).astype(np.int64)
        if movers.size:
            actions[movers] = rollout_moves(own[movers], opponent[movers], np.asarray(uniforms)[movers],
                                            width=width, rollouts=rollouts, horizon=horizon, epsilon=epsilon)
        return actions


def _planes(obs: np.ndarray, agent: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The own and opponent stone planes of GoBang observations (``bool[N, cells]`` each) and the
    indices of the seats to move."""
    obs = np.asarray(obs, dtype=np.float32)
    n_cells = (obs.shape[1] - N_SCALARS) // 2
    size = round(float(np.sqrt(n_cells)))
    if size * size != n_cells or obs.shape[1] != 2 * n_cells + N_SCALARS:
        raise ValueError(f"GoBang {agent}: observations of {obs.shape[1]} floats are not GoBang's "
                         "(2 * size * size + 5)")
    return obs[:, :n_cells] > 0.5, obs[:, n_cells:2 * n_cells] > 0.5, np.flatnonzero(obs[:, 2 * n_cells] > 0.5)


RULES = GoBangRules
