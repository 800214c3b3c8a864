"""AirHockey: two mallets (or two pairs) strike one puck at the other team's goal (pymunk physics).

One of the team games of the Arena platform (Song et al., "Arena: A General Evaluation Platform
and Building Toolkit for Multi-Agent Intelligence", AAAI 2020): two mallets, one puck, a goal at
each end; the puck slides with little friction and rebounds from the rails. Ids:
``AirHockey-2T1P-v1``, ``AirHockey-2T2P-v1``.

Table
    A railed rectangle, ``x`` in [-4, 4] and ``y`` in [-2, 2] (inner faces of the rails), with
    45-degree corner chamfers of 0.5 so that the puck cannot stick in a corner. Each end rail has a
    goal mouth 1.2 wide (``goal_width``) centred on ``y = 0``, opening into a railed goal slot 0.4
    deep that holds the whole puck. A centre line at ``x = 0`` splits the table into halves: team 0
    plays in ``x < 0`` and attacks the goal at ``x = +4``; team 1 plays in ``x > 0`` and attacks
    ``x = -4``.

Bodies and physics
    Mallets (the agents) are circles of radius 0.25 and mass 1 that do not rotate; the puck is a
    circle of radius 0.15 and mass 0.25. Collisions are solved by pymunk (Chipmunk2D), one
    ``space.step`` of ``dt = 0.1`` per env step. The table is almost frictionless: every body keeps
    98 % of its velocity per second (space damping 0.98), so a sliding puck keeps more than half its
    speed over a whole match, and it rebounds from the rails with restitution 0.9 (0.95 puck times
    0.95 rail; contact friction 0.05). A mallet's thrust of at most 8 is opposed by a drag of
    ``3.5 * velocity``, which caps its speed at about 2.3 units/s; a mallet strikes the puck with
    restitution 0.67, sending it off at up to about 4 units/s.

    Each mallet is confined to its own half: the centre line, and a bar across each goal mouth, are
    segments (radius 0.1) that only mallets collide with (pymunk ``ShapeFilter`` categories), with
    no rebound. The puck crosses the centre line and enters the goals freely; a mallet stops with
    its face 0.1 short of the line and of the goal mouth (on the step it arrives at full speed it
    overlaps them by up to a step's travel, about 0.2, and the solver pushes it back), so it never
    crosses into the other half nor enters a goal slot, and opposing mallets do not meet. The rails
    are 0.8 thick (segments of radius 0.4): a puck would have to travel more than 0.55 in one step
    (5.5 units/s) to pass one.

Face-off
    The puck starts on the centre spot (``y`` jittered by up to ``kickoff_jitter``), served at 0.6
    units/s straight toward one half (the side drawn from the match seed); each team stands in its
    own half in a formation (2T1P: one mallet 2 in front of its goal; 2T2P: a forward and a back)
    whose positions are jittered by up to ``kickoff_jitter`` in both coordinates; every draw comes
    from the match seed.

Seat frame (mirroring)
    Each seat sees the table, and acts, in its own frame: the world frame for team 0, and the world
    mirrored in ``x`` (``x -> -x``, ``y`` unchanged) for team 1. In its own frame every seat plays in
    ``x < 0`` and attacks ``+x``, so one policy can play either side.

Actions
    Discrete (default), 9 actions, directions in the seat frame (``E`` = ``+x`` = toward the goal
    the seat attacks, ``N`` = ``+y``), each a thrust of full strength:
    ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE``.
    Continuous: ``[fx, fy]`` in [-1, 1], the thrust in the seat frame as a fraction of full
    strength; a vector longer than 1 is scaled back to length 1 (diagonals are no stronger).

Observation (``float32``, seat frame; positions divided by 4, velocities by 3)
    ====== ===================================== =================================================
    cell   bounds (x cell, y cell)               meaning
    ====== ===================================== =================================================
    0      [0, 1]                                own active flag (always 1 in AirHockey)
    1-2    [-1, 0], [-0.5, 0.5]                  own position ``x, y`` (the own half)
    3-4    [-2, 2]                               own velocity ``vx, vy``
    5-6    [-1.1, 2.1], [-1, 1]                  puck position relative to the seat (puck - own)
    7-8    [-1.1, 1.1], [-0.5, 0.5]              puck position (absolute)
    9-10   [-2, 2]                               puck velocity
    11-12  [1, 2], [-0.5, 0.5]                   the attacked goal relative to the seat: the centre
                                                 of its mouth on the goal line, ``(4, 0)`` in the
                                                 seat frame, minus the seat's position
    13-14  [-1, 0], [-0.5, 0.5]                  the defended goal relative to the seat:
                                                 ``(-4, 0)`` minus the seat's position
    15+    teammates [-1, 1], opponents [0, 2]   every other seat, teammates first then opponents,
           (x); [-1, 1] (y); [-2, 2] (velocity)  each in seat order: position relative to the seat
                                                 (2 cells) then its velocity (2 cells)
    ====== ===================================== =================================================

    ``obs_dim = 15 + 4 * (n_agents - 1)``: 19 for 2T1P, 27 for 2T2P.

    Bounds: the rails' inner faces keep the puck within ``x`` in [-4.4, 4.4] (the goal slots
    included) and ``y`` in [-2, 2], and every mallet within its own half, ``x`` in [-4, 0] in its
    seat frame, which bounds positions and their differences. Velocities are bounded by
    ``VELOCITY_BOUND`` = 2 (6 units/s, half as fast again as the hardest strike; only a pile-up
    pushes a body that fast): a cell beyond its bounds is clipped to them. These bounds are the
    env's observation space.

Global state (``float32``, world frame, same scales)
    every seat's ``x, y, vx, vy`` in seat order, then the puck's ``x, y, vx, vy``, then the goals
    scored by team 0 and by team 1: ``state_dim = 4 * n_agents + 6``. A seat's ``x`` lies in its
    team's half ([-1, 0] for team 0, [0, 1] for team 1), the other cells as for the observation's
    absolute cells; each score in [0, 1] (the first goal ends the match).

Measures
    ``active`` (always true), ``target_distance`` (distance from the seat's centre to the puck's:
    the puck is every seat's target), ``velocity_to_target`` (the seat's velocity along the
    direction to the puck), ``energy`` (squared thrust length, 0..1: 1 for every discrete move, 0
    for noop), ``force`` (magnitude of the contact force on the seat this step: the impulse pymunk's
    solver applied to it, from mallets, puck, rails and barriers, divided by ``dt``),
    ``speed``, ``object_progress`` (the puck's displacement this step toward the goal the seat
    attacks: ``+dx`` for team 0, ``-dx`` for team 1) and ``outcome`` (+1 / -1 for the scoring /
    conceding team, 0 for a draw).

Episode end
    A goal (the puck entirely past a goal line inside the mouth) ends the match: the scoring team
    wins, own goals included. A match cut at ``max_cycles`` (default 300 steps, 30 s of play) goes
    to the team that kept the puck in the other team's half for more of its steps (territory, as
    judges score a bout that ends without a fall; steps with the puck exactly on the centre line
    count for neither), a draw when both counts are equal. ``team_result``: 1 win, 0.5 draw, 0 loss.

Default social tree
    Root CP ``win_loss`` (scale 100) over one CL ``team_progress`` node (scale 10) per team; each
    agent leaf is IS ``target`` (scale 1: progress toward the puck).

Heuristic
    From the observation alone. The seat nearest the puck among its teammates strikes: when the
    puck (led by its velocity) is within reach of its half, it picks a shot, at the attacked goal's
    mouth straight or off a side rail, whichever passes furthest from the opponents (the straight
    one preferred), runs to a spot behind the puck on that line (round the puck when the puck is in
    the way; where the spot is beyond a rail or the centre line, the nearest spot inside sets the
    shot's direction), then drives through the puck at full thrust. A puck deep in its own end
    (within 1.2 of the goal line) it first clears straight away from its goal; a puck sliding at
    its goal's mouth (off the side rails too) while the striker is not between the two, it blocks
    on the puck's path in front of the goal. Out of reach, it waits on the line from its own goal
    to the puck, 1.5 from the goal; its teammates keep goal on that line, 0.9 from the goal. It
    assumes the default goal width.

Game kwargs
    ``goal_width`` (float in [0.6, 2.8], default 1.2): width of each goal mouth;
    ``kickoff_jitter`` (float in [0, 0.5], default 0.3): largest random offset of each face-off
    position.

Playing it (``arena-league play``)
    A coarse text view of the top-down picture (team digits, ``#`` rails, ``+`` markings, ``o``
    the puck). A move is an action's number or name, a compass direction *on the table as drawn*
    (``E`` = right, whichever side you play: team 1's moves are mirrored into its seat frame for
    you); Enter repeats the last move. In a browser, the arrow keys or W A S D (two at once:
    diagonally). Discrete actions only.

Rendering
    A top-down picture of the table (400 pixels wide): the rails, the surface with its centre line
    and face-off circle, each goal slot in the colour of the team defending it, the mallets in their
    teams' colours, the puck in white. ``render_mode="rgb_array"`` returns it; ``"human"`` shows it.

Copies
    The rules pickle and copy (``pickle``, ``copy.deepcopy``) by replaying the match from its seed,
    actions and ``place`` calls (pymunk's contact caches cannot be copied): bit for bit.

Replay scene
    The table with its centre line and both goal slots (in the colour of the team defending each),
    every mallet and the puck (discs) and the score (text): entities ``table``, ``agent/<seat>``,
    ``puck``, ``score``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import pymunk

from arena_league.envs import scene
from arena_league.envs.controls import MirroredCompassControls
from arena_league.envs.options import Option
from arena_league.envs.physics2d import (
    COMPASS_MOVES,
    ONE,
    Bodies,
    CellLayout,
    Field,
    Material,
    Walls,
    World,
    ballgames,
)
from arena_league.envs.physics2d.geometry import Segment, goal_field_outline, wall_segments

#: Half length and half width of the table (inner faces of the rails).
HALF_LENGTH = 4.0
HALF_WIDTH = 2.0
#: Depth of each goal slot behind its goal line: the whole puck fits in.
GOAL_DEPTH = 0.4
#: Size of the 45-degree chamfer cut off each corner.
CORNER_CHAMFER = 0.5
#: Rails are pymunk segments this thick on each side of their centre line: to pass one, a puck
#: would have to move more than this plus its radius (0.55) in one step; it slides at up to about
#: 0.4 a step.
RAIL_RADIUS = 0.4
#: The centre line and the bars across the goal mouths (mallets only) are this thick each side.
BARRIER_RADIUS = 0.1
MALLET_RADIUS = 0.25
MALLET_MASS = 1.0
PUCK_RADIUS = 0.15
PUCK_MASS = 0.25
#: Physics step per env step (seconds).
DT = 0.1
#: Fraction of its velocity a body keeps after one second (pymunk ``Space.damping``): the air
#: table's little friction.
SPACE_DAMPING = 0.98
#: Full thrust of a mallet, and the drag coefficient opposing its velocity.
THRUST = 8.0
MALLET_DRAG = 3.5
#: A mallet's top speed, where full thrust meets drag and damping (about 2.3 units/s).
MALLET_TOP_SPEED = THRUST / (MALLET_DRAG - MALLET_MASS * np.log(SPACE_DAMPING))
#: Speed of the puck's serve at the face-off, toward one half drawn from the match seed.
SERVE_SPEED = 0.6
#: Overlap pymunk tolerates between touching bodies (its default, 0.1, is large at this scale).
COLLISION_SLOP = 0.01
#: Contact restitution and friction are the products of the two shapes' values.
#: (The barriers keep pymunk's 0 for both: a mallet stops dead against them.)
ELASTICITY = {"mallet": 0.7, "puck": 0.95, "rail": 0.95}
FRICTION = {"mallet": 0.5, "puck": 0.1, "rail": 0.5}
#: Collision categories (bits): two shapes collide when each one's mask holds the other's
#: categories. Rails and mallets keep pymunk's default filter (in every category, colliding with
#: every one); the barriers (centre line, goal-mouth bars) are in BARRIER only, and the puck, in
#: PUCK, collides with every category but BARRIER: so the puck passes the barriers, mallets do not.
BARRIER, PUCK = 1, 2
_BARRIER_FILTER = pymunk.ShapeFilter(categories=BARRIER)
_PUCK_FILTER = pymunk.ShapeFilter(categories=PUCK, mask=pymunk.ShapeFilter.ALL_MASKS() ^ BARRIER)
#: Observation scales: positions are divided by HALF_LENGTH, velocities by VELOCITY_UNIT.
POSITION_SCALE = 1.0 / HALF_LENGTH
VELOCITY_UNIT = 3.0
#: Bound of the velocity cells, in units of VELOCITY_UNIT (6 units/s; a strike sends the puck at
#: up to about 4, and only a pile-up pushes a body faster, which is clipped).
VELOCITY_BOUND = 2.0

DEFAULT_GOAL_WIDTH = 1.2
OPTIONS = (Option("goal_width", float, DEFAULT_GOAL_WIDTH, "width of each goal mouth", 0.6, 2.8),
           Option("kickoff_jitter", float, 0.3, "largest random offset of each face-off position", 0.0, 0.5))

#: Face-off spots of team 0 (team 1's are mirrored), per players per team: one mallet in front of
#: its goal; two as a forward and a back.
_FORMATIONS = {
    1: ((-2.0, 0.0),),
    2: ((-1.4, 0.8), (-2.9, -0.6)),
}
#: How the table is drawn: rails 0.25 thick, no dark rim round the puck (the text view sees a
#: white block as the puck, "o", a grey one as a marking).
_LOOK = ballgames.FieldLook(wall=0.25, margin=0.5, wall_colour=(40, 40, 40), surface_colour=(165, 195, 225),
                            marking_colour=(200, 200, 200), line_px=3, centre_circle=0.6, ball_rim=None)


def barrier_segments(goal_half_width: float) -> list[Segment]:
    """The mallets-only segments: the centre line, and a bar across each goal mouth, each running
    into the rails at both ends so that no mallet slips round it."""
    L, W, G, R = HALF_LENGTH, HALF_WIDTH, goal_half_width, RAIL_RADIUS
    return [((0.0, -W - R), (0.0, W + R)), ((L, -G - R), (L, G + R)), ((-L, -G - R), (-L, G + R))]


def airhockey_table(n_agents: int, goal_half_width: float) -> Field:
    """The railed table, the barriers, the mallets (discs that do not spin) and the puck, added in
    that order."""
    outline = goal_field_outline(HALF_LENGTH, HALF_WIDTH, goal_half_width, GOAL_DEPTH, CORNER_CHAMFER)
    return Field(dt=DT, damping=SPACE_DAMPING, collision_slop=COLLISION_SLOP, parts=(
        Walls(tuple(wall_segments(outline, RAIL_RADIUS)), RAIL_RADIUS, Material(ELASTICITY["rail"], FRICTION["rail"])),
        # the barriers keep pymunk's restitution and friction (0): every property set costs
        Walls(tuple(barrier_segments(goal_half_width)), BARRIER_RADIUS, Material(filter=_BARRIER_FILTER)),
        Bodies("mallet", n_agents, MALLET_RADIUS, MALLET_MASS, Material(ELASTICITY["mallet"], FRICTION["mallet"])),
        Bodies("puck", 1, PUCK_RADIUS, PUCK_MASS, Material(ELASTICITY["puck"], FRICTION["puck"], _PUCK_FILTER),
               rotates=True)))


class AirHockeyRules(ballgames.BallGameRules):
    """AirHockey on a railed pymunk table; see the module docstring for the manual."""

    name: ClassVar[str] = "AirHockey"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    summary: ClassVar[str] = "Mallets strike a sliding puck at the other goal, each in its own half (pymunk; first goal wins, else territory)"
    options = OPTIONS
    ball = "puck"
    position_scale = POSITION_SCALE
    velocity_unit = VELOCITY_UNIT

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        n = self.n_agents
        self.layout = self._observation_layout()
        self.obs_dim = self.layout.size
        #: steps that ended with the puck in team 0's half (x < 0) and in team 1's (x > 0)
        self.puck_steps = np.zeros(2, dtype=np.int64)

        # the sign that takes each cell of the seats' (x, y) pairs from the seat's frame to the world
        self._thrust_signs = np.stack([self._team_sign, np.ones(n)], axis=1).reshape(-1)
        self._first_seats = np.array([int(np.flatnonzero(self.team_of == t)[0]) for t in range(2)])
        # unit thrust of every move in the seat frame (x + iy): the matrices turn it into the world
        self._moves = np.ascontiguousarray(COMPASS_MOVES).view(np.complex128).reshape(-1)
        self._goal_line = HALF_LENGTH + PUCK_RADIUS
        low, high = self.clip_bounds(self.layout)
        self._obs_low, self._obs_high = low.reshape(n, -1), high.reshape(n, -1)
        self._layout_work_vector()

    # --- construction --------------------------------------------------------------------------
    def _observation_layout(self) -> CellLayout:
        """The observation's runs (seat frame; positions divided by 4, velocities by 3): in its seat
        frame a seat, and its teammates, lie in ``x`` in [-x, 0]; its opponents in [0, x]."""
        x, y, v = HALF_LENGTH * POSITION_SCALE, HALF_WIDTH * POSITION_SCALE, VELOCITY_BOUND
        puck_x = (HALF_LENGTH + GOAL_DEPTH) * POSITION_SCALE
        own, wide = ((-x, 0.0), (-y, y)), (-2 * y, 2 * y)
        others = [((-x, x), wide)] * (self.players_per_team - 1) + [((0.0, 2 * x), wide)] * self.players_per_team
        return ballgames.observation_layout("puck", own, ((-puck_x, puck_x + x), wide), ((-puck_x, puck_x), (-y, y)),
                                            (-v, v), (((x, 2 * x), (-y, y)), own), others)

    def _layout_work_vector(self) -> None:
        """The world's work vector holds everything a step reads: the bodies' ``[x, y, vx, vy]``,
        the seats' velocities before the step, their unit thrust in their own frames (the matrices
        mirror team 1's into the world), the puck's x before the step and a constant 1. One product
        of it gives every measure's linear part and every observation (the hot path is
        Python-bound), into preallocated arrays seen through views made here."""
        n = self.n_agents
        world = self.world = World(airhockey_table(n, self.goal_half_width),
                                   slots=(("v_before", 2 * n), ("thrust", 2 * n), ("puck_x_before", 1), (ONE, 1)))
        puck = world.index("puck")
        self._work = world.work  # read on the hot path
        self._mallet_pos = world.table[:n, 0:2]
        self._puck_state = world.table[puck]
        self._puck_x_at, self._puck_y_at = world.pos(puck, 0), world.pos(puck, 1)
        self._puck_x_before_at = world.at("puck_x_before")
        # complex views (x + iy) of the 2-vectors: fewer, cheaper numpy calls on the hot path
        self._mallet_vel_c = world.table[:n].view(np.complex128)[:, 1]
        self._v_before_c = world.complex_view("v_before")
        self._thrust = world.view("thrust").reshape(n, 2)
        self._thrust_c = world.complex_view("thrust")
        self._thrust_length = np.zeros((n, 1))  # a thrust's length, at least 1: its scale-back
        # applied force of every body (zero for the puck and the static body), in the world frame
        world.force_matrix = ballgames.seat_force_matrix(world, THRUST, MALLET_DRAG, self._thrust_signs)
        # measures (7 n rows) then observations (n * obs_dim rows), one product per step
        self._matrix = np.concatenate([
            ballgames.measure_matrix(world, "puck", self._team_sign, self._thrust_signs, MALLET_MASS, DT,
                                     SPACE_DAMPING, THRUST, MALLET_DRAG),
            ballgames.observation_matrix(world, self.layout, "puck", self.team_of, self._team_sign, POSITION_SCALE,
                                         1.0 / VELOCITY_UNIT, HALF_LENGTH)])
        self._linear = np.zeros(len(self._matrix))
        self._measure_vectors_c = self._linear[: 6 * n].view(np.complex128)  # conj(to_puck), velocity, force
        self._to_puck_c = self._measure_vectors_c[:n]
        self._velocity_c = self._measure_vectors_c[n: 2 * n]
        self._obs_rows = self._linear[7 * n:].reshape(n, self.obs_dim)
        self._obs_work = np.zeros((n, self.obs_dim))
        # The measures are arrays updated in place every step (the Measures contract allows it),
        # most of them views of these buffers, so that a step allocates almost nothing.
        self._norms = np.zeros(3 * n)  # distance to the puck, speed, contact force
        self._along_c = np.zeros(n, dtype=np.complex128)  # v * conj(d): its real part is v . d
        self._along = self._along_c.real
        self._safe_distance = np.zeros(n)
        m = self.measures
        m.target_distance, m.speed, m.force = self._norms[:n], self._norms[n: 2 * n], self._norms[2 * n:]
        m.object_progress = self._linear[6 * n: 7 * n]

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        mallet_xy, puck_xy = self.kickoff(_FORMATIONS[self.players_per_team])
        serve = (SERVE_SPEED if self.rng.random() < 0.5 else -SERVE_SPEED, 0.0)
        self.world.build({"mallet": mallet_xy, "puck": puck_xy}, {"puck": [serve]})
        self._measure_still_state()
        self.measures.active[:] = True
        self.measures.outcome[:] = 0.0
        self.score[:] = 0
        self.puck_steps[:] = 0
        self.game_over = False
        self._events = []

    def _measure_still_state(self) -> None:
        """Measures of the bodies as they stand, with no step behind them (no force, no progress)."""
        self.still_slots()
        self.measures.energy[:] = 0.0
        self._update_measures()
        self.measures.force[:] = 0.0

    def _update_measures(self) -> None:
        """One product of the work vector gives the measures' linear parts (``object_progress``
        among them) and the observations (:meth:`observe` clips them); the distances, speeds and
        forces are the lengths of its complex cells (the step sets ``energy`` itself)."""
        np.dot(self._matrix, self._work, out=self._linear)
        np.abs(self._measure_vectors_c, out=self._norms)
        # Re(v * conj(d)) is the dot product of the velocity v and the way d to the puck
        np.multiply(self._velocity_c, self._to_puck_c, out=self._along_c)
        np.maximum(self.measures.target_distance, 1e-9, out=self._safe_distance)
        np.divide(self._along, self._safe_distance, out=self.measures.velocity_to_target)

    def step(self, actions: np.ndarray) -> None:
        self._record("step", actions.copy())
        work = self._work
        energy = self.measures.energy
        if self.action_type == "discrete":
            self._moves.take(actions, out=self._thrust_c)
            self._move_energy.take(actions, out=energy)
        else:
            self._thrust[:] = actions
            length = np.abs(self._thrust_c)
            np.square(length, out=energy)
            np.minimum(energy, 1.0, out=energy)
            # a thrust longer than 1 is scaled back to length 1
            np.maximum(length, 1.0, out=self._thrust_length[:, 0])
            np.divide(self._thrust, self._thrust_length, out=self._thrust)
        self._v_before_c[:] = self._mallet_vel_c
        work[self._puck_x_before_at] = work[self._puck_x_at]
        self.world.step()  # thrust against a linear drag
        self._update_measures()

        puck_x = work[self._puck_x_at]
        if (puck_x > self._goal_line or puck_x < -self._goal_line) and abs(work[self._puck_y_at]) < self.goal_half_width:
            scorer = 0 if puck_x > 0 else 1
            self.score[scorer] += 1
            self.measures.outcome[:] = np.where(self.team_of == scorer, 1.0, -1.0)
            self.game_over = True
            self._events = [{"kind": "goal", "team": scorer}]
            return
        if puck_x != 0.0:
            self.puck_steps[int(puck_x > 0.0)] += 1
        if self._events:
            self._events = []

    def observe(self) -> np.ndarray:
        # the product was taken with the measures; two ufuncs clip faster than np.clip
        clipped = np.minimum(self._obs_rows, self._obs_high, out=self._obs_work)
        return np.maximum(clipped, self._obs_low, out=clipped).astype(np.float32)

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, v = HALF_LENGTH * POSITION_SCALE, HALF_WIDTH * POSITION_SCALE, VELOCITY_BOUND
        puck_x = (HALF_LENGTH + GOAL_DEPTH) * POSITION_SCALE
        # a seat lies in its team's half
        halves = [(-x, 0.0) if team == 0 else (0.0, x) for team in self.team_of]
        return ballgames.state_layout([*[(half, (-y, y), (-v, v), (-v, v)) for half in halves],
                                       ((-puck_x, puck_x), (-y, y), (-v, v), (-v, v))]).bounds()

    def finish(self) -> None:
        self._record("finish")
        # a match cut at max_cycles without a goal goes on territory: the team that kept the puck in
        # the other half longer wins, equal counts draw
        pressure = int(np.sign(self.puck_steps[1] - self.puck_steps[0]))  # +1: team 0 pressed
        self.measures.outcome[:] = pressure * self._team_sign

    def team_result(self) -> np.ndarray:
        # the goal's or the territory's outcome, the same for every seat of a team: +1 win, 0 draw, -1 loss
        return (self.measures.outcome[self._first_seats] + 1.0) / 2.0

    # --- tools ---------------------------------------------------------------------------------
    def place(self, mallet_xy: np.ndarray, puck_xy: np.ndarray, mallet_velocity: np.ndarray | None = None,
              puck_velocity: np.ndarray | None = None) -> None:
        """Put the bodies at given world positions and velocities (for tests and scripted
        scenarios); the match continues from there. Each mallet must stand in its own half, clear
        of the centre line, and the puck on the table."""
        self.place_bodies("mallet", mallet_xy, mallet_velocity, "puck", puck_xy, puck_velocity)

    def check_placement(self, mallet_xy: np.ndarray, puck_xy: np.ndarray) -> None:
        clear = MALLET_RADIUS + BARRIER_RADIUS
        seat_x = mallet_xy[:, 0] * self._team_sign  # in the seat frame: the own half is x < 0
        outside = (seat_x > -clear) | (seat_x < -HALF_LENGTH + MALLET_RADIUS) | (
            np.abs(mallet_xy[:, 1]) > HALF_WIDTH - MALLET_RADIUS)
        if outside.any():
            seat = int(np.flatnonzero(outside)[0])
            raise ValueError(f"mallet {seat} at {mallet_xy[seat].tolist()} is outside its team's half: team "
                             f"{int(self.team_of[seat])} plays in {'x < 0' if self.team_of[seat] == 0 else 'x > 0'}, "
                             f"at least {clear} from the centre line and {MALLET_RADIUS} inside the rails")
        if abs(puck_xy[0]) > HALF_LENGTH + GOAL_DEPTH - PUCK_RADIUS or abs(puck_xy[1]) > HALF_WIDTH - PUCK_RADIUS:
            raise ValueError(f"the puck at {puck_xy.tolist()} is off the table")

    def render_topdown(self) -> np.ndarray:
        return ballgames.draw_goal_field(_LOOK, HALF_LENGTH, HALF_WIDTH, self.goal_half_width, GOAL_DEPTH,
                                         CORNER_CHAMFER, self._mallet_pos, self.team_of, MALLET_RADIUS,
                                         self._puck_state[0:2], PUCK_RADIUS)

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        surface = [scene.cube(0, 0, -0.05, (2 * HALF_LENGTH, 2 * HALF_WIDTH, 0.1), (0.78, 0.88, 0.94, 1.0)),
                   scene.cube(0, 0, 0.001, (0.06, 2 * HALF_WIDTH, 0.002), (0.8, 0.8, 0.8, 1.0))]  # the centre line
        return ballgames.goal_field_entities(
            timestamp_ns, "table", surface, HALF_LENGTH, HALF_WIDTH, GOAL_DEPTH, 2 * self.goal_half_width,
            self.state(), self.team_of,
            lambda x, y, colour: {"cylinders": [scene.disc(x, y, 2 * MALLET_RADIUS, colour, height=0.15)]},
            "puck", lambda x, y: {"cylinders": [scene.disc(x, y, 2 * PUCK_RADIUS, (0.97,) * 3 + (1.0,), height=0.05)]})

    def human_controls(self, seat: int) -> AirHockeyControls:
        return AirHockeyControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------
    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        # the scripted play reads this module's constants, so it is imported once they exist
        from arena_league.envs.games.airhockey.heuristic import heuristic

        return heuristic(obs, action_type)


class AirHockeyControls(MirroredCompassControls):
    """Compass moves of one's mallet on the table as drawn (E = right), mirrored for the team that
    sees the table flipped."""

    move = "move your mallet on the table as drawn"
    key_hint = ("Arrow keys or W A S D slide your mallet on the table as drawn (two at once: diagonally); let go "
                "to stop pushing.")


RULES = AirHockeyRules
