"""CaptureFlag: two teams on a walled grid each guard a flag and carry the other's home to score.

After the capture-the-flag game of Jaderberg et al., "Human-level performance in 3D multiplayer
games with population-based reinforcement learning" (Science 2019), as adopted by Song et al.,
"Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent Intelligence" (AAAI
2020), here on a grid, built as a batched numpy engine with a scalar one-board engine for the env.
Ids: ``CaptureFlag-2T1P-v1`` and ``CaptureFlag-2T2P-v1``. Melting Pot's grid substrate
``paintball__capture_the_flag`` (four a side, tagging with a zapping beam that also paints the
floor) has the same scoring rule, a capture only while the own flag is home, and pays the whole
team; here a tag is a touch, as in the playground game, and there is no paint.

Field
-----
A ``rows x cols`` grid (default 11 x 20; ``cols`` even) with walls all round. Team 0's half is the
left ``cols / 2`` columns, team 1's the right. Each team's *stand* (where its flag rests) is at row
``rows // 2``, column 1 (team 0) and ``cols - 2`` (team 1). Each map comes from the match seed:
``wall_segments`` (default 8) straight wall segments of 2 to 4 cells (horizontal or vertical, at a
random cell) are laid in team 0's half and the half is mirrored into team 1's, so both teams play
the same map. No wall falls on the 5 x 3 block of each base (rows ``rows // 2 - 2 .. rows // 2 + 2``,
the three columns nearest the team's end wall). Cells the stands cannot reach become walls; a map
whose halves do not meet (rare) is played without walls. Same seed, same map.

Bodies and moves
----------------
Every seat is one cell; seats may share a cell. A move into a wall leaves the seat where it is.

Start
-----
Seat ``p`` of a team starts on its team's end column (column 0 or ``cols - 1``) at row
``rows // 2 - 1``, ``rows // 2 + 1`` (``p`` = 0, 1). Both flags on their stands, no captures.

Seat frame
----------
Team 1 sees and acts on the map mirrored left to right, so every seat sees its own base on the
left and the opponents' on the right: one policy plays either side.

Actions
-------
Discrete 5, in the seat frame: 0 stay, 1 up, 2 right (toward the opponents' base), 3 down, 4 left.
Every action is always legal; a seat waiting to respawn has its action ignored.

One step, exactly
-----------------
1. Every active seat moves (or not).
2. **Tags**: a seat is *exposed* while it stands in the opponents' half or carries their flag
   (a carrier is exposed everywhere, so two carriers waiting at home cannot freeze the match). An
   exposed seat on the same cell as, or orthogonally next to, an active opponent is tagged; all
   tags are judged at once on everyone's new cells (two exposed seats next to each other tag each
   other; a seat in its own half without a flag is never tagged). A tagged seat drops the flag it
   carries, which goes straight back to its stand; it leaves the field and is placed on its start
   cell, inactive.
3. **Pick-ups**: an active seat on the opponents' stand while their flag rests there takes it (the
   lowest seat first); the flag moves with its carrier.
4. **Captures**: a carrier on its own stand while its own flag rests there scores one capture for
   its team; the captured flag goes back to its stand. A carrier whose own flag is away waits (or
   its teammates tag the opponent carrying it home).
5. **Respawns**: a tagged seat misses the next ``respawn_delay`` steps (default 5) and is active
   again, on its start cell, from the step after.

The match ends when a team reaches ``captures_to_win`` captures (default 3), or at ``max_cycles``
(default 300): the team with more captures wins; on equal captures the team that held the
opponents' flag for more steps wins (a step counts for a team when it ends with one of its seats
carrying the opponents' flag, the pick-up's step included, the capture's not), as flag-time rules
settle a tied capture-the-flag game; equal captures and equal steps draw. Competent play seldom
captures in 300 steps: a heuristic team playing one that moves at random 10% of the time drew 72
of 200 2T1P matches (93 of 200 2T2P) on captures, 5 (4) on held steps; two such noisy heuristic
teams drew 136 (142) on captures, 8 (1) on held steps. Two plain heuristic teams play mirror
images of each other on the mirrored map (neither even picks up) and still draw every match.

Observation (``float32``, per seat, in its seat frame)
------------------------------------------------------
=========================  =====================================================================
index                      content
=========================  =====================================================================
``0``                      active (0 while waiting to respawn)
``1, 2``                   own row, column in the seat frame, scaled to [-1, 1]
``3``                      carrying the opponents' flag
``4, 5``                   own flag on its stand; opponents' flag on its stand
``6``                      standing in the opponents' half (taggable)
``7``                      steps left to respawn / ``respawn_delay`` (0 while active)
``8, 9``                   own team's and the opponents' captures / ``captures_to_win``
``10 .. 14``               per action: it leads into a wall
``15 .. 19``               per action: steps from the cell it leads to (the own cell when
                           blocked) to the opponents' stand, / (2 (rows + cols)), at most 1
``20 .. 24``               the same to the own stand
``25 .. 29``               per action: danger, the seat would be exposed on the cell with an active
                           opponent 1 step away or on it (1) or 2 steps away (0.5)
``30, 31``                 the opponents' flag now (on its stand or with its carrier), relative:
                           rows / (rows - 1), columns (seat frame) / (cols - 1)
``32, 33``                 the own flag now, the same
``34 .. 58``               walls in the 5 x 5 window around the seat (seat frame, row-major,
                           off the grid counts as wall)
then 5 per other seat      relative row, column (as above), active, carrying a flag, exposed (in
(teammates, then           its opponents' half or carrying)
opponents, in seat order)
=========================  =====================================================================

Size: ``59 + 5 (seats - 1)``: 64 for 2T1P, 74 for 2T2P. Bounds: positions [-1, 1], relative
positions [-1, 1], everything else [0, 1].

Global state: the walls (``rows * cols``, board frame), then per seat row and column scaled to
[-1, 1], active, carrying, respawn as in the observation; per team's flag its row and column
scaled to [-1, 1] and whether it is carried; both teams' captures / ``captures_to_win``. Bounds
[-1, 1]. ``state_dim = rows cols + 5 seats + 8``.

Measures
--------
``active`` (not waiting to respawn); ``target_distance`` (steps from the seat to its target: the
opponents' stand, or its own while carrying); ``velocity_to_target`` (how many steps closer to the
target it had before the step the seat's move brought it: +1, 0, -1; 0 for a tagged seat and the
step's respawn); ``object_progress`` (the same for every member of a team: how many steps the
opponents' flag it carries came nearer its own stand this step, with a capture counting the steps
of the last move and a tagged carrier losing what the carry had gained); ``outcome`` (at the end:
+1 win, 0 draw, -1 loss). ``team_result()`` is 1 / 0.5 / 0 by captures, then by steps holding the
opponents' flag (the engine's ``held_steps``).

Events: ``tag`` (the seat), ``pickup`` (the seat), ``capture`` (the team).

Default social tree
-------------------
Arena's convention for team games, as in Jaderberg et al.'s CTF where the learning signal is the
team's win and its captures: a CP ``win_loss`` root (scale 10) over one CL ``team_progress`` node
per team (scale 1: the team shares every step its carried flag comes home, a capture included,
and every loss a tag costs), each over an IS ``velocity_to_target`` leaf per seat (scale 0.05: a
seat's own way to the flag and back). CL rather than CC at the team level: within a team
everything is shared, and the competition between the teams is the root's; CC would fold both
into one node and lose the shaping of the carry. ``example_trees`` offers that alternative as
``flag_race``: a CC ``team_progress_race`` node over every seat (a team's carry gain minus the
mean of both teams'), each seat with the same IS leaf; in 2T2P it verifies as CC over 32 paired
samples.

Heuristic
---------
Deterministic, from the observation row: a carrier heads home by the per-action distances to its
own stand; a seat whose flag has been taken (or, at home, whose teammate carries the opponents'
flag) chases the nearest exposed opponent, the one carrying its flag first; with a teammate, the
seat further back (the upper one on a tie) guards: it heads for its own stand and chases exposed
opponents; everyone else heads for the opponents' stand. Unless chasing, it avoids cells with
danger (1: heavily, 0.5: a little); it never walks into a wall and moves rather than stands on a
tie. Against uniformly random play it won 60 of 60 seeded matches of either layout, 30 on each
side (``tests/test_game_captureflag.py``); two heuristic teams hold each other off at the centre
line (draws).

Tuned heuristics (``scripted:heuristic-commit0.5-hunt6-keep0.5-sortie0.9``) change only the
*keeper*, the lone seat or the guard, with four options, 0 (off) for the heuristic: ``keep``
(0 to 10) keeps it near enough its stand to be back within 2 steps of it ``keep`` - 1 steps
before any opponent could reach it (an exposed seat shuns cells within 2 steps of an active
opponent, so a raider never takes that flag); ``hunt`` (0 to 20) hunts an exposed opponent within
that many steps, each move judged on where the opponent will flee (a cornered one is tagged);
``commit`` (0 to 10) raids when the keeper is that many steps nearer the opponents' stand than any
opponent is to its own, a race it wins (an opponent back from a tag starts far away); otherwise it
waits on its stand, drawing a raider deep into its half, but ``sortie`` (0 to 1.5) walks it out
while every opponent is farther than ``sortie`` times the field's length from its stand, so that
one that stays away is raided. Against the heuristic in 2T1P (200 matches, league seeds 11 / 12):
``heuristic-commit0.5-hunt6-keep0.5-sortie0.9`` won 121 / 112 and lost 10 / 16 (200 of 200
against random play); ``heuristic-commit1-hunt20-sortie0.9`` won 80 / 88, lost 34 / 38;
``heuristic-commit1-hunt8-keep2`` won 38 / 40, lost 14 / 12; ``heuristic-hunt20``, which chases
but never raids, won none and lost 67 / 74. Without ``sortie`` a keeper seldom raids an opponent
that stays away: against random play (seed 11) the second won 200, the third 160 and the last
none (all draws). In 2T2P the guard already holds the stand and the raider plays as before: the
first drew all 200 against the heuristic.

Search agent (``scripted:search-wW-r1-hH[-eE]``, :func:`~arena_league.envs.games.captureflag.search.search_moves`)
    In a duel, with the opponent ``W`` steps away or nearer (Manhattan), it rebuilds the map from its
    observation (the walls of its window and their mirror image, the rest open) and plays every sequence
    of its next ``H`` moves (``5 ** H``) against the heuristic's predicted answers there: hunting an
    exposed opponent, it plays the first move of the soonest sequence that tags it, if any; raiding past
    an opponent in its own half, that of the sequence that picks up the flag soonest, or else ends
    nearest the opponents' stand, not within 2 steps of the opponent, never one that gets it tagged or
    lets the opponent reach a stand. Elsewhere (and in 2T2P) it plays
    ``heuristic-commit0.5-hunt6-keep0.5-sortie0.9``. ``R`` must be 1 (the play-outs are deterministic);
    ``E`` plays a uniformly random action with that probability. Against the heuristic in 2T1P (200
    matches, seats alternating): ``search-w8-r1-h3`` won 139 / 126 and lost 13 / 18 (league seeds 11 /
    12) and 129 of the population build's 200 (seed 0, its match ids; 15 lost), all 200 against random
    play (seed 11), about 10 s for the 200 matches on one core; ``search-w8-r1-h4`` won 134 / 130, five
    to eight times slower; ``search-w8-r1-h2`` 122 / 115. In 2T2P it drew all 200 (seed 11).

Game kwargs: ``rows`` (default 11, 7 .. 31), ``cols`` (default 20, even, 10 .. 40),
``wall_segments`` (default 8, 0 .. 20), ``respawn_delay`` (default 5, 1 .. 50),
``captures_to_win`` (default 3, 1 .. 20), declared in ``CaptureFlagRules.options``.

Batched engine
--------------
:class:`~arena_league.envs.games.captureflag.engine.CaptureFlagBoards` steps many boards at once
with whole-array numpy operations; a board's match is a function of its key and the actions::

    boards = CaptureFlagBoards(n_boards=1024, players_per_team=2, seed=0, autoreset=True, max_steps=300)
    while True:
        boards.step(boards.random_actions())   # int64[B, seats], each in its seat frame
        boards.done, boards.final_scores

``reset(boards=None, keys=None)``, ``set_board(board, walls, positions=None)`` (a position for
tests), ``observe() -> float32[B, seats, obs_dim]``, ``state()``, ``team_scores(boards=None)``.
:class:`~arena_league.envs.games.captureflag.engine.CaptureFlagMatches` is the match engine's
whole-array path (``CaptureFlagRules.batched_matches``), each match's map drawn from its seed as
``reset`` draws it.

One match
---------
The rules (and so the env) play one match on
:class:`~arena_league.envs.games.captureflag.scalar.ScalarBoard`: the same step in Python ints and
lists, observations built from rows of tables cut once per map. Maps are still drawn by a one-board
:class:`CaptureFlagBoards`, the reference, which ``CaptureFlagRules.engine`` hands to tools up to
date; what a tool sets on it (``set_board``, ``carrier``...) is the match from the next step on.
``tests/test_game_captureflag_scalar.py`` plays seeded matches of both layouts and several option
sets on both engines and finds every step alike. Speed through the PettingZoo API with the default
tree, one core: 25,000-31,000 env steps per CPU second in 2T1P and 21,000-24,000 in 2T2P on the
project's busy 2-core machine, against about 3,300 on a one-board ``CaptureFlagBoards``
(``docs/performance.md``).

Playing it (``arena-league play``)
----------------------------------
The map is drawn in text: ``#`` wall, ``F``/``f`` your team's / the opponents' flag, ``@`` you,
your teammates ``A``..., opponents ``1``... (lower case while they wait to respawn). Moves are ``w``,
``a``, ``s``, ``d`` (or ``up``, ``left``, ``down``, ``right``) on the map as drawn, Enter stays; in a
browser the arrow keys or W A S D.

Rendering
---------
A top-down picture (``max(8, 400 // cols)`` pixels a cell): each half's floor tinted in its
team's colour, walls dark, each stand white, seats in their team's colour (darker while they
carry, pale while they wait), each flag as a small square in its team's colour.
``render_mode="rgb_array"`` returns it; ``"human"`` shows it in a window.

Copies
------
The match is plain arrays and lists: rules pickle and copy as they are.

Replay scene
------------
The field (``field``: floor and walls), every seat (``agent/<seat>``: a cube in its team's colour,
flat while it waits) and each flag (``flag/<team>``: a sphere on a pole).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from arena_league.envs import scene
from arena_league.envs.controls import Controls, arrow_keys, key_controls
from arena_league.envs.core import GameRules, Measures, cell_bounds
from arena_league.envs.games.captureflag.engine import (
    ACTIONS,
    AT,
    N_ACTIONS,
    N_HEADER,
    PER_OTHER,
    CaptureFlagBoards,
    CaptureFlagMatches,
    match_key,
)
from arena_league.envs.games.captureflag.heuristic import heuristic_actions
from arena_league.envs.games.captureflag.scalar import ScalarBoard
from arena_league.envs.games.captureflag.search import search_moves
from arena_league.envs.options import Option
from arena_league.envs.rendering import TEAM_COLOURS, grid_picture

__all__ = ["RULES", "CaptureFlagBoards", "CaptureFlagMatches", "CaptureFlagRules"]


class CaptureFlagRules(GameRules):
    """One CaptureFlag match, played by a :class:`ScalarBoard` on maps its reference, a one-board
    :class:`CaptureFlagBoards` (``engine``), draws; the package docstring is its manual."""

    name: ClassVar[str] = "CaptureFlag"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete",)
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "target_distance", "velocity_to_target", "object_progress", "outcome"})
    default_max_cycles: ClassVar[int] = 300
    summary: ClassVar[str] = "two teams on a walled grid carry the other team's flag home; a tag sends a raider back"
    batched_matches: ClassVar[type[CaptureFlagMatches]] = CaptureFlagMatches
    options: ClassVar[tuple[Option, ...]] = (
        Option("rows", int, 11, "the map's height, in cells", low=7, high=31),
        Option("cols", int, 20, "the map's width, in cells; even (the halves mirror each other)", low=10, high=40),
        Option("wall_segments", int, 8, "wall segments laid in each half", low=0, high=20),
        Option("respawn_delay", int, 5, "steps a tagged seat misses", low=1, high=50),
        Option("captures_to_win", int, 3, "captures that end the match", low=1, high=20))
    heuristic_options: ClassVar[dict[str, tuple[float, float]]] = {"commit": (0.0, 10.0), "hunt": (0.0, 20.0),
                                                                   "keep": (0.0, 10.0), "sortie": (0.0, 1.5)}
    heuristic_options_meaning: ClassVar[str] = (
        "commit C: the keeper (the lone seat, or the guard) raids when it is C steps nearer the opponents' stand "
        "than any opponent is to its own (the heuristic's 0: off); hunt H: the keeper hunts an exposed opponent "
        "within H steps (0: off); keep K: the keeper stays near enough its stand to be back within 2 steps of it "
        "K - 1 steps before any opponent could reach it (0: off); sortie S: the keeper otherwise waits on its "
        "stand, but walks out while every opponent is farther than S times the field's length from it (0: off)")

    def __init__(self, n_teams: int, players_per_team: int, action_type: str, **options: Any) -> None:
        settings = self.checked_options(options)
        if settings["cols"] % 2:
            raise ValueError(f"CaptureFlag option cols must be even (the two halves mirror each other), not "
                             f"{settings['cols']}: try {settings['cols'] + 1}")
        self.check_layout(n_teams, players_per_team, action_type)
        super().__init__(n_teams, players_per_team, action_type)
        self.settings = settings
        self._engine = CaptureFlagBoards(1, players_per_team, **settings)
        self._board = ScalarBoard(self._engine)
        self._mirrored = False  # True once a tool holds the engine: then it is the match, between steps
        self.obs_dim, self.state_dim = self._engine.obs_dim, self._engine.state_dim
        self.n_actions, self.act_dim, self.action_meanings = N_ACTIONS, 0, ACTIONS
        self._all_measures = Measures.allocate(self.n_agents, self.measures_provided, 1)
        self.measures = self._all_measures.row(0)
        self._events: list[dict] = []

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self.measures = self._all_measures.row(0)  # views of the one-match arrays again

    # --- the engine, for tools ------------------------------------------------------------------
    @property
    def engine(self) -> CaptureFlagBoards:
        """The match as board 0 of a one-board :class:`CaptureFlagBoards`, for tools and tests:
        up to date when read; what a tool then sets on it (``set_board``, ``carrier``...) is the
        match from the next step on, and every step from then on keeps it up to date."""
        if not self._mirrored:
            self._board.store(self._engine)
            self._mirrored = True
        return self._engine

    def _current(self) -> ScalarBoard:
        """The scalar board, holding the match (read back from the engine a tool holds)."""
        if self._mirrored:
            self._board.load(self._engine)
        return self._board

    def _seen(self) -> CaptureFlagBoards:
        """The engine up to date, to read the match from (pictures, the text view)."""
        if not self._mirrored:
            self._board.store(self._engine)
        return self._engine

    # --- the match -------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self._engine.reset(keys=match_key(seed))
        self._board.load(self._engine)
        self._board.write_measures(self.measures, ended=False)
        self.game_over = False
        self._events = []

    def step(self, actions: np.ndarray) -> None:
        if self.game_over:
            raise RuntimeError("CaptureFlag: the match is over; call reset() before step()")
        values = np.asarray(actions, dtype=np.int64).reshape(-1)
        if values.shape != (self.n_agents,):
            raise ValueError(f"CaptureFlag takes one integer action per seat, shape ({self.n_agents},); got shape "
                             f"{np.shape(actions)}")
        moves = values.tolist()
        if min(moves) < 0 or max(moves) >= N_ACTIONS:
            raise ValueError("CaptureFlag actions are 0 stay, 1 up, 2 right, 3 down, 4 left (seat frame)")
        board = self._current()
        board.step(moves)
        board.write_measures(self.measures, ended=board.done)
        self._events = board.events()
        self.game_over = board.done
        if self._mirrored:
            board.store(self._engine)

    def finish(self) -> None:
        self.measures.outcome[:] = 2.0 * self.team_result()[self.team_of] - 1.0
        self._board.forget_measures()

    def team_result(self) -> np.ndarray:
        return self._current().team_scores()

    def events(self) -> list[dict]:
        return list(self._events)

    def observe(self) -> np.ndarray:
        return self._current().observe()

    def state(self) -> np.ndarray:
        return self._current().state()

    # --- what seats see ----------------------------------------------------------------------
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        low, high = cell_bounds((0, 1, self.obs_dim))
        for name, cells in (("position", 2), ("enemy_flag", 2), ("own_flag", 2)):
            low[AT[name]:AT[name] + cells] = -1.0
        others = low[N_HEADER:].reshape(-1, PER_OTHER)
        others[:, :2] = -1.0
        return low, high

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return cell_bounds((-1, 1, self.state_dim))

    def render_topdown(self) -> np.ndarray:
        engine = self._seen()
        r, c = engine.rows, engine.cols
        codes = np.zeros((r, c), dtype=np.int64)
        codes[:, c // 2:] = 1
        codes[engine.walls[0, engine._inner].reshape(r, c)] = 2
        palette = {0: _tint(TEAM_COLOURS[0]), 1: _tint(TEAM_COLOURS[1]), 2: (50, 50, 55), 3: (255, 255, 255)}
        for team in range(2):
            palette[4 + 3 * team] = TEAM_COLOURS[team]
            palette[5 + 3 * team] = tuple(int(0.5 * x) for x in TEAM_COLOURS[team])
            palette[6 + 3 * team] = _tint(TEAM_COLOURS[team], 0.45)
        cell_px = max(8, 400 // c)
        stands = engine.cell(engine.stands)
        for cell in stands:
            codes.reshape(-1)[cell] = 3
        cells = engine.cell(engine.pos[0])
        carrying = engine.carrying[0]
        for seat in range(self.n_agents):
            team = int(self.team_of[seat])
            code = 4 + 3 * team + (1 if carrying[seat] else 0) + (2 if not engine.active[0, seat] else 0)
            codes.reshape(-1)[cells[seat]] = min(code, 6 + 3 * team)
        picture = grid_picture(codes, palette, cell_px)
        quarter = cell_px // 4
        for team, cell in enumerate(engine.flag_cells(0)):
            row, col = divmod(int(cell), c)
            y, x = row * cell_px + quarter, col * cell_px + quarter
            picture[y:y + 2 * quarter, x:x + 2 * quarter] = TEAM_COLOURS[team]
            picture[y:y + 2 * quarter, x:x + 1] = 0
            picture[y:y + 1, x:x + 2 * quarter] = 0
        return picture

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        engine, ts = self._seen(), timestamp_ns
        r, c = engine.rows, engine.cols
        floor = [scene.cube(c / 4, r / 2, -0.05, (c / 2, r, 0.1), scene.team_colour(0, 0.25)),
                 scene.cube(3 * c / 4, r / 2, -0.05, (c / 2, r, 0.1), scene.team_colour(1, 0.25))]
        wall = (0.3, 0.3, 0.32, 1.0)
        floor += [scene.cube(*_xy(int(cell), r, c), 0.4, (1.0, 1.0, 0.8), wall)
                  for cell in np.flatnonzero(engine.walls[0, engine._inner])]
        out = [scene.entity("field", ts, cubes=floor)]
        cells = engine.cell(engine.pos[0])
        for seat in range(self.n_agents):
            height = 0.7 if engine.active[0, seat] else 0.1
            out.append(scene.entity(f"agent/{seat}", ts, cubes=[scene.cube(
                *_xy(int(cells[seat]), r, c), height / 2, (0.7, 0.7, height),
                scene.team_colour(int(self.team_of[seat])))]))
        for team, cell in enumerate(engine.flag_cells(0)):
            x, y = _xy(int(cell), r, c)
            out.append(scene.entity(f"flag/{team}", ts, cubes=[scene.cube(x, y, 0.6, (0.08, 0.08, 1.2), wall)],
                                    spheres=[scene.sphere(x, y, 1.2, (0.4, 0.4, 0.4), scene.team_colour(team))]))
        return out

    def human_controls(self, seat: int) -> CaptureFlagControls:
        return CaptureFlagControls(self, seat)

    # --- the social tree and the scripted player ----------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        def leaf(seat: int) -> dict:
            return {"agent": f"player_{seat}", "scheme": "IS", "reward": "velocity_to_target", "scale": 0.05}

        teams = [{"scheme": "CL", "reward": "team_progress", "scale": 1,
                  "children": [leaf(t * players_per_team + p) for p in range(players_per_team)]}
                 for t in range(n_teams)]
        return {"scheme": "CP", "reward": "win_loss", "scale": 10, "children": teams}

    @classmethod
    def example_trees(cls, n_teams: int, players_per_team: int) -> dict[str, dict]:
        seats = [{"agent": f"player_{s}", "scheme": "IS", "reward": "velocity_to_target", "scale": 0.05}
                 for s in range(n_teams * players_per_team)]
        return {"flag_race": {"scheme": "CC", "reward": "team_progress_race", "scale": 1, "children": seats}}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str, *, commit: float = 0.0, hunt: float = 0.0, keep: float = 0.0,
                  sortie: float = 0.0) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] < N_HEADER or (obs.shape[1] - N_HEADER) % PER_OTHER:
            raise ValueError(f"CaptureFlag heuristic: observations of shape {obs.shape} are not CaptureFlag's "
                             f"(N, {N_HEADER} + {PER_OTHER} (seats - 1))")
        seats = 1 + (obs.shape[1] - N_HEADER) // PER_OTHER
        return heuristic_actions(obs, seats // 2, commit=commit, hunt=hunt, keep=keep, sortie=sortie)

    search_budget_meaning: ClassVar[str] = (
        "in a duel, with the opponent W steps away or nearer, every sequence of H moves played against the "
        "heuristic's predicted answers on the map rebuilt from the observation, to tag the opponent or raid past "
        "it; the tuned heuristic heuristic-commit0.5-hunt6-keep0.5-sortie0.9 elsewhere; R must be 1")
    search_without_rollouts: ClassVar[str | None] = "the heuristic it plays against is deterministic"

    @staticmethod
    def search(obs: np.ndarray, uniforms: np.ndarray, *, action_type: str, width: int, rollouts: int, horizon: int,
               epsilon: float) -> np.ndarray:
        """:func:`~arena_league.envs.games.captureflag.search.search_moves`, ``epsilon`` of the moves random."""
        obs = np.asarray(obs, dtype=np.float32)
        if obs.ndim != 2 or obs.shape[1] < N_HEADER or (obs.shape[1] - N_HEADER) % PER_OTHER:
            raise ValueError(f"CaptureFlag search: observations of shape {obs.shape} are not CaptureFlag's "
                             f"(N, {N_HEADER} + {PER_OTHER} (seats - 1))")
        seats = 1 + (obs.shape[1] - N_HEADER) // PER_OTHER
        actions = search_moves(obs, seats // 2, near=width, horizon=horizon)
        u = np.asarray(uniforms, dtype=np.float64).reshape(-1)
        if epsilon > 0 and len(u) == len(actions):
            wild = u < epsilon
            actions = np.where(wild, np.minimum((u / epsilon * N_ACTIONS).astype(np.int64), N_ACTIONS - 1), actions)
        return actions


def _tint(colour: tuple[int, int, int], share: float = 0.15) -> tuple[int, int, int]:
    """``colour`` mixed with white, ``share`` of it kept."""
    return tuple(int(255 - share * (255 - x)) for x in colour)  # type: ignore[return-value]


def _xy(cell: int, rows: int, cols: int) -> tuple[float, float]:
    row, col = divmod(cell, cols)
    return col + 0.5, rows - row - 0.5


#: What a person types for each move on the map as drawn.
HUMAN_KEYS: dict[str, int] = {"": 0, "stay": 0, "w": 1, "up": 1, "d": 2, "right": 2, "s": 3, "down": 3, "a": 4,
                              "left": 4}
_MIRRORED = (0, 1, 4, 3, 2)  # left and right swap in team 1's frame


class CaptureFlagControls(Controls):
    """A person moves a seat on the map as drawn (w/a/s/d, Enter stays), turned into the seat frame."""

    rules: CaptureFlagRules

    def view(self) -> str:
        rules, engine = self.rules, self.rules._seen()
        r, c = engine.rows, engine.cols
        chars = np.full(r * c, ".", dtype="<U1")
        chars[engine.walls[0, engine._inner]] = "#"
        team = int(rules.team_of[self.seat])
        for t, cell in enumerate(engine.flag_cells(0)):
            chars[cell] = "F" if t == team else "f"
        cells = engine.cell(engine.pos[0])
        mates = iter("ABC")
        rivals = iter("1234")
        for seat in range(rules.n_agents):
            mark = "@" if seat == self.seat else next(mates) if rules.team_of[seat] == team else next(rivals)
            chars[cells[seat]] = mark if engine.active[0, seat] else mark.lower()
        lines = ["".join(chars[i * c:(i + 1) * c]) for i in range(r)]
        side = "left" if team == 0 else "right"
        score = engine.captures[0]
        return "\n".join(lines) + (f"\nYou are @ (team {team}, base on the {side}). Captures: you {score[team]}, "
                                   f"them {score[1 - team]}.")

    def prompt(self, step: int) -> str:
        return f"step {step}: w up, a left, s down, d right (Enter: stay) > "

    def parse(self, text: str) -> tuple[int | None, str | None]:
        if text not in HUMAN_KEYS:
            return None, f"{text!r} is not a move: type w (up), a (left), s (down) or d (right), or Enter to stay"
        move = HUMAN_KEYS[text]
        return (_MIRRORED[move] if int(self.rules.team_of[self.seat]) == 1 else move), None

    def web(self) -> dict[str, Any]:
        return key_controls(arrow_keys("w", "a", "s", "d"), 6.0,
                            "Arrow keys or W A S D move you on the map as drawn; let go to stay.", release="stay")


RULES = CaptureFlagRules
