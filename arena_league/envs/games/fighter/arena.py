"""Fighter's arena as data over the 2D engine: its constants, the draw of mirrored bunkers from the
seed, the :class:`Field` and world every match is built from, the observation as a gather over the
world's work vector, the state, and the pictures. The game's rules (the package's ``__init__``)
play the match over them; its manual says what each part means.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from arena_league.envs import scene
from arena_league.envs.physics2d import Bodies, CellLayout, Field, Material, Run, Walls, World
from arena_league.envs.physics2d.gather import Gather
from arena_league.envs.physics2d.shots import EMPTY, TileMap
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

#: Tiles across and up; the arena spans [-COLS/2, COLS/2] x [-ROWS/2, ROWS/2] in tiles of side 1.
COLS, ROWS, TILE = 16, 10, 1.0
HALF_X, HALF_Y = COLS * TILE / 2, ROWS * TILE / 2
#: The one kind of solid tile: a bunker's, which stops fighters and shells and never breaks.
BUNKER = 1
#: Bunker footprints in tiles (columns, rows); each pair of bunkers is one of them, drawn uniformly.
FOOTPRINTS = ((1, 2), (2, 1), (2, 2), (1, 3), (3, 1))
#: The columns of team 0's half a bunker may cover (the two by each side wall and the two in the
#: middle stay open), and its rows (the outer two stay open).
BUNKER_COLUMNS, BUNKER_ROWS = (2, COLS // 2 - 2), (1, ROWS - 2)
#: Tries at placing one pair before the draw starts over (the arena has room for many more).
_PLACEMENT_TRIES = 200
WALL_RADIUS = 0.2
FIGHTER_RADIUS, FIGHTER_MASS = 0.35, 1.0
#: Seconds per env step (one pymunk step), fraction of velocity kept after a second of coasting.
DT, DAMPING = 0.1, 0.5
#: Full thrust and the drag opposing a fighter's velocity: top speed about 2.57 units/s.
THRUST, DRAG = 12.0, 4.0
TOP_SPEED = THRUST * DT / (1.0 - DAMPING**DT + DRAG * DT / FIGHTER_MASS)
#: Shell speed (units/s) and the env steps from one shot until the next may be fired.
SHELL_SPEED, RELOAD_STEPS = 12.0, 3
#: A continuous thrust shorter than this fraction of full strength leaves the heading as it was.
TURN_THRESHOLD = 0.3
#: Team 0's start spots per players per team (team 1's are their mirror images in x).
STARTS = {1: ((-7.0, 0.0),), 2: ((-7.0, 2.0), (-7.0, -2.0))}
#: Positions are divided by this in observations and state; velocities by VELOCITY_UNIT, clipped
#: to +-VELOCITY_BOUND of it.
POSITION_UNIT, VELOCITY_UNIT, VELOCITY_BOUND = HALF_X, 3.0, 2.0


def mirror_column(col: int) -> int:
    return COLS - 1 - col


def draw_bunkers(rng: np.random.Generator, pairs: int) -> np.ndarray:
    """``int8[ROWS, COLS]`` tiles (row 0 at the bottom), the same under the mirror in x: ``pairs``
    bunkers in team 0's half, each a footprint drawn from FOOTPRINTS placed at a uniform spot
    within BUNKER_COLUMNS x BUNKER_ROWS at least one open tile away from every other (redrawn
    until it is), and their mirror images."""
    while True:
        kinds = np.zeros((ROWS, COLS), dtype=np.int8)
        placed = 0
        for _ in range(_PLACEMENT_TRIES):
            width, height = FOOTPRINTS[int(rng.integers(len(FOOTPRINTS)))]
            col = int(rng.integers(BUNKER_COLUMNS[0], BUNKER_COLUMNS[1] - width + 2))
            row = int(rng.integers(BUNKER_ROWS[0], BUNKER_ROWS[1] - height + 2))
            if kinds[max(row - 1, 0): row + height + 1, max(col - 1, 0): col + width + 1].any():
                continue  # touching another bunker
            kinds[row: row + height, col: col + width] = BUNKER
            placed += 1
            if placed == pairs:
                kinds[:, COLS // 2:] = kinds[:, : COLS // 2][:, ::-1]
                return kinds


def arena_field(n_agents: int) -> Field:
    """The outer wall, then the fighters (discs that do not spin); the bunkers follow (:func:`arena_tiles`)."""
    x, y = HALF_X + WALL_RADIUS, HALF_Y + WALL_RADIUS
    corners = ((-x, -y), (x, -y), (x, y), (-x, y))
    return Field(dt=DT, damping=DAMPING, collision_slop=0.01, parts=(
        Walls(tuple(zip(corners, corners[1:] + corners[:1])), WALL_RADIUS),
        Bodies("fighter", n_agents, FIGHTER_RADIUS, FIGHTER_MASS, Material(elasticity=0.2))))


def arena_tiles() -> TileMap:
    return TileMap(ROWS, COLS, TILE, (-HALF_X, -HALF_Y), breakable=())


def arena_world(n_agents: int) -> World:
    """Slots after the bodies' block, per seat: its thrust in its own frame, heading (world), hit
    points share, reload share, in-play flag, its shell's position and direction (world, 0 when
    none flies) and flying flag; then a constant 0."""
    n = n_agents
    return World(arena_field(n), slots=(("thrust", 2 * n), ("heading", 2 * n), ("hit_points", n), ("reload", n),
                                         ("active", n), ("shell", 2 * n), ("shell_direction", 2 * n), ("flying", n),
                                         ("zero", 1)))


def thrust_matrix(world: World, x_sign: np.ndarray) -> np.ndarray:
    """Each fighter's force: its thrust (seat frame, x mirrored for team 1) at full strength, less drag."""
    forces = world.matrix(2 * world.n_bodies)
    for seat, sign in enumerate(x_sign):
        rows = (2 * seat, 2 * seat + 1)
        forces[rows, (world.at("thrust", 2 * seat), world.at("thrust", 2 * seat + 1))] = THRUST * sign, THRUST
        forces[rows, (world.vel(seat, 0), world.vel(seat, 1))] = -DRAG
    return forces


def arena_observation(n_agents: int) -> CellLayout:
    """The observation's runs (seat frame; positions over POSITION_UNIT, velocities over VELOCITY_UNIT)."""
    wide, high = 1.0, HALF_Y / POSITION_UNIT
    spot, gap, v = ((-wide, wide), (-high, high)), ((-2 * wide, 2 * wide), (-2 * high, 2 * high)), (-VELOCITY_BOUND,
                                                                                                   VELOCITY_BOUND)
    runs = [Run("active", 1, (0, 1), "own in-play flag"), Run("position", 2, spot, "own position"),
            Run("velocity", 2, v, "own velocity"), Run("heading", 2, (-1, 1), "own heading (a unit vector)"),
            Run("hit_points", 1, (0, 1), "own hit points left, a share of hit_points"),
            Run("reload", 1, (0, 1), "steps until the gun is loaded, a share of 3 (0: loaded)")]
    for k in range(n_agents - 1):
        runs += [Run(f"other_{k}", 2, gap, "another fighter relative to the seat"),
                 Run(f"other_{k}_velocity", 2, v, "its velocity"), Run(f"other_{k}_heading", 2, (-1, 1), "its heading"),
                 Run(f"other_{k}_hit_points", 1, (0, 1), "its hit points share"),
                 Run(f"other_{k}_active", 1, (0, 1), "its in-play flag")]
    for k in range(n_agents):
        runs += [Run(f"shell_{k}_flying", 1, (0, 1), "1 while that seat's shell flies (own first)"),
                 Run(f"shell_{k}", 2, spot, "the shell's position (0 when none flies)"),
                 Run(f"shell_{k}_direction", 2, (-1, 1), "its direction (0 when none flies)")]
    return CellLayout([*runs, Run("bunkers", ROWS * COLS, (0, 1),
                                  "1 on every bunker tile, row by row from the bottom, each from the seat's own side")])


def observation_gather(world: World, layout: CellLayout, x_sign: np.ndarray, order: list[list[int]]) -> Gather:
    """Every seat's observation up to its bunker plane as one gather over the work vector (the
    mirror keeps one nonzero entry in each row of a seat's frame); ``order[seat]``: the other seats
    as it observes them."""
    n = len(x_sign)
    size = layout.at("bunkers")
    gather = Gather(world.work, n * size, world.at("zero"))
    p, vs = 1.0 / POSITION_UNIT, 1.0 / VELOCITY_UNIT

    def pair(slot: str, seat: int) -> int:
        return world.at(slot, 2 * seat)

    for seat in range(n):
        frame = np.diag([x_sign[seat], 1.0])
        first = seat * size

        def cell(name: str, first: int = first) -> int:
            return first + layout.at(name)

        gather.put(cell("active"), world.at("active", seat))
        gather.put_vector(cell("position"), frame, world.pos(seat, 0), None, p)
        gather.put_vector(cell("velocity"), frame, world.vel(seat, 0), None, vs)
        gather.put_vector(cell("heading"), frame, pair("heading", seat))
        gather.put(cell("hit_points"), world.at("hit_points", seat))
        gather.put(cell("reload"), world.at("reload", seat))
        for k, other in enumerate(order[seat]):
            gather.put_vector(cell(f"other_{k}"), frame, world.pos(other, 0), world.pos(seat, 0), p)
            gather.put_vector(cell(f"other_{k}_velocity"), frame, world.vel(other, 0), None, vs)
            gather.put_vector(cell(f"other_{k}_heading"), frame, pair("heading", other))
            gather.put(cell(f"other_{k}_hit_points"), world.at("hit_points", other))
            gather.put(cell(f"other_{k}_active"), world.at("active", other))
        for k, shooter in enumerate([seat, *order[seat]]):
            gather.put(cell(f"shell_{k}_flying"), world.at("flying", shooter))
            gather.put_vector(cell(f"shell_{k}"), frame, pair("shell", shooter), None, p)
            gather.put_vector(cell(f"shell_{k}_direction"), frame, pair("shell_direction", shooter))
    return gather


def bunker_order(x_sign: np.ndarray) -> np.ndarray:
    """``intp[n, ROWS * COLS]``: each seat's bunker cells as indices into the row-major world tiles
    (the mirror in x reverses every row)."""
    grid = np.arange(ROWS * COLS).reshape(ROWS, COLS)
    return np.stack([(grid if sign > 0 else grid[:, ::-1]).reshape(-1) for sign in x_sign]).astype(np.intp)


def arena_state(n_agents: int) -> CellLayout:
    """The global state's runs (world frame, same scales as the observation)."""
    high, v = HALF_Y / POSITION_UNIT, (-VELOCITY_BOUND, VELOCITY_BOUND)
    seat = ((-1, 1), (-high, high), v, v, (-1, 1), (-1, 1), (0, 1), (0, 1), (0, 1), (0, 1), (-1, 1), (-high, high),
            (-1, 1), (-1, 1))
    return CellLayout([*[Run(f"seat_{k}", 14, seat) for k in range(n_agents)],
                       Run("bunkers", ROWS * COLS, (0, 1))])


def state_index(world: World, n_agents: int) -> tuple[np.ndarray, np.ndarray]:
    """Columns of the work vector and their scales: per seat ``x, y, vx, vy``, heading, hit
    points, reload, in-play flag, shell flying flag, shell position and direction."""
    columns, scales = [], []
    p, vs = 1.0 / POSITION_UNIT, 1.0 / VELOCITY_UNIT
    for seat in range(n_agents):
        columns += [world.pos(seat, 0), world.pos(seat, 1), world.vel(seat, 0), world.vel(seat, 1),
                    world.at("heading", 2 * seat), world.at("heading", 2 * seat + 1), world.at("hit_points", seat),
                    world.at("reload", seat), world.at("active", seat), world.at("flying", seat),
                    world.at("shell", 2 * seat), world.at("shell", 2 * seat + 1),
                    world.at("shell_direction", 2 * seat), world.at("shell_direction", 2 * seat + 1)]
        scales += [p, p, vs, vs, 1, 1, 1, 1, 1, 1, p, p, 1, 1]
    return np.array(columns, dtype=np.intp), np.array(scales, dtype=np.float64)


def tile_box(row: int, col: int) -> tuple[float, float, float, float]:
    x0, y0 = -HALF_X + col * TILE, -HALF_Y + row * TILE
    return x0, y0, x0 + TILE, y0 + TILE


def arena_picture(kinds: np.ndarray, xy: np.ndarray, heading: np.ndarray, active: np.ndarray, team_of: np.ndarray,
                  shells: np.ndarray, flying: np.ndarray, fighter: Bodies) -> np.ndarray:
    """The top-down picture: the sand floor, the bunkers (dark olive), the fighters with a tick
    along their heading (pale once out of play), the shells in flight (white)."""
    from arena_league.envs.physics2d.picture import draw_body

    pad = WALL_RADIUS
    canvas = Canvas(-HALF_X - pad, HALF_X + pad, -HALF_Y - pad, HALF_Y + pad, size=480, background=(70, 70, 70))
    canvas.rect(-HALF_X, -HALF_Y, HALF_X, HALF_Y, fill=(196, 178, 128))
    for row, col in zip(*np.nonzero(kinds)):
        canvas.rect(*tile_box(int(row), int(col)), fill=(85, 95, 55), outline=(60, 68, 40))
    for seat, team in enumerate(team_of):
        fill = TEAM_COLOURS[team] if active[seat] else tuple(int(c * 0.4 + 150) for c in TEAM_COLOURS[team])
        draw_body(canvas, fighter, *xy[seat], tuple(heading[seat]), fill, tick_px=3)
    for (x, y), up in zip(shells, flying):
        if up:
            canvas.circle(x, y, 0.1, fill=(250, 250, 250))
    return canvas.array()


def arena_scene(ts: int, kinds: np.ndarray, xy: np.ndarray, heading: np.ndarray, active: np.ndarray,
                team_of: np.ndarray, shells: np.ndarray, flying: np.ndarray) -> list[dict[str, Any]]:
    """The replay scene's entities: ``arena`` (floor and walls), ``bunkers``, ``agent/<seat>``, ``shells``."""
    t, wall = 2 * WALL_RADIUS, (0.3, 0.3, 0.3, 1.0)
    out = [scene.entity("arena", ts, cubes=[
        scene.cube(0, 0, -0.05, (2 * HALF_X, 2 * HALF_Y, 0.1), (0.77, 0.7, 0.5, 1.0)),
        scene.cube(0, HALF_Y + t / 2, 0.2, (2 * HALF_X + 2 * t, t, 0.4), wall),
        scene.cube(0, -HALF_Y - t / 2, 0.2, (2 * HALF_X + 2 * t, t, 0.4), wall),
        scene.cube(HALF_X + t / 2, 0, 0.2, (t, 2 * HALF_Y, 0.4), wall),
        scene.cube(-HALF_X - t / 2, 0, 0.2, (t, 2 * HALF_Y, 0.4), wall)])]
    bunkers = []
    for row, col in zip(*np.nonzero(kinds != EMPTY)):
        x0, y0, x1, y1 = tile_box(int(row), int(col))
        bunkers.append(scene.cube((x0 + x1) / 2, (y0 + y1) / 2, 0.4, (TILE, TILE, 0.8), (0.33, 0.37, 0.22, 1.0)))
    out.append(scene.entity("bunkers", ts, cubes=bunkers))
    for seat, team in enumerate(team_of):
        x, y = float(xy[seat, 0]), float(xy[seat, 1])
        yaw = math.atan2(float(heading[seat, 1]), float(heading[seat, 0]))
        colour = scene.team_colour(int(team), 1.0 if active[seat] else 0.3)
        out.append(scene.entity(f"agent/{seat}", ts, cylinders=[scene.disc(x, y, 2 * FIGHTER_RADIUS, colour, height=0.3)],
                                arrows=[scene.arrow(x, y, 0.3, yaw, 0.6, colour)]))
    out.append(scene.entity("shells", ts, spheres=[
        scene.sphere(float(x), float(y), 0.2, (0.16, 0.16, 0.16), (1.0, 1.0, 1.0, 1.0))
        for (x, y), up in zip(shells, flying) if up]))
    return out
