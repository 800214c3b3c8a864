"""BlowBlow's platform as data over the 2D engine: its constants, the :class:`Field` every match is
built from, the world and its work vector, the observation and state layouts, the matrices over the
work vector that give the applied forces, the measures' linear parts, the observations and the
global state, the discrete actions' tables, the start spots and the marked opponents, the checks of
a placement, and the picture and replay scene of the platform. :class:`PlatformRules` lays the work
vector out for the game's rules (the package's ``__init__``), which play the match over it; its
manual says what each part means.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pymunk

from arena_league.envs import scene
from arena_league.envs.physics2d import (
    COMPASS_MOVE_NAMES,
    COMPASS_MOVES,
    ONE,
    Bodies,
    CellLayout,
    Field,
    Material,
    Physics2DRules,
    Run,
    World,
)
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

AGENT_RADIUS = 0.25
AGENT_MASS = 1.0
#: Physics step per env step (seconds), and the fraction of its velocity a body keeps after one
#: second (pymunk ``Space.damping``).
DT = 0.1
SPACE_DAMPING = 0.5
#: Full thrust of an agent, and the drag coefficient opposing its velocity.
THRUST = 5.0
AGENT_DRAG = 2.0
#: An agent's top speed, where full thrust meets drag and damping (about 1.86 units/s).
AGENT_TOP_SPEED = THRUST / (AGENT_DRAG - AGENT_MASS * np.log(SPACE_DAMPING))
#: A thrust shorter than this fraction of full strength leaves the heading as it was.
HEADING_MIN_THRUST = 0.1
#: Momentum of a blow's puff (the blower's recoil), the reach of its cone (between centres), the
#: cone's half-angle, and the steps from a blow until the seat may blow again.
BLOW_IMPULSE = 1.2
BLOW_RANGE = 2.5
BLOW_HALF_ANGLE = math.radians(30.0)
BLOW_COOLDOWN = 6
#: Overlap pymunk tolerates between touching bodies (its default, 0.1, is large at this scale).
COLLISION_SLOP = 0.01
#: Contact restitution and friction are the products of the two shapes' values: 0.25 and 0.09.
ELASTICITY = 0.5
FRICTION = 0.3
#: Observation scales: positions are divided by the platform's radius, velocities by VELOCITY_UNIT;
#: velocity cells are bounded by VELOCITY_BOUND (6 units/s, three times an agent's top speed).
VELOCITY_UNIT = 3.0
VELOCITY_BOUND = 2.0
#: Mean distances from the centre this close count as equal when a cut match is judged (mirrored
#: play stays mirrored up to the solver's rounding).
CENTRE_TIE = 1e-6
DEFAULT_PLATFORM_RADIUS = 3.0

#: Start spots of team 0 in units of the platform's radius (team 1's are turned), per players per team.
_FORMATIONS = {1: ((-0.45, 0.0),), 2: ((-0.45, 0.25), (-0.45, -0.25))}
#: The discrete blow action, after the compass moves; the observation's cells of the seat's own,
#: and per other seat.
BLOW_ACTION = len(COMPASS_MOVE_NAMES)
OWN_CELLS, OTHER_CELLS = 9, 8
COS_HALF_ANGLE = math.cos(BLOW_HALF_ANGLE)
#: A seat that fell collides with nothing.
GONE_FILTER = pymunk.ShapeFilter(categories=0, mask=0)


def blowblow_field(n_agents: int) -> Field:
    """The agents (discs that do not spin) and no walls: the platform's edge is judged, not built."""
    return Field(dt=DT, damping=SPACE_DAMPING, collision_slop=COLLISION_SLOP, parts=(
        Bodies("agent", n_agents, AGENT_RADIUS, AGENT_MASS, Material(ELASTICITY, FRICTION)),))


def blowblow_world(n_agents: int) -> World:
    """The platform's world; slots after the bodies' block, per seat (world frame): its heading, its
    velocity before the step, its thrust as a fraction of full strength and the impulse its blows
    and those it caught give it this step; then the step from which each seat may blow again, the
    step count and a constant 1."""
    n = n_agents
    return World(blowblow_field(n), slots=(
        ("heading", 2 * n), ("v_before", 2 * n), ("thrust", 2 * n), ("impulse", 2 * n), ("ready", n),
        ("step", 1), (ONE, 1)))


def _seat_runs(prefix: str, relative: bool) -> list[Run]:
    span = 2 if relative else 1
    return [Run(f"{prefix}on", 1, (0, 1), "on-platform flag: 1 while the seat is on the platform"),
            Run(f"{prefix}position", 2, (-span, span), "position relative to the seat" if relative else "position"),
            Run(f"{prefix}velocity", 2, (-VELOCITY_BOUND, VELOCITY_BOUND), "velocity"),
            Run(f"{prefix}heading", 2, (-1, 1), "heading (a unit vector)"),
            Run(f"{prefix}cooldown", 1, (0, 1), "steps left before the seat may blow again, over 6")]


def blowblow_observation(n_agents: int) -> CellLayout:
    """The observation's runs: the seat's own cells, then every other seat's, the teammate first,
    then the opponents in seat order."""
    own = _seat_runs("", False)
    return CellLayout([own[0], Run("size", 1, (0, 1), "R / 4 (the platform's size: positions are in units of R)"),
                       *own[1:], *[run for k in range(n_agents - 1) for run in _seat_runs(f"other_{k}_", True)]])


def blowblow_state(n_agents: int) -> CellLayout:
    """The global state's runs (world frame): every seat's own cells, in seat order."""
    return CellLayout([run for k in range(n_agents) for run in _seat_runs(f"seat_{k}_", False)])


def force_matrix(world: World, n_agents: int) -> np.ndarray:
    """Every agent's applied force: thrust against a linear drag, and this step's impulses spread
    over the step."""
    F = world.matrix(2 * n_agents)
    for k in range(2 * n_agents):
        F[k, world.vel(k // 2, k % 2)] = -AGENT_DRAG
        F[k, world.at("thrust", k)] = THRUST
        F[k, world.at("impulse", k)] = 1.0 / DT
    return F


def measure_matrix(world: World, n_agents: int, marked: list[int]) -> np.ndarray:
    """The linear parts of the measures over the work vector; rows, read as complex numbers:
    every seat's position; its way to its target (``marked[seat]`` - own; :func:`retarget`);
    its contact force, the impulse the solver added beyond damping, drag, thrust and blows
    (Chipmunk integrates ``v' = v * damping**dt + f / m * dt`` before it solves the contacts),
    over ``dt``; its velocity and its heading conjugated (their products with the way to the
    target give dot products)."""
    n = n_agents
    M = world.matrix(10 * n)
    keep = SPACE_DAMPING**DT - AGENT_DRAG * DT / AGENT_MASS
    force, velocity, heading = 4 * n, 6 * n, 8 * n
    for i in range(n):
        retarget(world, M, n, i, marked[i])
        for axis, conj in ((0, 1.0), (1, -1.0)):
            k = 2 * i + axis
            M[k, world.pos(i, axis)] = 1.0
            M[force + k, world.vel(i, axis)] = AGENT_MASS / DT
            M[force + k, world.at("v_before", k)] = -keep * AGENT_MASS / DT
            M[force + k, world.at("thrust", k)] = -THRUST
            M[force + k, world.at("impulse", k)] = -1.0 / DT
            M[velocity + k, world.vel(i, axis)] = conj
            M[heading + k, world.at("heading", k)] = conj
    return M


def retarget(world: World, matrix: np.ndarray, n_agents: int, seat: int, target: int) -> None:
    """Point the rows of ``seat``'s way to its target, in ``matrix``, at the seat ``target``."""
    first = 2 * (n_agents + seat)
    matrix[first: first + 2] = 0.0
    for axis in range(2):
        matrix[first + axis, world.pos(target, axis)] = 1.0
        matrix[first + axis, world.pos(seat, axis)] = -1.0


def other_seats(team_of: np.ndarray, seat: int) -> list[int]:
    """The other seats in observation order: teammates, then the opponents (seat order each)."""
    n, team = len(team_of), int(team_of[seat])
    return ([j for j in range(n) if j != seat and team_of[j] == team]
            + [j for j in range(n) if team_of[j] != team])


def _seat_cells(world: World, rows: np.ndarray, seat: int, frame: float, relative_to: int | None,
                platform_radius: float) -> None:
    """Eight cells about ``seat`` from the work vector: flag, position (relative to the seat
    ``relative_to``, if any), velocity, heading and cooldown, turned by ``frame`` (+1 or -1)."""
    ps, vs = frame / platform_radius, frame / VELOCITY_UNIT
    rows[0, world.at(ONE)] = 1.0
    for axis in range(2):
        rows[1 + axis, world.pos(seat, axis)] += ps
        if relative_to is not None:
            rows[1 + axis, world.pos(relative_to, axis)] -= ps
        rows[3 + axis, world.vel(seat, axis)] = vs
        rows[5 + axis, world.at("heading", 2 * seat + axis)] = frame
    rows[7, world.at("ready", seat)] = 1.0 / BLOW_COOLDOWN
    rows[7, world.at("step")] = -1.0 / BLOW_COOLDOWN


def observation_matrix(world: World, cells: CellLayout, team_of: np.ndarray, sign: np.ndarray,
                       platform_radius: float) -> np.ndarray:
    """The observations of every seat as one matrix over the work vector (``sign``: each seat's
    frame, +1 or -1)."""
    n, width, obs_dim = len(team_of), len(world.work), cells.size
    A = np.zeros((n, obs_dim, width))
    for i in range(n):
        own = np.zeros((OTHER_CELLS, width))
        _seat_cells(world, own, i, float(sign[i]), None, platform_radius)
        A[i, cells.at("on")], A[i, cells.at("position"): OWN_CELLS] = own[0], own[1:]
        A[i, cells.at("size"), world.at(ONE)] = platform_radius / 4.0
        for m, j in enumerate(other_seats(team_of, i)):
            first = cells.at(f"other_{m}_on")
            _seat_cells(world, A[i, first: first + OTHER_CELLS], j, float(sign[i]), i, platform_radius)
    return A.reshape(n * obs_dim, width)


def state_matrix(world: World, n_agents: int, platform_radius: float) -> np.ndarray:
    """The global state as one matrix over the work vector: every seat's cells, world frame."""
    S = world.matrix(OTHER_CELLS * n_agents)
    for i in range(n_agents):
        _seat_cells(world, S[OTHER_CELLS * i: OTHER_CELLS * (i + 1)], i, 1.0, None, platform_radius)
    return S


def seat_rows(cells: CellLayout, team_of: np.ndarray, measure_rows: int) -> list[np.ndarray]:
    """Per seat, the rows of the measures-then-observations matrix to zero once it fell: its
    position (its radius, by which falls are judged, reads 0 from then on), its own observation and
    its cells in the others'."""
    n, obs_dim = len(team_of), cells.size
    obs_row = [measure_rows + i * obs_dim for i in range(n)]
    return [np.array([2 * seat, 2 * seat + 1, *range(obs_row[seat], obs_row[seat] + obs_dim), *[
        obs_row[i] + cells.at(f"other_{other_seats(team_of, i).index(seat)}_on") + c
        for i in range(n) if i != seat for c in range(OTHER_CELLS)]], dtype=np.intp) for seat in range(n)]


def start_spots(rng: np.random.Generator, players: int, jitter: float, platform_radius: float) -> np.ndarray:
    """Every seat's start: team 0's spots, each jittered by up to ``jitter``, then team 1's, turned
    by half a turn."""
    spots = np.asarray(_FORMATIONS[players], dtype=np.float64) * platform_radius
    team0 = spots + rng.uniform(-jitter, jitter, spots.shape)
    return np.concatenate([team0, -team0])


def action_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per discrete action: its thrust in the seat frame (``x + iy``; the compass moves, then the
    blow: no thrust), its energy, and whether it sets the heading."""
    moves = np.ascontiguousarray(COMPASS_MOVES).view(np.complex128).reshape(-1)
    move_table = np.append(moves, 0j)
    energy_table = np.abs(move_table) ** 2
    return move_table, energy_table, energy_table > 0.0


def marked_at_start(team_of: np.ndarray, players: int) -> list[int]:
    """The opponent each seat marks at the start: the one straight ahead, across the platform
    (team 0's seat k stands opposite team 1's seat 1 - k)."""
    p = players
    return [int(1 - team_of[i]) * p + (p - 1 - i % p) for i in range(len(team_of))]


def check_placement(agent_xy: np.ndarray, on: np.ndarray, current_xy: np.ndarray, platform_radius: float) -> None:
    """Refuse a placement with a seat still on the platform off it, or two agents closer than an
    agent radius (the seats that fell counted where they lie, ``current_xy``)."""
    n = len(on)
    off = np.flatnonzero(on & (np.linalg.norm(agent_xy, axis=1) > platform_radius))
    if len(off):
        raise ValueError(f"agent {off[0]} at {agent_xy[off[0]].tolist()} is off the platform: its centre must "
                         f"lie within {platform_radius} of the platform's centre")
    xy = np.where(on[:, None], agent_xy, current_xy)
    if (np.linalg.norm(xy[:, None] - xy[None], axis=2) + np.eye(n) * 99).min() < AGENT_RADIUS:
        raise ValueError(f"agents must stand at least {AGENT_RADIUS} apart (centre to centre)")


class PlatformRules(Physics2DRules):
    """The platform's construction for the game's rules: the world and its work vector, the
    matrices over it and the preallocated arrays a step writes into. The rules set the layouts,
    ``_sign``, ``_marked_at_start`` and ``platform_radius`` before they call
    :meth:`_layout_work_vector`."""

    def _layout_work_vector(self) -> None:
        """The world's work vector (:func:`blowblow_world`) holds everything a step reads. One matrix
        product of it gives the measures' linear parts and every observation at once (few numpy
        calls: the hot path is Python-bound), the world's force matrix the forces; results land in
        preallocated arrays, seen through the views made here."""
        n = self.n_agents
        world = self.world = blowblow_world(n)
        self._work, self._step_at, self._ready_at = world.work, world.at("step"), world.at("ready")
        # complex views (x + iy) of the 2-vectors: fewer, cheaper numpy calls on the hot path
        self._agent_pos_c, self._agent_vel_c = world.table.view(np.complex128).T
        self._heading_c, self._v_before_c, self._thrust_c, self._impulse_c = (
            world.complex_view(slot) for slot in ("heading", "v_before", "thrust", "impulse"))
        world.force_matrix = force_matrix(world, n)
        # measures then observations (n * obs_dim rows), one product per step; the rows of what a
        # seat that fell shows, and of what it sees, are zeroed in the match's copy
        self._measure_rows = 10 * n
        self._full_matrix = np.concatenate([
            measure_matrix(world, n, self._marked_at_start),
            observation_matrix(world, self.layout, self.team_of, self._sign, self.platform_radius)])
        self._matrix = self._full_matrix.copy()
        self._linear = np.zeros(len(self._matrix))
        linear_c = self._linear[: self._measure_rows].view(np.complex128)
        # every seat's position (as of the last product), way to its target, contact force, velocity
        # and heading (conjugated); distance from the centre, to the target, contact force, speed
        self._position_c, self._to_target_c = linear_c[:n], linear_c[n: 2 * n]
        self._velocity_heading_conj, self._norm_source = linear_c[3 * n:].reshape(2, n), linear_c[: 4 * n]
        self._norms = np.zeros(4 * n)
        self._radius = self._norms[:n]
        self._obs_rows = self._linear[self._measure_rows:].reshape(n, self.obs_dim)
        self._obs_work = np.zeros((n, self.obs_dim))
        self._along_c = np.zeros((2, n), dtype=np.complex128)
        self._along_real = self._along_c.real
        self._along = np.zeros((2, n))  # velocity and heading along the way to the target
        m = self.measures
        m.velocity_to_target, m.facing_target = self._along
        m.target_distance, m.force, m.speed = self._norms[n:].reshape(3, n)
        self._kept_distance, self._kept_facing = np.zeros(n), np.zeros(n)
        self._move_xy = np.zeros((n, 2))  # step buffers
        self._move_c = self._move_xy.view(np.complex128).reshape(n)
        self._move_length, self._turns_heading = np.zeros(n), np.zeros(n, dtype=bool)
        self._seat_rows = seat_rows(self.layout, self.team_of, self._measure_rows)
        self._full_state_matrix = state_matrix(world, n, self.platform_radius)

    def _retarget(self, matrix: np.ndarray, seat: int, target: int) -> None:
        """Point the rows of ``seat``'s way to its target, in ``matrix``, at the seat ``target``."""
        retarget(self.world, matrix, self.n_agents, seat, target)


def platform_picture(platform_radius: float, xy: np.ndarray, heading: np.ndarray, on: np.ndarray,
                     team_of: np.ndarray, blowers: list[int]) -> np.ndarray:
    """The top-down picture: the void, the platform with its edge, the cones of the blows of the
    seats ``blowers``, the agents with a tick along their heading, those off the platform darkened."""
    R, dark = platform_radius, (20, 20, 20)
    canvas = Canvas(-R - 0.6, R + 0.6, -R - 0.6, R + 0.6, size=400, background=(30, 30, 40))
    canvas.circle(0.0, 0.0, R + 0.05, fill=(150, 150, 150))  # the edge
    canvas.circle(0.0, 0.0, R, fill=(205, 185, 140))
    for seat in blowers:  # the last step's blows' cones
        x, y = xy[seat]
        angle = math.atan2(heading[seat, 1], heading[seat, 0])
        arc = [canvas.px(x + BLOW_RANGE * math.cos(angle + a), y + BLOW_RANGE * math.sin(angle + a))
               for a in np.linspace(-BLOW_HALF_ANGLE, BLOW_HALF_ANGLE, 7)]
        canvas.draw.polygon([canvas.px(x, y), *arc], fill=(170, 205, 235))
    for seat, ((x, y), (hx, hy)) in enumerate(zip(xy, heading)):
        colour = TEAM_COLOURS[team_of[seat]]
        if not on[seat]:
            canvas.circle(x, y, AGENT_RADIUS, fill=tuple(c // 3 for c in colour), outline=dark)
            continue
        canvas.circle(x, y, AGENT_RADIUS, fill=colour, outline=dark)
        canvas.line(x, y, x + AGENT_RADIUS * hx, y + AGENT_RADIUS * hy, fill=dark, width_px=3)
    return canvas.array()


def platform_scene(ts: int, platform_radius: float, xy: np.ndarray, heading: np.ndarray, on: np.ndarray,
                   team_of: np.ndarray, blowers: list[int], team_on: np.ndarray) -> list[dict[str, Any]]:
    """The replay scene's entities: ``platform``, ``agent/<seat>``, ``blows`` (of the seats
    ``blowers``) and ``score`` (``team_on``: agents on the platform per team)."""
    R = platform_radius
    below = 2 * R + 1.2  # the void, far below the platform: dark ground
    out = [scene.entity("platform", ts,
                        cubes=[scene.cube(0.0, 0.0, -1.0, (below, below, 0.1), (0.12, 0.12, 0.16, 1.0))],
                        cylinders=[scene.disc(0.0, 0.0, 2 * R, (0.8, 0.73, 0.55, 1.0), height=0.1)])]
    yaw = np.arctan2(heading[:, 1], heading[:, 0])
    for seat in range(len(team_of)):
        x, y = (float(v) for v in xy[seat])
        team = int(team_of[seat])
        if on[seat]:
            out.append(scene.entity(f"agent/{seat}", ts, cylinders=[
                scene.disc(x, y, 2 * AGENT_RADIUS, scene.team_colour(team), height=0.3)], arrows=[
                scene.arrow(x, y, 0.35, float(yaw[seat]), 0.5, (0.1, 0.1, 0.1, 1.0))]))
        else:  # fallen: faded, below the platform's top
            out.append(scene.entity(f"agent/{seat}", ts, cylinders=[
                scene.disc(x, y, 2 * AGENT_RADIUS, scene.team_colour(team, 0.4), height=0.05)]))
    out.append(scene.entity("blows", ts, arrows=[
        scene.arrow(float(xy[s, 0]), float(xy[s, 1]), 0.2, float(yaw[s]), BLOW_RANGE, (0.67, 0.8, 0.92, 0.6))
        for s in blowers]))
    score = " : ".join(str(int(team)) for team in team_on)
    return [*out, scene.entity("score", ts, texts=[scene.text(0, R + 0.6, 0.2, score)])]
