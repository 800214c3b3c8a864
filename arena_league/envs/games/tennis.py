"""Tennis: two rackets (or two pairs) hit a ball over a net, seen from the side (pymunk physics).

One of the competitive games of the Arena platform (Song et al., "Arena: A General Evaluation
Platform and Building Toolkit for Multi-Agent Intelligence", AAAI 2020), which took it from Unity
ML-Agents: a racket on each side of a net keeps a ball in play; a ball that bounces twice on
one's side, or that one hits out or into the net, is the other side's point. Ids:
``Tennis-2T1P-v1``, ``Tennis-2T2P-v1``.

Court (a side view: ``x`` along the court, ``y`` up)
    The floor is ``y = 0``; the court runs from baseline to baseline, ``x`` in [-4, 4], with a
    run-off of 1 beyond each baseline up to a back fence (inner faces at ``x = +-5``), and a ceiling
    closes the hall at ``y = 6``. The net stands at ``x = 0``, 1 high and 0.16 thick (a segment of
    radius 0.08 whose top reaches ``y = 1``). Team 0 plays on the ``x < 0`` side, team 1 on
    ``x > 0``.

Bodies and physics
    Rackets (the agents) are circles of radius 0.3 and mass 1 that do not rotate; the ball is a
    circle of radius 0.15 and mass 0.1 that does not spin either. Gravity (6 units/s^2, down)
    pulls the ball; the rackets are held, so they do not fall. pymunk (Chipmunk2D) solves the
    collisions in two ``space.step`` calls of ``dt = 0.05`` per env step of 0.1 s, so that a ball
    as fast as about 9 units/s cannot pass through the net between two of them. Every body keeps
    90 % of its velocity per second (space damping 0.9: air drag). The ball rebounds from the
    floor and from a racket with restitution 0.81 (0.9 times 0.9), from the fences and the ceiling
    with 0.54, and from the net with 0.18 (a dead net); contact friction is 0.15 with the floor,
    the fences and the net, 0.225 with a racket. A racket's thrust of at most 10 is opposed by a
    drag of ``3.5 * velocity``, which caps its speed at about 2.8 units/s.

    Each racket is confined to its own side and its reach: the plane of the net (from the floor to
    the reach height), and a reach ceiling at ``y = 2.5``, are segments (radius 0.1) that only
    rackets collide with (pymunk ``ShapeFilter`` categories), with no rebound; so a racket's centre
    stays within ``x`` in [-4.7, -0.4] on team 0's side (mirrored on team 1's) and ``y`` in
    [0.3, 2.2], and rackets of the two teams never meet. The ball passes those barriers freely.
    Teammates do not collide with each other (they play in different lanes of the court, seen
    from the side).

Points
    Each point starts with a serve: the rackets stand on their spots (2T1P: ``(-3, 0.8)``; 2T2P: a
    back racket at ``(-3, 0.8)`` and a low front one at ``(-1.2, 0.5)``; team 1's mirrored), each
    jittered by up to ``start_jitter`` in both coordinates, and the ball is tossed at ``(-2.5, 1.8)``
    on the server's side (mirrored for team 1; ``x`` jittered by up to ``start_jitter``) at 1 unit/s
    upward. The serve alternates between the teams, the first server drawn from the match seed;
    every draw comes from the match seed.

    The team whose racket touched the ball last *played* it (the server, for its toss). A team may
    touch the ball any number of times before it crosses the net. The ball *lands* when it comes
    into contact with the floor or a back fence (a contact that begins: a ball rolling on the floor
    lands once). A point ends, in favour of the team named, when the ball

    * lands before being struck, on a serve: the receiver's (a *fault*);
    * lands on the side of the team that played it before bouncing in on the other side: the
      other team's (*net*: it did not cross the net);
    * lands beyond the other team's baseline (``|x| > 4``) or on its back fence, before bouncing in:
      the other team's (*out*);
    * lands a second time after bouncing in on the receiving side, anywhere: the team that played
      it (*not returned*);
    * stays on one side of the net for 40 steps in a row (4 s): the other team's (*held*; no side
      may keep the ball, on its racket or rolling).

    A racket touching the ball resets the rally: the ball is that team's shot and has not bounced
    in. Contacts are judged after each of the two physics steps of an env step, in order, on every
    one that pushed the ball (its velocity is not that of a free flight), from the bodies' positions
    then, as pymunk's contact test sees them: a racket touches the ball when their centres are
    nearer than the two radii; the ball touches the floor when its bottom is below it, a fence when
    its side is beyond the fence's face. The ball landing comes before a racket's touch when both
    happen at once; when rackets of both teams touch the ball at once, the team on whose side the
    ball's centre lies played it. The ball is on the side its centre is (exactly on ``x = 0``, on
    the side it came from). A point that ends mid-step ends the step's physics; the next serve is
    laid out at once.

Seat frame (mirroring)
    Each seat sees the court, and acts, in its own frame: the world frame for team 0, and the world
    mirrored in ``x`` (``x -> -x``, ``y`` unchanged) for team 1. In its own frame every seat plays on
    the ``x < 0`` side and hits toward ``+x``, so one policy can play either side.

Actions
    Discrete (default), 9 actions, directions in the seat frame (``E`` = ``+x`` = toward the net,
    ``N`` = ``+y`` = up), each a thrust of full strength:
    ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE``.
    Continuous: ``[fx, fy]`` in [-1, 1], the thrust in the seat frame as a fraction of full
    strength; a vector longer than 1 is scaled back to length 1 (diagonals are no stronger).

Observation (``float32``, seat frame; positions divided by 4, velocities by 4)
    ====== =================================== =====================================================
    cell   bounds (x cell, y cell)             meaning
    ====== =================================== =====================================================
    0      [0, 1]                              own active flag (always 1 in Tennis)
    1-2    [-1.25, 0], [0, 0.625]              own position ``x, y`` (the own side, within reach)
    3-4    [-3, 3]                             own velocity ``vx, vy``
    5-6    [-1.25, 2.5], [-0.625, 1.5]         ball position relative to the seat (ball - own)
    7-8    [-1.25, 1.25], [0, 1.5]             ball position (absolute)
    9-10   [-3, 3]                             ball velocity
    11     [0, 1]                              1 when the own team played the ball last (or tosses
                                               it to serve), 0 when the other team did
    12     [0, 1]                              1 once the ball has bounced in on the receiving
                                               side since it was played (it must be returned
                                               before it lands again)
    13     [0, 1]                              1 while the ball is a serve's toss not yet struck
    14     [0, 1]                              steps the ball has spent on its side of the net in a
                                               row, as a share of 40 (at 1 that side loses the point)
    15-16  [0, 1]                              the own team's points, then the other team's, as
                                               shares of ``points``
    17+    teammates [-1.25, 1.25], opponents  every other seat, teammates first then opponents,
           [0, 2.5] (x); [-0.625, 0.625] (y);  each in seat order: position relative to the seat
           [-3, 3] (velocity)                  (2 cells) then its velocity (2 cells)
    ====== =================================== =====================================================

    ``obs_dim = 17 + 4 * (n_agents - 1)``: 21 for 2T1P, 29 for 2T2P.

    Bounds: the fences, the floor and the ceiling keep the ball within ``x`` in [-5, 5] and ``y``
    in [0, 6]; the barriers keep every racket within ``x`` in [-5, 0] on its side and ``y`` in [0,
    2.5], which bounds positions and their differences. Velocities are bounded by
    ``VELOCITY_BOUND`` = 3 (12 units/s, four times a racket's top speed and more than the hardest
    shot; only a pile-up pushes a body faster). A cell beyond its bounds is clipped to them. These
    bounds are the env's observation space.

Global state (``float32``, world frame, same scales)
    every seat's ``x, y, vx, vy`` in seat order, then the ball's ``x, y, vx, vy``, then the points
    of team 0 and of team 1 as shares of ``points``, then which team played the ball last (two
    cells, one of them 1), the bounced-in flag, the toss flag and the side clock:
    ``state_dim = 4 * n_agents + 11``. A seat's ``x`` lies in its team's side ([-1.25, 0] for team
    0, [0, 1.25] for team 1), the other cells as for the observation's absolute cells.

Measures
    ``active`` (always true), ``resource_gain`` (the points the seat won this step: a point won by
    its team is shared equally among its members), ``target_distance`` (distance from the racket's
    centre to the ball's: the ball is every seat's target; at a new serve it jumps to the tossed
    ball), ``velocity_to_target`` (the racket's velocity along the direction to the ball),
    ``energy`` (squared thrust length, 0..1: 1 for every discrete move, 0 for noop), ``force``
    (magnitude of the contact force on the racket this step: the impulse pymunk's solver applied to
    it, from the ball and the barriers, divided by ``dt``; 0 on a step a new serve is laid out),
    ``speed`` and ``outcome`` (+1 / -1 for the winning / losing team, 0 for a draw; 0 until the
    match ends). Events: ``{"kind": "hit", "seat": i}`` when a racket's contact with the ball
    begins, ``{"kind": "bounce", "side": t}`` when the ball bounces in on team ``t``'s side, and
    ``{"kind": "point", "team": t, "reason": r}`` with ``r`` one of ``fault``, ``net``, ``out``,
    ``not_returned``, ``held``.

Episode end
    The first team to win ``points`` points (default 7, as in a tie-break) wins the match. A match
    cut at ``max_cycles`` (default 600 steps, 60 s of play) goes to the team with more points, a
    draw when both have as many. ``team_result``: 1 win, 0.5 draw, 0 loss.

Default social tree
    Root CP ``resource_share`` (scale 100: the points are the contested resource; each point pays
    its winner's team +0.5 and the other -0.5); each agent leaf is IS ``target`` (scale 1: progress
    toward the ball). With two players a team, the root's children are one CL ``team_target`` node
    (scale 10: the team's mean progress toward the ball) per team over its two leaves; with one, the
    leaves themselves.

Heuristic
    From the observation alone. The seat predicts the ball's flight over the next 1.5 s (exactly as
    the physics steps move it in the air, and one bounce off the floor). When the ball is its
    team's to play (the other team played it, or it is the own toss) and it is the teammate best
    placed (the nearest to the ball, a racket in front of the ball counting as further), it weighs
    strokes: a moment to meet the ball on its side (every 0.1 s, before the ball lands on a toss or
    once it has bounced in, else before it lands a second time), and a racket velocity (a direction
    from +x to up, and a speed; for discrete actions only the compass directions E, NE and N, which
    it can swing exactly). A racket that meets the ball along their relative velocity strikes it on
    that line however early or late it comes, and the ball leaves at ``v + 1.65 (u - v)`` (ball
    velocity ``v``, racket velocity ``u``; restitution 0.81, a racket ten times the ball's mass): the
    seat picks the stroke whose shot clears the net by 0.25 and lands nearest 2.6 beyond it, the
    ball at a comfortable height (about 1.1) and soon, with the racket able to stand ready on the
    stroke's line in time. It waits on that line behind the spot of contact, then runs through the
    spot at full thrust from the moment that brings it there at the stroke's speed (a racket at
    rest reaches speed ``v`` after ``-ln(1 - v / V) / 3.6`` s at full thrust, ``V`` its top speed).
    A seat with no ball to play goes to its spot (the back spot, or the front one for the
    teammate nearer the net). It assumes the default court.

Game kwargs
    ``points`` (int in [1, 21], default 7: points to win the match), ``start_jitter`` (float in
    [0, 0.3], default 0.2).

Playing it (``arena-league play``)
    A coarse text view of the side picture (team digits, ``+`` the net, ``o`` the ball; the view's
    edge is the hall's: the floor is its bottom line). A move is an action's number or name, a compass direction
    *on the court as drawn* (``E`` = right, ``N`` = up, whichever side you play: team 1's moves are
    mirrored into its seat frame for you); Enter repeats the last move. In a browser, the arrow
    keys or W A S D (two at once: diagonally). Discrete actions only.

Rendering
    A side picture of the hall (400 pixels wide): the air in light grey framed by the floor, the
    fences and the ceiling in dark grey, the baselines as white marks in the floor, the net, a faint
    line at the rackets' reach, the rackets in their teams' colours and the ball in white.
    ``render_mode="rgb_array"`` returns it; ``"human"`` shows it in a window.

Copies
    The rules pickle and copy (``pickle``, ``copy.deepcopy``) by playing the match again from its
    seed and the actions (and ``place`` calls) since, as pymunk's contact caches cannot be copied;
    a copy goes on bit for bit as the original does.

Replay scene
    The court in 3D, the side view's plane standing along ``x`` with its height as ``z``: the floor
    (``x``, ``y``) with its baselines, the net, every racket and the ball (spheres; teammates in
    lanes ``y = +-0.4``) and the score (text): entities ``court``, ``agent/<seat>``, ``ball``,
    ``score``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import pymunk

from arena_league.envs import scene
from arena_league.envs.core import GameRules, ReplayedMatch, cell_bounds
from arena_league.envs.games.soccer import SoccerControls
from arena_league.envs.physics2d import (
    COMPASS_MOVE_NAMES,
    COMPASS_MOVES,
    BodyFields,
    add_discs,
    add_walls,
    checked_kwargs,
    space_link,
)
from arena_league.envs.rendering import TEAM_COLOURS, Canvas
from arena_league.envs.social import team_tree

#: The court's baselines lie at x = +-HALF_LENGTH; the back fences' inner faces RUNOFF beyond.
HALF_LENGTH = 4.0
RUNOFF = 1.0
FENCE_X = HALF_LENGTH + RUNOFF
#: The hall's ceiling (inner face): the ball rebounds from it.
HALL_HEIGHT = 6.0
#: The net: a segment of this radius at x = 0 whose top reaches NET_HEIGHT.
NET_HEIGHT = 1.0
NET_RADIUS = 0.08
#: Rackets reach no higher than this (the inner face of their ceiling).
REACH_HEIGHT = 2.5
#: Floor, fences and ceiling are pymunk segments this thick on each side of their centre line.
WALL_RADIUS = 0.5
#: The racket-only barriers (the plane of the net, the reach ceiling) are this thick each side.
BARRIER_RADIUS = 0.1
RACKET_RADIUS = 0.3
RACKET_MASS = 1.0
BALL_RADIUS = 0.15
BALL_MASS = 0.1
#: Contact distance of a racket and the ball (centre to centre).
CONTACT = RACKET_RADIUS + BALL_RADIUS
#: Gravity on the ball (units/s^2, down); the rackets are held.
GRAVITY = 6.0
#: One env step (seconds) and the physics steps it is solved in.
DT = 0.1
SUBSTEPS = 2
SUBSTEP = DT / SUBSTEPS
#: Fraction of its velocity a body keeps after one second (pymunk ``Space.damping``): air drag.
SPACE_DAMPING = 0.9
#: Full thrust of a racket, and the drag coefficient opposing its velocity.
THRUST = 10.0
RACKET_DRAG = 3.5
#: A racket's top speed, where full thrust meets drag and damping (about 2.8 units/s).
RACKET_TOP_SPEED = THRUST / (RACKET_DRAG - RACKET_MASS * np.log(SPACE_DAMPING))
#: Overlap pymunk tolerates between touching bodies (its default, 0.1, is large at this scale).
COLLISION_SLOP = 0.01
#: Contact restitution and friction are the products of the two shapes' values.
#: (The barriers keep pymunk's 0 for both: a racket stops dead against them.)
ELASTICITY = {"ball": 0.9, "racket": 0.9, "floor": 0.9, "wall": 0.6, "net": 0.2}
FRICTION = {"ball": 0.3, "racket": 0.75, "floor": 0.5, "wall": 0.5, "net": 0.5}
#: Collision categories (bits): the barriers are in BARRIER only; the ball, in BALL, collides with
#: every category but BARRIER; rackets keep pymunk's default categories and mask, in a group per
#: team (shapes of one group never collide: teammates pass each other).
BARRIER, BALL = 1, 2
_BARRIER_FILTER = pymunk.ShapeFilter(categories=BARRIER)
_BALL_FILTER = pymunk.ShapeFilter(categories=BALL, mask=pymunk.ShapeFilter.ALL_MASKS() ^ BARRIER)
_RACKET_FILTERS = (pymunk.ShapeFilter(group=1), pymunk.ShapeFilter(group=2))
#: Steps the ball may stay on one side of the net in a row: at this many, that side loses the point.
HOLD_LIMIT = 40
#: Observation scales: positions are divided by POSITION_UNIT, velocities by VELOCITY_UNIT.
POSITION_UNIT = 4.0
POSITION_SCALE = 1.0 / POSITION_UNIT
VELOCITY_UNIT = 4.0
#: Bound of the velocity cells, in units of VELOCITY_UNIT (12 units/s).
VELOCITY_BOUND = 3.0

DEFAULT_POINTS = 7
_POINTS_RANGE = (1, 21)
_JITTER_RANGE = (0.0, 0.3, 0.2)

#: Serve spots of team 0 (team 1's are mirrored), per players per team: one racket at the back;
#: two as a back and a front racket.
_FORMATIONS = {
    1: ((-3.0, 0.8),),
    2: ((-3.0, 0.8), (-1.2, 0.5)),
}
#: Where the server's toss starts (team 0's; mirrored for team 1) and its upward speed.
TOSS_XY = (-2.5, 1.8)
TOSS_SPEED = 1.0
#: Why a point ends (the ``reason`` of a point event).
POINT_REASONS = ("fault", "net", "out", "not_returned", "held")

#: A physics step leaves a ball that touched nothing at its velocity times _FREE_KEEP plus
#: _FREE_FALL (down): a ball whose velocity differs by more than _FREE_TOLERANCE was pushed.
_FREE_KEEP = SPACE_DAMPING**SUBSTEP
_FREE_FALL = -GRAVITY * SUBSTEP
_FREE_TOLERANCE = 1e-9

#: Body fields the physics link reads after every physics step and writes before it.
_STATE_FIELDS = BodyFields.POSITION | BodyFields.VELOCITY
_FORCE_FIELDS = BodyFields.FORCE


class TennisRules(ReplayedMatch, GameRules):
    """Tennis in a side-view pymunk hall; see the module docstring for the manual."""

    name: ClassVar[str] = "Tennis"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "resource_gain", "target_distance", "velocity_to_target", "energy", "force", "speed", "outcome"}
    )
    default_max_cycles: ClassVar[int] = 600
    summary: ClassVar[str] = ("Rackets hit a ball over a net, seen from the side (pymunk; a ball landing twice, "
                              "out or in the net is the other side's point; first to 7 points wins)")

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        self.check_layout(n_teams, players_per_team, action_type)
        settings = checked_kwargs("Tennis", kwargs, {
            "points": (*_POINTS_RANGE, DEFAULT_POINTS, int, " (to win the match)"), "start_jitter": _JITTER_RANGE})
        points, jitter = settings["points"], settings["start_jitter"]
        super().__init__(n_teams, players_per_team, action_type)
        self._arguments = ((n_teams, players_per_team, action_type), dict(kwargs))
        self._calls = []
        self.points = int(points)
        self.start_jitter = float(jitter)
        n = self.n_agents
        self.n_actions = len(COMPASS_MOVE_NAMES)
        self.act_dim = 2
        self.action_meanings = COMPASS_MOVE_NAMES
        self.obs_dim = 17 + 4 * (n - 1)
        self.state_dim = 4 * n + 11

        # +1 for team 0, -1 for team 1: the x sign of each seat's frame
        self._team_sign = np.where(self.team_of == 0, 1.0, -1.0)
        self._first_seats = np.arange(n_teams) * players_per_team
        # every seat's serve spot, team 1's mirrored
        self._spots = np.tile(np.asarray(_FORMATIONS[players_per_team], dtype=np.float64), (n_teams, 1))
        self._spots[:, 0] *= self._team_sign
        # unit thrust of every move in the seat frame (x + iy): the matrices turn it into the world
        self._moves = np.ascontiguousarray(COMPASS_MOVES).view(np.complex128).reshape(-1)
        self._move_energy = (COMPASS_MOVES**2).sum(axis=1)
        self._obs_low, self._obs_high = (np.tile(bound.astype(np.float64), (n, 1)) for bound in self.observation_bounds())
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())
        self._layout_work_vector()
        self.space: pymunk.Space | None = None
        self._events: list[dict] = []
        # the rally, kept in plain Python on the hot path (the work vector mirrors it for observations)
        self._player = 0  # the team that played the ball last (the server, for its toss)
        self._bounced = False
        self._tossed = False
        self._side = 0  # the side of the net the ball is on
        self._clock = 0  # steps the ball has ended on that side in a row
        self._server = 0
        self._landed = False  # whether the ball touched the floor or a fence after the last physics step
        self._touching = 0  # bit mask of the seats whose racket touched the ball after the last physics step
        self.score = np.zeros(2, dtype=np.int64)

    # --- construction --------------------------------------------------------------------------
    def _layout_work_vector(self) -> None:
        """One float64 vector holds everything a step reads, and one matrix product of it gives the
        measures' linear parts and every observation at once (few numpy calls: the hot path is
        Python-bound). Their results land in preallocated arrays, seen through views made here.

        Layout of the work vector: ``[x, y, vx, vy]`` of every seat, the ball and pymunk's static
        body (written in place by the physics link), spare room, the seats' unit thrust in their own
        frames (as the actions give it: the matrices mirror team 1's into the world), a constant 1,
        the applied force ``[fx, fy]`` of every body (which the link writes to pymunk), which team
        played the ball last (two cells), the bounced-in and toss flags, the side clock (a share of
        HOLD_LIMIT) and the points of each team.
        """
        n = self.n_agents
        self._n_bodies = n + 2  # the physics link also visits the space's static body
        body_floats = 4 * self._n_bodies
        # pymunk's batch array grows (reallocates) when fewer than 3 free slots are left: leave 8
        self._thrust_at = body_floats + 8
        self._one_at = self._thrust_at + 2 * n
        self._force_at = self._one_at + 1
        self._played_at = self._force_at + 2 * self._n_bodies
        self._bounced_at = self._played_at + 2
        self._toss_at = self._bounced_at + 1
        self._clock_at = self._toss_at + 1
        self._score_at = self._clock_at + 1
        work = np.zeros(self._score_at + 2)
        work[self._one_at] = 1.0
        self._work = work
        table = work[:body_floats].reshape(self._n_bodies, 4)
        self._racket_pos = table[:n, 0:2]
        self._ball_state = table[n]
        self._ball_x_at, self._ball_y_at = 4 * n, 4 * n + 1
        self._ball_cells = slice(4 * n, 4 * n + 4)
        # complex views (x + iy) of the 2-vectors: fewer, cheaper numpy calls on the hot path
        bodies_c = table.view(np.complex128)
        self._racket_pos_c = bodies_c[:n, 0]
        self._racket_vel_c = bodies_c[:n, 1]
        self._ball_pos_c = bodies_c[n: n + 1, 0]
        self._thrust = work[self._thrust_at: self._one_at].reshape(n, 2)
        self._thrust_c = work[self._thrust_at: self._one_at].view(np.complex128)
        self._thrust_length = np.zeros(n)  # a thrust's length, then at least 1: its scale-back
        self._to_ball_c = np.zeros(n, dtype=np.complex128)  # ball - racket, after every physics step
        self._to_ball = np.zeros(n)  # its length
        self._force_array = work[self._force_at: self._played_at]
        self._link = space_link(_STATE_FIELDS, work, _FORCE_FIELDS, self._force_array)
        # every body's position and velocity, written at once to lay out a serve (the static
        # body's stay zero); the link reads nothing back into its own array
        self._placement = np.zeros(4 * self._n_bodies)
        self._placement_link = space_link(_STATE_FIELDS, np.zeros(4 * self._n_bodies + 8), _STATE_FIELDS,
                                          self._placement)
        # applied force of every body in the world frame: thrust against drag for the rackets,
        # gravity for the ball, none for the static body; a product of the cells before the forces
        self._force_matrix = np.zeros((2 * self._n_bodies, self._force_at))
        self._force_source = work[: self._force_at]
        for k in range(2 * n):
            self._force_matrix[k, self._thrust_at + k] = THRUST * self._axis_sign(k)
            self._force_matrix[k, 4 * (k // 2) + 2 + k % 2] = -RACKET_DRAG
        self._force_matrix[2 * n + 1, self._one_at] = -BALL_MASS * GRAVITY
        # measures (6 n rows) then observations (n * obs_dim rows), one product per step
        self._matrix = np.concatenate([self._measure_map(), self._observation_map()])
        self._linear = np.zeros(len(self._matrix))
        self._measure_vectors_c = self._linear[: 6 * n].view(np.complex128)  # conj(to_ball), velocity, force
        self._to_target_conj_c = self._measure_vectors_c[:n]
        self._velocity_c = self._measure_vectors_c[n: 2 * n]
        self._obs_rows = self._linear[6 * n:].reshape(n, self.obs_dim)
        self._obs_work = np.zeros((n, self.obs_dim))
        self._state_matrix = self._state_map()
        # The measures are arrays updated in place every step (the Measures contract allows it),
        # most of them views of these buffers, so that a step allocates almost nothing.
        self._norms = np.zeros(3 * n)  # distance to the ball, speed, contact force
        self._along_c = np.zeros(n, dtype=np.complex128)  # v * conj(d): its real part is v . d
        self._along = self._along_c.real
        self._gained = False  # whether resource_gain holds a non-zero value to clear
        m = self.measures
        m.target_distance, m.speed, m.force = self._norms[:n], self._norms[n: 2 * n], self._norms[2 * n:]

    def _axis_sign(self, cell: int) -> float:
        """The sign that takes cell ``cell`` of the seats' (x, y) pairs from the seat's frame
        to the world (or back): team 1 sees x mirrored."""
        return float(self._team_sign[cell // 2]) if cell % 2 == 0 else 1.0

    def _pos(self, body: int, axis: int) -> int:
        return 4 * body + axis

    def _vel(self, body: int, axis: int) -> int:
        return 4 * body + 2 + axis

    def _measure_map(self) -> np.ndarray:
        """The linear parts of the measures as one matrix over the work vector.

        Rows: ``[to_ball (x, -y), velocity (x, y), contact force (x, y)]`` of every seat, read as
        complex numbers (``to_ball`` conjugated). The contact force is the impulse the solver added
        beyond damping and the applied force ``f`` over the two physics steps, divided by ``dt``:
        Chipmunk integrates ``v' = v * k + f / m * h`` (``k = damping**h``) before solving contacts,
        and the same ``f = THRUST * u - DRAG * v0`` acts in both, so the velocity before the step is
        ``v0 = (THRUST * u - f) / DRAG`` and the impulse ``m v2 - m k^2 v0 - (1 + k) h f``.
        """
        n = self.n_agents
        M = np.zeros((6 * n, len(self._work)))
        ball = n
        keep = SPACE_DAMPING**SUBSTEP
        before = keep * keep * RACKET_MASS / RACKET_DRAG  # the impulse's share of v0 * DRAG
        for i in range(n):
            for ax in range(2):
                conj = 1.0 if ax == 0 else -1.0
                M[2 * i + ax, self._pos(ball, ax)] = conj
                M[2 * i + ax, self._pos(i, ax)] = -conj
                M[2 * n + 2 * i + ax, self._vel(i, ax)] = 1.0
                row = 4 * n + 2 * i + ax
                M[row, self._vel(i, ax)] = RACKET_MASS / DT
                M[row, self._thrust_at + 2 * i + ax] = -before * THRUST * self._axis_sign(2 * i + ax) / DT
                M[row, self._force_at + 2 * i + ax] = (before - (1.0 + keep) * SUBSTEP) / DT
        return M

    def _other_seats(self, seat: int) -> list[int]:
        """The other seats in observation order: teammates, then opponents, each in seat order."""
        team = int(self.team_of[seat])
        mates = [j for j in np.flatnonzero(self.team_of == team).tolist() if j != seat]
        return mates + np.flatnonzero(self.team_of != team).tolist()

    def _observation_map(self) -> np.ndarray:
        """The observations of every seat as one matrix over the work vector."""
        n = self.n_agents
        A = np.zeros((n, self.obs_dim, len(self._work)))
        ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
        ball = n
        for i in range(n):
            rows = A[i]
            sign = self._team_sign[i]
            team = int(self.team_of[i])
            rows[0, self._one_at] = 1.0
            for ax, scale in ((0, sign), (1, 1.0)):
                rows[1 + ax, self._pos(i, ax)] = ps * scale
                rows[3 + ax, self._vel(i, ax)] = vs * scale
                rows[5 + ax, self._pos(ball, ax)] = ps * scale
                rows[5 + ax, self._pos(i, ax)] = -ps * scale
                rows[7 + ax, self._pos(ball, ax)] = ps * scale
                rows[9 + ax, self._vel(ball, ax)] = vs * scale
                for k, j in enumerate(self._other_seats(i)):
                    rows[17 + 4 * k + ax, self._pos(j, ax)] = ps * scale
                    rows[17 + 4 * k + ax, self._pos(i, ax)] = -ps * scale
                    rows[19 + 4 * k + ax, self._vel(j, ax)] = vs * scale
            rows[11, self._played_at + team] = 1.0
            rows[12, self._bounced_at] = 1.0
            rows[13, self._toss_at] = 1.0
            rows[14, self._clock_at] = 1.0
            rows[15, self._score_at + team] = 1.0 / self.points
            rows[16, self._score_at + 1 - team] = 1.0 / self.points
        return A.reshape(n * self.obs_dim, len(self._work))

    def _state_map(self) -> np.ndarray:
        """The global state as one matrix over the work vector."""
        n = self.n_agents
        S = np.zeros((self.state_dim, len(self._work)))
        for body in range(n + 1):
            for ax in range(2):
                S[4 * body + ax, self._pos(body, ax)] = POSITION_SCALE
                S[4 * body + 2 + ax, self._vel(body, ax)] = 1.0 / VELOCITY_UNIT
        row = 4 * (n + 1)
        S[row, self._score_at] = S[row + 1, self._score_at + 1] = 1.0 / self.points
        for k, cell in enumerate((self._played_at, self._played_at + 1, self._bounced_at, self._toss_at,
                                  self._clock_at)):
            S[row + 2 + k, cell] = 1.0
        return S

    def _build_space(self, racket_xy: np.ndarray, ball_xy: np.ndarray, ball_velocity: tuple[float, float]) -> None:
        # A fresh space each match: no cached contacts survive from the previous one, so a seed
        # gives the same match whatever was played before.
        space = pymunk.Space()
        space.damping = SPACE_DAMPING
        space.collision_slop = COLLISION_SLOP
        F, H, R = FENCE_X, HALL_HEIGHT, WALL_RADIUS
        add_walls(space, [((-F - R, -R), (F + R, -R))], R, ELASTICITY["floor"], FRICTION["floor"])
        add_walls(space, [((-F - R, -R), (-F - R, H + R)), ((F + R, -R), (F + R, H + R)),
                          ((-F - R, H + R), (F + R, H + R))], R, ELASTICITY["wall"], FRICTION["wall"])
        add_walls(space, [((0.0, 0.0), (0.0, NET_HEIGHT - NET_RADIUS))], NET_RADIUS, ELASTICITY["net"],
                  FRICTION["net"])
        # the rackets' barriers: the plane of the net up to the reach ceiling, and that ceiling,
        # each running into the floor or the fences at its ends so that no racket slips round it
        barriers = []
        reach = REACH_HEIGHT + BARRIER_RADIUS
        for a, b in (((0.0, -R), (0.0, reach)), ((-F - R, reach), (F + R, reach))):
            segment = pymunk.Segment(space.static_body, a, b, BARRIER_RADIUS)
            segment.filter = _BARRIER_FILTER
            barriers.append(segment)
        space.add(*barriers)
        self._rackets = add_discs(space, racket_xy, RACKET_MASS, RACKET_RADIUS, ELASTICITY["racket"],
                                  FRICTION["racket"])
        for team, body in zip(self.team_of.tolist(), self._rackets):
            for shape in body.shapes:
                shape.filter = _RACKET_FILTERS[team]
        (self._ball,) = add_discs(space, [ball_xy], BALL_MASS, BALL_RADIUS, ELASTICITY["ball"], FRICTION["ball"])
        for shape in self._ball.shapes:
            shape.filter = _BALL_FILTER
        self._ball.velocity = ball_velocity
        self.space = space
        self._link.bind(space)
        self._placement_link.bind(space)
        if self._link.body_ids != [body.id for body in self._rackets] + [self._ball.id, space.static_body.id]:
            raise RuntimeError("pymunk.batch visits the bodies in an unexpected order; Tennis supports "
                               "pymunk 7 (pip install 'pymunk>=7,<8')")
        self._link.read_bodies()

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        self._server = int(self.rng.integers(2))
        racket_xy, ball_xy, ball_velocity = self._draw_serve()
        self._build_space(racket_xy, ball_xy, ball_velocity)
        self.score[:] = 0
        self._work[self._score_at: self._score_at + 2] = 0.0
        self._start_rally()
        self.measures.active[:] = True
        self.measures.outcome[:] = 0.0
        self.game_over = False
        self._events = []

    def _draw_serve(self) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
        """The rackets' spots, the toss's start and its velocity for a serve of ``self._server``:
        the spots and the toss's ``x`` jittered (one draw of the match's generator)."""
        jitter = self.rng.uniform(-self.start_jitter, self.start_jitter, 2 * self.n_agents + 1)
        racket_xy = self._spots + jitter[:-1].reshape(-1, 2)
        sign = 1.0 if self._server == 0 else -1.0
        return racket_xy, np.array([sign * (TOSS_XY[0] + jitter[-1]), TOSS_XY[1]]), (0.0, TOSS_SPEED)

    def _serve(self) -> None:
        """Lay out the next point's serve in the running space."""
        racket_xy, ball_xy, ball_velocity = self._draw_serve()
        self._move_bodies(racket_xy, np.zeros_like(racket_xy), ball_xy, ball_velocity)
        self._start_rally(keep_energy=True)

    def _move_bodies(self, racket_xy: np.ndarray, racket_velocity: np.ndarray, ball_xy: np.ndarray,
                     ball_velocity: Any) -> None:
        """Set every body's position and velocity (world frame) in one batch write."""
        n = self.n_agents
        layout = self._placement[: 4 * (n + 1)].reshape(n + 1, 4)
        layout[:n, 0:2] = racket_xy
        layout[:n, 2:4] = racket_velocity
        layout[n, 0:2] = ball_xy
        layout[n, 2:4] = ball_velocity
        self._placement_link.write_bodies()  # the static body keeps (0, 0) and no velocity
        self._link.read_bodies()

    def _start_rally(self, keep_energy: bool = False) -> None:
        """The rally of a serve by ``self._server``: its toss, on its side, played by it."""
        self._set_rally(player=self._server, bounced=False, tossed=True)
        self._side = self._server
        self._clock = 0
        self._work[self._clock_at] = 0.0
        self._measure_still_state(keep_energy)

    def _set_rally(self, player: int, bounced: bool, tossed: bool) -> None:
        self._player, self._bounced, self._tossed = player, bounced, tossed
        work = self._work
        work[self._played_at] = 1.0 - player
        work[self._played_at + 1] = float(player)
        work[self._bounced_at] = float(bounced)
        work[self._toss_at] = float(tossed)

    def _measure_still_state(self, keep_energy: bool = False) -> None:
        """Measures of the bodies as they stand, with no step behind them (no force; no effort
        unless ``keep_energy``: a serve laid out mid-step keeps the step's), and the contacts the
        ball starts with."""
        if not keep_energy:
            self.measures.energy[:] = 0.0
        self._update_measures()
        self.measures.force[:] = 0.0
        self._landed = self._on_ground()
        self._touching = self._touch_mask()

    def _update_measures(self) -> None:
        """One product of the work vector gives the measures' linear parts and the observations
        (:meth:`observe` clips them); the distances, speeds and forces are the lengths of its complex
        cells (the step sets ``energy`` itself)."""
        np.dot(self._matrix, self._work, out=self._linear)
        np.abs(self._measure_vectors_c, out=self._norms)
        # Re(v * conj(d)) is the dot product of the velocity v and the way d to the ball
        np.multiply(self._velocity_c, self._to_target_conj_c, out=self._along_c)
        # (never 0: the solver keeps the ball's centre well outside a racket)
        np.divide(self._along, self.measures.target_distance, out=self.measures.velocity_to_target)

    def _on_ground(self) -> bool:
        """Whether the ball touches the floor or a back fence."""
        work = self._work
        return work[self._ball_y_at] < BALL_RADIUS or abs(work[self._ball_x_at]) > FENCE_X - BALL_RADIUS

    def _touch_mask(self) -> int:
        """Bit mask of the seats whose racket touches the ball."""
        np.subtract(self._ball_pos_c, self._racket_pos_c, out=self._to_ball_c)
        distance = np.abs(self._to_ball_c, out=self._to_ball).tolist()
        if min(distance) >= CONTACT:
            return 0
        return sum(1 << seat for seat, d in enumerate(distance) if d < CONTACT)

    def step(self, actions: np.ndarray) -> None:
        self._record("step", actions.copy())
        energy = self.measures.energy
        thrust = self._thrust_c
        if self.action_type == "discrete":
            self._moves.take(actions, out=thrust)
            self._move_energy.take(actions, out=energy)
        else:
            self._thrust[:] = actions
            length = np.abs(thrust, out=self._thrust_length)
            np.square(length, out=energy)
            # a thrust longer than 1 is scaled back to length 1 (a Python max of a few cells is
            # cheaper than the two ufuncs when none is)
            if max(energy.tolist()) > 1.0:
                np.minimum(energy, 1.0, out=energy)
                np.maximum(length, 1.0, out=length)
                np.divide(thrust, length, out=thrust)
        if self._gained:
            self.measures.resource_gain[:] = 0.0
            self._gained = False
        if self._events:
            self._events = []

        # thrust against a linear drag, gravity on the ball; pymunk clears the forces after every
        # physics step, so they are written before each
        np.dot(self._force_matrix, self._force_source, out=self._force_array)
        link = self._link
        work = self._work
        ball = self._ball_cells
        x, _, vx, vy = work[ball].tolist()
        for _ in range(SUBSTEPS):
            link.write_bodies()
            link.step(SUBSTEP)
            link.read_bodies()
            x, _, wx, wy = work[ball].tolist()
            # a physics step that pushed the ball (a contact) is judged; in free flight its velocity
            # is exactly the damped one plus gravity's (up to rounding), and it touches nothing
            if abs(wx - vx * _FREE_KEEP) > _FREE_TOLERANCE or abs(wy - vy * _FREE_KEEP - _FREE_FALL) > _FREE_TOLERANCE:
                winner = self._judge_contacts()
                if winner >= 0:
                    self._win_point(winner)
                    return
            elif self._landed or self._touching:
                self._landed, self._touching = False, 0
            vx, vy = wx, wy
        # the side clock: a side that keeps the ball HOLD_LIMIT steps in a row loses the point
        side = self._side if x == 0.0 else int(x > 0.0)
        if side == self._side:
            self._clock += 1
            if self._clock >= HOLD_LIMIT:
                self._win_point(self._point(1 - side, "held"))
                return
        else:
            self._side = side
            self._clock = 1
        work[self._clock_at] = self._clock / HOLD_LIMIT
        self._update_measures()

    def _judge_contacts(self) -> int:
        """The rally after one physics step: a landing, then the rackets' touches. Returns the team
        that wins the point, or -1 while the ball is in play."""
        landed = self._on_ground()
        new_landing = landed and not self._landed
        self._landed = landed
        if new_landing:
            winner = self._judge_landing()
            if winner >= 0:
                return winner
        touching = self._touch_mask()
        if touching:
            new = touching & ~self._touching
            if new:
                self._events += [{"kind": "hit", "seat": seat} for seat in range(self.n_agents) if new >> seat & 1]
            teams = {int(self.team_of[seat]) for seat in range(self.n_agents) if touching >> seat & 1}
            if len(teams) == 2:
                player = self._ball_side()
            else:
                (player,) = teams
            self._set_rally(player=player, bounced=False, tossed=False)
        self._touching = touching
        return -1

    def _ball_side(self) -> int:
        """The side of the net the ball is on (exactly on it, the side it came from)."""
        x = self._work[self._ball_x_at]
        return self._side if x == 0.0 else int(x > 0.0)

    def _judge_landing(self) -> int:
        """The rally when the ball lands: the point's winner, or -1 when it bounced in."""
        player = self._player
        if self._tossed:
            return self._point(1 - player, "fault")
        if self._bounced:
            return self._point(player, "not_returned")
        side = self._ball_side()
        if side == player:
            return self._point(1 - player, "net")
        if abs(self._work[self._ball_x_at]) > HALF_LENGTH:  # beyond the baseline, or on the back fence
            return self._point(1 - player, "out")
        self._set_rally(player=player, bounced=True, tossed=False)
        self._events.append({"kind": "bounce", "side": side})
        return -1

    def _point(self, team: int, reason: str) -> int:
        self._events.append({"kind": "point", "team": team, "reason": reason})
        return team

    def _win_point(self, team: int) -> None:
        """Score the point for ``team``: the match ends at ``points``, else the next serve."""
        self.score[team] += 1
        self._work[self._score_at + team] = float(self.score[team])
        gain = self.measures.resource_gain
        gain[self._first_seats[team]: self._first_seats[team] + self.players_per_team] = 1.0 / self.players_per_team
        self._gained = True
        if self.score[team] >= self.points:
            self.game_over = True
            self._set_outcome()
            self._update_measures()
            return
        self._server = 1 - self._server
        self._serve()

    def _set_outcome(self) -> None:
        result = self.team_result()
        self.measures.outcome[:] = (2.0 * result - 1.0)[self.team_of]

    def observe(self) -> np.ndarray:
        # the product was taken with the measures; two ufuncs clip faster than np.clip
        clipped = np.minimum(self._obs_rows, self._obs_high, out=self._obs_work)
        return np.maximum(clipped, self._obs_low, out=clipped).astype(np.float32)

    def state(self) -> np.ndarray:
        state = self._state_matrix @ self._work
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, v = FENCE_X * POSITION_SCALE, REACH_HEIGHT * POSITION_SCALE, VELOCITY_BOUND
        top = HALL_HEIGHT * POSITION_SCALE
        n_mates = self.players_per_team - 1
        velocity = (-v, v, 2)
        # in the seat frame a seat, and its teammates, lie in x in [-x, 0]; its opponents in [0, x]
        return cell_bounds((0, 1, 1), (-x, 0.0, 1), (0.0, y, 1), velocity,
                           (-x, 2 * x, 1), (-y, top, 1), (-x, x, 1), (0.0, top, 1), velocity,
                           (0, 1, 6),
                           *[run for _ in range(n_mates) for run in ((-x, x, 1), (-y, y, 1), velocity)],
                           *[run for _ in range(self.players_per_team) for run in ((0.0, 2 * x, 1), (-y, y, 1),
                                                                                   velocity)])

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, v = FENCE_X * POSITION_SCALE, REACH_HEIGHT * POSITION_SCALE, VELOCITY_BOUND
        top = HALL_HEIGHT * POSITION_SCALE
        sides = [(-x, 0.0, 1) if team == 0 else (0.0, x, 1) for team in self.team_of]
        return cell_bounds(*[run for side in sides for run in (side, (0.0, y, 1), (-v, v, 2))],
                           (-x, x, 1), (0.0, top, 1), (-v, v, 2), (0, 1, 7))

    def finish(self) -> None:
        self._record("finish")
        # a match cut at max_cycles goes to the team with more points, a draw on equal points
        self._set_outcome()

    def team_result(self) -> np.ndarray:
        # more points wins: 1 win, 0.5 draw, 0 loss
        return np.sign(self.score - self.score[::-1]) * 0.5 + 0.5

    def events(self) -> list[dict]:
        return list(self._events)

    # --- tools ---------------------------------------------------------------------------------
    @property
    def rally(self) -> dict[str, Any]:
        """The rally now: which team ``played`` the ball last, whether it ``bounced`` in since,
        whether it is a ``toss`` not yet struck, the ``side`` it is on and the side ``clock``
        (steps in a row), and the ``server`` of the point."""
        return {"played": self._player, "bounced": self._bounced, "toss": self._tossed, "side": self._side,
                "clock": self._clock, "server": self._server}

    def place(self, racket_xy: np.ndarray, ball_xy: np.ndarray, racket_velocity: np.ndarray | None = None,
              ball_velocity: np.ndarray | None = None, played: int = 0, bounced: bool = False,
              score: tuple[int, int] | None = None) -> None:
        """Put the bodies at given world positions and velocities with the ball in play, struck
        last by team ``played`` (having ``bounced`` in since, or not), for tests and scripted
        scenarios; the side clock starts afresh and the match continues from there, each team
        keeping its points (or taking ``score``). Each racket must stand within its side and reach,
        and the ball in the hall above the floor."""
        if self.space is None:
            raise RuntimeError("call reset(seed) before place()")
        racket_xy = np.asarray(racket_xy, dtype=np.float64).reshape(self.n_agents, 2)
        racket_velocity = (np.zeros((self.n_agents, 2)) if racket_velocity is None
                           else np.asarray(racket_velocity, dtype=np.float64).reshape(self.n_agents, 2))
        ball_xy = np.array(ball_xy, dtype=np.float64).reshape(2)
        ball_velocity = np.zeros(2) if ball_velocity is None else np.array(ball_velocity, dtype=np.float64).reshape(2)
        clear = RACKET_RADIUS + BARRIER_RADIUS
        seat_x = racket_xy[:, 0] * self._team_sign  # in the seat frame: the own side is x < 0
        outside = ((seat_x > -clear) | (seat_x < -FENCE_X + RACKET_RADIUS) | (racket_xy[:, 1] < RACKET_RADIUS)
                   | (racket_xy[:, 1] > REACH_HEIGHT - RACKET_RADIUS))
        if outside.any():
            seat = int(np.flatnonzero(outside)[0])
            raise ValueError(f"racket {seat} at {racket_xy[seat].tolist()} is outside its side or reach: team "
                             f"{int(self.team_of[seat])} plays on {'x < 0' if self.team_of[seat] == 0 else 'x > 0'}, "
                             f"at least {clear} from the net, and a racket's centre lies within y in "
                             f"[{RACKET_RADIUS}, {REACH_HEIGHT - RACKET_RADIUS}]")
        if abs(ball_xy[0]) > FENCE_X - BALL_RADIUS or not BALL_RADIUS <= ball_xy[1] <= HALL_HEIGHT - BALL_RADIUS:
            raise ValueError(f"the ball at {ball_xy.tolist()} is outside the hall: its centre must lie within x in "
                             f"[-{FENCE_X - BALL_RADIUS}, {FENCE_X - BALL_RADIUS}] and y in "
                             f"[{BALL_RADIUS}, {HALL_HEIGHT - BALL_RADIUS}]")
        if played not in (0, 1):
            raise ValueError(f"played is the team that struck the ball last, 0 or 1, not {played!r}")
        if score is not None:
            score = tuple(int(s) for s in score)
            if len(score) != 2 or min(score) < 0 or max(score) >= self.points:
                raise ValueError(f"score must be two points counts in [0, {self.points - 1}] (a team with "
                                 f"{self.points} has won), not {score!r}")
        self._record("place", racket_xy.copy(), ball_xy.copy(), racket_velocity.copy(), ball_velocity.copy(),
                     played, bounced, score)
        self._move_bodies(racket_xy, racket_velocity, ball_xy, ball_velocity)
        if score is not None:
            self.score[:] = score
            self._work[self._score_at: self._score_at + 2] = self.score
        self._set_rally(player=int(played), bounced=bool(bounced), tossed=False)
        self._side = self._ball_side()
        self._clock = 0
        self._work[self._clock_at] = 0.0
        self._events = []
        self._measure_still_state()

    def render_topdown(self) -> np.ndarray:
        F, H, L = FENCE_X, HALL_HEIGHT, HALF_LENGTH
        margin = 0.25
        canvas = Canvas(-F - margin, F + margin, -margin, H + margin, size=400, background=(40, 40, 40))
        canvas.rect(-F, 0.0, F, H, fill=(205, 215, 225))  # the hall's air, framed by floor, fences, ceiling
        for x in (-L, L):  # the baselines
            canvas.line(x, 0.0, x, -margin, fill=(235, 235, 235), width_px=3)
        canvas.rect(-NET_RADIUS, 0.0, NET_RADIUS, NET_HEIGHT, fill=(235, 235, 235))
        canvas.line(-F, REACH_HEIGHT, F, REACH_HEIGHT, fill=(175, 185, 195))  # how high rackets reach
        for seat in range(self.n_agents):
            x, y = self._racket_pos[seat]
            canvas.circle(x, y, RACKET_RADIUS, fill=TEAM_COLOURS[self.team_of[seat]], outline=(20, 20, 20))
        bx, by = self._ball_state[0:2]
        # no dark rim: the text view sees a white block as the ball ("o"), a grey one as a marking
        canvas.circle(bx, by, BALL_RADIUS, fill=(250, 250, 250))
        return canvas.array()

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        F, L, ts = FENCE_X, HALF_LENGTH, timestamp_ns
        lane = 0.4 if self.players_per_team > 1 else 0.0
        line = (0.95, 0.95, 0.95, 1.0)
        out = [scene.entity("court", ts, cubes=[
            scene.cube(0, 0, -0.05, (2 * F, 2.0, 0.1), (0.35, 0.55, 0.31, 1.0)),
            scene.cube(-L, 0, 0.001, (0.05, 2.0, 0.002), line),  # the baselines
            scene.cube(L, 0, 0.001, (0.05, 2.0, 0.002), line),
            scene.cube(0, 0, NET_HEIGHT / 2, (2 * NET_RADIUS, 2.0, NET_HEIGHT), (0.9, 0.9, 0.9, 0.8))])]
        for seat in range(self.n_agents):
            x, z = self._racket_pos[seat]
            y = lane * (1 if seat % self.players_per_team == 0 else -1)
            d = 2 * RACKET_RADIUS
            out.append(scene.entity(f"agent/{seat}", ts, spheres=[
                scene.sphere(float(x), y, float(z), (d, 0.1, d), scene.team_colour(int(self.team_of[seat])))]))
        bx, bz = self._ball_state[0:2]
        d = 2 * BALL_RADIUS
        out.append(scene.entity("ball", ts, spheres=[
            scene.sphere(float(bx), 0.0, float(bz), (d, d, d), (0.85, 0.95, 0.3, 1.0))]))
        out.append(scene.entity("score", ts, texts=[scene.text(0, 0, HALL_HEIGHT / 2,
                                                               f"{int(self.score[0])} : {int(self.score[1])}")]))
        return out

    def human_controls(self, seat: int) -> TennisControls:
        return TennisControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        # the points' share at the root, the team's mean progress toward the ball, each seat's own
        return team_tree(n_teams, players_per_team, "resource_share")

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        return _heuristic(obs, action_type)


#: The heuristic's look-ahead: physics steps of the ball's predicted flight (1.5 s); it weighs
#: meeting the ball after every ``_STRIDE``-th of them.
_LOOKAHEAD = 30
_STRIDE = 2
#: Restitution and friction of the ball on the floor and on a racket (products of the shapes' values).
_FLOOR_RESTITUTION = ELASTICITY["ball"] * ELASTICITY["floor"]
_FLOOR_FRICTION = FRICTION["ball"] * FRICTION["floor"]
_RACKET_RESTITUTION = ELASTICITY["ball"] * ELASTICITY["racket"]
#: What a head-on stroke gives the ball of the closing velocity: (1 + restitution) times the
#: racket's share of the two masses (the racket is ten times as heavy).
_STROKE = (1.0 + _RACKET_RESTITUTION) * RACKET_MASS / (RACKET_MASS + BALL_MASS)
#: Where the heuristic's shots should land beyond the net, how far above the net they must pass,
#: and the height it likes to strike the ball at.
_AIM_X = 2.6
_NET_MARGIN = 0.25
_STRIKE_HEIGHT = 1.1
#: The directions of the racket's swing it weighs (angles above +x, seat frame): every 15 degrees
#: from +x to up for continuous actions; for discrete ones the compass directions E, NE and N,
#: which it swings exactly.
_SWING_ANGLES = {"continuous": np.radians(np.arange(0.0, 91.0, 15.0)), "discrete": np.radians([0.0, 45.0, 90.0])}
_SWING_DIRECTIONS = {kind: np.stack([np.cos(a), np.sin(a)], axis=1) for kind, a in _SWING_ANGLES.items()}
#: A racket at rest running at full thrust: its speed after ``t`` seconds is ``V (1 - exp(-rate t))``
#: under drag and damping (``V`` its top speed).
_SWING_RATE = (RACKET_DRAG - RACKET_MASS * np.log(SPACE_DAMPING)) / RACKET_MASS


def _run_speed(time: np.ndarray) -> np.ndarray:
    """Speed of a racket ``time`` seconds into a run at full thrust from rest."""
    return RACKET_TOP_SPEED * (1.0 - np.exp(-_SWING_RATE * time))


def _run_distance(time: np.ndarray) -> np.ndarray:
    """Distance a racket covers in ``time`` seconds of a run at full thrust from rest."""
    return RACKET_TOP_SPEED * time - _run_speed(time) / _SWING_RATE


#: The racket speeds it weighs, and the time and distance a run needs to reach each.
_SWING_SPEEDS = np.linspace(0.6, 0.92 * RACKET_TOP_SPEED, 8)
_RUN_TIME = -np.log(1.0 - _SWING_SPEEDS / RACKET_TOP_SPEED) / _SWING_RATE
_RUN_UP = _run_distance(_RUN_TIME)
#: The gains of its steering toward where the racket should be, and how fast it should move.
_POSITION_GAIN = 20.0
_VELOCITY_GAIN = 5.0
#: Where the racket's centre can go in the seat frame (x, then y), a little inside the barriers.
_REACH_LOW = np.array([-FENCE_X + RACKET_RADIUS + 0.05, RACKET_RADIUS + 0.03])
_REACH_HIGH = np.array([-(RACKET_RADIUS + BARRIER_RADIUS) - 0.03, REACH_HEIGHT - RACKET_RADIUS - 0.05])
#: Where a racket waits while the other team has the ball: the back spot, or the front one for the
#: teammate nearer the net.
_BACK_SPOT, _FRONT_SPOT = np.array(_FORMATIONS[2][0]), np.array(_FORMATIONS[2][1])


def _flight_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients of a free flight's physics steps ``(S1 h, S2 h^2, D, G h)``: after ``k`` steps of
    ``h``, with ``d`` the damping of one step, Chipmunk (which moves a body by its velocity before it
    updates that velocity) has the ball at ``p + S1[k] h v + S2[k] h^2 a`` moving at
    ``D[k] v + G[k] h a``."""
    d = SPACE_DAMPING**SUBSTEP
    powers = d ** np.arange(_LOOKAHEAD + 1)
    gained = (1.0 - powers) / (1.0 - d)  # the sum of d**j for j < k
    s1 = np.concatenate([[0.0], np.cumsum(powers)[:-1]])
    s2 = np.concatenate([[0.0], np.cumsum(gained)[:-1]])
    return s1 * SUBSTEP, s2 * SUBSTEP**2, powers, gained * SUBSTEP


_S1, _S2, _DECAY, _GAIN = _flight_tables()
_DOWN = np.array([0.0, -GRAVITY])


def _fly(p: np.ndarray, v: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Free flights from ``p``, ``v`` (``[N, 2]``) after ``k`` (``[N, K]``) physics steps."""
    position = p[:, None, :] + _S1[k][..., None] * v[:, None, :] + _S2[k][..., None] * _DOWN
    return position, _DECAY[k][..., None] * v[:, None, :] + _GAIN[k][..., None] * _DOWN


def _predict_flight(ball: np.ndarray, velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ball's positions and velocities after each of the next ``_LOOKAHEAD`` physics steps
    (``[N, K, 2]`` each, step 0 now), bouncing once off the floor, and how many times it has landed
    by each step (``[N, K]``: 0, 1, or 2 once it lands again)."""
    k = np.broadcast_to(np.arange(_LOOKAHEAD + 1), (len(ball), _LOOKAHEAD + 1))
    position, speed = _fly(ball, velocity, k)
    low = position[:, :, 1] < BALL_RADIUS
    low[:, 0] = False
    bounces = low.any(axis=1)
    first = np.where(bounces, low.argmax(axis=1), _LOOKAHEAD)
    rows = np.arange(len(ball))
    # the bounce: the vertical speed turned back, the horizontal one braked by the floor's friction
    v_in = speed[rows, first - 1]
    brake = _FLOOR_FRICTION * (1.0 + _FLOOR_RESTITUTION) * np.abs(v_in[:, 1])
    v_out = np.stack([np.sign(v_in[:, 0]) * np.maximum(np.abs(v_in[:, 0]) - brake, 0.0),
                      -_FLOOR_RESTITUTION * v_in[:, 1]], axis=1)
    after = np.maximum(k - first[:, None], 0)
    again, again_speed = _fly(position[rows, first], v_out, after)
    later = (k > first[:, None]) & bounces[:, None]
    position = np.where(later[..., None], again, position)
    speed = np.where(later[..., None], again_speed, speed)
    second = np.cumsum(later & (position[:, :, 1] < BALL_RADIUS) & (after > 1), axis=1) > 0
    landings = ((k >= first[:, None]) & bounces[:, None]).astype(np.int64) + second
    return position, speed, landings


def _shots(contact: np.ndarray, incoming: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Head-on strokes at balls met at ``contact`` moving at ``incoming`` (``[N, K, 2]``, seat
    frame) by a racket moving at every speed of ``_SWING_SPEEDS`` in every one of ``directions``:
    where the struck ball lands (``[N, K, A, S]``; air drag roughly allowed for), whether it clears
    the net by ``_NET_MARGIN``, and the line of impact (racket to ball, ``[N, K, A, S, 2]``).

    A racket that meets the ball along their relative velocity strikes it on that line, however
    early or late it comes: the ball leaves at ``v + _STROKE * (u - v)`` (racket velocity ``u``)."""
    racket = directions[:, None, :] * _SWING_SPEEDS[None, :, None]  # [A, S, 2]
    closing = racket[None, None] - incoming[:, :, None, None, :]
    size = np.sqrt(np.einsum("...i,...i->...", closing, closing))
    line = closing / np.maximum(size, 1e-9)[..., None]
    v_out = 0.95 * (incoming[:, :, None, None, :] + _STROKE * closing)  # 0.95: about what air drag takes
    x0, y0 = contact[:, :, None, None, 0], contact[:, :, None, None, 1]
    vx, vy = v_out[..., 0], v_out[..., 1]
    t_land = (vy + np.sqrt(vy * vy + 2.0 * GRAVITY * np.maximum(y0 - BALL_RADIUS, 0.0))) / GRAVITY
    t_net = -x0 / np.maximum(vx, 1e-6)
    at_net = y0 + vy * t_net - 0.5 * GRAVITY * t_net * t_net
    clears = (vx > 0.3) & (at_net > NET_HEIGHT + BALL_RADIUS + _NET_MARGIN) & (t_net < t_land)
    return x0 + vx * t_land, clears, line


def _legal_flight(obs: np.ndarray, toss: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ball's predicted flight seen from each row's seat (positions and velocities, ``[N, K,
    2]``) and the physics steps at whose end its racket may strike it (``[N, K]``, every
    ``_STRIDE``-th): on its side at a reachable height, before the ball lands on a toss or once it
    has bounced in, else before it lands a second time, the first landing in the own court."""
    position, speed, landings = _predict_flight(obs[:, 7:9] * POSITION_UNIT, obs[:, 9:11] * VELOCITY_UNIT)
    in_court = (landings == 1) & (position[:, :, 0] < 0.0) & (position[:, :, 0] > -HALF_LENGTH)
    bounced_in = np.cumsum(in_court, axis=1) > 0
    at_most_once = (toss | (obs[:, 12] > 0.5))[:, None]
    legal = np.where(at_most_once, landings == 0, (landings == 0) | ((landings == 1) & bounced_in))
    legal &= (position[:, :, 1] > 0.35) & (position[:, :, 1] < 2.2) & (position[:, :, 0] < -0.1)
    legal[:, np.arange(_LOOKAHEAD + 1) % _STRIDE != 0] = False
    legal[:, 0] = False
    return position, speed, legal


def _strokes(me: np.ndarray, velocity: np.ndarray, position: np.ndarray, speed: np.ndarray, legal: np.ndarray,
             directions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The best stroke of each seat at the predicted ball (``[N, K, 2]``; at every ``_STRIDE``-th
    physics step where ``legal``): whether it found one, its moment (physics steps from now), its
    direction and speed (indices) and the racket's spot at contact (``[N, 2]``)."""
    n = len(me)
    moments = np.arange(0, _LOOKAHEAD + 1, _STRIDE)
    moments = moments[legal[:, moments].any(axis=0)]  # (weighing only the moments some row may strike at)
    position, speed, legal = position[:, moments], speed[:, moments], legal[:, moments]
    landing, clears, line = _shots(position, speed, directions)
    spot = position[:, :, None, None, :] - line * CONTACT  # the racket's centre at contact
    ready = spot - directions[None, None, :, None, :] * _RUN_UP[:, None]

    def inside(p: np.ndarray) -> np.ndarray:
        return ((p[..., 0] > _REACH_LOW[0]) & (p[..., 0] < _REACH_HIGH[0]) & (p[..., 1] > _REACH_LOW[1])
                & (p[..., 1] < _REACH_HIGH[1]))

    # the racket should stand ready behind the spot by the moment less the run's time, or be on the
    # run already (near the line there, behind the spot within the run-up, moving along it):
    # lateness costs, as does a run-up that starts out of reach
    t = moments * SUBSTEP
    gap = ready - me[:, None, None, None, :]
    to_ready = np.sqrt(np.einsum("...i,...i->...", gap, gap))
    late = np.maximum(to_ready / RACKET_TOP_SPEED - np.maximum(t[:, None, None] - _RUN_TIME, 0.0), 0.0)
    offset = spot - me[:, None, None, None, :]
    d = directions[None, None, :, None, :]
    ahead = (offset * d).sum(axis=-1)
    aside = np.abs(offset[..., 0] * d[..., 1] - offset[..., 1] * d[..., 0])
    moving = (velocity @ directions.T)[:, None, :, None]
    running = (aside < 0.15) & (ahead > -0.05) & (ahead <= _RUN_UP + 0.1) & (moving > 0.3)
    late = np.where(running, 0.0, late)
    good = legal[:, :, None, None] & clears & inside(spot) & (landing > 0.5) & (landing < HALF_LENGTH - 0.3)
    cost = (np.abs(landing - _AIM_X) + 0.5 * np.abs(position[:, :, None, None, 1] - _STRIKE_HEIGHT)
            + 0.3 * t[:, None, None] + 4.0 * late + 2.0 * ~inside(ready))
    cost = np.where(good, cost, np.inf).reshape(n, -1)
    best = cost.argmin(axis=1)
    found = np.isfinite(cost[np.arange(n), best])
    k, a, w = np.unravel_index(best, good.shape[1:])
    return found, moments[k], a, w, spot[np.arange(n), k, a, w]


def _heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
    obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
    n_others, rest = divmod(obs.shape[1] - 17, 4)
    if rest or n_others not in (1, 3):
        raise ValueError(f"Tennis heuristic: an observation of {obs.shape[1]} cells is not Tennis's "
                         "(17 + 4 * (n_agents - 1) cells)")
    n_mates = (n_others + 1) // 2 - 1
    me = obs[:, 1:3] * POSITION_UNIT
    velocity = obs[:, 3:5] * VELOCITY_UNIT
    ball = obs[:, 7:9] * POSITION_UNIT
    toss = obs[:, 13] > 0.5
    # the ball is the seat's team's to play when the other team played it last, or on its own toss
    to_play = (obs[:, 11] < 0.5) | toss

    # roles: the teammate best placed plays the ball (the nearest, a racket in front of the ball
    # counting as further: it strikes toward +x); the others keep their spots
    def placing(xy: np.ndarray) -> np.ndarray:
        return np.hypot(*(ball - xy).T) + 1.5 * np.maximum(xy[:, 0] - ball[:, 0] + 0.3, 0.0)

    own_placing = placing(me)
    home = np.tile(_BACK_SPOT, (len(obs), 1))
    for mate in range(n_mates):
        mate_xy = me + obs[:, 17 + 4 * mate: 19 + 4 * mate] * POSITION_UNIT
        to_play &= placing(mate_xy) >= own_placing
        home[me[:, 0] > mate_xy[:, 0]] = _FRONT_SPOT
    target = home
    target_velocity = np.zeros_like(me)
    running = np.zeros(len(obs), dtype=bool)
    direction = np.zeros_like(me)

    p = np.flatnonzero(to_play)
    if len(p):
        position, speed, legal = _legal_flight(obs[p], toss[p])
        playable = legal.any(axis=1)
        p, position, speed, legal = p[playable], position[playable], speed[playable], legal[playable]
    if len(p):
        directions = _SWING_DIRECTIONS[action_type]
        found, k, a, w, spot = _strokes(me[p], velocity[p], position, speed, legal, directions)
        p, k, a, w, spot = p[found], k[found], a[found], w[found], spot[found]
        # the stroke: stand ready behind the spot, then run through it at full thrust from the
        # moment that brings the racket there at the stroke's speed, steering onto the run
        direction[p] = directions[a]
        elapsed = np.maximum(_RUN_TIME[w] - k * SUBSTEP, 0.0)  # time into the run
        target[p] = spot - direction[p] * (_RUN_UP[w] - _run_distance(elapsed))[:, None]
        target_velocity[p] = direction[p] * _run_speed(elapsed)[:, None]
        running[p] = elapsed > 0.0
    target = np.clip(target, _REACH_LOW, _REACH_HIGH)
    heading = (_POSITION_GAIN * (target - me) + _VELOCITY_GAIN * (target_velocity - velocity)) / THRUST
    heading += np.where(running[:, None], direction, 0.0)  # the run's full thrust
    length = np.hypot(heading[:, 0], heading[:, 1])
    if action_type == "continuous":
        return np.clip(heading / np.maximum(length, 1.0)[:, None], -1.0, 1.0).astype(np.float32)
    angle = np.arctan2(heading[:, 1], heading[:, 0])
    move = 1 + np.round(angle / (np.pi / 4)).astype(np.int64) % 8
    return np.where(length < 0.3, 0, move).astype(np.int64)


class TennisControls(SoccerControls):
    """Compass moves of one's racket on the court as drawn (E = right, N = up), mirrored for the
    team that sees the court flipped (Soccer's moves)."""

    move = "move your racket on the court as drawn"
    key_hint = ("Arrow keys or W A S D swing your racket on the court as drawn (two at once: diagonally); let go "
                "to stop pushing.")


RULES = TennisRules
