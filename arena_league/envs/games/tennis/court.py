"""Tennis's court as data over the 2D engine: its constants, the :class:`Field` every match is
built from (the hall, the net, the rackets' barriers, the rackets and the ball), the observation
layout, the matrices over the world's work vector that give the applied forces, the measures'
linear parts, the observations and the global state, the serve spots and their draw, the check of a
placement, and the pictures of the court; and :class:`TennisCourt`, the base of the rules that
builds the world and its views and takes the measures from one product of its work vector. The
game's rules (the package's ``__init__``) play the match over them; its manual says what each part
means.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pymunk

from arena_league.envs import scene
from arena_league.envs.core import cell_bounds
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




def tennis_world(team_of: np.ndarray) -> World:
    """The hall's world; its work vector holds everything a step reads, and one matrix product of it
    gives the measures' linear parts and every observation at once.

    After the bodies' ``[x, y, vx, vy]`` (the rackets, the ball and pymunk's static body), the
    slots: the seats' unit thrust in their own frames (as the actions give it: the matrices
    mirror team 1's into the world), a constant 1, the applied force ``[fx, fy]`` of every body
    (which the link writes to pymunk), which team played the ball last (two cells), the
    bounced-in and toss flags, the side clock (a share of HOLD_LIMIT) and the points of each team.
    """
    n = len(team_of)
    return World(tennis_hall(team_of), applied="force", slots=(
        ("thrust", 2 * n), (ONE, 1), ("force", 2 * (n + 2)), ("played", 2), ("bounced", 1), ("toss", 1),
        ("clock", 1), ("score", 2)))


def axis_sign(team_sign: np.ndarray, cell: int) -> float:
    """The sign that takes cell ``cell`` of the seats' (x, y) pairs from the seat's frame
    to the world (or back): team 1 sees x mirrored."""
    return float(team_sign[cell // 2]) if cell % 2 == 0 else 1.0


def force_matrix(world: World, team_sign: np.ndarray) -> np.ndarray:
    """Applied force of every body in the world frame: thrust against drag for the rackets,
    gravity for the ball, none for the static body; a product of the cells before the forces."""
    ball, thrust_at = world.index("ball"), world.at("thrust")
    F = np.zeros((2 * world.n_bodies, len(world.force_source)))
    for k in range(2 * len(team_sign)):
        F[k, thrust_at + k] = THRUST * axis_sign(team_sign, k)
        F[k, world.vel(k // 2, k % 2)] = -RACKET_DRAG
    F[2 * ball + 1, world.at(ONE)] = -BALL_MASS * GRAVITY
    return F


def measure_matrix(world: World, team_sign: np.ndarray) -> np.ndarray:
    """The linear parts of the measures as one matrix over the work vector.

    Rows: ``[to_ball (x, -y), velocity (x, y), contact force (x, y)]`` of every seat, read as
    complex numbers (``to_ball`` conjugated). The contact force is the impulse the solver added
    beyond damping and the applied force ``f`` over the two physics steps, divided by ``dt``:
    Chipmunk integrates ``v' = v * k + f / m * h`` (``k = damping**h``) before solving contacts,
    and the same ``f = THRUST * u - DRAG * v0`` acts in both, so the velocity before the step is
    ``v0 = (THRUST * u - f) / DRAG`` and the impulse ``m v2 - m k^2 v0 - (1 + k) h f``.
    """
    n = len(team_sign)
    M = world.matrix(6 * n)
    ball, thrust_at, force_at = world.index("ball"), world.at("thrust"), world.at("force")
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
            M[row, thrust_at + 2 * i + ax] = -before * THRUST * axis_sign(team_sign, 2 * i + ax) / DT
            M[row, force_at + 2 * i + ax] = (before - (1.0 + keep) * SUBSTEP) / DT
    return M


def observation_matrix(world: World, cells: CellLayout, team_of: np.ndarray, team_sign: np.ndarray,
                       points: int) -> np.ndarray:
    """The observations of every seat as one matrix over the work vector (``points``: to win)."""
    n, obs_dim = len(team_of), cells.size
    A = np.zeros((n, obs_dim, len(world.work)))
    ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
    ball, pos, vel = world.index("ball"), world.pos, world.vel
    one_at, played_at, score_at = world.at(ONE), world.at("played"), world.at("score")
    for i in range(n):
        rows = A[i]
        sign = team_sign[i]
        team = int(team_of[i])
        # the other seats in observation order: teammates, then opponents, each in seat order
        others = [j for j in range(n) if j != i and team_of[j] == team]
        others += [j for j in range(n) if team_of[j] != team]
        rows[cells.at("active"), one_at] = 1.0
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
        rows[cells.at("played"), played_at + team] = 1.0
        rows[cells.at("bounced"), world.at("bounced")] = 1.0
        rows[cells.at("toss"), world.at("toss")] = 1.0
        rows[cells.at("clock"), world.at("clock")] = 1.0
        rows[cells.at("points", 0), score_at + team] = 1.0 / points
        rows[cells.at("points", 1), score_at + 1 - team] = 1.0 / points
    return A.reshape(n * obs_dim, len(world.work))


def state_matrix(world: World, n_agents: int, points: int) -> np.ndarray:
    """The global state as one matrix over the work vector: ``4 * n_agents + 11`` rows."""
    S = world.matrix(4 * n_agents + 11)
    for body in range(n_agents + 1):
        for ax in range(2):
            S[4 * body + ax, world.pos(body, ax)] = POSITION_SCALE
            S[4 * body + 2 + ax, world.vel(body, ax)] = 1.0 / VELOCITY_UNIT
    row = 4 * (n_agents + 1)
    score_at, played_at = world.at("score"), world.at("played")
    S[row, score_at] = S[row + 1, score_at + 1] = 1.0 / points
    for k, cell in enumerate((played_at, played_at + 1, world.at("bounced"), world.at("toss"), world.at("clock"))):
        S[row + 2 + k, cell] = 1.0
    return S


def tennis_state_bounds(team_of: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The global state's bounds: each seat's ``x`` on its team's side, the rest as observed."""
    x, y, v = FENCE_X * POSITION_SCALE, REACH_HEIGHT * POSITION_SCALE, VELOCITY_BOUND
    top = HALL_HEIGHT * POSITION_SCALE
    sides = [(-x, 0.0, 1) if team == 0 else (0.0, x, 1) for team in team_of]
    return cell_bounds(*[run for side in sides for run in (side, (0.0, y, 1), (-v, v, 2))],
                       (-x, x, 1), (0.0, top, 1), (-v, v, 2), (0, 1, 7))


def serve_spots(players_per_team: int, n_teams: int, team_sign: np.ndarray) -> np.ndarray:
    """Every seat's serve spot, team 1's mirrored."""
    spots = np.tile(np.asarray(_FORMATIONS[players_per_team], dtype=np.float64), (n_teams, 1))
    spots[:, 0] *= team_sign
    return spots


def draw_serve(rng: np.random.Generator, jitter: float, spots: np.ndarray,
               server: int) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """The rackets' spots, the toss's start and its velocity for a serve of ``server``: the spots
    and the toss's ``x`` jittered by up to ``jitter`` (one draw of ``rng``)."""
    draw = rng.uniform(-jitter, jitter, 2 * len(spots) + 1)
    racket_xy = spots + draw[:-1].reshape(-1, 2)
    sign = 1.0 if server == 0 else -1.0
    return racket_xy, np.array([sign * (TOSS_XY[0] + draw[-1]), TOSS_XY[1]]), (0.0, TOSS_SPEED)


def check_placement(racket_xy: np.ndarray, ball_xy: np.ndarray, played: int, score: Any, team_of: np.ndarray,
                    team_sign: np.ndarray, points: int) -> tuple[int, ...] | None:
    """Refuse a placement with a racket outside its side or reach, the ball outside the hall, a
    ``played`` that is no team or a ``score`` that is not two counts short of ``points``; returns
    the score as a tuple of ints (None stays None)."""
    clear = RACKET_RADIUS + BARRIER_RADIUS
    seat_x = racket_xy[:, 0] * team_sign  # in the seat frame: the own side is x < 0
    outside = ((seat_x > -clear) | (seat_x < -FENCE_X + RACKET_RADIUS) | (racket_xy[:, 1] < RACKET_RADIUS)
               | (racket_xy[:, 1] > REACH_HEIGHT - RACKET_RADIUS))
    if outside.any():
        seat = int(np.flatnonzero(outside)[0])
        raise ValueError(f"racket {seat} at {racket_xy[seat].tolist()} is outside its side or reach: team "
                         f"{int(team_of[seat])} plays on {'x < 0' if team_of[seat] == 0 else 'x > 0'}, "
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
        if len(score) != 2 or min(score) < 0 or max(score) >= points:
            raise ValueError(f"score must be two points counts in [0, {points - 1}] (a team with "
                             f"{points} has won), not {score!r}")
    return score


def court_picture(racket_xy: np.ndarray, ball_xy: np.ndarray, team_of: np.ndarray) -> np.ndarray:
    """The side picture of the hall: its air, the baselines, the net, the reach, the rackets, the ball."""
    F, H, L = FENCE_X, HALL_HEIGHT, HALF_LENGTH
    margin = 0.25
    canvas = Canvas(-F - margin, F + margin, -margin, H + margin, size=400, background=(40, 40, 40))
    canvas.rect(-F, 0.0, F, H, fill=(205, 215, 225))  # the hall's air, framed by floor, fences, ceiling
    for x in (-L, L):  # the baselines
        canvas.line(x, 0.0, x, -margin, fill=(235, 235, 235), width_px=3)
    canvas.rect(-NET_RADIUS, 0.0, NET_RADIUS, NET_HEIGHT, fill=(235, 235, 235))
    canvas.line(-F, REACH_HEIGHT, F, REACH_HEIGHT, fill=(175, 185, 195))  # how high rackets reach
    for seat in range(len(team_of)):
        x, y = racket_xy[seat]
        canvas.circle(x, y, RACKET_RADIUS, fill=TEAM_COLOURS[team_of[seat]], outline=(20, 20, 20))
    bx, by = ball_xy[0:2]
    # no dark rim: the text view sees a white block as the ball ("o"), a grey one as a marking
    canvas.circle(bx, by, BALL_RADIUS, fill=(250, 250, 250))
    return canvas.array()


def court_scene(ts: int, racket_xy: np.ndarray, ball_xy: np.ndarray, team_of: np.ndarray, players_per_team: int,
                score: np.ndarray) -> list[dict[str, Any]]:
    """The replay scene's entities: ``court``, ``agent/<seat>``, ``ball``, ``score``."""
    F, L = FENCE_X, HALF_LENGTH
    lane = 0.4 if players_per_team > 1 else 0.0
    line = (0.95, 0.95, 0.95, 1.0)
    out = [scene.entity("court", ts, cubes=[
        scene.cube(0, 0, -0.05, (2 * F, 2.0, 0.1), (0.35, 0.55, 0.31, 1.0)),
        scene.cube(-L, 0, 0.001, (0.05, 2.0, 0.002), line),  # the baselines
        scene.cube(L, 0, 0.001, (0.05, 2.0, 0.002), line),
        scene.cube(0, 0, NET_HEIGHT / 2, (2 * NET_RADIUS, 2.0, NET_HEIGHT), (0.9, 0.9, 0.9, 0.8))])]
    for seat in range(len(team_of)):
        x, z = racket_xy[seat]
        y = lane * (1 if seat % players_per_team == 0 else -1)
        d = 2 * RACKET_RADIUS
        out.append(scene.entity(f"agent/{seat}", ts, spheres=[
            scene.sphere(float(x), y, float(z), (d, 0.1, d), scene.team_colour(int(team_of[seat])))]))
    bx, bz = ball_xy[0:2]
    d = 2 * BALL_RADIUS
    out.append(scene.entity("ball", ts, spheres=[
        scene.sphere(float(bx), 0.0, float(bz), (d, d, d), (0.85, 0.95, 0.3, 1.0))]))
    out.append(scene.entity("score", ts, texts=[scene.text(0, 0, HALL_HEIGHT / 2, f"{int(score[0])} : {int(score[1])}")]))
    return out


class TennisCourt(Physics2DRules):
    """The court under the rules: the settings, the world and the views of its work vector that a
    step reads, the measures from one product of it, and the bounds; :class:`TennisRules` (the
    package's) plays the match over it."""

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
        self._spots = serve_spots(players_per_team, n_teams, self._team_sign)
        # unit thrust of every move in the seat frame (x + iy): the matrices turn it into the world
        self._obs_low, self._obs_high = (bound.reshape(n, self.obs_dim) for bound in self.clip_bounds(self.layout))
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())
        self._layout_work_vector()

    def _layout_work_vector(self) -> None:
        """The world's work vector holds everything a step reads, and one matrix product of it gives
        the measures' linear parts and every observation at once (few numpy calls: the hot path is
        Python-bound). Their results land in preallocated arrays, seen through views made here
        (:func:`tennis_world` says what the vector holds)."""
        n = self.n_agents
        world = self.world = tennis_world(self.team_of)
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
        # applied force of every body: thrust against drag, gravity; a product of the cells before the forces
        self._force_matrix = force_matrix(world, self._team_sign)
        self._force_source = world.force_source
        # measures (6 n rows) then observations (n * obs_dim rows), one product per step
        self._matrix = np.concatenate([measure_matrix(world, self._team_sign),
                                       observation_matrix(world, self.layout, self.team_of, self._team_sign,
                                                          self.points)])
        self._linear = np.zeros(len(self._matrix))
        self._measure_vectors_c = self._linear[: 6 * n].view(np.complex128)  # conj(to_ball), velocity, force
        self._to_target_conj_c = self._measure_vectors_c[:n]
        self._velocity_c = self._measure_vectors_c[n: 2 * n]
        self._obs_rows = self._linear[6 * n:].reshape(n, self.obs_dim)
        self._obs_work = np.zeros((n, self.obs_dim))
        self._state_matrix = state_matrix(world, n, self.points)
        # The measures are arrays updated in place every step (the Measures contract allows it),
        # most of them views of these buffers, so that a step allocates almost nothing.
        self._norms = np.zeros(3 * n)  # distance to the ball, speed, contact force
        self._along_c = np.zeros(n, dtype=np.complex128)  # v * conj(d): its real part is v . d
        self._along = self._along_c.real
        self._gained = False  # whether resource_gain holds a non-zero value to clear
        m = self.measures
        m.target_distance, m.speed, m.force = self._norms[:n], self._norms[n: 2 * n], self._norms[2 * n:]

    def _move_bodies(self, racket_xy: np.ndarray, racket_velocity: Any, ball_xy: np.ndarray,
                     ball_velocity: Any) -> None:
        """Set every body's position and velocity (world frame) in one batch write."""
        self.world.place_all({"racket": racket_xy, "ball": ball_xy}, {"racket": racket_velocity, "ball": ball_velocity})


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

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return tennis_state_bounds(self.team_of)
