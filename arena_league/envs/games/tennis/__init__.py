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
    From the observation alone: the teammate best placed to play the ball predicts its flight,
    picks a stroke that clears the net and lands deep in the other court, and runs its racket
    through the spot of contact at the stroke's speed; the others keep their spots. It assumes the
    default court; :mod:`arena_league.envs.games.tennis.heuristic` describes it in full.

Game kwargs
    ``points`` (an integer in [1, 21], default 7: points to win the match), ``start_jitter`` (a
    number in [0, 0.3], default 0.2: largest random offset of each serve position).

Playing it (``arena-league play``)
    A coarse text view of the side picture (team digits, ``+`` the net, ``o`` the ball; the view's
    edge is the hall's: the floor is its bottom line). A move is an action's number or name, a
    compass direction *on the court as drawn* (``E`` = right, ``N`` = up, whichever side you play:
    team 1's moves are mirrored into its seat frame for you); Enter repeats the last move. In a
    browser, the arrow keys or W A S D (two at once: diagonally). Discrete actions only.

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
from arena_league.envs.controls import MirroredCompassControls
from arena_league.envs.core import cell_bounds
from arena_league.envs.options import Option
from arena_league.envs.physics2d import (
    COMPASS_MOVE_NAMES,
    ONE,
    Bodies,
    CellLayout,
    Field,
    Material,
    Physics2DRules,
    Run,
    SeatThrust,
    Walls,
    World,
    mirror_signs,
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
OPTIONS = (Option("points", int, DEFAULT_POINTS, "points to win the match", 1, 21),
           Option("start_jitter", float, 0.2, "largest random offset of each serve position", 0.0, 0.3))

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


def tennis_hall(team_of: np.ndarray) -> Field:
    """The hall seen from the side: floor, fences and ceiling, the net, the rackets' barriers (the
    plane of the net up to the reach ceiling, and that ceiling, each running into the floor or the
    fences at its ends so that no racket slips round it), the rackets and the ball, in that order."""
    F, H, R = FENCE_X, HALL_HEIGHT, WALL_RADIUS
    reach = REACH_HEIGHT + BARRIER_RADIUS
    rackets = tuple(Material(ELASTICITY["racket"], FRICTION["racket"], _RACKET_FILTERS[team]) for team in team_of.tolist())
    return Field(dt=SUBSTEP, damping=SPACE_DAMPING, collision_slop=COLLISION_SLOP, substeps=SUBSTEPS, parts=(
        Walls((((-F - R, -R), (F + R, -R)),), R, Material(ELASTICITY["floor"], FRICTION["floor"])),
        Walls((((-F - R, -R), (-F - R, H + R)), ((F + R, -R), (F + R, H + R)), ((-F - R, H + R), (F + R, H + R))),
              R, Material(ELASTICITY["wall"], FRICTION["wall"])),
        Walls((((0.0, 0.0), (0.0, NET_HEIGHT - NET_RADIUS)),), NET_RADIUS, Material(ELASTICITY["net"], FRICTION["net"])),
        Walls((((0.0, -R), (0.0, reach)), ((-F - R, reach), (F + R, reach))), BARRIER_RADIUS,
              Material(filter=_BARRIER_FILTER)),
        Bodies("racket", len(team_of), RACKET_RADIUS, RACKET_MASS, rackets),
        Bodies("ball", 1, BALL_RADIUS, BALL_MASS, Material(ELASTICITY["ball"], FRICTION["ball"], _BALL_FILTER))))


def tennis_observation(players_per_team: int) -> CellLayout:
    """The observation's runs (seat frame; positions divided by 4, velocities by 4)."""
    x, y, top, v = FENCE_X * POSITION_SCALE, REACH_HEIGHT * POSITION_SCALE, HALL_HEIGHT * POSITION_SCALE, VELOCITY_BOUND
    velocity = (-v, v)
    runs = [Run("active", 1, (0, 1), "own active flag (always 1 in Tennis)"),
            Run("position", 2, ((-x, 0.0), (0.0, y)), "own position ``x, y`` (the own side, within reach)"),
            Run("velocity", 2, velocity, "own velocity ``vx, vy``"),
            Run("ball_relative", 2, ((-x, 2 * x), (-y, top)), "ball position relative to the seat (ball - own)"),
            Run("ball", 2, ((-x, x), (0.0, top)), "ball position (absolute)"),
            Run("ball_velocity", 2, velocity, "ball velocity"),
            Run("played", 1, (0, 1), "1 when the own team played the ball last (or tosses it to serve), 0 when "
                                     "the other team did"),
            Run("bounced", 1, (0, 1), "1 once the ball has bounced in on the receiving side since it was played "
                                      "(it must be returned before it lands again)"),
            Run("toss", 1, (0, 1), "1 while the ball is a serve's toss not yet struck"),
            Run("clock", 1, (0, 1), f"steps the ball has spent on its side of the net in a row, as a share of "
                                    f"{HOLD_LIMIT} (at 1 that side loses the point)"),
            Run("points", 2, (0, 1), "the own team's points, then the other team's, as shares of ``points``")]
    for k in range(2 * players_per_team - 1):
        # in the seat frame teammates lie in x in [-x, 0], opponents in [0, x]
        mate = k < players_per_team - 1
        runs += [Run(f"other_{k}", 2, ((-x, x) if mate else (0.0, 2 * x), (-y, y)),
                     f"{'a teammate' if mate else 'an opponent'}'s position relative to the seat (teammates "
                     "first then opponents, each in seat order)"),
                 Run(f"other_{k}_velocity", 2, velocity, "that seat's velocity")]
    return CellLayout(runs)


class TennisRules(Physics2DRules):
    """Tennis in a side-view pymunk hall; see the package docstring for the manual."""

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
    options = OPTIONS

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        self.points = self.settings["points"]
        self.start_jitter = self.settings["start_jitter"]
        n = self.n_agents
        self.n_actions = len(COMPASS_MOVE_NAMES)
        self.act_dim = 2
        self.action_meanings = COMPASS_MOVE_NAMES
        self.layout = tennis_observation(players_per_team)
        self.obs_dim = self.layout.size
        self.state_dim = 4 * n + 11

        self._team_sign = mirror_signs(self.team_of)  # the x sign of each seat's frame
        self._first_seats = np.arange(n_teams) * players_per_team
        # every seat's serve spot, team 1's mirrored
        self._spots = np.tile(np.asarray(_FORMATIONS[players_per_team], dtype=np.float64), (n_teams, 1))
        self._spots[:, 0] *= self._team_sign
        # unit thrust of every move in the seat frame (x + iy): the matrices turn it into the world
        self._obs_low, self._obs_high = (bound.reshape(n, self.obs_dim) for bound in self.clip_bounds(self.layout))
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())
        self._layout_work_vector()
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
        """The world's work vector holds everything a step reads, and one matrix product of it gives
        the measures' linear parts and every observation at once (few numpy calls: the hot path is
        Python-bound). Their results land in preallocated arrays, seen through views made here.

        After the bodies' ``[x, y, vx, vy]`` (the rackets, the ball and pymunk's static body), the
        slots: the seats' unit thrust in their own frames (as the actions give it: the matrices
        mirror team 1's into the world), a constant 1, the applied force ``[fx, fy]`` of every body
        (which the link writes to pymunk), which team played the ball last (two cells), the
        bounced-in and toss flags, the side clock (a share of HOLD_LIMIT) and the points of each team.
        """
        n = self.n_agents
        world = self.world = World(tennis_hall(self.team_of), applied="force", slots=(
            ("thrust", 2 * n), (ONE, 1), ("force", 2 * (n + 2)), ("played", 2), ("bounced", 1), ("toss", 1),
            ("clock", 1), ("score", 2)))
        self._work, self._link = world.work, world.link
        ball = world.index("ball")
        self._thrust_at, self._one_at, self._force_at = world.at("thrust"), world.at(ONE), world.at("force")
        self._played_at, self._bounced_at, self._toss_at = world.at("played"), world.at("bounced"), world.at("toss")
        self._clock_at, self._score_at = world.at("clock"), world.at("score")
        self._racket_pos = world.table[:n, 0:2]
        self._ball_state = world.table[ball]
        self._ball_x_at, self._ball_y_at = world.pos(ball, 0), world.pos(ball, 1)
        self._ball_cells = slice(self._ball_x_at, self._ball_x_at + 4)
        # complex views (x + iy) of the 2-vectors: fewer, cheaper numpy calls on the hot path
        bodies_c = world.table.view(np.complex128)
        self._racket_pos_c = bodies_c[:n, 0]
        self._ball_pos_c = bodies_c[ball: ball + 1, 0]
        self._seat_thrust = SeatThrust(world.complex_view("thrust"), self.action_type)
        self._to_ball_c = np.zeros(n, dtype=np.complex128)  # ball - racket, after every physics step
        self._to_ball = np.zeros(n)  # its length
        self._force_array = world.applied
        # applied force of every body in the world frame: thrust against drag for the rackets,
        # gravity for the ball, none for the static body; a product of the cells before the forces
        self._force_matrix = np.zeros((2 * world.n_bodies, len(world.force_source)))
        self._force_source = world.force_source
        for k in range(2 * n):
            self._force_matrix[k, self._thrust_at + k] = THRUST * self._axis_sign(k)
            self._force_matrix[k, world.vel(k // 2, k % 2)] = -RACKET_DRAG
        self._force_matrix[2 * ball + 1, self._one_at] = -BALL_MASS * GRAVITY
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

    def _measure_map(self) -> np.ndarray:
        """The linear parts of the measures as one matrix over the work vector.

        Rows: ``[to_ball (x, -y), velocity (x, y), contact force (x, y)]`` of every seat, read as
        complex numbers (``to_ball`` conjugated). The contact force is the impulse the solver added
        beyond damping and the applied force ``f`` over the two physics steps, divided by ``dt``:
        Chipmunk integrates ``v' = v * k + f / m * h`` (``k = damping**h``) before solving contacts,
        and the same ``f = THRUST * u - DRAG * v0`` acts in both, so the velocity before the step is
        ``v0 = (THRUST * u - f) / DRAG`` and the impulse ``m v2 - m k^2 v0 - (1 + k) h f``.
        """
        n, world = self.n_agents, self.world
        M = world.matrix(6 * n)
        ball = world.index("ball")
        keep = SPACE_DAMPING**SUBSTEP
        before = keep * keep * RACKET_MASS / RACKET_DRAG  # the impulse's share of v0 * DRAG
        for i in range(n):
            for ax in range(2):
                conj = 1.0 if ax == 0 else -1.0
                M[2 * i + ax, world.pos(ball, ax)] = conj
                M[2 * i + ax, world.pos(i, ax)] = -conj
                M[2 * n + 2 * i + ax, world.vel(i, ax)] = 1.0
                row = 4 * n + 2 * i + ax
                M[row, world.vel(i, ax)] = RACKET_MASS / DT
                M[row, self._thrust_at + 2 * i + ax] = -before * THRUST * self._axis_sign(2 * i + ax) / DT
                M[row, self._force_at + 2 * i + ax] = (before - (1.0 + keep) * SUBSTEP) / DT
        return M

    def _observation_map(self) -> np.ndarray:
        """The observations of every seat as one matrix over the work vector."""
        n, world, cells = self.n_agents, self.world, self.layout
        A = np.zeros((n, self.obs_dim, len(world.work)))
        ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
        ball, pos, vel = world.index("ball"), world.pos, world.vel
        for i in range(n):
            rows = A[i]
            sign = self._team_sign[i]
            team = int(self.team_of[i])
            # the other seats in observation order: teammates, then opponents, each in seat order
            others = [j for j in range(n) if j != i and self.team_of[j] == team]
            others += [j for j in range(n) if self.team_of[j] != team]
            rows[cells.at("active"), self._one_at] = 1.0
            for ax, scale in ((0, sign), (1, 1.0)):
                rows[cells.at("position", ax), pos(i, ax)] = ps * scale
                rows[cells.at("velocity", ax), vel(i, ax)] = vs * scale
                rows[cells.at("ball_relative", ax), pos(ball, ax)] = ps * scale
                rows[cells.at("ball_relative", ax), pos(i, ax)] = -ps * scale
                rows[cells.at("ball", ax), pos(ball, ax)] = ps * scale
                rows[cells.at("ball_velocity", ax), vel(ball, ax)] = vs * scale
                for k, j in enumerate(others):
                    rows[cells.at(f"other_{k}", ax), pos(j, ax)] = ps * scale
                    rows[cells.at(f"other_{k}", ax), pos(i, ax)] = -ps * scale
                    rows[cells.at(f"other_{k}_velocity", ax), vel(j, ax)] = vs * scale
            rows[cells.at("played"), self._played_at + team] = 1.0
            rows[cells.at("bounced"), self._bounced_at] = 1.0
            rows[cells.at("toss"), self._toss_at] = 1.0
            rows[cells.at("clock"), self._clock_at] = 1.0
            rows[cells.at("points", 0), self._score_at + team] = 1.0 / self.points
            rows[cells.at("points", 1), self._score_at + 1 - team] = 1.0 / self.points
        return A.reshape(n * self.obs_dim, len(world.work))

    def _state_map(self) -> np.ndarray:
        """The global state as one matrix over the work vector."""
        n, world = self.n_agents, self.world
        S = world.matrix(self.state_dim)
        for body in range(n + 1):
            for ax in range(2):
                S[4 * body + ax, world.pos(body, ax)] = POSITION_SCALE
                S[4 * body + 2 + ax, world.vel(body, ax)] = 1.0 / VELOCITY_UNIT
        row = 4 * (n + 1)
        S[row, self._score_at] = S[row + 1, self._score_at + 1] = 1.0 / self.points
        for k, cell in enumerate((self._played_at, self._played_at + 1, self._bounced_at, self._toss_at,
                                  self._clock_at)):
            S[row + 2 + k, cell] = 1.0
        return S

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        self._server = int(self.rng.integers(2))
        racket_xy, ball_xy, ball_velocity = self._draw_serve()
        self.world.build({"racket": racket_xy, "ball": ball_xy}, {"ball": (ball_velocity,)})
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
        self._move_bodies(racket_xy, None, ball_xy, ball_velocity)
        self._start_rally(keep_energy=True)

    def _move_bodies(self, racket_xy: np.ndarray, racket_velocity: Any, ball_xy: np.ndarray,
                     ball_velocity: Any) -> None:
        """Set every body's position and velocity (world frame) in one batch write."""
        self.world.place_all({"racket": racket_xy, "ball": ball_xy}, {"racket": racket_velocity, "ball": ball_velocity})


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
        self._seat_thrust.set(actions, self.measures.energy)
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
        return self.layout.bounds()

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
        if self.world.space is None:
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
        from arena_league.envs.games.tennis.heuristic import heuristic  # the scripted play, loaded when asked

        return heuristic(obs, action_type)

class TennisControls(MirroredCompassControls):
    """Compass moves of one's racket on the court as drawn (E = right, N = up), mirrored for the
    team that sees the court flipped."""

    move = "move your racket on the court as drawn"
    key_hint = ("Arrow keys or W A S D swing your racket on the court as drawn (two at once: diagonally); let go "
                "to stop pushing.")


RULES = TennisRules
