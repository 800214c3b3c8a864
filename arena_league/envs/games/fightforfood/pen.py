"""FightForFood's pen as data over the 2D engine: its constants, the :class:`Field` every match is
built from, the observation and state layouts, the matrices over the world's work vector that give
the applied forces, the measures' linear parts, the observations and the global state, the start
spots and the draw of the food, and the pictures of the pen. The game's rules (the package's
``__init__``) play the match over them; its manual says what each part means.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from arena_league.envs import scene
from arena_league.envs.physics2d import ONE, Bodies, CellLayout, Field, Material, Run, Walls, World
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

#: Half side of the pen (inner faces of the walls).
HALF_SIZE = 3.0
#: Walls are pymunk segments this thick on each side of their centre line.
WALL_RADIUS = 0.3
AGENT_RADIUS = 0.25
AGENT_MASS = 1.0
PELLET_RADIUS = 0.1
#: An agent eats a pellet whose centre lies this near its own: the two touch.
EAT_DISTANCE = AGENT_RADIUS + PELLET_RADIUS
#: Pellets lie within this of the centre in both coordinates, this far apart at least, and this far
#: from every start spot at least.
FOOD_LIMIT = 2.6
#: The least and the most food pellets a match may have.
FOOD_RANGE = (4, 24)
FOOD_GAP = 0.6
START_CLEARANCE = 0.8
#: Physics step per env step (seconds).
DT = 0.1
#: Fraction of its velocity a body keeps after one second (pymunk ``Space.damping``).
SPACE_DAMPING = 0.4
#: Full thrust of an agent, and the drag coefficient opposing its velocity.
THRUST = 6.0
AGENT_DRAG = 3.1
#: An agent's top speed, where full thrust meets drag and damping (about 1.5 units/s).
AGENT_TOP_SPEED = THRUST / (AGENT_DRAG - AGENT_MASS * np.log(SPACE_DAMPING))
#: Overlap pymunk tolerates between touching bodies (its default, 0.1, is large at this scale).
COLLISION_SLOP = 0.01
#: Contact restitution is the product of the two shapes' values: 0.25 agent-agent, 0.4 agent-wall.
ELASTICITY = {"agent": 0.5, "wall": 0.8}
FRICTION = 0.3
#: Observation scales: positions are divided by HALF_SIZE, velocities by VELOCITY_UNIT.
POSITION_SCALE = 1.0 / HALF_SIZE
VELOCITY_UNIT = 3.0
#: Bound of the velocity cells, in units of VELOCITY_UNIT (6 units/s, four times an agent's top
#: speed; only a pile-up can push a body faster, and that is clipped).
VELOCITY_BOUND = 2.0
#: Draws of one pellet group before the placement gives up (it never needs nearly so many).
_PLACEMENT_TRIES = 10_000
#: Start spots of team 0 (the other teams' are turned), per players per team.
_FORMATIONS = {
    1: ((-2.2, 0.0),),
    2: ((-2.2, 0.8), (-2.2, -0.8)),
}


def pen_field(n_agents: int) -> Field:
    """The walled square pen, then the agents (discs that do not spin), added in that order."""
    edge = HALF_SIZE + WALL_RADIUS
    corners = [(-edge, -edge), (edge, -edge), (edge, edge), (-edge, edge)]
    return Field(dt=DT, damping=SPACE_DAMPING, collision_slop=COLLISION_SLOP, parts=(
        Walls(tuple((corners[k], corners[(k + 1) % 4]) for k in range(4)), WALL_RADIUS,
              Material(ELASTICITY["wall"], FRICTION)),
        Bodies("agent", n_agents, AGENT_RADIUS, AGENT_MASS, Material(ELASTICITY["agent"], FRICTION))))


def pen_world(n_agents: int, n_teams: int, food: int) -> World:
    """The pen's world; slots after the bodies' block: the seats' velocities before the step, their
    unit thrust in their own frames (as the actions give it: the matrices turn it into the world),
    every pellet's ``x, y``, every pellet's still-there flag, the food eaten by each team, the food
    left, and a constant 1."""
    return World(pen_field(n_agents), slots=(("v_before", 2 * n_agents), ("thrust", 2 * n_agents), ("pellet", 2 * food),
                                              ("present", food), ("eaten", n_teams), ("left", 1), (ONE, 1)))


def pen_observation(n_teams: int, food: int, n_agents: int) -> CellLayout:
    """The observation's runs (seat frame; positions divided by 3, velocities by 3)."""
    v = (-VELOCITY_BOUND, VELOCITY_BOUND)
    runs = [Run("active", 1, (0, 1), "own active flag (always 1)"), Run("position", 2, (-1, 1), "own position"),
            Run("velocity", 2, v, "own velocity"),
            Run("eaten", n_teams, (0, 1), "food eaten by each team, own first, as a share of food"),
            Run("left", 1, (0, 1), "food left, as a share of food")]
    for k in range(food):
        runs += [Run(f"pellet_{k}", 2, (-2, 2), "a pellet relative to the seat (0 once eaten)"),
                 Run(f"pellet_{k}_there", 1, (0, 1), "1 while that pellet is there")]
    for k in range(n_agents - 1):
        runs += [Run(f"other_{k}", 2, (-2, 2), "another seat's position relative to the seat"),
                 Run(f"other_{k}_velocity", 2, v, "that seat's velocity")]
    return CellLayout(runs)


def pen_state(n_agents: int, food: int, n_teams: int) -> CellLayout:
    """The global state's runs (world frame, same scales)."""
    v = (-VELOCITY_BOUND, VELOCITY_BOUND)
    return CellLayout([*[Run(f"seat_{k}", 4, ((-1, 1), (-1, 1), v, v)) for k in range(n_agents)],
                       *[Run(f"pellet_{k}", 3, ((-1, 1), (-1, 1), (0, 1))) for k in range(food)],
                       Run("food", n_teams + 1, (0, 1))])


def force_matrix(world: World, team_of: np.ndarray, turns: np.ndarray) -> np.ndarray:
    """Every body's applied force (zero for the static body), in the world frame: full thrust
    turned from the seat's frame, against a linear drag."""
    F = world.matrix(2 * world.n_bodies)
    for i, team in enumerate(team_of):
        turn = turns[team]
        for ax in range(2):
            F[2 * i + ax, world.at("thrust", 2 * i): world.at("thrust", 2 * i + 2)] = THRUST * turn[ax]
            F[2 * i + ax, world.at("v_before", 2 * i + ax)] = -AGENT_DRAG
    return F


def measure_matrix(world: World, team_of: np.ndarray, turns: np.ndarray) -> np.ndarray:
    """The linear parts of the measures as one matrix over the work vector.

    Rows: ``[velocity (x, -y), contact force (x, y)]`` of every seat, read as complex numbers
    (the velocity conjugated: its product with the way to the target gives their dot product). The
    contact force is the impulse the solver added beyond damping and the applied force (Chipmunk
    integrates ``v' = v * damping**dt + f / m * dt`` before solving contacts), divided by ``dt``.
    """
    n = len(team_of)
    M = world.matrix(4 * n)
    # velocity kept from before the step, drag included (force = THRUST * thrust - DRAG * v)
    keep = SPACE_DAMPING**DT - AGENT_DRAG * DT / AGENT_MASS
    for i in range(n):
        turn = turns[team_of[i]]
        for ax in range(2):
            M[2 * i + ax, world.vel(i, ax)] = 1.0 if ax == 0 else -1.0
            row = 2 * n + 2 * i + ax
            M[row, world.vel(i, ax)] = AGENT_MASS / DT
            M[row, world.at("v_before", 2 * i + ax)] = -keep * AGENT_MASS / DT
            M[row, world.at("thrust", 2 * i): world.at("thrust", 2 * i + 2)] = -THRUST * turn[ax]
    return M


def other_seats(team_of: np.ndarray, n_teams: int, seat: int) -> list[int]:
    """The other seats in observation order: teammates, then the other teams in turn order."""
    team = int(team_of[seat])
    order = [(team + k) % n_teams for k in range(n_teams)]
    return [j for t in order for j in np.flatnonzero(team_of == t).tolist() if j != seat]


def _add_turned(rows: np.ndarray, cell: int, columns: list[int], matrix: np.ndarray) -> None:
    """Add ``matrix @ work[columns]`` to observation cells ``cell, cell + 1`` of one seat's rows."""
    rows[cell: cell + 2, columns] += matrix


def observation_matrix(world: World, cells: CellLayout, team_of: np.ndarray, turns: np.ndarray,
                       slot_pellet: np.ndarray) -> np.ndarray:
    """The observations of every seat as one matrix over the work vector (``slot_pellet[t]``: the
    pellet each slot shows team ``t``)."""
    n, teams, food = len(team_of), len(turns), slot_pellet.shape[1]
    A = np.zeros((n, cells.size, len(world.work)))
    ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
    pos = [[world.pos(i, 0), world.pos(i, 1)] for i in range(n)]
    vel = [[world.vel(i, 0), world.vel(i, 1)] for i in range(n)]
    for i in range(n):
        rows = A[i]
        rotation = turns[team_of[i]].T  # world -> the seat's frame
        team = int(team_of[i])
        rows[cells.at("active"), world.at(ONE)] = 1.0
        _add_turned(rows, cells.at("position"), pos[i], ps * rotation)
        _add_turned(rows, cells.at("velocity"), vel[i], vs * rotation)
        for k in range(teams):
            rows[cells.at("eaten", k), world.at("eaten", (team + k) % teams)] = 1.0 / food
        rows[cells.at("left"), world.at("left")] = 1.0 / food
        for slot, pellet in enumerate(slot_pellet[team]):
            cell = cells.at(f"pellet_{slot}")
            _add_turned(rows, cell, [world.at("pellet", 2 * pellet), world.at("pellet", 2 * pellet + 1)], ps * rotation)
            _add_turned(rows, cell, pos[i], -ps * rotation)
            rows[cells.at(f"pellet_{slot}_there"), world.at("present", pellet)] = 1.0
        for k, j in enumerate(other_seats(team_of, teams, i)):
            _add_turned(rows, cells.at(f"other_{k}"), pos[j], ps * rotation)
            _add_turned(rows, cells.at(f"other_{k}"), pos[i], -ps * rotation)
            _add_turned(rows, cells.at(f"other_{k}_velocity"), vel[j], vs * rotation)
    return A.reshape(n * cells.size, len(world.work))


def state_matrix(world: World, n_agents: int, food: int, n_teams: int) -> np.ndarray:
    """The global state as one matrix over the work vector."""
    S = world.matrix(4 * n_agents + 3 * food + n_teams + 1)
    for i in range(n_agents):
        for ax in range(2):
            S[4 * i + ax, world.pos(i, ax)] = POSITION_SCALE
            S[4 * i + 2 + ax, world.vel(i, ax)] = 1.0 / VELOCITY_UNIT
    for k in range(food):
        row = 4 * n_agents + 3 * k
        S[row, world.at("pellet", 2 * k)] = S[row + 1, world.at("pellet", 2 * k + 1)] = POSITION_SCALE
        S[row + 2, world.at("present", k)] = 1.0
    row = 4 * n_agents + 3 * food
    for t in range(n_teams):
        S[row + t, world.at("eaten", t)] = 1.0 / food
    S[row + n_teams, world.at("left")] = 1.0 / food
    return S


def start_spots(rng: np.random.Generator, players: int, jitter: float, turns: np.ndarray) -> np.ndarray:
    """Every seat's start: team 0's spots, each jittered by up to ``jitter``, turned for each team."""
    slots = np.asarray(_FORMATIONS[players], dtype=np.float64)
    team0 = slots + rng.uniform(-jitter, jitter, slots.shape)
    return np.concatenate([team0 @ turn.T for turn in turns])


def check_placement(agent_xy: np.ndarray, pellet_xy: np.ndarray, present: np.ndarray) -> None:
    """Refuse a placement with an agent or a pellet outside the pen, or no pellet left."""
    inside = HALF_SIZE - AGENT_RADIUS
    outside = np.flatnonzero((np.abs(agent_xy) > inside).any(axis=1))
    if len(outside):
        seat = int(outside[0])
        raise ValueError(f"agent {seat} at {agent_xy[seat].tolist()} is outside the pen: its centre must lie "
                         f"within [-{inside}, {inside}] in both coordinates")
    if (np.abs(pellet_xy) > FOOD_LIMIT).any():
        raise ValueError(f"every pellet must lie within [-{FOOD_LIMIT}, {FOOD_LIMIT}] in both coordinates")
    if not present.any():
        raise ValueError("at least one pellet must be left: the match ends when the food is exhausted")


def draw_food(rng: np.random.Generator, turns: np.ndarray, starts: np.ndarray, food: int) -> np.ndarray:
    """``food`` pellet positions: groups of a uniform point and its images under the teams'
    turns, each at least FOOD_GAP from the others and START_CLEARANCE from every start."""
    teams = len(turns)
    pellets = np.zeros((food, 2))
    for group in range(food // teams):
        placed = pellets[: group * teams]
        for _ in range(_PLACEMENT_TRIES):
            images = turns @ rng.uniform(-FOOD_LIMIT, FOOD_LIMIT, 2)
            apart = np.linalg.norm(images[:, None] - images[None], axis=2)[np.triu_indices(teams, 1)]
            if (apart.min() >= FOOD_GAP
                    and np.linalg.norm(images[:, None] - placed[None], axis=2).min(initial=np.inf) >= FOOD_GAP
                    and np.linalg.norm(images[:, None] - starts[None], axis=2).min() >= START_CLEARANCE):
                pellets[group * teams: (group + 1) * teams] = images
                break
        else:  # pragma: no cover - the pen has room for far more pellets than the option allows
            raise RuntimeError(f"FightForFood could not place {food} pellets")
    return pellets


def pen_picture(agent_xy: np.ndarray, team_of: np.ndarray, food_xy: np.ndarray) -> np.ndarray:
    """The top-down picture: the walls, the floor, the pellets ``food_xy`` in white, the agents."""
    H, R = HALF_SIZE, 0.25  # walls drawn 0.25 thick
    canvas = Canvas(-H - R, H + R, -H - R, H + R, size=400, background=(40, 40, 40))
    canvas.rect(-H, -H, H, H, fill=(205, 185, 140))
    for x, y in food_xy:
        canvas.circle(x, y, 1.5 * PELLET_RADIUS, fill=(250, 250, 250))  # drawn larger, to be seen
    for (x, y), team in zip(agent_xy, team_of):
        canvas.circle(x, y, AGENT_RADIUS, fill=TEAM_COLOURS[team], outline=(20, 20, 20))
    return canvas.array()


def pen_scene(ts: int, agent_xy: np.ndarray, team_of: np.ndarray, food_xy: np.ndarray,
              eaten: np.ndarray) -> list[dict[str, Any]]:
    """The replay scene's entities: ``pen``, ``agent/<seat>``, ``food`` (``food_xy``), ``score``."""
    H, thick = HALF_SIZE, 0.2
    wall = (0.3, 0.3, 0.3, 1.0)
    out = [scene.entity("pen", ts, cubes=[
        scene.cube(0, 0, -0.05, (2 * H, 2 * H, 0.1), (0.8, 0.73, 0.55, 1.0)),
        scene.cube(0, H + thick / 2, 0.1, (2 * H + 2 * thick, thick, 0.2), wall),
        scene.cube(0, -H - thick / 2, 0.1, (2 * H + 2 * thick, thick, 0.2), wall),
        scene.cube(H + thick / 2, 0, 0.1, (thick, 2 * H, 0.2), wall),
        scene.cube(-H - thick / 2, 0, 0.1, (thick, 2 * H, 0.2), wall)])]
    for seat, ((x, y), team) in enumerate(zip(agent_xy, team_of)):
        out.append(scene.entity(f"agent/{seat}", ts, cylinders=[
            scene.disc(float(x), float(y), 2 * AGENT_RADIUS, scene.team_colour(int(team)), height=0.2)]))
    d = 2 * PELLET_RADIUS
    out.append(scene.entity("food", ts, spheres=[
        scene.sphere(float(x), float(y), PELLET_RADIUS, (d, d, d), (0.97, 0.97, 0.97, 1.0)) for x, y in food_xy]))
    score = " : ".join(f"{food:g}" for food in eaten)
    out.append(scene.entity("score", ts, texts=[scene.text(0, H + 0.6, 0.2, score)]))
    return out
