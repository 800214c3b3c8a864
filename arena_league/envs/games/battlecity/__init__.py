"""BattleCity: tanks drive and shoot in a maze of brick and steel; a shell on the enemy base wins.

One of the top-down combat games of the Arena platform (Song et al., "Arena: A General Evaluation
Platform and Building Toolkit for Multi-Agent Intelligence", AAAI 2020), after the arcade game:
each team guards a base at its own edge of a maze whose bricks shells break and whose steel stops
them. Ids: ``BattleCity-2T1P-v1``, ``BattleCity-2T2P-v1``.

Field
    A square maze of 13 x 13 tiles of side 1, ``x`` and ``y`` in [-6.5, 6.5] (the inner faces of
    an outer wall), ``y`` up; tile ``(row, col)`` has its centre at ``(-6 + col, -6 + row)``. A
    tile is empty, brick, steel or a base. Team 0's base is the tile ``(0, 6)`` (centre ``(0,
    -6)``) in a ring of five bricks ``(0, 5), (1, 5), (1, 6), (1, 7), (0, 7)``; team 1's is their
    image under the half turn about the centre, ``(12, 6)``.

The maze, from the seed
    Every tile of the bottom half (rows 0-5, and columns 0-5 of the middle row 6) is drawn in turn
    from the match seed: steel with probability ``steel_density``, else brick with probability
    ``brick_density``, else empty; the centre tile is empty; the bases and their rings are laid;
    every start tile and the tiles beside it are cleared; the top half is the image of the bottom
    half under the half turn, so the two teams' sides are the same seen from either base. A maze
    in which some open or brick tile cannot be reached from the starts without crossing steel is
    drawn again (after 50 draws, without steel). Same seed, same maze.

Bodies and physics
    Tanks are discs of radius 0.4 and mass 1 that do not spin; the outer wall and every brick,
    steel and base tile stop them (each run of such tiles along a row is one static box). One pymunk step of 0.1 s per env step;
    space damping 0.5 (a coasting tank keeps half its velocity after a second); a tank's thrust of
    at most 9 is opposed by a drag of ``3 * velocity``: top speed about 2.45 tiles/s. Contacts
    have no friction (a tank slides along walls) and a restitution of 0.01 between tanks, 0
    against walls and tiles. Every match starts from an empty pymunk space (a new one, or the last
    match's emptied and restarted, which plays the same bit for bit), filled with the outer wall, the
    tanks in seat order, then the runs of tiles row by row from the bottom, left to right; a broken
    brick's run is replaced by the runs left on either side of it.

Start
    Team 0's tanks stand at the centres of the tiles ``(0, 3)`` (1P) or ``(0, 3)`` and ``(0, 9)``
    (2P), heading ``+y``; team 1's stand on the images of those tiles, heading ``-y``. Every tank
    has ``hit_points`` hit points, a loaded gun and no shell in flight.

Seat frame
    Team 1 sees and acts in the world turned by a half turn (both axes negated): every seat sees
    its own base at the bottom (``-y``) and the enemy base at the top, so one policy plays either
    side.

Actions
    Discrete (default), 10: ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE`` (full thrust
    that way, seat frame; the tank turns to face the way it is pushed), ``9 fire`` (no thrust; a
    shell leaves along the heading). Continuous: ``[fx, fy, fire]`` in [-1, 1]: the thrust as a
    fraction of full (scaled back to length 1 when longer; a thrust longer than 0.3 turns the tank
    to face along it), and a shot when ``fire > 0``.

Shots (:mod:`arena_league.envs.physics2d.shots`)
    ============================ =================================================================
    rule                         value
    ============================ =================================================================
    shells a tank has in flight  at most 1; a shot also needs the gun loaded
    reload                       5 steps: a tank that fired at step ``t`` may fire again at ``t + 5``
    where a shell starts         the tank's centre before the step's physics, along its heading
    shell speed                  8 tiles/s (0.8 a step), in a straight line, a point
    order                        the tanks move first, then every shell in flight in seat order
    what stops a shell           the first thing on its way: a tank (a disc of radius 0.4), a tile
                                 other than empty, or the outer wall; shells pass each other
    shells pass                  the shooter, its teammates and tanks out of play (a tank
                                 destroyed by an earlier seat's shell in the same step still
                                 stops the later ones)
    a shell on a tank            the tank loses 1 hit point; at 0 it is destroyed
    a shell on a brick           the brick is gone (its box leaves the space); tanks may pass
    a shell on steel             stopped; the steel stays
    a shell on a base            the base is destroyed (the own base too) and its team is out
    ============================ =================================================================

    A destroyed tank, or every tank of a team whose base fell, is *out of play*: it stops where it
    is, collides with nothing and is ignored by shells; its actions do nothing (a shell it fired
    before flies on).

Observation (``float32``, seat frame; positions divided by 6.5, velocities by 3)
    ============ ================= ================================================================
    cells        bounds            meaning
    ============ ================= ================================================================
    0            [0, 1]            own in-play flag
    1-2          [-1, 1]           own position
    3-4          [-2, 2]           own velocity
    5-6          [-1, 1]           own heading (a unit vector)
    7            [0, 1]            own hit points left, a share of ``hit_points``
    8            [0, 1]            steps until the gun is loaded, a share of 5 (0: loaded)
    9-10         [-2, 2]           own base relative to the seat
    11-12        [-2, 2]           the enemy base relative to the seat
    13 ..        see meaning       every other tank, teammates first then opponents (seat order),
                                   8 cells each: position relative to the seat (2, [-2, 2]),
                                   velocity (2, [-2, 2]), heading (2, [-1, 1]), hit points share
                                   (1, [0, 1]), in-play flag (1, [0, 1])
    ..           see meaning       every seat's shell, own first then the others as above, 5 cells
                                   each: flying flag ([0, 1]), position relative to the seat (2,
                                   [-2, 2]), direction (2, [-1, 1]); all 0 when none flies
    last 338     [0, 1]            the tiles in the seat frame, row by row from the seat's own edge
                                   (row 0 at its base), 13 cells a row: 169 cells 1 on brick, then
                                   169 cells 1 on steel (bases are neither: their places are fixed)
    ============ ================= ================================================================

    ``obs_dim = 13 + 8 (n - 1) + 5 n + 338`` for ``n`` seats: 369 for 2T1P, 395 for 2T2P. Tanks
    and shells stay inside the maze, so positions lie in [-1, 1] and differences in [-2, 2];
    velocities are clipped to [-2, 2] (6 tiles/s, more than twice top speed).

Global state (``float32``, world frame, same scales)
    Per seat 14 cells: ``x, y, vx, vy``, heading (2), hit points share, reload share, in-play
    flag, shell flying flag, shell position (2) and direction (2); then each team's base-standing
    flag (2); then the 169 tiles' kinds divided by 3 (0 empty, 1/3 brick, 2/3 steel, 1 base), row
    by row in the world: ``state_dim = 14 n + 171``.

Measures
    ``active`` and ``alive`` (the tank is in play), ``target_distance`` (its centre's distance to
    the enemy base's centre; frozen once out of play), ``energy`` (squared thrust length: 1 for a
    discrete move, 0 for noop and fire), ``outcome`` (+1 / -1 for the winning / losing team, 0 a
    draw; 0 until the match ends). Events: ``fire`` (seat), ``hit`` (seat, target, hit_points
    left), ``destroyed`` (seat, by), ``brick`` (seat, row, col), ``base`` (team, by).

Episode end
    A team is *out* when its base is destroyed or its last tank is; the match ends at once, won
    by the team still in (a draw when both went out on the same step). A match cut at
    ``max_cycles`` (default 600 steps, 60 s) is decided by the hit points left, summed over each
    team's tanks (a tank out of play counts 0): more wins, equal is a draw. ``team_result``: 1
    win, 0.5 draw, 0 loss.

Default social tree
    Root CP ``ranking`` with ``order: survive`` (scale 100: the team outlasting the other ranks
    first; a match cut short leaves both unresolved, sharing the places). Each tank's leaf is IS
    ``target`` (scale 1: progress toward the enemy base). With two players a team, the root's
    children are one CL ``team_living_longer`` node per team (scale 0.1: +0.1 a step while a tank
    of the team is in play) over the team's two leaves; with one, the leaves themselves.

Heuristic (:mod:`.heuristic`)
    From the observation alone: shoot an opponent in line with a clear way to it, else drive tile
    by tile along the cheapest way to the enemy base (a brick costs four steps, steel and the own
    base cannot be crossed), facing and shooting a brick or the base in the way. Tuned heuristics
    (``scripted:heuristic-aim0.2-brick1-snipe12``) take ``aim`` (how far off its line an opponent
    still counts as in line, 0.1 to 0.5 tiles, the heuristic's 0.35), ``brick`` (a brick's cost
    beyond an empty tile, 0.5 to 8, 3) and ``snipe`` (0 to 12 tiles, 0: off; from a tile that many
    below or beside the enemy base with no steel between, shoot the base through the bricks when
    that is the cheapest way). Shooting the base from afar wins the race to it, and a tank that
    waits facing up the base's column fires first at one coming down it:
    ``heuristic-aim0.2-brick1-snipe12`` beat the heuristic in 158 and 162 of 200 matches on
    2T1P (league seeds 11, 12; 11 and 10 draws) and 155 of 200 on 2T2P (seed 11);
    ``heuristic-snipe12`` won 141, ``heuristic-brick1`` 65 (13 losses) and ``heuristic-brick5`` 7
    (33 losses), and ``heuristic-aim0.2-brick5`` lost 88 of 200 (2T1P, seed 11).

Game kwargs
    ``hit_points`` (int in [1, 5], default 3), ``brick_density`` (float in [0, 0.6], default
    0.35), ``steel_density`` (float in [0, 0.2], default 0.08).

Playing it
    Compass moves on the maze as drawn (turned into the seat's frame for team 1), ``f`` (or
    ``fire``) to shoot; in a browser the arrow keys or W A S D (two at once: diagonally) and Space
    (or F) to shoot. Discrete actions only.

Rendering
    A top-down picture (416 pixels wide): the floor, bricks (brown) and steel (grey), each base in
    its team's colour (dark once destroyed), the tanks with a tick along their heading (faded once
    out of play), the shells in flight (white).

Copies
    By replaying the match from its seed and the actions (and ``place`` calls) since
    (:class:`~arena_league.envs.core.ReplayedMatch`, through
    :class:`~arena_league.envs.physics2d.Physics2DRules`): a copy goes on bit for bit.

Replay scene
    ``maze`` (floor and outer wall), ``tiles`` (bricks and steel), ``base/<team>``,
    ``agent/<seat>`` (a tank) and ``shells``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import pymunk

from arena_league.envs.controls import TurnedCompassControls
from arena_league.envs.games.battlecity.heuristic import BRICK_COST, IN_LINE
from arena_league.envs.games.battlecity.maze import (
    BASE,
    BRICK,
    DT,
    GRID,
    HALF,
    RELOAD_STEPS,
    SHELL_SPEED,
    STEEL,
    TANK_RADIUS,
    TURN_THRESHOLD,
    base_tiles,
    draw_maze,
    force_matrix,
    maze_observation,
    maze_picture,
    maze_scene,
    maze_state,
    maze_tiles,
    maze_world,
    moving_cells,
    observation_matrix,
    start_tiles,
    state_matrix,
    tile_centre,
    tile_order,
)
from arena_league.envs.options import Option
from arena_league.envs.physics2d import Physics2DRules, SeatThrust
from arena_league.envs.physics2d.shots import (
    EMPTY,
    FIRE_ACTION,
    SHOOTER_ACTIONS,
    FireKey,
    Shells,
    ThrustFacing,
    )

OPTIONS = (Option("hit_points", int, 3, "hits a tank takes before it is destroyed", 1, 5),
           Option("brick_density", float, 0.35, "chance that a drawn tile is brick (when not steel)", 0.0, 0.6),
           Option("steel_density", float, 0.08, "chance that a drawn tile is steel", 0.0, 0.2))

ACTION_MEANINGS = SHOOTER_ACTIONS
_OUT_OF_PLAY = pymunk.ShapeFilter(categories=0, mask=0)
#: The ufunc np.clip calls, without np.clip's argument handling (the same values as a minimum then a
#: maximum: the bounds are ordered and no cell at a bound of 0 is -0.0).
_clip = np._core.umath.clip


class BattleCityRules(Physics2DRules):
    """BattleCity in a pymunk maze with shots that break bricks; see the module docstring."""

    name: ClassVar[str] = "BattleCity"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "alive", "target_distance", "energy", "outcome"})
    default_max_cycles: ClassVar[int] = 600
    summary: ClassVar[str] = ("Tanks drive and shoot in a maze of brick and steel; a shell on the enemy base, or the "
                              "last enemy tank destroyed, wins (pymunk)")
    options = OPTIONS
    heuristic_options: ClassVar[dict[str, tuple[float, float]]] = {"aim": (0.1, 0.5), "brick": (0.5, 8.0),
                                                                   "snipe": (0.0, 12.0)}
    heuristic_options_meaning: ClassVar[str] = (
        f"aim A: an opponent within A tiles of the tank's row or column line counts as in line (the heuristic's "
        f"{IN_LINE}); brick B: entering a brick or the enemy base costs B beyond an empty tile, and a sniping shell B "
        f"(the heuristic's {BRICK_COST:g}); snipe S: from a tile at most S tiles below or beside the enemy base with no "
        f"steel between, shoot the base through the bricks when that is the cheapest way (the heuristic's 0, never)")

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs: Any) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        self.max_hit_points = self.settings["hit_points"]
        self.brick_density, self.steel_density = self.settings["brick_density"], self.settings["steel_density"]
        n = self.n_agents
        self.n_actions, self.act_dim, self.action_meanings = len(ACTION_MEANINGS), 3, ACTION_MEANINGS
        self.layout = maze_observation(n)
        self.obs_dim = self.layout.size
        self.state_dim = maze_state(n).size
        self.frame = np.where(self.team_of == 0, 1.0, -1.0)  # the half turn negates both axes
        world = self.world = maze_world(n)
        self._work = world.work
        world.force_matrix = force_matrix(world, self.frame)
        self._tank_kind = world.field.bodies[0]
        self.tiles = maze_tiles()
        self.shells = Shells(self.team_of[:, None] != self.team_of[None, :], SHELL_SPEED, TANK_RADIUS, RELOAD_STEPS)
        order = [self.other_seats(seat) for seat in range(n)]
        self._moving = moving_cells(n)
        self._obs_matrix, self._obs_mask = observation_matrix(world, self.layout, self.team_of, self.frame, order)
        low, high = self.clip_bounds(self.layout)
        self._obs_low = low.reshape(n, -1)[:, : self._moving].reshape(-1)
        self._obs_high = high.reshape(n, -1)[:, : self._moving].reshape(-1)
        self._obs_linear = np.zeros(n * self._moving)
        self._obs_rows = self._obs_linear.reshape(n, self._moving)
        self._obs_scale = np.zeros(n * self._moving)
        self._tile_order = tile_order(self.team_of, self.frame)
        self._planes = np.zeros(2 * GRID * GRID, dtype=np.float32)
        # every seat's observation with its tile planes laid out, redone only when a tile changed
        self._seen = np.zeros((n, self.obs_dim), dtype=np.float32)
        self._planes_changed = True
        # where each cell of the brick plane shows in the seats' observations (flat indices into
        # _seen), so that a brick broken mid-match clears its few cells rather than every plane
        self._seen_flat = self._seen.reshape(-1)
        self._brick_seen: list[list[int]] = [[] for _ in range(GRID * GRID)]
        for seat, order in enumerate(self._tile_order.tolist()):
            for k, cell in enumerate(order):
                if cell < GRID * GRID:
                    self._brick_seen[cell].append(seat * self.obs_dim + self._moving + k)
        self._state_matrix = state_matrix(world, n)
        self._state_low, self._state_high = (b.astype(np.float64)[: 14 * n + 2] for b in self.state_bounds())
        # views of the work vector the step reads and writes
        self._tank_xy = world.table[:n, 0:2]
        self._seat_thrust = SeatThrust(world.complex_view("thrust"), action_type)
        self._thrust_c = world.complex_view("thrust")
        self._heading = world.view("heading").reshape(n, 2)
        self._hit_points = world.view("hit_points")
        self._reload = world.view("reload")
        self._active = world.view("active")
        self._shell = world.view("shell").reshape(n, 2)
        self._standing = world.view("base_standing")
        bases = np.array([tile_centre(*tile) for tile in base_tiles()])
        world.view("base")[:] = bases.reshape(-1)
        self.discrete = action_type == "discrete"
        self._tank_c = world.table[:n].view(np.complex128)[:, 0]
        self._enemy_base_c = bases[1 - self.team_of].view(np.complex128).reshape(-1).copy()
        self._to_base_c = np.zeros(n, dtype=np.complex128)
        self._length = np.zeros(n)
        self._thrust_pairs = world.view("thrust").reshape(n, 2)
        self._facing = ThrustFacing(np.repeat(self.frame[:, None], 2, axis=1), TURN_THRESHOLD)
        self._facing.learn_moves(self._seat_thrust.move_pairs, self._seat_thrust.move_lengths)
        self._heading_flat = world.view("heading")
        # the shells' cells (positions, directions, flags): adjacent slots, written in one go
        self._shell_cells = world.work[world.at("shell", 0): world.at("flying", n - 1) + 1]
        assert len(self._shell_cells) == 5 * n
        self._reload_shares = [steps * (1.0 / RELOAD_STEPS) for steps in range(RELOAD_STEPS + 1)]
        self._hits_left = np.zeros(n, dtype=np.int64)

    # --- the match ---------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        p = self.players_per_team
        self.kinds = draw_maze(self.rng, p, self.brick_density, self.steel_density)
        starts = np.array([tile_centre(*tile) for tile in start_tiles(p)])
        space = self.world.build({"tank": starts})
        self.tiles.build(space, self.kinds)
        self.kinds = self.tiles.kinds
        self._planes[: GRID * GRID] = (self.kinds == BRICK).reshape(-1)
        self._planes[GRID * GRID:] = (self.kinds == STEEL).reshape(-1)
        self._planes_changed = True
        self.shells.reset()
        self._heading[:, 0] = 0.0
        self._heading[:, 1] = self.frame
        self._thrust_c[:] = 0.0
        self._hits_left[:] = self.max_hit_points
        self._hit_points[:] = 1.0
        self._reload[:] = 0.0
        self._active[:] = 1.0
        self._standing[:] = 1.0
        self._sync_shells()
        m = self.measures
        m.active[:], m.alive[:], m.energy[:], m.outcome[:] = True, True, 0.0, 0.0
        self._all_active, self._decided = True, False
        self._measure_distances()
        self.team_out = np.zeros(2, dtype=bool)
        self.game_over = False
        self._events = []

    def _measure_distances(self) -> None:
        """Every tank's distance to the enemy base, frozen for tanks out of play."""
        np.subtract(self._tank_c, self._enemy_base_c, out=self._to_base_c)
        if self._all_active:
            np.abs(self._to_base_c, out=self.measures.target_distance)
        else:
            np.copyto(self.measures.target_distance, np.abs(self._to_base_c), where=self.measures.active)

    def _sync_shells(self) -> None:
        self._shell_cells[:] = self.shells.cells()

    def step(self, actions: np.ndarray) -> None:
        # (a few seats: the actions, thrust and shells go through Python lists, and the numpy calls
        # left are guarded where the common step needs none)
        self._record("step", actions.copy())
        m = self.measures
        if self.discrete:
            moves = actions.tolist()
            fire = [action == FIRE_ACTION for action in moves]
            if True in fire:
                moves = [0 if shoots else action for action, shoots in zip(moves, fire)]
            self._seat_thrust.set_moves(moves, m.energy)
        else:
            fire = [pull > 0.0 for pull in actions[:, 2].tolist()]
            self._seat_thrust.set(actions[:, :2], m.energy)
            thrust, length = self._seat_thrust.listed()
        if not self._all_active:
            thrust_c = self._thrust_c
            np.multiply(thrust_c, self._active, out=thrust_c)
            np.multiply(m.energy, self._active, out=m.energy)
            thrust, length = self._thrust_pairs.reshape(-1).tolist(), np.abs(thrust_c, out=self._length).tolist()
            self._facing.face(thrust, length, self._heading_flat)
        elif self.discrete:
            self._facing.face_moves(moves, self._heading_flat)
        else:
            self._facing.face(thrust, length, self._heading_flat)
        if self._events:
            self._events = []
        if True in fire:
            self._fire_shells(fire)

        self.world.step()

        shells = self.shells
        if shells.in_flight():
            for hit in shells.advance(DT, self.tiles, self._tank_xy, m.active):
                self._resolve(hit)
            self._sync_shells()
        if shells.reload():
            shares = self._reload_shares
            self._reload[:] = [shares[steps] for steps in shells.waits]
        self._measure_distances()
        if self._decided and not self.game_over:
            self.game_over = True
            self._set_outcome()

    def _fire_shells(self, fire: list[bool]) -> None:
        """Every seat that fires, is in play, has its gun loaded and no shell in flight shoots."""
        for seat in self.shells.pull_triggers(fire, self._tank_xy, self._heading, self.measures.active):
            self._events.append({"kind": "fire", "seat": seat})  # (its shell is shown once it has moved)

    def _resolve(self, hit: Any) -> None:
        if hit.seat >= 0:
            target = hit.seat
            if not self.measures.active[target]:
                return  # destroyed by an earlier seat's shell this step: the wreck stops this one
            self._hits_left[target] -= 1
            self._hit_points[target] = self._hits_left[target] / self.max_hit_points
            self._events.append({"kind": "hit", "seat": hit.shooter, "target": target,
                                 "hit_points": int(self._hits_left[target])})
            if self._hits_left[target] <= 0:
                self._take_out(target)
                self._events.append({"kind": "destroyed", "seat": target, "by": hit.shooter})
                team = int(self.team_of[target])
                if not self.measures.active[self.team_of == team].any():
                    self.team_out[team] = self._decided = True
        elif hit.kind == BRICK:
            cell = hit.row * GRID + hit.col
            self._planes[cell] = 0.0
            seen = self._seen_flat
            for at in self._brick_seen[cell]:
                seen[at] = 0.0
            self._events.append({"kind": "brick", "seat": hit.shooter, "row": hit.row, "col": hit.col})
        elif hit.kind == BASE:
            team = base_tiles().index((hit.row, hit.col))
            self._standing[team] = 0.0
            self.team_out[team] = self._decided = True
            self._events.append({"kind": "base", "team": team, "by": hit.shooter})
            for seat in np.flatnonzero(self.team_of == team).tolist():
                self._take_out(seat)

    def _take_out(self, seat: int) -> None:
        """The tank stops where it is, collides with nothing, and its actions do nothing."""
        m = self.measures
        if not m.active[seat]:
            return
        m.active[seat] = m.alive[seat] = False
        self._all_active = False
        self._active[seat] = 0.0
        self._hits_left[seat] = 0
        self._hit_points[seat] = 0.0
        body = self.world.bodies["tank"][seat]
        for shape in body.shapes:
            shape.filter = _OUT_OF_PLAY
        body.velocity = (0.0, 0.0)
        self.world.read()

    def _set_outcome(self) -> None:
        result = self.team_result()
        self.measures.outcome[:] = (2.0 * result - 1.0)[self.team_of]

    def finish(self) -> None:
        self._record("finish")
        self._set_outcome()

    def team_result(self) -> np.ndarray:
        if self.team_out.any():
            return np.where(self.team_out.all(), 0.5, np.where(self.team_out, 0.0, 1.0))
        left = np.bincount(self.team_of, weights=self._hits_left, minlength=2)
        return np.where(left[0] == left[1], 0.5, (left == left.max()).astype(np.float64))

    def observe(self) -> np.ndarray:
        linear = np.dot(self._obs_matrix, self._work, out=self._obs_linear)
        np.multiply(linear, self._work.take(self._obs_mask, out=self._obs_scale), out=linear)
        _clip(linear, self._obs_low, self._obs_high, out=linear)
        if self._planes_changed:
            self._planes.take(self._tile_order, out=self._seen[:, self._moving:])
            self._planes_changed = False
        obs = self._seen.copy()
        obs[:, : self._moving] = self._obs_rows
        return obs

    def state(self) -> np.ndarray:
        moving = self._state_matrix @ self._work
        moving.clip(self._state_low, self._state_high, out=moving)
        return np.concatenate([moving, self.kinds.reshape(-1) / 3.0]).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return maze_state(self.n_agents).bounds()

    # --- tools for tests and scripted scenarios --------------------------------------------------
    def place(self, tank_xy: np.ndarray, heading: np.ndarray | None = None, kinds: np.ndarray | None = None) -> None:
        """Put the tanks at world positions (at rest) with world headings (unit vectors; kept when
        None), and optionally lay a new maze ``kinds`` (``int8[13, 13]``: 0 empty, 1 brick, 2 steel,
        3 base; the bases' tiles must hold bases while they stand); the match goes on from there."""
        if self.world.space is None:
            raise RuntimeError("call reset(seed) before place()")
        tank_xy = np.asarray(tank_xy, dtype=np.float64).reshape(self.n_agents, 2)
        if (np.abs(tank_xy) > HALF - TANK_RADIUS).any():
            raise ValueError(f"every tank's centre must lie within [-{HALF - TANK_RADIUS}, {HALF - TANK_RADIUS}] in "
                             "both coordinates")
        heading = self._heading.copy() if heading is None else np.asarray(heading, dtype=np.float64).reshape(-1, 2)
        kinds = None if kinds is None else np.asarray(kinds, dtype=np.int8).reshape(GRID, GRID).copy()
        if kinds is not None:
            for team, tile in enumerate(base_tiles()):
                if (kinds[tile] == BASE) != bool(self._standing[team]):
                    raise ValueError(f"tile {tile} must hold a base (3) exactly while team {team}'s base stands")
            if not np.isin(kinds, (EMPTY, BRICK, STEEL, BASE)).all():
                raise ValueError("maze kinds are 0 empty, 1 brick, 2 steel or 3 base")
        self._record("place", tank_xy.copy(), heading.copy(), kinds)
        self.world.place("tank", tank_xy)
        self._heading[:] = heading
        if kinds is not None:
            self.tiles.build(self.world.space, kinds)
            self._planes[: GRID * GRID] = (self.kinds == BRICK).reshape(-1)
            self._planes[GRID * GRID:] = (self.kinds == STEEL).reshape(-1)
            self._planes_changed = True
        self.world.read()
        self._measure_distances()
        self._events = []

    # --- what the layers above see -------------------------------------------------------------
    def render_topdown(self) -> np.ndarray:
        return maze_picture(self.kinds, self._tank_xy, self._heading, self.measures.active, self.team_of,
                            self._shell, self.shells.flying, self._standing > 0.5, self._tank_kind)

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        return maze_scene(timestamp_ns, self.kinds, self._tank_xy, self._heading, self.measures.active, self.team_of,
                          self._shell, self.shells.flying, self._standing > 0.5)

    def human_controls(self, seat: int) -> BattleCityControls:
        return BattleCityControls(self, seat)

    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        def leaf(seat: int) -> dict:
            return {"agent": f"player_{seat}", "scheme": "IS", "reward": "target", "scale": 1}

        if players_per_team == 1:
            children: list = [leaf(t) for t in range(n_teams)]
        else:
            children = [{"scheme": "CL", "reward": "team_living_longer", "scale": 0.1,
                         "children": [leaf(t * players_per_team + p) for p in range(players_per_team)]}
                        for t in range(n_teams)]
        return {"scheme": "CP", "reward": "ranking", "scale": 100, "params": {"order": "survive"},
                "children": children}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str, *, aim: float = IN_LINE, brick: float = BRICK_COST,
                  snipe: float = 0.0) -> np.ndarray:
        """Shoot an opponent in a clear line, else drive and shoot along the cheapest way to the
        enemy base (see the module); the options tune it (``heuristic_options_meaning``)."""
        from arena_league.envs.games.battlecity.heuristic import heuristic

        return heuristic(obs, action_type, aim=aim, brick=brick, snipe=snipe)


class BattleCityControls(FireKey, TurnedCompassControls):
    """Compass moves on the maze as drawn (E = right), turned into the seat's frame, and ``f`` to fire."""

    move = "drive on the maze as drawn"
    key_hint = ("Arrow keys or W A S D drive on the maze as drawn (two at once: diagonally); Space (or F) fires "
                "along your heading; let go to stop pushing.")


RULES = BattleCityRules
