"""Fighter: fighters move and shoot among bunkers; the last team standing wins.

One of the top-down combat games of the Arena platform (Song et al., "Arena: A General Evaluation
Platform and Building Toolkit for Multi-Agent Intelligence", AAAI 2020): "take advantage of
various bunkers and destroy the opponent". Ids: ``Fighter-2T1P-v1``, ``Fighter-2T2P-v1``.

Field
    An open arena ``x`` in [-8, 8], ``y`` in [-5, 5] (the inner faces of an outer wall), ``y`` up,
    laid out in 16 x 10 tiles of side 1 (tile ``(row, col)`` spans ``x`` in ``[-8 + col, -7 +
    col]``, ``y`` in ``[-5 + row, -4 + row]``). Team 0 starts on the left (``x < 0``), team 1 on
    the right.

Bunkers, from the seed
    ``bunker_pairs`` bunkers (default 4) are drawn in team 0's half, each a block of 1 x 2, 2 x 1,
    2 x 2, 1 x 3 or 3 x 1 tiles (columns x rows, drawn uniformly) at a uniform spot within columns
    2-6 and rows 1-8, redrawn while it would touch another bunker (a bunker keeps at least one open
    tile all round it); team 1's half holds their mirror images in ``x``. The two columns by each
    side wall, the two in the middle and the top and bottom rows stay open, so every open tile can
    be reached from every other. A bunker stops fighters and shells and never breaks. Same seed,
    same bunkers.

Bodies and physics
    Fighters are discs of radius 0.35 and mass 1 that do not spin; one pymunk step of 0.1 s per
    env step; space damping 0.5; a fighter's thrust of at most 12 is opposed by a drag of ``4 *
    velocity``: top speed about 2.57 units/s. Restitution 0.04 between fighters, 0 against walls
    and bunkers, no friction. Every match starts from an empty pymunk space (a new one, or the last
    match's emptied and restarted, which plays the same bit for bit), filled with the outer wall, the
    fighters in seat order, then the bunkers' runs of tiles along each row (one static box each),
    row by row from the bottom.

Start
    Team 0 at ``(-7, 0)`` (1P) or ``(-7, 2)`` and ``(-7, -2)`` (2P), heading ``+x``; team 1 at
    the mirror images, heading ``-x``. Every fighter has ``hit_points`` hit points (default 5), a
    loaded gun and no shell in flight.

Seat frame
    Team 1 sees and acts in the world mirrored in ``x``: every seat starts on the left, facing
    ``+x``, so one policy plays either side.

Actions
    Discrete (default), 10: ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE`` (full thrust
    that way, seat frame; the fighter turns to face the way it is pushed), ``9 fire`` (no thrust;
    a shell leaves along the heading). Continuous: ``[fx, fy, fire]`` in [-1, 1]: the thrust as a
    fraction of full (scaled back to length 1 when longer; longer than 0.3 turns the fighter along
    it), and a shot when ``fire > 0``.

Shots (:mod:`arena_league.envs.physics2d.shots`)
    ============================ =================================================================
    rule                         value
    ============================ =================================================================
    shells a fighter has aloft   at most 1; a shot also needs the gun loaded
    reload                       3 steps: a fighter that fired at step ``t`` may fire again at ``t + 3``
    where a shell starts         the fighter's centre before the step's physics, along its heading
    shell speed                  12 units/s (1.2 a step), in a straight line, a point
    order                        the fighters move first, then every shell in flight in seat order
    what stops a shell           the first thing on its way: an opponent in play (a disc of radius
                                 0.35), a bunker or the outer wall; shells pass each other, the
                                 shooter, its teammates and fighters out of play (one destroyed by
                                 an earlier seat's shell in the same step still stops later ones)
    a shell on an opponent       1 hit point lost and 1 damage to the shooter's team; at 0 hit
                                 points the fighter is destroyed
    ============================ =================================================================

    A destroyed fighter is out of play: it stops where it is, collides with nothing and its actions
    do nothing (a shell it fired before flies on).

Observation (``float32``, seat frame; positions divided by 8, velocities by 3)
    ============ ================== ===============================================================
    cells        bounds             meaning
    ============ ================== ===============================================================
    0            [0, 1]             own in-play flag
    1-2          [-1, 1], ±0.625    own position
    3-4          [-2, 2]            own velocity
    5-6          [-1, 1]            own heading (a unit vector)
    7            [0, 1]             own hit points left, a share of ``hit_points``
    8            [0, 1]             steps until the gun is loaded, a share of 3 (0: loaded)
    9 ..         see meaning        every other fighter, teammates first then opponents (seat
                                    order), 8 cells each: position relative to the seat (2,
                                    [-2, 2] and [-1.25, 1.25]), velocity (2, [-2, 2]), heading (2,
                                    [-1, 1]), hit points share, in-play flag (1 each, [0, 1])
    ..           see meaning        every seat's shell, own first then the others as above, 5
                                    cells each: flying flag ([0, 1]), position (2, as own
                                    position's bounds), direction (2, [-1, 1]); all 0 when none flies
    last 160     [0, 1]             1 on every bunker tile, row by row from the bottom, each row
                                    from the seat's own side wall
    ============ ================== ===============================================================

    ``obs_dim = 9 + 8 (n - 1) + 5 n + 160`` for ``n`` seats: 187 for 2T1P, 213 for 2T2P.
    Velocities are clipped to [-2, 2] (6 units/s, more than twice top speed).

Global state (``float32``, world frame, same scales)
    Per seat 14 cells: ``x, y, vx, vy``, heading (2), hit points share, reload share, in-play
    flag, shell flying flag, shell position (2) and direction (2); then the 160 bunker tiles, row
    by row in the world: ``state_dim = 14 n + 160``.

Measures
    ``active`` and ``alive`` (the fighter is in play), ``target_distance`` (to the nearest opponent
    in play; kept when none is left), ``facing_target`` (cosine of the angle between the heading
    and the way to that opponent), ``energy`` (squared thrust length: 1 for a discrete move, 0 for
    noop and fire), ``outcome`` (+1 / -1 for the winning / losing team, 0 a draw; 0 until the
    end). Events: ``fire`` (seat), ``hit`` (seat, target, hit_points left), ``destroyed`` (seat, by).

Episode end
    The match ends when a team has no fighter in play: the other team wins (a draw when both lose
    their last fighters on the same step). A match cut at ``max_cycles`` (default 400 steps, 40 s)
    goes to the team that did more damage (equal: a draw). ``team_result``: 1 win, 0.5 draw, 0 loss.

Default social tree
    Root CP ``ranking`` with ``order: survive`` (scale 100: the team outlasting the other ranks
    first; a cut match leaves both unresolved, sharing the places). Each fighter's leaf is IS
    ``facing_target`` (scale 0.1: aiming at the nearest opponent). With two players a team, the
    root's children are one CL ``team_living_longer`` node per team (scale 0.1) over the team's
    two leaves; with one, the leaves themselves.

Heuristic (:mod:`.heuristic`)
    From the observation alone: against the nearest opponent in play, fire when facing it along
    a compass line that passes it with no bunker in between; turn to such a line when there is
    one; otherwise run down the open tiles' distance to the opponent.

Tuned heuristics
    The same script with options, named with them (``scripted:heuristic-dodge4``): ``dodge`` (0 to
    10 steps, the heuristic's 0) sidesteps an opponent's shell due to hit within that many steps,
    and ``lead`` (0 to 2, 0) aims at where the opponent will be after that many times the shell's
    flight. Two plain heuristics trade shot for shot (every match a draw); one that dodges takes
    fewer: ``heuristic-dodge4`` beat the heuristic in 167 and 171 of 200 matches on 2T1P and 165
    and 161 on 2T2P (league seeds 11 and 12), ``heuristic-dodge8`` in 145 and ``heuristic-dodge2``
    in 94 (62 lost; seed 11), while ``heuristic-lead1`` won 28 and lost 109 (seed 11).

Game kwargs
    ``hit_points`` (int in [1, 10], default 5), ``bunker_pairs`` (int in [1, 6], default 4).

Playing it
    Compass moves on the arena as drawn (mirrored into the seat's frame for team 1), ``f`` (or
    ``fire``) to shoot; in a browser the arrow keys or W A S D (two at once: diagonally) and Space
    (or F) to shoot. Discrete actions only.

Rendering
    A top-down picture (480 pixels wide): the sand floor, the bunkers (olive), the fighters in
    their teams' colours with a tick along their heading (pale once out of play), the shells in
    flight (white).

Copies
    By replaying the match from its seed and the actions (and ``place`` calls) since
    (:class:`~arena_league.envs.core.ReplayedMatch`, through
    :class:`~arena_league.envs.physics2d.Physics2DRules`): a copy goes on bit for bit.

Replay scene
    ``arena`` (floor and walls), ``bunkers``, ``agent/<seat>`` (a fighter) and ``shells``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
import pymunk

from arena_league.envs.controls import MirroredCompassControls
from arena_league.envs.games.fighter.arena import (
    BUNKER,
    COLS,
    DT,
    FIGHTER_RADIUS,
    HALF_X,
    HALF_Y,
    RELOAD_STEPS,
    ROWS,
    SHELL_SPEED,
    STARTS,
    TURN_THRESHOLD,
    arena_observation,
    arena_picture,
    arena_scene,
    arena_state,
    arena_tiles,
    arena_world,
    bunker_order,
    draw_bunkers,
    observation_gather,
    state_index,
    thrust_matrix,
)
from arena_league.envs.options import Option
from arena_league.envs.physics2d import Physics2DRules, SeatThrust, mirror_signs
from arena_league.envs.physics2d.shots import FIRE_ACTION, SHOOTER_ACTIONS, FireKey, Shells, ThrustFacing

OPTIONS = (Option("hit_points", int, 5, "hits a fighter takes before it is destroyed", 1, 10),
           Option("bunker_pairs", int, 4, "bunkers in each half (mirrored in the other)", 1, 6))

_NOWHERE = pymunk.ShapeFilter(categories=0, mask=0)
#: The ufunc np.clip calls, without np.clip's argument handling (the same values).
_clip = np._core.umath.clip


def _over(x: float, y: float) -> float:
    """``x / y`` as numpy divides (infinite or NaN over 0, where Python raises)."""
    return x / y if y else float(np.divide(x, y))


class FighterRules(Physics2DRules):
    """Fighter in a pymunk arena with mirrored bunkers and shots; see the module docstring."""

    name: ClassVar[str] = "Fighter"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "alive", "target_distance", "facing_target", "energy", "outcome"})
    default_max_cycles: ClassVar[int] = 400
    summary: ClassVar[str] = ("Fighters move and shoot among mirrored bunkers; the last team standing wins, the one "
                              "that did more damage at time-out (pymunk)")
    options = OPTIONS
    n_actions, act_dim, action_meanings = len(SHOOTER_ACTIONS), 3, SHOOTER_ACTIONS
    heuristic_options: ClassVar[dict[str, tuple[float, float]]] = {"dodge": (0.0, 10.0), "lead": (0.0, 2.0)}
    heuristic_options_meaning: ClassVar[str] = (
        "dodge D: sidestep an opponent's shell due to hit within D steps (the heuristic's 0: never); lead L: aim "
        "where the opponent will be after L times the shell's flight to it (the heuristic's 0: where it is)")

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs: Any) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        self.max_hit_points, self.bunker_pairs = self.settings["hit_points"], self.settings["bunker_pairs"]
        n = self.n_agents
        self.layout = arena_observation(n)
        self.obs_dim, self.state_dim = self.layout.size, arena_state(n).size
        self.x_sign = mirror_signs(self.team_of)
        self.world = world = arena_world(n)
        world.force_matrix = thrust_matrix(world, self.x_sign)
        self.tiles = arena_tiles()
        self.shells = Shells(self.team_of[:, None] != self.team_of[None, :], SHELL_SPEED, FIGHTER_RADIUS, RELOAD_STEPS)
        self._kind = world.field.bodies[0]
        self._work = world.work
        self._moving = self.layout.at("bunkers")
        self._gather = observation_gather(world, self.layout, self.x_sign, [self.other_seats(s) for s in range(n)])
        low, high = (bound.reshape(n, -1)[:, : self._moving] for bound in self.clip_bounds(self.layout))
        self._low, self._high = low.astype(np.float32), high.astype(np.float32)
        self._gathered = np.zeros((n, self._moving), dtype=np.float32)
        self._gathered_flat = self._gathered.reshape(-1)
        self._bunker_order = bunker_order(self.x_sign)
        self._plane = np.zeros(ROWS * COLS, dtype=np.float32)
        # every seat's observation with its bunker plane laid out (bunkers stand all match)
        self._seen = np.zeros((n, self.obs_dim), dtype=np.float32)
        self._state_columns, self._state_scales = state_index(world, n)
        state_low, state_high = arena_state(n).bounds()
        self._state_low, self._state_high = state_low[: 14 * n], state_high[: 14 * n]
        self._xy = world.table[:n, 0:2]
        self._xy_c = world.table[:n].view(np.complex128)[:, 0]
        self._thrust = world.view("thrust").reshape(n, 2)
        self._thrust_c = world.complex_view("thrust")
        self._seat_thrust = SeatThrust(self._thrust_c, action_type)
        self._heading = world.view("heading").reshape(n, 2)
        self._heading_c = world.complex_view("heading")
        self._share = world.view("hit_points")
        self._reload, self._in_play = world.view("reload"), world.view("active")
        self._shell_xy = world.view("shell").reshape(n, 2)
        self._frame = np.stack([self.x_sign, np.ones(n)], axis=1)
        self._facing = ThrustFacing(self._frame, TURN_THRESHOLD)
        self._facing.learn_moves(self._seat_thrust.move_pairs, self._seat_thrust.move_lengths)
        self._rivals = self.team_of[:, None] != self.team_of[None, :]
        self._way, self._apart = np.zeros((n, n), dtype=np.complex128), np.zeros((n, n))
        self._length = np.zeros(n)
        # views and buffers the step reuses
        self._xy_row, self._xy_column = self._xy_c[None, :], self._xy_c[:, None]
        self._heading_flat = world.view("heading")
        # the shells' cells (positions, directions, flags): adjacent slots, written in one go
        self._shell_cells = world.work[world.at("shell", 0): world.at("flying", n - 1) + 1]
        assert len(self._shell_cells) == 5 * n
        self._heading_column = self._heading_c[:, None]
        self._conj_headings, self._faced = np.zeros((n, n), dtype=np.complex128), np.zeros((n, n), dtype=np.complex128)
        self._rival_seats = [np.flatnonzero(row).tolist() for row in self._rivals]
        self._reload_shares = [steps / RELOAD_STEPS for steps in range(RELOAD_STEPS + 1)]
        self.hits_left = np.zeros(n, dtype=np.int64)
        self.damage = np.zeros(2)

    # --- the match ---------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        self.kinds = draw_bunkers(self.rng, self.bunker_pairs)
        own = np.array(STARTS[self.players_per_team])
        starts = np.concatenate([own, own * (-1.0, 1.0)])
        self.tiles.build(self.world.build({"fighter": starts}), self.kinds)
        self.kinds = self.tiles.kinds
        self._plane[:] = self.kinds.reshape(-1) == BUNKER
        self._plane.take(self._bunker_order, out=self._seen[:, self._moving:])
        self.shells.reset()
        self._show_shells()
        self._heading[:] = self._frame * (1.0, 0.0)
        self._thrust[:] = 0.0
        self.hits_left[:] = self.max_hit_points
        self._share[:], self._reload[:], self._in_play[:] = 1.0, 0.0, 1.0
        self.damage[:] = 0.0
        m = self.measures
        m.active[:], m.alive[:], m.energy[:], m.outcome[:] = True, True, 0.0, 0.0
        self._everyone_in = True
        self._aim()
        self.game_over, self._events = False, []

    def _show_shells(self) -> None:
        """The shells into the work vector, those not in flight as zeros."""
        self._shell_cells[:] = self.shells.cells(hide_idle=True)

    def _aim(self) -> None:
        """Each fighter's nearest opponent in play: its distance and how squarely it is faced (kept
        when none is left)."""
        # (numpy for the complex abs and product, whose kernels Python's floats do not reproduce;
        # the pick of the nearest opponent and the division in Python)
        m = self.measures
        way = np.subtract(self._xy_row, self._xy_column, out=self._way)
        apart = np.abs(way, out=self._apart).tolist()
        np.conjugate(self._heading_column, out=self._conj_headings)
        facing = np.multiply(self._conj_headings, way, out=self._faced).real.tolist()
        if self._everyone_in:
            reach, active = self._rival_seats, None
        else:
            active = m.active.tolist()
            reach = [[j for j in rivals if active[j]] for rivals in self._rival_seats]
        distances, facings = [], []
        for seat, rivals in enumerate(reach):
            row, best, nearest = apart[seat], math.inf, -1
            for j in rivals:  # the first of the nearest, as argmin
                if row[j] < best:
                    best, nearest = row[j], j
            distances.append(best)
            facings.append(_over(facing[seat][nearest], best) if nearest >= 0 else 0.0)
        if active is None:
            m.target_distance[:] = distances
            m.facing_target[:] = facings
        else:
            kept_distance, kept_facing = m.target_distance.tolist(), m.facing_target.tolist()
            for seat, distance in enumerate(distances):
                if distance != math.inf:
                    kept_distance[seat], kept_facing[seat] = distance, facings[seat]
            m.target_distance[:] = kept_distance
            m.facing_target[:] = kept_facing

    def step(self, actions: np.ndarray) -> None:
        # (a few seats: the actions, thrust and shells go through Python lists, not numpy calls)
        self._record("step", actions.copy())
        m = self.measures
        if self.action_type == "discrete":
            moves = actions.tolist()
            firing = [action == FIRE_ACTION for action in moves]
            if True in firing:  # (a fire is a noop move)
                moves = [0 if fire else action for action, fire in zip(moves, firing)]
            self._seat_thrust.set_moves(moves, m.energy)
        else:
            firing = [pull > 0.0 for pull in actions[:, 2].tolist()]
            self._seat_thrust.set(actions[:, :2], m.energy)
            thrust, length = self._seat_thrust.listed()
        if not self._everyone_in:
            self._thrust_c *= self._in_play
            m.energy *= self._in_play
            thrust, length = self._thrust.reshape(-1).tolist(), np.abs(self._thrust_c, out=self._length).tolist()
            self._facing.face(thrust, length, self._heading_flat)
        elif self.action_type == "discrete":
            self._facing.face_moves(moves, self._heading_flat)
        else:
            self._facing.face(thrust, length, self._heading_flat)
        self._events = []
        if True in firing:
            for seat in self.shells.pull_triggers(firing, self._xy, self._heading, m.active):
                self._events.append({"kind": "fire", "seat": seat})  # (its shell is shown once it has moved)
        self.world.step()
        shells = self.shells
        if shells.in_flight():
            for hit in shells.advance(DT, self.tiles, self._xy, m.active):
                if hit.seat >= 0:
                    self._damage(hit.shooter, hit.seat)
            self._show_shells()
        if shells.reload():
            shares = self._reload_shares
            self._reload[:] = [shares[steps] for steps in shells.waits]
        self._aim()
        if not self._everyone_in and not (np.bincount(self.team_of, weights=m.active, minlength=2) > 0).all():
            self.game_over = True
            self._set_outcome()

    def _damage(self, shooter: int, target: int) -> None:
        """One hit on ``target`` (the shell stops on a wreck it reaches the same step, harmlessly)."""
        m = self.measures
        if not m.active[target]:
            return
        self.hits_left[target] -= 1
        self._share[target] = self.hits_left[target] / self.max_hit_points
        self.damage[self.team_of[shooter]] += 1.0
        self._events.append({"kind": "hit", "seat": shooter, "target": target,
                             "hit_points": int(self.hits_left[target])})
        if self.hits_left[target] == 0:
            m.active[target] = m.alive[target] = False
            self._in_play[target] = 0.0
            self._everyone_in = False
            body = self.world.bodies["fighter"][target]
            for shape in body.shapes:
                shape.filter = _NOWHERE
            body.velocity = (0.0, 0.0)
            self.world.read()
            self._events.append({"kind": "destroyed", "seat": target, "by": shooter})

    def team_result(self) -> np.ndarray:
        teams_in = np.bincount(self.team_of, weights=self.measures.active, minlength=2) > 0
        score = teams_in.astype(np.float64) if not teams_in.all() else self.damage
        if score[0] == score[1]:
            return np.array([0.5, 0.5])
        return (score == score.max()).astype(np.float64)

    def _set_outcome(self) -> None:
        self.measures.outcome[:] = 2.0 * self.team_result()[self.team_of] - 1.0

    def finish(self) -> None:
        self._record("finish")
        self._set_outcome()

    def observe(self) -> np.ndarray:
        gathered = self._gathered
        self._gather.fill(self._gathered_flat)
        _clip(gathered, self._low, self._high, out=gathered)
        obs = self._seen.copy()
        obs[:, : self._moving] = gathered
        return obs

    def state(self) -> np.ndarray:
        moving = np.clip(self._work[self._state_columns] * self._state_scales, self._state_low, self._state_high)
        return np.concatenate([moving, self._plane]).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return arena_state(self.n_agents).bounds()

    def place(self, xy: np.ndarray, heading: np.ndarray | None = None) -> None:
        """Put the fighters at world positions (at rest) with world headings (unit vectors; kept
        when None), for tests and scripted scenarios; the match goes on from there."""
        if self.world.space is None:
            raise RuntimeError("call reset(seed) before place()")
        xy = np.asarray(xy, dtype=np.float64).reshape(self.n_agents, 2)
        limit = np.array([HALF_X, HALF_Y]) - FIGHTER_RADIUS
        if (np.abs(xy) > limit).any():
            raise ValueError(f"every fighter's centre must lie within |x| <= {limit[0]} and |y| <= {limit[1]}")
        heading = self._heading.copy() if heading is None else np.asarray(heading, dtype=np.float64).reshape(-1, 2)
        self._record("place", xy.copy(), heading.copy())
        self.world.place("fighter", xy)
        self.world.read()
        self._heading[:] = heading
        self._aim()
        self._events = []

    # --- what the layers above see -------------------------------------------------------------
    def render_topdown(self) -> np.ndarray:
        return arena_picture(self.kinds, self._xy, self._heading, self.measures.active, self.team_of, self._shell_xy,
                             self.shells.flying, self._kind)

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        return arena_scene(timestamp_ns, self.kinds, self._xy, self._heading, self.measures.active, self.team_of,
                           self._shell_xy, self.shells.flying)

    def human_controls(self, seat: int) -> FighterControls:
        return FighterControls(self, seat)

    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        seats = [[t * players_per_team + p for p in range(players_per_team)] for t in range(n_teams)]
        leaves = [[{"agent": f"player_{s}", "scheme": "IS", "reward": "facing_target", "scale": 0.1} for s in team]
                  for team in seats]
        children = ([team[0] for team in leaves] if players_per_team == 1 else
                    [{"scheme": "CL", "reward": "team_living_longer", "scale": 0.1, "children": team} for team in leaves])
        return {"scheme": "CP", "reward": "ranking", "scale": 100, "params": {"order": "survive"},
                "children": children}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str, *, dodge: float = 0.0, lead: float = 0.0) -> np.ndarray:
        """Shoot the nearest opponent along a clear compass line, else close in; ``dodge`` and ``lead``
        tune it (see the module)."""
        from arena_league.envs.games.fighter.heuristic import heuristic

        return heuristic(obs, action_type, dodge=dodge, lead=lead)


class FighterControls(FireKey, MirroredCompassControls):
    """Compass moves on the arena as drawn (E = right), mirrored into the seat's frame, and ``f`` to fire."""

    move = "move on the arena as drawn"


RULES = FighterRules
