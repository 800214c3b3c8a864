"""Boomer: players lay bombs on a grid of walls; the last team standing wins.

Arena's game "inspired by Bomberman" (Song et al., "Arena: A General Evaluation Platform and
Building Toolkit for Multi-Agent Intelligence", AAAI 2020), on the rules of Pommerman (Resnick et
al., "Pommerman: A Multi-Agent Playground", 2018; the NeurIPS 2018 competition), built as a batched
numpy engine, with a one-board engine in plain Python for single matches. Ids: ``Boomer-2T1P-v1`` (a duel), ``Boomer-4T1P-v1`` (free-for-all of four, as
Pommerman's FFA) and ``Boomer-2T2P-v1`` (two teams of two, as Pommerman's team game).

Field
-----
A ``size x size`` board (default 11), off-board cells count as rigid wall. Every cell is one of:
passage, rigid wall (indestructible), wooden wall (a blast destroys it), or a power-up lying in the
open. The map is drawn from the match seed and is the same turned by a quarter (clockwise) about
the centre, so every corner, hence every seat, starts alike:

* each seat starts one cell in from its corner, at (1, 1) turned; its own cell and the next two
  cells toward each neighbouring corner, (1, 2), (1, 3), (2, 1), (3, 1) turned, start clear;
* wooden lanes join the corners: (1, i) for ``4 <= i <= size - 5``, turned (12 walls at size 11);
* ``n_rigid`` rigid walls (default 36) and the rest of ``n_wood`` wooden walls (default 36 in
  all) fill whole quarter-turn orbits of four cells, drawn uniformly among the cells left (never
  the centre); the rigid walls are drawn again until every cell that is not rigid is reachable;
* ``n_items`` power-ups (default 20) hide under the wooden walls of ``n_items / 4`` drawn wooden
  orbits, one kind per orbit (uniform): extra bomb, +1 blast range, kick.

Bodies and rules
----------------
A player has ``ammo`` (bombs it may have on the board, starts 1, at most 10), a ``blast_strength``
(default 2, at most 10) and may ``kick`` (starts false). A bomb explodes on the 10th step counting the
one it is laid on (Pommerman's bomb life); a flame burns for 3 board states (the step of its
explosion and the 2 after).

One step, exactly:

1. Flames burn down one step; where a flame goes out over a destroyed wooden wall, its hidden
   power-up appears.
2. Kicked bombs slide one cell along their direction; a bomb that would enter a wall, a power-up,
   a bomb, a player or a cell another bomb enters stops where it is.
3. Players act. ``bomb`` lays a bomb on one's own cell (when ammo > 0 and no bomb lies there; the
   player stays, and may leave the cell later; no one else may enter it). A move into a wall
   fails. A move into a bomb fails unless the player can kick and the cell past the bomb holds no
   wall, power-up, bomb or player: then the bomb moves one cell now and keeps sliding on the next
   steps (step 2). All moves are simultaneous: moves into the same cell, swaps, a move into a
   player who stays, into a cell a kicked bomb enters, and two kicks into one cell all fail, again
   until no move fails. A player who ends its move on a power-up takes it (extra bomb: ammo + 1;
   range: blast strength + 1; kick).
4. Every bomb's timer counts down by 1. A bomb at 0, or lying in a flame, explodes; so does every
   bomb its blast reaches, in the same step (a chain reaction). A blast covers the bomb's cell and
   ``strength - 1`` cells in each of the four directions; a rigid wall stops an arm before it, a
   wooden wall stops an arm on it (that wall burns down). An exploded bomb returns its ammo to
   its owner. Every blast cell becomes a flame for this step and the next 2; a power-up lying in
   a blast is lost.
5. A player standing in a flame dies.

The match ends when at most one team has a player left, or at ``max_cycles`` (default 800, as
Pommerman's).

Where Boomer differs from Pommerman, and why:

* The map is the same under a quarter turn, not under Pommerman's mirror in the diagonal: the
  mirror maps Pommerman's teams (seats 0 and 2 on one diagonal, 1 and 3 on the other) onto
  themselves, so its team game was not symmetric between teams; a quarter turn maps every seat
  onto the next. All non-rigid cells are reachable (Pommerman accepts up to 4 cut off).
* Blast strength 2 (Pommerman's default) reaches one cell past the bomb; ``blast_strength``
  changes it for the whole match (2..10).
* Simultaneous moves are settled by the rule of step 3, simpler than Pommerman's sequence of
  reverts: bombs slide before players move (Pommerman moves both at once), a kick needs the cell
  past the bomb clear when the players act, and a sliding bomb stops behind another bomb even
  when that one slides on.
* A blast on a flame that still burns over a destroyed wooden wall keeps that wall's power-up
  hidden until the last flame goes out (Pommerman loses it).
* The duel (2T1P) is played on the same 11-board, from opposite corners (Pommerman's OneVsOne uses an
  8-board with 16 rigid and 16 wooden walls and 10 power-ups: ``size=8, n_rigid=16, n_wood=16,
  n_items=8`` comes close). There is no fog and no radio (Pommerman's TeamRadio): every seat sees
  the whole board, as in Pommerman's free-for-all and team games.
* A timed-out match is a tie among the teams left (Pommerman: everyone loses), and the result
  ranks teams by when they were eliminated (Pommerman: the last one standing wins, all others
  lose alike): elimination order, Arena's convention for last-standing games.

Seat frame
----------
Every seat sees and acts in *its own frame*: the board turned back by its quarter turns so that
it starts at (1, 1), the top-left corner. Quarter turns: 2T1P seats 0, 1 at 0, 2 (opposite
corners); 4T1P seats 0..3 at 0, 1, 2, 3; 2T2P team 0 (seats 0, 1) at 0, 2 and team 1 (seats 2, 3)
at 1, 3, so teammates start in opposite corners as in Pommerman and a quarter turn maps one team
onto the other. One policy plays any seat.

Actions
-------
Discrete 6 (Pommerman's): 0 stop, 1 up, 2 down, 3 left, 4 right (in the seat's own frame), 5 bomb.
Every action is always legal (``action_mask()`` is ``None``); a dead seat's actions are ignored.

Observation (``float32``, per seat, in its own frame; all cells in [0, 1])
-------------------------------------------------------------------------
=======================================  ==========================================================
index                                    content
=======================================  ==========================================================
``0 .. 3``                               own alive flag, ammo / 10, blast strength / 10, can kick
``4 .. 4 seats - 1``                     the same 4 values of every other seat, teammates first,
                                         then opponents, in seat order (zeros for the dead)
then 11 planes of ``size^2`` cells,      rigid wall; wooden wall; power-ups: extra bomb, range,
row-major (row 0 is the seat's "up")     kick; bomb: 1 / steps to its explosion; blast: 1 / steps
                                         until a known blast reaches the cell (the earliest, chains
                                         included, sliding ignored); flame: board states it still
                                         burns, this one included, / 3; own position; teammates'
                                         positions; opponents' positions
=======================================  ==========================================================

Size ``4 seats + 11 size^2``: 1339 for two seats, 1347 for four (size 11). A dead seat's row is 0.

Global state: the first 8 planes in the board's frame (``8 size^2``), then per seat alive,
ammo / 10, blast strength / 10, can kick, row / (size - 1), column / (size - 1) (zeros for the
dead): ``8 size^2 + 6 seats`` cells, all in [0, 1].

Measures
--------
``active`` and ``alive`` (the player lives), ``resource_gain`` (1 on a step it takes a power-up),
``outcome`` (at the end, ``2 * team_result / (teams - 1) - 1``: +1 win, 0 draw, -1 loss with two
teams). Events of each step, each with its ``seat``: ``laid_a_bomb``, ``kicked_a_bomb``,
``took_a_power_up``, ``death``.

Episode end
-----------
``team_result()`` ranks teams by elimination order: a team with a player left outlives every
eliminated team, the others rank by the step their last player died (later is better); teams out
on the same step, or left at the end, tie. A team scores 1 per team it beats and 0.5 per team it
ties (two teams: 1 / 0.5 / 0).

Default social tree
-------------------
A CP ``ranking`` root with order ``"survive"`` (scale 1) over the teams: the agents themselves in
1P layouts, NL nodes of the two teammates in 2T2P. Places pay ``1 - 2 p / (teams - 1)``: +1 / -1
in a duel, as Pommerman's win and loss.

Heuristic
---------
Deterministic, from each observation alone: among stop and the four moves, it keeps those that
lead to a cell no known blast will reach on a path that never stands in a flame (looking 13 steps
ahead); it lays a bomb where it stands when the blast would reach a wooden wall or an opponent and
such a way out exists with that bomb counted; otherwise it walks (stop on a tie) toward the nearest
cell next to a wooden wall or an opponent, or onto a power-up; with no safe move it at least avoids
a cell that burns on the next step. It outlives uniformly random play in 397 of 400 duels
(seeded, seats swapped halfway; 1 draw, 2 losses).

Tuned heuristics
    The same script with other constants, named with them (``scripted:heuristic-hunt1-wary1``):
    ``hunt`` (holding that many bombs, it seeks the cells its blast would reach an opponent from,
    and power-ups, instead of wood), ``wary`` (its ways out keep that many steps off an opponent, who
    may step into a shared cell first: both moves then fail), ``block`` (with an opponent in a known
    blast, it stands where the opponent keeps fewest ways out) and ``press`` (it bombs rather than
    contest the one cell between it and an opponent); all 0 in the heuristic. Two heuristics draw
    every duel (the map and play are symmetric); ``heuristic-block10-hunt1-wary1`` beat the heuristic
    in 120 of 200 duels (49 draws, league seed 11) and 111 of 200 (59 draws, seed 12), 119 of 200
    team games (2T2P, seed 11) and all 200 duels against random play; ``heuristic-hunt1`` won 94 of
    200 (91 draws), ``heuristic-press1`` 26 (37 losses), ``heuristic-wary2`` 18 (67 losses; seed 11).

Search agent (``scripted:search-wW-r1-hH[-eE]``, :func:`~arena_league.envs.games.boomer.search.search_moves`)
    In a duel, with the opponent 6 steps away or nearer, it rebuilds the board from its observation on
    the batched engine (a bomb counted as the nearer player's, at that player's blast strength, lying
    still; nothing hidden under wood) and tries ``W`` first actions: the tuned heuristic
    ``heuristic-block10-hunt1-wary1``'s own, then bomb, stop, up, down, left, right. Each is played out
    ``H`` steps, the opponent by the heuristic from its own seat, itself by that tuned heuristic; it
    plays the first action whose play-out ends best (the opponent out first, over neither, over both
    out on one step, over itself out first), the tuned heuristic's own on a tie. Farther from the
    opponent, and in team and free-for-all games, it plays the tuned heuristic. The play-outs are
    deterministic, so ``R`` must be 1; ``E`` plays a uniformly random action with that probability.
    It sees how the heuristic answers, so it walks the opponent into its blasts: ``search-w6-r1-h10``
    beat the heuristic in 189 of 200 duels (8 draws, 3 losses; league seed 11) and 189 of 200 (7 draws,
    4 losses; seed 12), all 200 against random play (seed 11), and, playing the tuned heuristic there,
    119 of 200 team games (2T2P, 42 draws, seed 11). Its decisions cost about 3 ms each on average
    (100-120 s for the 200 duels against the heuristic on one core, against 12 s for the tuned heuristic).

Game kwargs
-----------
``size`` (default 11, 7..15), ``n_rigid`` (default 36), ``n_wood`` (default 36), ``n_items``
(default 20; at most ``n_wood``), all three multiples of 4 (the default counts need a board of at
least 10; a smaller one takes fewer walls); ``blast_strength`` (default 2, 2..10).
Declared in ``BoomerRules.options`` (listed by ``arena-league games``).

Batched engine
--------------
:class:`~arena_league.envs.games.boomer.boards.BoomerBoards` steps many boards at once with
whole-array numpy operations (bombs, flames and walls as per-cell arrays of every board; a chain
reaction loops over the bombs that explode, not over the boards)::

    boards = BoomerBoards(n_boards=1024, n_seats=4, seed=0, autoreset=True)
    while True:
        boards.step(boards.random_actions())   # int64[B, seats], each in its seat's frame
        boards.done, boards.final_scores       # boards that ended on this step, their team scores

A board's map is a function of its ``uint64`` key only (``reset(boards, keys)``), whatever else is
in the batch. :class:`BoomerMatches` is the match engine's and training's whole-array path
(``BoomerRules.batched_matches``): matches of one layout on one engine built like the rules' own,
each match's key drawn from its seed as ``BoomerRules.reset`` draws it.

One-board engine
----------------
A single match (``BoomerRules``, hence the PettingZoo env) runs on
:class:`~arena_league.envs.games.boomer.board.BoomerBoard`, the batched engine's rules for one board
in plain Python: a one-board batch pays numpy's per-call cost on some 150-200 array operations a step
(about 3,000 env steps per CPU second), while a match holds a few seats, bombs and flames. Its cells
are ``bytearray`` s, its bombs and flames sets of cells, and it keeps the eight shared observation
planes up to date cell by cell, so all seats' observations are one gather. It equals
``BoomerBoards`` exactly, step by step: maps, cells, seats, observations, global state, team scores
(``tests/test_game_boomer_board.py``). Through the PettingZoo API with random actions (a match ends
every 15-24 steps, and each draws a map), 23,000-28,000 env steps per CPU second on one core for
2T1P and 19,000-22,000 for 2T2P and 4T1P on a shared machine (docs/performance.md), up from about
3,000 on a one-board batch.

Playing it (``arena-league play``)
----------------------------------
The board is drawn in text: ``#`` rigid, ``+`` wood, ``e`` ``r`` ``k`` power-ups (extra bomb,
range, kick), a digit a bomb's steps left (9 for 9 or more), ``*`` flame, you ``@``, teammates
``A``.., opponents ``X``... A move is ``w``, ``a``, ``s``, ``d`` (or ``up``, ``left``, ``down``,
``right``) on the board *as drawn*, turned into the seat's frame for you; ``b`` lays a bomb; Enter
or ``x`` stops. In a browser (4 steps a second): each press of an arrow key or W A S D moves one cell,
space or B lays a bomb; without a press the player stops.

Rendering
---------
A top-down picture, ``320 // size`` pixels a cell: passages light, rigid walls dark grey, wooden
walls brown, power-ups (extra bomb blue, range orange, kick green), flames red-orange, bombs
black, players in their team's colour. ``render_mode="rgb_array"`` returns it.

Copies
------
The match is plain numpy arrays: rules pickle and copy as they are.

Replay scene
------------
The board's floor (entity ``board``), the walls (``walls``: rigid grey, wood brown cubes), the
power-ups (``power_ups``, spheres), bombs (``bombs``, black spheres), flames (``flames``, flat
orange cubes) and each player (``agent/<seat>``, a sphere in its team's colour; empty once dead).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from arena_league.envs import scene
from arena_league.envs.boards import BoardSlots, OneBoard
from arena_league.envs.controls import Controls, arrow_keys, key_controls
from arena_league.envs.core import GameRules, Measures, cell_bounds
from arena_league.envs.games.boomer.board import BoomerBoard
from arena_league.envs.games.boomer.boards import (
    ACTIONS,
    BOMB,
    EXTRA_BOMB,
    KICK,
    N_BOARD_PLANES,
    RANGE,
    RIGID,
    STATE_PER_AGENT,
    WOOD,
    BoomerBoards,
)
from arena_league.envs.games.boomer.heuristic import heuristic_actions
from arena_league.envs.games.boomer.search import search_moves
from arena_league.envs.options import Option
from arena_league.envs.rendering import TEAM_COLOURS, grid_picture
from arena_league.envs.social import team_groups

#: Quarter turns of each seat's start, by layout (teams, players per team).
QUARTER_TURNS: dict[tuple[int, int], tuple[int, ...]] = {(2, 1): (0, 2), (4, 1): (0, 1, 2, 3), (2, 2): (0, 2, 1, 3)}
#: The action of a move on the board as drawn, by compass direction (0 up, 1 right, 2 down, 3 left).
_MOVE_OF_DIRECTION = (1, 4, 2, 3)


#: Picture colours by code: passage, rigid, wood, the three power-ups, flame, bomb (then the teams').
PALETTE: dict[int, tuple[int, int, int]] = {0: (236, 232, 214), 1: (80, 80, 88), 2: (150, 105, 60),
                                            EXTRA_BOMB: (60, 120, 230), RANGE: (240, 150, 30), KICK: (60, 180, 90),
                                            6: (250, 90, 30), 7: (20, 20, 20)}


#: Each measure and the engine's array it copies, every step.
MEASURE_SOURCES: tuple[tuple[str, str], ...] = (("alive", "alive"), ("active", "alive"), ("resource_gain", "picked"))


def final_outcome(team_scores: np.ndarray, team_of: np.ndarray, n_teams: int) -> np.ndarray:
    """``float64[k, seats]``: every seat's ``outcome`` from its team's score (``[k, teams]``)."""
    return 2.0 * team_scores[:, team_of] / (n_teams - 1) - 1.0


def start_measures(m: Measures, slot: Any = slice(None)) -> None:
    """The measures of a match at its start (one match's, or one slot of many)."""
    m.active[slot] = True
    m.alive[slot] = True
    m.resource_gain[slot] = 0.0
    m.outcome[slot] = 0.0


class BoomerMatches(BoardSlots):
    """Boomer matches stepped together on a ``BoomerBoards`` engine built like ``BoomerRules``' own
    one-board engine; each match's key is drawn from its seed as ``BoomerRules.reset`` draws it.
    ``measures`` holds every match's measures as the rules set them; ``state()`` every match's
    global state (what a training batch computes rewards from)."""

    def __init__(self, rules: Any, n_slots: int, max_cycles: int) -> None:
        one = rules.engine
        self.n_slots = n_slots
        self.max_cycles = max_cycles
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.n_teams = rules.n_teams
        self.boards = BoomerBoards(n_slots, one.n_seats, size=one.size, n_rigid=one.n_rigid, n_wood=one.n_wood,
                                   n_items=one.n_items, blast_strength=one.blast_strength, team_of=one.team_of,
                                   quarter_turns=one.quarter_turns, max_steps=max_cycles)
        self.boards.done[:] = True  # idle slots: the engine leaves finished boards alone
        self.measures = Measures.allocate(rules.n_agents, rules.measures_provided, n_slots)

    def start(self, slot: int, seed: int) -> None:
        key = np.random.default_rng(seed).integers(0, 2**64, size=1, dtype=np.uint64)
        self.boards.reset(np.array([slot]), keys=key)
        start_measures(self.measures, slot)

    def acting(self) -> np.ndarray:
        return self.boards.alive & ~self.boards.done[:, None]

    def step(self, actions: np.ndarray) -> np.ndarray:
        boards = self.boards
        live = ~boards.done
        boards.step(actions.astype(np.int64, copy=False))  # the engine cuts a match at max_cycles itself
        ended = live & boards.done
        for measure, source in MEASURE_SOURCES:
            np.copyto(getattr(self.measures, measure), getattr(boards, source), where=live[:, None])
        if ended.any():
            finished = np.flatnonzero(ended)
            self.measures.outcome[finished] = final_outcome(boards.team_scores(finished), self.team_of, self.n_teams)
        return ended

    def steps(self, slot: int) -> int:
        return int(self.boards.t[slot])


class BoomerRules(OneBoard, GameRules):
    """One Boomer match (the one-board engine, ``BoomerBoard``); the package docstring is its manual."""

    name: ClassVar[str] = "Boomer"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2), (4, 1))
    action_types: ClassVar[tuple[str, ...]] = ("discrete",)
    measures_provided: ClassVar[frozenset[str]] = frozenset({"active", "alive", "resource_gain", "outcome"})
    default_max_cycles: ClassVar[int] = 800
    summary: ClassVar[str] = "players lay bombs among rigid and wooden walls; the last team standing wins"
    batched_matches: ClassVar[type[BoomerMatches]] = BoomerMatches
    options: ClassVar[tuple[Option, ...]] = (
        Option("size", int, 11, "the board's side, in cells", low=7, high=15),
        Option("n_rigid", int, 36, "rigid walls (a multiple of 4)", low=0),
        Option("n_wood", int, 36, "wooden walls, the lanes between corners included (a multiple of 4)", low=0),
        Option("n_items", int, 20, "power-ups hidden under wooden walls (a multiple of 4, at most n_wood)", low=0),
        Option("blast_strength", int, 2, "every player's starting blast strength: an arm reaches strength - 1 "
               "cells past the bomb", low=2, high=10))

    def __init__(self, n_teams: int, players_per_team: int, action_type: str, **options: Any) -> None:
        settings = self.checked_options(options)
        if action_type != "discrete":
            raise ValueError(f"Boomer has only the 'discrete' action variant, not {action_type!r}")
        super().__init__(n_teams, players_per_team, action_type)
        self.settings = settings
        self.engine = BoomerBoard(self.n_agents, size=settings["size"], n_rigid=settings["n_rigid"],
                                  n_wood=settings["n_wood"], n_items=settings["n_items"],
                                  blast_strength=settings["blast_strength"], team_of=self.team_of,
                                  quarter_turns=QUARTER_TURNS[(n_teams, players_per_team)])
        self.size = self.engine.size
        self.obs_dim = self.engine.obs_dim
        self.state_dim = self.engine.state_dim
        self.n_actions = len(ACTIONS)
        self.act_dim = 0
        self.action_meanings = ACTIONS
        self._events: list[dict] = []
        self._gained = False

    # --- the match -------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.engine.reset(keys=self.rng.integers(0, 2**64, size=1, dtype=np.uint64))
        start_measures(self.measures)
        self.game_over = False
        self._events = []
        self._gained = False

    def step(self, actions: np.ndarray) -> None:
        if self.game_over:
            raise RuntimeError("Boomer: the match is over; call reset() before step()")
        engine = self.engine
        actions = np.asarray(actions, dtype=np.int64).reshape(-1).tolist()
        if len(actions) != self.n_agents:
            raise ValueError(f"Boomer takes one action per seat ({self.n_agents}), not {len(actions)}")
        engine.play(actions)
        measures = self.measures
        # the measures change only with a death or a power-up taken (or the step after one): most steps write nothing
        if self._gained or any(engine._picked):
            measures.resource_gain[:] = engine._picked
            self._gained = any(engine._picked)
        if engine.eventful:
            if any(engine._died):
                measures.alive[:] = measures.active[:] = engine._alive
            self._events = [{"kind": kind, "seat": seat} for kind, flags in (
                ("laid_a_bomb", engine._laid), ("kicked_a_bomb", engine._kicked), ("took_a_power_up", engine._picked),
                ("death", engine._died)) if True in flags for seat, flag in enumerate(flags) if flag]
        elif self._events:
            self._events = []
        if engine._done:
            self.game_over = True
            self.finish()

    def finish(self) -> None:
        self.measures.outcome[:] = final_outcome(self.team_result()[None, :], self.team_of, self.n_teams)[0]

    # --- what seats see: every cell in [0, 1] ----------------------------------------------------
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return cell_bounds((0, 1, self.obs_dim))

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return cell_bounds((0, 1, N_BOARD_PLANES * self.size ** 2 + STATE_PER_AGENT * self.n_agents))

    def picture_codes(self) -> np.ndarray:
        """``int64[size, size]`` of what the picture paints on each cell (:data:`PALETTE`'s keys)."""
        engine = self.engine
        codes = engine.grid(0).copy()  # 0 passage, 1 rigid, 2 wood, 3..5 power-ups
        inner = engine._inner
        codes.reshape(-1)[engine.flame[0, inner] > 0] = 6
        codes.reshape(-1)[engine.bomb_timer[0, inner] > 0] = 7
        cells = engine.board_cell(engine.position[0])
        for seat in np.flatnonzero(engine.alive[0]):
            codes.reshape(-1)[cells[seat]] = 8 + int(self.team_of[seat]) % len(TEAM_COLOURS)
        return codes

    def render_topdown(self) -> np.ndarray:
        palette = dict(PALETTE)
        palette.update({8 + k: colour for k, colour in enumerate(TEAM_COLOURS)})
        picture = grid_picture(self.picture_codes(), palette, max(4, 320 // self.size))
        framed = np.full((picture.shape[0] + 4, picture.shape[1] + 4, 3), 60, dtype=np.uint8)
        framed[2:-2, 2:-2] = picture
        return framed

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        engine, size, ts = self.engine, self.size, timestamp_ns
        inner = engine._inner
        terrain = engine.terrain[0, inner]

        def at(cell: int) -> tuple[float, float]:
            return scene.board_xy(int(cell), size)

        walls = [scene.cube(*at(c), 0.4, (1.0, 1.0, 0.8), (0.35, 0.35, 0.38, 1.0)) for c in np.flatnonzero(terrain == RIGID)]
        walls += [scene.cube(*at(c), 0.3, (0.9, 0.9, 0.6), (0.6, 0.42, 0.25, 1.0)) for c in np.flatnonzero(terrain == WOOD)]
        items = [scene.sphere(*at(c), 0.25, (0.45, 0.45, 0.45), scene.colour_of(PALETTE[int(terrain[c])]))
                 for c in np.flatnonzero(terrain >= EXTRA_BOMB)]
        bombs = [scene.sphere(*at(c), 0.3, (0.6, 0.6, 0.6), (0.05, 0.05, 0.05, 1.0))
                 for c in np.flatnonzero(engine.bomb_timer[0, inner] > 0)]
        flames = [scene.cube(*at(c), 0.05, (1.0, 1.0, 0.1), (1.0, 0.4, 0.1, 0.8))
                  for c in np.flatnonzero(engine.flame[0, inner] > 0)]
        out = [scene.entity("board", ts, cubes=[scene.cube(size / 2, size / 2, -0.05, (size, size, 0.1),
                                                           (0.92, 0.9, 0.82, 1.0))]),
               scene.entity("walls", ts, cubes=walls), scene.entity("power_ups", ts, spheres=items),
               scene.entity("bombs", ts, spheres=bombs), scene.entity("flames", ts, cubes=flames)]
        cells = engine.board_cell(engine.position[0])
        for seat in range(self.n_agents):
            body = [scene.sphere(*at(cells[seat]), 0.45, (0.8, 0.8, 0.9), scene.team_colour(int(self.team_of[seat])))] \
                if engine.alive[0, seat] else []
            out.append(scene.entity(f"agent/{seat}", ts, spheres=body))
        return out

    def human_controls(self, seat: int) -> BoomerControls:
        return BoomerControls(self, seat)

    # --- the social tree and the scripted player ----------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        children = team_groups(n_teams, players_per_team)
        return {"scheme": "CP", "reward": "ranking", "scale": 1, "params": {"order": "survive"},
                "children": children}

    heuristic_options: ClassVar[dict[str, tuple[float, float]]] = {"block": (0, 20), "hunt": (0, 10), "press": (0, 1),
                                                                  "wary": (0, 3)}
    heuristic_options_meaning: ClassVar[str] = (
        "block B: while an opponent stands in a known blast, each of its ways out left open by the cell it moves to "
        "costs B steps of walking (the heuristic's 0: it ignores them); hunt H: holding H bombs or more, it walks "
        "toward the cells its blast would reach an opponent from and power-ups, no longer toward wood, and waits "
        "where it cannot get there (the heuristic's 0: never); press P: with P 1, when it and an opponent two "
        "steps away head for the one cell between them, it lays a bomb there instead (the heuristic's 0: never); "
        "wary W: it flees, and lays a bomb only with a way out, on cells more than W steps from an opponent "
        "where such ways exist (the heuristic's 0: any way out)")

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str, *, block: float = 0, hunt: float = 0, press: float = 0,
                  wary: float = 0) -> np.ndarray:
        return heuristic_actions(obs, block=block, hunt=hunt, press=press, wary=wary)

    search_budget_meaning: ClassVar[str] = (
        "W first actions (the tuned heuristic's own, then bomb, stop, up, down, left, right), each played out H "
        "steps on the board rebuilt from a duel seat's observation with both players' heuristics; R must be 1")
    search_without_rollouts: ClassVar[str | None] = "both players' heuristics are deterministic"

    @staticmethod
    def search(obs: np.ndarray, uniforms: np.ndarray, *, action_type: str, width: int, rollouts: int, horizon: int,
               epsilon: float) -> np.ndarray:
        """:func:`~arena_league.envs.games.boomer.search.search_moves` (dead seats stop; the rules ignore them)."""
        obs = np.asarray(obs, dtype=np.float32)
        actions = search_moves(obs, uniforms, width=width, rollouts=rollouts, horizon=horizon, epsilon=epsilon)
        return np.where(obs[:, 0] > 0.5, actions, 0) if len(obs) else actions



#: What a person types for each move on the board as drawn (compass: 0 up, 1 right, 2 down, 3 left).
HUMAN_MOVES: dict[str, int] = {"w": 0, "up": 0, "d": 1, "right": 1, "s": 2, "down": 2, "a": 3, "left": 3}
_CELL_CHARS = {0: ".", RIGID: "#", WOOD: "+", EXTRA_BOMB: "e", RANGE: "r", KICK: "k"}


class BoomerControls(Controls):
    """A person moves on the board as drawn (w/a/s/d), turned into the seat's frame; b lays a bomb."""

    rules: BoomerRules

    def view(self) -> str:
        rules, engine = self.rules, self.rules.engine
        inner = engine._inner
        chars = np.array([_CELL_CHARS[int(c)] for c in engine.terrain[0, inner]], dtype="<U1")
        chars[engine.flame[0, inner] > 0] = "*"
        timers = engine.bomb_timer[0, inner]
        for cell in np.flatnonzero(timers > 0):
            chars[cell] = str(min(int(timers[cell]), 9))
        cells = engine.board_cell(engine.position[0])
        mates = [s for s in range(rules.n_agents) if s != self.seat and rules.team_of[s] == rules.team_of[self.seat]]
        rivals = [s for s in range(rules.n_agents) if rules.team_of[s] != rules.team_of[self.seat]]
        names = {self.seat: "@"} | {s: chr(ord("A") + k) for k, s in enumerate(mates)} | \
            {s: chr(ord("X") + k) for k, s in enumerate(rivals)}
        for seat, name in names.items():
            if engine.alive[0, seat]:
                chars[cells[seat]] = name
        size = rules.size
        lines = ["".join(chars[r * size:(r + 1) * size]) for r in range(size)]
        under = int(engine.bomb_timer[0, engine.position[0, self.seat]]) if engine.alive[0, self.seat] else 0
        me = f"You are @: ammo {int(engine.ammo[0, self.seat])}, blast strength {int(engine.strength[0, self.seat])}" \
             f"{', can kick' if engine.can_kick[0, self.seat] else ''}" \
             f"{f', on a bomb ({under} steps left)' if under else ''}{'' if engine.alive[0, self.seat] else ' (dead)'}."
        return "\n".join(lines) + "\n" + me

    def prompt(self, step: int) -> str:
        return f"step {step}: w up, a left, s down, d right, b bomb (Enter: stop) > "

    def parse(self, text: str) -> tuple[int | None, str | None]:
        if text in ("", "x", "stop"):
            return 0, None
        if text in ("b", "bomb"):
            return BOMB, None
        if text not in HUMAN_MOVES:
            return None, f"{text!r} is not a move: type w, a, s or d to move, b to lay a bomb, or Enter to stop"
        turns = int(self.rules.engine.quarter_turns[self.seat])
        return _MOVE_OF_DIRECTION[(HUMAN_MOVES[text] - turns) % 4], None

    def web(self) -> dict[str, Any]:
        keys = arrow_keys("w", "a", "s", "d") | {" ": "b", "b": "b", "B": "b"}
        # a press is one step's answer (the player stops after it): a tap of the bomb key is never lost
        return key_controls(keys, 4.0, "Each press of an arrow key or W A S D moves one cell on the board as drawn; "
                            "space or B lays a bomb.")


RULES = BoomerRules
