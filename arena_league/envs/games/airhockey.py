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
    ``goal_width`` (float in [0.6, 2.8], default 1.2), ``kickoff_jitter`` (float in [0, 0.5],
    default 0.3).

Playing it (``arena-league play``)
    A coarse text view of the top-down picture (team digits, ``#`` rails, ``+`` markings, ``o``
    the puck). A move is an action's number or name, a compass direction *on the table as drawn*
    (``E`` = right, whichever side you play: team 1's moves are mirrored into its seat frame for
    you); Enter repeats the last move. In a browser, the arrow keys or W A S D (two at once:
    diagonally). Discrete actions only.

Rendering
    A top-down picture of the table (400 pixels wide): the rails, the playing surface with its
    centre line and face-off circle, each goal slot in the colour of the team defending it, the
    mallets in their teams' colours and the puck in white. ``render_mode="rgb_array"`` returns it;
    ``"human"`` shows it in a window.

Copies
    The rules pickle and copy (``pickle``, ``copy.deepcopy``) by playing the match again from its
    seed and the actions (and ``place`` calls) since, as pymunk's contact caches cannot be copied;
    a copy goes on bit for bit as the original does.

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
from arena_league.envs.core import GameRules, ReplayedMatch, cell_bounds
from arena_league.envs.games.soccer import (
    HALF_LENGTH,
    POSITION_SCALE,
    VELOCITY_UNIT,
    SoccerControls,
    SoccerRules,
)
from arena_league.envs.physics2d import (
    COMPASS_MOVE_NAMES,
    COMPASS_MOVES,
    BodyFields,
    add_discs,
    checked_kwargs,
    space_link,
)
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

#: Half width of the table (inner faces of the rails); its half length, the observation scales and
#: the mirrored moves are Soccer's (``HALF_LENGTH`` = 4, ``POSITION_SCALE``, ``VELOCITY_UNIT``,
#: ``_MIRRORED_MOVE``), as is the observation's layout, built by the same methods.
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
#: Bound of the velocity cells, in units of VELOCITY_UNIT (6 units/s; a strike sends the puck at
#: up to about 4, and only a pile-up pushes a body faster, which is clipped).
VELOCITY_BOUND = 2.0


DEFAULT_GOAL_WIDTH = 1.2
_GAME_KWARGS = {"goal_width": (0.6, 2.8, DEFAULT_GOAL_WIDTH), "kickoff_jitter": (0.0, 0.5, 0.3)}

#: Face-off spots of team 0 (team 1's are mirrored), per players per team: one mallet in front of
#: its goal; two as a forward and a back.
_FORMATIONS = {
    1: ((-2.0, 0.0),),
    2: ((-1.4, 0.8), (-2.9, -0.6)),
}


def _table_outline(goal_half_width: float) -> list[tuple[float, float]]:
    """Inner boundary of the rails (table plus both goal slots), counter-clockwise."""
    L, W, G, D, c = HALF_LENGTH, HALF_WIDTH, goal_half_width, GOAL_DEPTH, CORNER_CHAMFER
    return [(-L + c, -W), (L - c, -W), (L, -W + c), (L, -G), (L + D, -G), (L + D, G), (L, G),
            (L, W - c), (L - c, W), (-L + c, W), (-L, W - c), (-L, G), (-L - D, G), (-L - D, -G),
            (-L, -G), (-L, -W + c)]


def _pushed_outline(outline: list[tuple[float, float]], offset: float) -> list[tuple[float, float]]:
    """``outline`` (counter-clockwise) with every edge pushed outward by ``offset``: each corner
    is where its two neighbouring edges' pushed lines meet."""
    pts = np.asarray(outline, dtype=np.float64)
    edges = np.roll(pts, -1, axis=0) - pts
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / np.linalg.norm(edges, axis=1, keepdims=True)
    corners = []
    for k in range(len(pts)):
        before, after = edges[k - 1], edges[k]
        start = pts[k] + offset * normals[k - 1]
        gap = offset * (normals[k] - normals[k - 1])
        # start + t * before lies on the pushed line of the next edge
        t = (gap[0] * after[1] - gap[1] * after[0]) / (before[0] * after[1] - before[1] * after[0])
        corners.append((float(start[0] + t * before[0]), float(start[1] + t * before[1])))
    return corners


def _rail_segments(goal_half_width: float) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Centre lines of the rail segments (radius RAIL_RADIUS) whose inner faces follow the table's
    outline."""
    corners = _pushed_outline(_table_outline(goal_half_width), RAIL_RADIUS)
    return [(corners[k], corners[(k + 1) % len(corners)]) for k in range(len(corners))]


def _barrier_segments(goal_half_width: float) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The mallets-only segments: the centre line, and a bar across each goal mouth, each running
    into the rails at both ends so that no mallet slips round it."""
    L, W, G, R = HALF_LENGTH, HALF_WIDTH, goal_half_width, RAIL_RADIUS
    return [((0.0, -W - R), (0.0, W + R)), ((L, -G - R), (L, G + R)), ((-L, -G - R), (-L, G + R))]


def _rebound_y(y: np.ndarray) -> np.ndarray:
    """Where a puck's straight path, whose ``y`` would be ``y`` without the side rails, lies once
    it has rebounded from them (each rebound mirrors the path; the corners' chamfers ignored)."""
    half = HALF_WIDTH - PUCK_RADIUS
    folded = np.mod(y + half, 4 * half)
    return np.where(folded > 2 * half, 4 * half - folded, folded) - half


def _clearance(start: np.ndarray, end: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Per row, the least distance from the ``points`` (``[N, K, 2]``) to the segment from
    ``start`` to ``end`` (``[N, 2]`` each)."""
    way = (end - start)[:, None, :]
    offset = points - start[:, None, :]
    t = np.clip((offset * way).sum(axis=2) / np.maximum((way * way).sum(axis=2), 1e-9), 0.0, 1.0)
    return np.linalg.norm(offset - t[..., None] * way, axis=2).min(axis=1)


def _shot(puck: np.ndarray, mouth: np.ndarray, opponents: np.ndarray) -> np.ndarray:
    """Where to send the puck, per row: at the ``mouth`` straight, or at the point of a side rail
    from which it rebounds into the mouth, whichever way passes furthest from the ``opponents``
    (the straight shot preferred by 0.4). A rebound keeps only the rail's restitution (0.9) of the
    puck's speed across the rail, so the path after it is flatter: the mouth's mirror image, at
    which the puck is sent, lies 1 / 0.9 times as far beyond the rail as the mouth is inside it."""
    half = HALF_WIDTH - PUCK_RADIUS
    restitution = ELASTICITY["puck"] * ELASTICITY["rail"]
    straight = _clearance(puck, mouth, opponents) + 0.4
    aims, scores = [mouth], [straight]
    for side in (1.0, -1.0):
        mirrored_y = side * half + (side * half - mouth[:, 1]) / restitution
        share = (side * half - puck[:, 1]) / (mirrored_y - puck[:, 1])
        rail = np.stack([puck[:, 0] + share * (mouth[:, 0] - puck[:, 0]), np.full(len(puck), side * half)], axis=1)
        # a rebound from the corner's chamfer goes astray
        clear = rail[:, 0] < HALF_LENGTH - CORNER_CHAMFER - 0.3
        score = np.minimum(_clearance(puck, rail, opponents), _clearance(rail, mouth, opponents))
        aims.append(rail)
        scores.append(np.where(clear, score, -np.inf))
    best = np.argmax(np.stack(scores, axis=1), axis=1)
    return np.stack(aims, axis=1)[np.arange(len(puck)), best]


#: Body fields the physics link reads after every step and writes before it.
_STATE_FIELDS = BodyFields.POSITION | BodyFields.VELOCITY
_FORCE_FIELDS = BodyFields.FORCE


class AirHockeyRules(ReplayedMatch, GameRules):
    """AirHockey on a railed pymunk table; see the module docstring for the manual."""

    name: ClassVar[str] = "AirHockey"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "target_distance", "velocity_to_target", "energy", "force", "speed", "object_progress",
         "outcome"}
    )
    default_max_cycles: ClassVar[int] = 300
    # The same layout of the observation and the state, the same events and tree as Soccer's:
    def events(self) -> list[dict]:
        return list(self._events)

    def state(self) -> np.ndarray:
        n = self.n_agents
        table = self._work[: 4 * (n + 1)].reshape(n + 1, 4)
        scaled = table * np.array([POSITION_SCALE, POSITION_SCALE, 1 / VELOCITY_UNIT, 1 / VELOCITY_UNIT])
        state = np.concatenate([scaled.reshape(-1), self.score.astype(np.float64)])
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    default_tree = SoccerRules.__dict__["default_tree"]

    def _pos(self, body: int, axis: int) -> int:
        return 4 * body + axis

    def _vel(self, body: int, axis: int) -> int:
        return 4 * body + 2 + axis

    def _observation_map(self) -> np.ndarray:
        """The observations of every seat as one matrix over the work vector."""
        n = self.n_agents
        A = np.zeros((n, self.obs_dim, len(self._work)))
        ball, one = n, self._one_at
        ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
        pos, vel = self._pos, self._vel
        for i in range(n):
            sign = (self._team_sign[i], 1.0)
            team = self.team_of[i]
            others = [j for j in range(n) if j != i and self.team_of[j] == team]
            others += [j for j in range(n) if self.team_of[j] != team]
            A[i, 0, one] = 1.0
            for ax in range(2):
                s = sign[ax]
                A[i, 1 + ax, pos(i, ax)] = s * ps
                A[i, 3 + ax, vel(i, ax)] = s * vs
                A[i, 5 + ax, pos(ball, ax)] = s * ps
                A[i, 5 + ax, pos(i, ax)] -= s * ps
                A[i, 7 + ax, pos(ball, ax)] = s * ps
                A[i, 9 + ax, vel(ball, ax)] = s * vs
                # goals in the seat frame are at (+L, 0) (attacked) and (-L, 0) (defended)
                A[i, 11 + ax, pos(i, ax)] = -s * ps
                A[i, 13 + ax, pos(i, ax)] = -s * ps
                for k, j in enumerate(others):
                    c = 15 + 4 * k
                    A[i, c + ax, pos(j, ax)] = s * ps
                    A[i, c + ax, pos(i, ax)] -= s * ps
                    A[i, c + 2 + ax, vel(j, ax)] = s * vs
            A[i, 11, one] = HALF_LENGTH * ps
            A[i, 13, one] = -HALF_LENGTH * ps
        return A.reshape(n * self.obs_dim, len(self._work))

    summary: ClassVar[str] = "Mallets strike a sliding puck at the other goal, each in its own half (pymunk; first goal wins, else territory)"

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        self.check_layout(n_teams, players_per_team, action_type)
        settings = checked_kwargs("AirHockey", kwargs, _GAME_KWARGS)
        super().__init__(n_teams, players_per_team, action_type)
        self._arguments = ((n_teams, players_per_team, action_type), dict(kwargs))
        self._calls = []
        self.goal_half_width = settings["goal_width"] / 2
        self.kickoff_jitter = settings["kickoff_jitter"]
        n = self.n_agents
        self.n_actions = len(COMPASS_MOVE_NAMES)
        self.act_dim = 2
        self.action_meanings = COMPASS_MOVE_NAMES
        self.obs_dim = 15 + 4 * (n - 1)
        self.state_dim = 4 * n + 6
        self.score = np.zeros(2, dtype=np.int64)
        #: steps that ended with the puck in team 0's half (x < 0) and in team 1's (x > 0)
        self.puck_steps = np.zeros(2, dtype=np.int64)

        # +1 for team 0, -1 for team 1: the x sign of each seat's frame
        self._team_sign = np.where(self.team_of == 0, 1.0, -1.0)
        self._first_seats = np.array([int(np.flatnonzero(self.team_of == t)[0]) for t in range(2)])
        # unit thrust of every move in the seat frame (x + iy): the matrices turn it into the world
        self._moves = np.ascontiguousarray(COMPASS_MOVES).view(np.complex128).reshape(-1)
        self._move_energy = (COMPASS_MOVES**2).sum(axis=1)
        self._rails = _rail_segments(self.goal_half_width)
        self._barriers = _barrier_segments(self.goal_half_width)
        self._goal_line = HALF_LENGTH + PUCK_RADIUS
        self._obs_low, self._obs_high = (np.tile(bound.astype(np.float64), (n, 1)) for bound in self.observation_bounds())
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())
        self._layout_work_vector()
        self.space: pymunk.Space | None = None
        self._events: list[dict] = []

    # --- construction --------------------------------------------------------------------------
    def _layout_work_vector(self) -> None:
        """One float64 vector holds everything a step reads, and one matrix product of it gives
        every measure's linear part and every observation at once (few numpy calls: the hot path
        is Python-bound). Their results land in preallocated arrays, seen through views made here.

        Layout of the work vector: ``[x, y, vx, vy]`` of every seat, the puck and pymunk's static
        body (written in place by the physics link), spare room, the seats' velocities before the
        step, their unit thrust in their own frames (as the actions give it: the matrices mirror
        team 1's into the world), the puck's x before the step, and a constant 1.
        """
        n = self.n_agents
        self._n_bodies = n + 2  # the physics link also visits the space's static body
        body_floats = 4 * self._n_bodies
        # pymunk's batch array grows (reallocates) when fewer than 3 free slots are left: leave 8
        self._v_before_at = body_floats + 8
        self._thrust_at = self._v_before_at + 2 * n
        self._puck_x_before_at = self._thrust_at + 2 * n
        self._one_at = self._puck_x_before_at + 1
        work = np.zeros(self._one_at + 1)
        work[self._one_at] = 1.0
        self._work = work
        table = work[:body_floats].reshape(self._n_bodies, 4)
        self._mallet_pos = table[:n, 0:2]
        self._puck_state = table[n]
        self._puck_x_at, self._puck_y_at = 4 * n, 4 * n + 1
        # complex views (x + iy) of the 2-vectors: fewer, cheaper numpy calls on the hot path
        self._mallet_vel_c = table[:n].view(np.complex128)[:, 1]
        self._v_before_c = work[self._v_before_at: self._thrust_at].view(np.complex128)
        self._thrust = work[self._thrust_at: self._puck_x_before_at].reshape(n, 2)
        self._thrust_c = work[self._thrust_at: self._puck_x_before_at].view(np.complex128)
        self._thrust_length = np.zeros((n, 1))  # a thrust's length, at least 1: its scale-back
        self._force_array = np.zeros(2 * self._n_bodies)
        self._link = space_link(_STATE_FIELDS, work, _FORCE_FIELDS, self._force_array)
        # applied force of every body (zero for the puck and the static body), in the world frame
        self._force_matrix = np.zeros((2 * self._n_bodies, len(work)))
        for k in range(2 * n):
            self._force_matrix[k, self._thrust_at + k] = THRUST * self._axis_sign(k)
            self._force_matrix[k, self._v_before_at + k] = -MALLET_DRAG
        # measures (7 n rows) then observations (n * obs_dim rows), one product per step
        self._matrix = np.concatenate([self._measure_map(), self._observation_map()])
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

    def _axis_sign(self, cell: int) -> float:
        """The sign that takes cell ``cell`` of the seats' (x, y) pairs from the seat's frame
        to the world (or back): team 1 sees x mirrored."""
        return float(self._team_sign[cell // 2]) if cell % 2 == 0 else 1.0

    def _measure_map(self) -> np.ndarray:
        """The linear parts of the measures as one matrix over the work vector.

        Rows: ``[to_puck (x, -y), velocity (x, y), contact force (x, y)]`` of every seat, read as
        complex numbers (``to_puck`` conjugated), then every seat's ``object_progress``. The contact
        force is the impulse the solver added beyond damping and the applied force (Chipmunk
        integrates ``v' = v * damping**dt + f / m * dt`` before solving contacts), divided by ``dt``.
        """
        n = self.n_agents
        M = np.zeros((7 * n, len(self._work)))
        puck = n
        # velocity kept from before the step, drag included (force = THRUST * thrust - DRAG * v)
        keep = SPACE_DAMPING**DT - MALLET_DRAG * DT / MALLET_MASS
        for i in range(n):
            for ax in range(2):
                conj = 1.0 if ax == 0 else -1.0
                M[2 * i + ax, self._pos(puck, ax)] = conj
                M[2 * i + ax, self._pos(i, ax)] = -conj
                M[2 * n + 2 * i + ax, self._vel(i, ax)] = 1.0
                row = 4 * n + 2 * i + ax
                M[row, self._vel(i, ax)] = MALLET_MASS / DT
                M[row, self._v_before_at + 2 * i + ax] = -keep * MALLET_MASS / DT
                M[row, self._thrust_at + 2 * i + ax] = -THRUST * self._axis_sign(2 * i + ax)
            M[6 * n + i, self._puck_x_at] = self._team_sign[i]
            M[6 * n + i, self._puck_x_before_at] = -self._team_sign[i]
        return M

    def _build_space(self, mallet_xy: np.ndarray, puck_xy: np.ndarray, puck_velocity: tuple[float, float]) -> None:
        # A fresh space each match: no cached contacts survive from the previous one, so a seed
        # gives the same match whatever was played before.
        space = pymunk.Space()
        space.damping = SPACE_DAMPING
        space.collision_slop = COLLISION_SLOP
        # Only the barriers and the puck need a filter, and the barriers keep pymunk's restitution
        # and friction (0): every property set costs, and a space is built every match.
        statics = []
        for a, b in self._rails:
            seg = pymunk.Segment(space.static_body, a, b, RAIL_RADIUS)
            seg.elasticity = ELASTICITY["rail"]
            seg.friction = FRICTION["rail"]
            statics.append(seg)
        for a, b in self._barriers:
            seg = pymunk.Segment(space.static_body, a, b, BARRIER_RADIUS)
            seg.filter = _BARRIER_FILTER
            statics.append(seg)
        space.add(*statics)
        self._mallets = add_discs(space, mallet_xy, MALLET_MASS, MALLET_RADIUS, ELASTICITY["mallet"], FRICTION["mallet"])
        puck = pymunk.Body(PUCK_MASS, pymunk.moment_for_circle(PUCK_MASS, 0.0, PUCK_RADIUS))
        puck.position = float(puck_xy[0]), float(puck_xy[1])
        puck.velocity = puck_velocity
        shape = pymunk.Circle(puck, PUCK_RADIUS)
        shape.elasticity = ELASTICITY["puck"]
        shape.friction = FRICTION["puck"]
        shape.filter = _PUCK_FILTER
        space.add(puck, shape)
        self._puck = puck
        self.space = space
        self._link.bind(space)
        if self._link.body_ids != [body.id for body in self._mallets] + [puck.id, space.static_body.id]:
            raise RuntimeError("pymunk.batch visits the bodies in an unexpected order; AirHockey supports "
                               "pymunk 7 (pip install 'pymunk>=7,<8')")
        self._link.read_bodies()

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        jitter = self.kickoff_jitter
        slots = np.asarray(_FORMATIONS[self.players_per_team], dtype=np.float64)
        team0 = slots + self.rng.uniform(-jitter, jitter, slots.shape)
        team1 = slots + self.rng.uniform(-jitter, jitter, slots.shape)
        team1[:, 0] *= -1.0
        puck_xy = np.array([0.0, self.rng.uniform(-jitter, jitter)])
        serve = (SERVE_SPEED if self.rng.random() < 0.5 else -SERVE_SPEED, 0.0)
        self._build_space(np.concatenate([team0, team1]), puck_xy, serve)
        self._measure_still_state()
        self.measures.active[:] = True
        self.measures.outcome[:] = 0.0
        self.score[:] = 0
        self.puck_steps[:] = 0
        self.game_over = False
        self._events = []

    def _measure_still_state(self) -> None:
        """Measures of the bodies as they stand, with no step behind them (no force, no progress)."""
        work = self._work
        work[self._v_before_at: self._one_at] = 0.0
        work[self._puck_x_before_at] = work[self._puck_x_at]
        self._v_before_c[:] = self._mallet_vel_c
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

        # thrust against a linear drag; pymunk clears the forces after every step
        np.dot(self._force_matrix, work, out=self._force_array)
        link = self._link
        link.write_bodies()
        link.step(DT)
        link.read_bodies()
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

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, v = HALF_LENGTH * POSITION_SCALE, HALF_WIDTH * POSITION_SCALE, VELOCITY_BOUND
        puck_x = (HALF_LENGTH + GOAL_DEPTH) * POSITION_SCALE
        n_mates = self.players_per_team - 1
        own_y, wide_y, velocity = (-y, y, 1), (-2 * y, 2 * y, 1), (-v, v, 2)
        # in the seat frame a seat, and its teammates, lie in x in [-x, 0]; its opponents in [0, x]
        return cell_bounds((0, 1, 1), (-x, 0.0, 1), own_y, velocity,
                           (-puck_x, puck_x + x, 1), wide_y, (-puck_x, puck_x, 1), own_y, velocity,
                           (x, 2 * x, 1), own_y, (-x, 0.0, 1), own_y,
                           *[run for _ in range(n_mates) for run in ((-x, x, 1), wide_y, velocity)],
                           *[run for _ in range(self.players_per_team) for run in ((0.0, 2 * x, 1), wide_y, velocity)])

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, v = HALF_LENGTH * POSITION_SCALE, HALF_WIDTH * POSITION_SCALE, VELOCITY_BOUND
        puck_x = (HALF_LENGTH + GOAL_DEPTH) * POSITION_SCALE
        halves = [(-x, 0.0, 1) if team == 0 else (0.0, x, 1) for team in self.team_of]
        return cell_bounds(*[run for half in halves for run in (half, (-y, y, 1), (-v, v, 2))],
                           (-puck_x, puck_x, 1), (-y, y, 1), (-v, v, 2), (0, 1, 2))

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
        mallet_xy = np.asarray(mallet_xy, dtype=np.float64).reshape(self.n_agents, 2)
        mallet_velocity = (np.zeros((self.n_agents, 2)) if mallet_velocity is None
                           else np.asarray(mallet_velocity, dtype=np.float64).reshape(self.n_agents, 2))
        puck_xy = np.array(puck_xy, dtype=np.float64).reshape(2)
        if self.space is None:
            raise RuntimeError("call reset(seed) before place()")
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
        self._record("place", mallet_xy.copy(), puck_xy.copy(), mallet_velocity.copy(),
                     None if puck_velocity is None else np.array(puck_velocity, dtype=np.float64))
        for body, xy, v in zip(self._mallets, mallet_xy, mallet_velocity):
            body.position = float(xy[0]), float(xy[1])
            body.velocity = float(v[0]), float(v[1])
        self._puck.position = float(puck_xy[0]), float(puck_xy[1])
        pv = (0.0, 0.0) if puck_velocity is None else (float(puck_velocity[0]), float(puck_velocity[1]))
        self._puck.velocity = pv
        self._link.read_bodies()
        self._measure_still_state()

    def render_topdown(self) -> np.ndarray:
        L, W, D, R = HALF_LENGTH, HALF_WIDTH, GOAL_DEPTH, 0.25  # rails drawn 0.25 thick
        margin = D + 2 * R
        canvas = Canvas(-L - margin, L + margin, -W - 2 * R, W + 2 * R, size=400, background=(70, 70, 70))
        outline = _table_outline(self.goal_half_width)
        rails = _pushed_outline(outline, R)
        canvas.draw.polygon([canvas.px(x, y) for x, y in rails], fill=(40, 40, 40))
        canvas.draw.polygon([canvas.px(x, y) for x, y in outline], fill=(165, 195, 225))
        G = self.goal_half_width
        for side, team in ((1, 1), (-1, 0)):  # goal slot coloured by the team defending it
            colour = TEAM_COLOURS[team]
            canvas.rect(min(side * L, side * (L + D)), -G, max(side * L, side * (L + D)), G,
                        fill=tuple(int(0.5 * c + 0.5 * 240) for c in colour))
        canvas.line(0.0, -W, 0.0, W, fill=(200, 200, 200), width_px=3)
        canvas.circle(0.0, 0.0, 0.6, fill=None, outline=(200, 200, 200))
        for seat in range(self.n_agents):
            x, y = self._mallet_pos[seat]
            canvas.circle(x, y, MALLET_RADIUS, fill=TEAM_COLOURS[self.team_of[seat]], outline=(20, 20, 20))
        px, py = self._puck_state[0:2]
        # no dark rim: the text view sees a white block as the puck ("o"), a grey one as a marking
        canvas.circle(px, py, PUCK_RADIUS, fill=(250, 250, 250))
        return canvas.array()

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        length, width, depth, ts = HALF_LENGTH, HALF_WIDTH, GOAL_DEPTH, timestamp_ns
        state = self.state().astype(np.float64)
        goal_width = 2 * self.goal_half_width
        n = self.n_agents
        surface = (0.78, 0.88, 0.94, 1.0)
        out = [scene.entity("table", ts, cubes=[
            scene.cube(0, 0, -0.05, (2 * length, 2 * width, 0.1), surface),
            scene.cube(0, 0, 0.001, (0.06, 2 * width, 0.002), (0.8, 0.8, 0.8, 1.0)),  # the centre line
            # goal x = -L is defended by team 0, x = +L by team 1
            scene.cube(-length - depth / 2, 0, -0.05, (depth, goal_width, 0.1), scene.team_colour(0, 0.6)),
            scene.cube(length + depth / 2, 0, -0.05, (depth, goal_width, 0.1), scene.team_colour(1, 0.6))])]
        unit = length  # positions are stored divided by HALF_LENGTH
        for seat in range(n):
            x, y = state[4 * seat] * unit, state[4 * seat + 1] * unit
            out.append(scene.entity(f"agent/{seat}", ts, cylinders=[
                scene.disc(x, y, 2 * MALLET_RADIUS, scene.team_colour(int(self.team_of[seat])), height=0.15)]))
        px, py = state[4 * n] * unit, state[4 * n + 1] * unit
        out.append(scene.entity("puck", ts, cylinders=[
            scene.disc(px, py, 2 * PUCK_RADIUS, (0.97, 0.97, 0.97, 1.0), height=0.05)]))
        goals = state[4 * n + 4: 4 * n + 6]
        out.append(scene.entity("score", ts, texts=[scene.text(0, width + 0.6, 0.2,
                                                               f"{int(goals[0])} : {int(goals[1])}")]))
        return out

    def human_controls(self, seat: int) -> AirHockeyControls:
        return AirHockeyControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
        n_agents = (obs.shape[1] - 15) // 4 + 1
        n_mates = n_agents // 2 - 1  # AirHockey always has two teams
        me = obs[:, 1:3] * HALF_LENGTH
        velocity = obs[:, 3:5] * VELOCITY_UNIT
        puck_now = obs[:, 7:9] * HALF_LENGTH
        puck_velocity = obs[:, 9:11] * VELOCITY_UNIT
        goal = me + obs[:, 11:13] * HALF_LENGTH
        own_goal = me + obs[:, 13:15] * HALF_LENGTH
        # lead the sliding puck by about the time the mallet needs to get there (at most 0.6 s)
        eta = np.minimum(np.linalg.norm(puck_now - me, axis=1) / MALLET_TOP_SPEED, 0.6)
        puck_limit = np.array([HALF_LENGTH - PUCK_RADIUS, HALF_WIDTH - PUCK_RADIUS])
        puck = np.clip(puck_now + puck_velocity * eta[:, None], -puck_limit, puck_limit)
        contact = MALLET_RADIUS + PUCK_RADIUS
        rel = me - puck
        # the seat's half in its frame: clear of the rails, the goal-mouth bar and the centre line
        low = np.array([-HALF_LENGTH + MALLET_RADIUS + BARRIER_RADIUS, -HALF_WIDTH + MALLET_RADIUS])
        high = np.array([-(MALLET_RADIUS + BARRIER_RADIUS) - 0.02, HALF_WIDTH - MALLET_RADIUS])
        in_reach = puck[:, 0] < high[0] + contact - 0.05

        # roles: the teammate nearest the puck strikes; the others keep goal
        my_distance = np.linalg.norm(rel, axis=1)
        rank = np.zeros(len(obs), dtype=np.int64)
        for k in range(n_mates):
            mate = me + obs[:, 15 + 4 * k: 17 + 4 * k] * HALF_LENGTH
            rank += np.linalg.norm(mate - puck, axis=1) < my_distance
        striking = (rank == 0) & in_reach
        first = 15 + 4 * n_mates
        opponents = me[:, None, :] + np.stack(
            [obs[:, first + 4 * k: first + 4 * k + 2] for k in range(n_mates + 1)], axis=1) * HALF_LENGTH
        # a puck in the own half sliding at the own goal's mouth (off the side rails too), with the
        # striker not between it and the goal, is blocked on its path in front of the goal
        coming = puck_velocity[:, 0] < -0.3
        slope = puck_velocity[:, 1] / np.where(coming, puck_velocity[:, 0], -1.0)
        at_goal_line = _rebound_y(puck_now[:, 1] + slope * (own_goal[:, 0] - puck_now[:, 0]))
        dangerous = coming & (puck_now[:, 0] < 0.0) & (np.abs(at_goal_line) < DEFAULT_GOAL_WIDTH / 2 + 0.2)
        blocking = (rank == 0) & dangerous & (me[:, 0] > puck_now[:, 0] - contact)
        block_x = np.maximum(low[0], np.minimum(own_goal[:, 0] + 0.6, puck_now[:, 0] - contact - 0.2))
        block_spot = np.stack([block_x, _rebound_y(puck_now[:, 1] + slope * (block_x - puck_now[:, 0]))], axis=1)
        striking &= ~blocking
        # out of reach, wait on the line from the own goal to the puck: the striker well out, a
        # keeper close in
        guard = puck - own_goal
        guard /= np.maximum(np.linalg.norm(guard, axis=1, keepdims=True), 1e-9)
        guard_spot = own_goal + guard * np.where(rank == 0, 1.5, 0.9)[:, None]

        # the striker runs to a spot behind the puck on the line from the goal mouth through it,
        # then drives through; where that spot lies outside the half, the nearest spot inside
        # sets the shot's direction. A puck deep in the own end is first cleared away from the
        # own goal (the striker then stands between the two).
        aim = _shot(puck, goal + np.array([0.3, 0.0]), opponents) - puck
        aim /= np.maximum(np.linalg.norm(aim, axis=1, keepdims=True), 1e-9)
        deep = puck[:, 0] - own_goal[:, 0] < 1.2
        aim = np.where(deep[:, None], guard, aim)
        behind_spot = puck - aim * (contact + 0.5)  # a run-up, to strike hard
        target = np.where(blocking[:, None], block_spot, guard_spot)
        target = np.clip(np.where(striking[:, None], behind_spot, target), low, high)
        push = puck - target
        push /= np.maximum(np.linalg.norm(push, axis=1, keepdims=True), 1e-9)
        along = np.einsum("ij,ij->i", rel, push)  # < 0: the seat is behind the puck
        lateral = rel - along[:, None] * push
        lateral_len = np.linalg.norm(lateral, axis=1)
        side = np.where(lateral_len[:, None] > 1e-6, lateral / np.maximum(lateral_len, 1e-9)[:, None],
                        np.stack([-push[:, 1], push[:, 0]], axis=1))
        # when the straight way there runs into the puck, go round it on the seat's side
        path = target - me
        t = np.clip(np.einsum("ij,ij->i", -rel, path) / np.maximum(np.einsum("ij,ij->i", path, path), 1e-9), 0, 1)
        blocked = striking & (np.linalg.norm(puck - (me + t[:, None] * path), axis=1) < contact + 0.05)
        around = np.clip(puck + side * (contact + 0.3) - push * (contact + 0.3), low, high)
        waypoint = np.where(blocked[:, None], around, target)
        aligned = striking & (along < -0.5 * contact) & (lateral_len < 0.35 * contact)
        waypoint = np.where(aligned[:, None], puck + push * 0.6, waypoint)

        heading = waypoint - me
        distance = np.linalg.norm(heading, axis=1, keepdims=True)
        # steer the velocity, not just the position, so the seat does not overshoot; a strike
        # goes through at full thrust
        heading = heading / np.maximum(distance, 1e-9) * np.minimum(1.0, distance / 0.3)
        heading -= np.where(aligned, 0.0, 0.2)[:, None] * velocity
        length = np.linalg.norm(heading, axis=1)
        if action_type == "continuous":
            return np.clip(heading / np.maximum(length, 1.0)[:, None], -1.0, 1.0).astype(np.float32)
        angle = np.arctan2(heading[:, 1], heading[:, 0])
        move = 1 + np.round(angle / (np.pi / 4)).astype(np.int64) % 8
        return np.where(length < 0.3, 0, move).astype(np.int64)


class AirHockeyControls(SoccerControls):
    """Compass moves of one's mallet on the table as drawn (E = right), mirrored for the team that
    sees the table flipped (Soccer's moves)."""

    move = "move your mallet on the table as drawn"
    key_hint = ("Arrow keys or W A S D slide your mallet on the table as drawn (two at once: diagonally); let go "
                "to stop pushing.")


RULES = AirHockeyRules
