"""BattleCity's maze as data over the 2D engine: its constants, the draw of a symmetric maze from
the seed, the :class:`Field` and world every match is built from, the observation and state
layouts with the matrices over the world's work vector that fill them, and the pictures. The
game's rules (the package's ``__init__``) play the match over them; its manual says what each part
means.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from arena_league.envs import scene
from arena_league.envs.physics2d import ONE, Bodies, CellLayout, Field, Material, Run, Walls, World
from arena_league.envs.physics2d.shots import EMPTY, TileMap
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

#: Tiles a side, side of a tile; the maze spans [-HALF, HALF] in both coordinates.
GRID, TILE = 13, 1.0
HALF = GRID * TILE / 2
#: Tile kinds: shells break bricks and bases and stop at steel.
BRICK, STEEL, BASE = 1, 2, 3
KIND_NAMES = {EMPTY: "empty", BRICK: "brick", STEEL: "steel", BASE: "base"}
#: The outer wall: pymunk segments this thick on each side of their centre line.
WALL_RADIUS = 0.2
TANK_RADIUS, TANK_MASS = 0.4, 1.0
#: Seconds per env step (one pymunk step), fraction of velocity kept after a second of coasting.
DT, DAMPING = 0.1, 0.5
#: Full thrust and the drag opposing a tank's velocity: top speed about 2.45 units/s.
THRUST, DRAG = 9.0, 3.0
TOP_SPEED = THRUST * DT / (1.0 - DAMPING**DT + DRAG * DT / TANK_MASS)
#: A shell's speed (units/s) and the env steps from one shot until the next may be fired.
SHELL_SPEED, RELOAD_STEPS = 8.0, 5
#: A thrust (continuous) shorter than this fraction of full strength leaves the heading as it was.
TURN_THRESHOLD = 0.3
COLLISION_SLOP = 0.01
#: A tank's elasticity; walls and tiles keep pymunk's 0 (restitution is the product of the two),
#: and nothing has friction, so a tank slides along a wall.
ELASTICITY = 0.1
#: Velocities in observations are divided by this, and clipped to +-VELOCITY_BOUND of it.
VELOCITY_UNIT, VELOCITY_BOUND = 3.0, 2.0
#: Team 0's base tile (row, col) and its ring of bricks; team 1's are their half-turned images.
BASE_TILE = (0, GRID // 2)
BASE_RING = ((0, GRID // 2 - 1), (1, GRID // 2 - 1), (1, GRID // 2), (1, GRID // 2 + 1), (0, GRID // 2 + 1))
#: Team 0's start tiles per players per team (team 1's are their half-turned images).
START_TILES = {1: ((0, 3),), 2: ((0, 3), (0, GRID - 4))}
#: Draws of a maze before its steel is dropped (a closed-off maze is redrawn; rarely needs two).
_MAZE_TRIES = 50
#: A tile and its four neighbours: what joins passable tiles into one region.
_RING = tuple(np.array(BASE_RING).T)  # (rows, cols): the ring's tiles as one index
_ROW_BITS = GRID + 1  # a maze row's bits in _open, and a zero bit that keeps rows apart


def turned(row: int, col: int) -> tuple[int, int]:
    """The tile the half turn about the maze's centre takes ``(row, col)`` to."""
    return GRID - 1 - row, GRID - 1 - col


def tile_centre(row: int, col: int) -> tuple[float, float]:
    return -HALF + (col + 0.5) * TILE, -HALF + (row + 0.5) * TILE


def base_tiles() -> tuple[tuple[int, int], tuple[int, int]]:
    """Each team's base tile."""
    return BASE_TILE, turned(*BASE_TILE)


def start_tiles(players: int) -> list[tuple[int, int]]:
    """Every seat's start tile, team 0's seats first."""
    own = list(START_TILES[players])
    return own + [turned(*tile) for tile in own]


def draw_maze(rng: np.random.Generator, players: int, brick: float, steel: float) -> np.ndarray:
    """``int8[GRID, GRID]`` tile kinds (row 0 at the bottom), the same under the half turn: the
    bottom half (and the left half of the middle row) drawn tile by tile, steel with probability
    ``steel`` and brick with ``brick``, the starts and the tiles beside them cleared, each base in
    its ring of bricks; redrawn until every open or brick tile can be reached from every start
    without crossing steel (steel dropped after ``_MAZE_TRIES`` draws)."""
    cleared, start = _cleared(players), start_tiles(players)[0]
    for attempt in range(_MAZE_TRIES + 1):
        draw = rng.random((GRID // 2 + 1, GRID))
        steel_now = steel if attempt < _MAZE_TRIES else 0.0
        kinds = np.zeros((GRID, GRID), dtype=np.int8)
        # STEEL (2) below steel_now, BRICK (1) below steel_now + brick, else EMPTY (0)
        half = kinds[: GRID // 2 + 1]
        np.less(draw, steel_now + brick, out=half, casting="unsafe")
        half += draw < steel_now
        kinds[GRID // 2, GRID // 2:] = EMPTY  # the middle row's right half is the image of its left half
        kinds[_RING] = BRICK
        kinds[BASE_TILE] = BASE
        kinds[cleared] = EMPTY
        kinds[GRID // 2 + 1:] = kinds[: GRID // 2][::-1, ::-1]
        kinds[GRID // 2, GRID // 2 + 1:] = kinds[GRID // 2, : GRID // 2][::-1]
        if _open(kinds, start):
            return kinds
    raise AssertionError("unreachable: a maze without steel is always open")  # pragma: no cover


@functools.cache
def _cleared(players: int) -> np.ndarray:
    """The tiles of the bottom half a maze keeps open: every start tile and the tiles beside it."""
    mask = np.zeros((GRID, GRID), dtype=bool)
    for row, col in start_tiles(players):
        for dr, dc in ((0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)):
            if 0 <= row + dr < GRID // 2 and 0 <= col + dc < GRID:
                mask[row + dr, col + dc] = True
    mask.flags.writeable = False
    return mask


def _open(kinds: np.ndarray, start: tuple[int, int]) -> bool:
    """Whether every tile but steel and the bases is reachable from ``start`` through such tiles
    (one component of the four-neighbour grid): the tiles as the bits of one Python integer, a row
    of ``GRID`` bits and a zero bit after it (so that a step sideways never wraps to the next row),
    grown from ``start`` one step in the four directions at a time until nothing is added."""
    passable = np.zeros((GRID, _ROW_BITS), dtype=bool)
    np.equal(kinds, EMPTY, out=passable[:, :GRID])
    passable[:, :GRID] |= kinds == BRICK
    tiles = int.from_bytes(np.packbits(passable.reshape(-1), bitorder="little").tobytes(), "little")
    reached = 1 << (start[0] * _ROW_BITS + start[1])
    if not tiles & reached:
        return tiles == 0
    while True:
        grown = (reached | reached << 1 | reached >> 1 | reached << _ROW_BITS | reached >> _ROW_BITS) & tiles
        if grown == reached:
            return reached == tiles
        reached = grown


def maze_field(n_agents: int) -> Field:
    """The outer wall (its inner faces on the maze's edge), then the tanks (discs that do not
    spin), added in that order; the tiles follow (:func:`maze_tiles`)."""
    edge = HALF + WALL_RADIUS
    corners = [(-edge, -edge), (edge, -edge), (edge, edge), (-edge, edge)]
    return Field(dt=DT, damping=DAMPING, collision_slop=COLLISION_SLOP, parts=(
        Walls(tuple((corners[k], corners[(k + 1) % 4]) for k in range(4)), WALL_RADIUS),
        Bodies("tank", n_agents, TANK_RADIUS, TANK_MASS, Material(ELASTICITY))))


def maze_tiles() -> TileMap:
    return TileMap(GRID, GRID, TILE, (-HALF, -HALF), breakable=(BRICK, BASE))


def maze_world(n_agents: int) -> World:
    """The maze's world; slots after the bodies' block, per seat: its thrust in its own frame, its
    heading (world), hit points left (a share of the most), reload left (a share of RELOAD_STEPS),
    whether it is in play, its shell's position and direction (world) and whether it flies; then
    each team's base centre (world), whether it stands, and a constant 1."""
    n = n_agents
    return World(maze_field(n), slots=(("thrust", 2 * n), ("heading", 2 * n), ("hit_points", n), ("reload", n),
                                        ("active", n), ("shell", 2 * n), ("shell_direction", 2 * n),
                                        ("flying", n), ("base", 4), ("base_standing", 2), (ONE, 1)))


def force_matrix(world: World, frame: np.ndarray) -> np.ndarray:
    """Every tank's applied force: full thrust turned from its seat frame (``frame[seat]`` is +1
    or -1: the half turn negates both axes), against a linear drag."""
    F = world.matrix(2 * world.n_bodies)
    for i, sign in enumerate(frame):
        for ax in range(2):
            F[2 * i + ax, world.at("thrust", 2 * i + ax)] = THRUST * sign
            F[2 * i + ax, world.vel(i, ax)] = -DRAG
    return F


def maze_observation(n_agents: int) -> CellLayout:
    """The observation's runs (seat frame; positions divided by HALF, velocities by VELOCITY_UNIT)."""
    v, rel = (-VELOCITY_BOUND, VELOCITY_BOUND), (-2, 2)
    runs = [Run("active", 1, (0, 1), "own in-play flag"), Run("position", 2, (-1, 1), "own position"),
            Run("velocity", 2, v, "own velocity"), Run("heading", 2, (-1, 1), "own heading (a unit vector)"),
            Run("hit_points", 1, (0, 1), "own hit points left, a share of hit_points"),
            Run("reload", 1, (0, 1), "steps until the next shot, a share of the reload time (0: ready)"),
            Run("own_base", 2, rel, "own base relative to the seat"),
            Run("enemy_base", 2, rel, "the enemy base relative to the seat")]
    for k in range(n_agents - 1):
        runs += [Run(f"other_{k}", 2, rel, "another tank relative to the seat"),
                 Run(f"other_{k}_velocity", 2, v, "its velocity"),
                 Run(f"other_{k}_heading", 2, (-1, 1), "its heading"),
                 Run(f"other_{k}_hit_points", 1, (0, 1), "its hit points left, a share of hit_points"),
                 Run(f"other_{k}_active", 1, (0, 1), "its in-play flag")]
    for k in range(n_agents):
        runs += [Run(f"shell_{k}_flying", 1, (0, 1), "1 while that seat's shell flies (own first)"),
                 Run(f"shell_{k}", 2, rel, "the shell relative to the seat (0 when none flies)"),
                 Run(f"shell_{k}_direction", 2, (-1, 1), "its direction (0 when none flies)")]
    runs += [Run("bricks", GRID * GRID, (0, 1), "1 on every brick tile, row by row from the seat's own edge"),
             Run("steel", GRID * GRID, (0, 1), "1 on every steel tile, in the same order")]
    return CellLayout(runs)


#: Cells of the observation before the tile planes (what the observation matrix fills).
def moving_cells(n_agents: int) -> int:
    return maze_observation(n_agents).at("bricks")


def observation_matrix(world: World, cells: CellLayout, team_of: np.ndarray, frame: np.ndarray,
                       order: list[list[int]]) -> tuple[np.ndarray, np.ndarray]:
    """Every seat's observation up to its tile planes as one matrix over the work vector, and for
    each of those cells the work-vector column it is multiplied by afterwards (the shell's flying
    flag for the shell's cells, so that a shell not in flight reads 0; the constant 1 otherwise).
    ``order[seat]`` lists the other seats as the seat observes them."""
    n, size = len(team_of), moving_cells(len(team_of))
    A = np.zeros((n, size, len(world.work)))
    mask = np.full((n, size), world.at(ONE), dtype=np.intp)
    p, vs = 1.0 / HALF, 1.0 / VELOCITY_UNIT

    def put(rows: np.ndarray, cell: int, columns: list[int], factor: float) -> None:
        for ax in range(2):
            rows[cell + ax, columns[ax]] += factor

    pos = [[world.pos(i, 0), world.pos(i, 1)] for i in range(n)]
    vel = [[world.vel(i, 0), world.vel(i, 1)] for i in range(n)]
    heading = [[world.at("heading", 2 * i), world.at("heading", 2 * i + 1)] for i in range(n)]
    shell = [[world.at("shell", 2 * i), world.at("shell", 2 * i + 1)] for i in range(n)]
    shell_dir = [[world.at("shell_direction", 2 * i), world.at("shell_direction", 2 * i + 1)] for i in range(n)]
    base = [[world.at("base", 2 * t), world.at("base", 2 * t + 1)] for t in range(2)]
    for i in range(n):
        rows, s, team = A[i], frame[i], int(team_of[i])
        rows[cells.at("active"), world.at("active", i)] = 1.0
        put(rows, cells.at("position"), pos[i], s * p)
        put(rows, cells.at("velocity"), vel[i], s * vs)
        put(rows, cells.at("heading"), heading[i], s)
        rows[cells.at("hit_points"), world.at("hit_points", i)] = 1.0
        rows[cells.at("reload"), world.at("reload", i)] = 1.0
        for name, t in (("own_base", team), ("enemy_base", 1 - team)):
            put(rows, cells.at(name), base[t], s * p)
            put(rows, cells.at(name), pos[i], -s * p)
        for k, j in enumerate(order[i]):
            put(rows, cells.at(f"other_{k}"), pos[j], s * p)
            put(rows, cells.at(f"other_{k}"), pos[i], -s * p)
            put(rows, cells.at(f"other_{k}_velocity"), vel[j], s * vs)
            put(rows, cells.at(f"other_{k}_heading"), heading[j], s)
            rows[cells.at(f"other_{k}_hit_points"), world.at("hit_points", j)] = 1.0
            rows[cells.at(f"other_{k}_active"), world.at("active", j)] = 1.0
        for k, j in enumerate([i, *order[i]]):
            rows[cells.at(f"shell_{k}_flying"), world.at("flying", j)] = 1.0
            put(rows, cells.at(f"shell_{k}"), shell[j], s * p)
            put(rows, cells.at(f"shell_{k}"), pos[i], -s * p)
            put(rows, cells.at(f"shell_{k}_direction"), shell_dir[j], s)
            start = cells.at(f"shell_{k}")
            mask[i, start: start + 4] = world.at("flying", j)
    return A.reshape(n * size, len(world.work)), mask.reshape(-1)


def tile_order(team_of: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """``intp[n, 2 * GRID**2]``: for each seat, the cells of the two tile planes (bricks, then
    steel, each ``GRID**2`` long, row-major in the world) in its own frame: the half turn reverses
    a row-major grid."""
    flat = np.arange(GRID * GRID)
    rows = []
    for sign in frame:
        one = flat if sign > 0 else flat[::-1]
        rows.append(np.concatenate([one, one + GRID * GRID]))
    return np.array(rows, dtype=np.intp)


def maze_state(n_agents: int) -> CellLayout:
    """The global state's runs (world frame, same scales as the observation)."""
    v = (-VELOCITY_BOUND, VELOCITY_BOUND)
    seat = ((-1, 1), (-1, 1), v, v, (-1, 1), (-1, 1), (0, 1), (0, 1), (0, 1), (0, 1), (-1, 1), (-1, 1),
            (-1, 1), (-1, 1))
    return CellLayout([*[Run(f"seat_{k}", 14, seat) for k in range(n_agents)],
                       Run("base_standing", 2, (0, 1)), Run("tiles", GRID * GRID, (0, 1))])


def state_matrix(world: World, n_agents: int) -> np.ndarray:
    """The global state up to its tiles as one matrix over the work vector: per seat ``x, y, vx,
    vy``, heading, hit points, reload, in-play flag, shell flying flag, shell position and
    direction; then each base's standing flag."""
    S = world.matrix(14 * n_agents + 2)
    p, vs = 1.0 / HALF, 1.0 / VELOCITY_UNIT
    for i in range(n_agents):
        row = 14 * i
        for ax in range(2):
            S[row + ax, world.pos(i, ax)] = p
            S[row + 2 + ax, world.vel(i, ax)] = vs
            S[row + 4 + ax, world.at("heading", 2 * i + ax)] = 1.0
            S[row + 10 + ax, world.at("shell", 2 * i + ax)] = p
            S[row + 12 + ax, world.at("shell_direction", 2 * i + ax)] = 1.0
        for k, slot in enumerate(("hit_points", "reload", "active", "flying")):
            S[row + 6 + k, world.at(slot, i)] = 1.0
    for t in range(2):
        S[14 * n_agents + t, world.at("base_standing", t)] = 1.0
    return S


_TILE_COLOURS = {BRICK: (170, 80, 40), STEEL: (165, 170, 180)}
_FLOOR = (25, 25, 25)


def maze_picture(kinds: np.ndarray, tank_xy: np.ndarray, heading: np.ndarray, active: np.ndarray,
                 team_of: np.ndarray, shells: np.ndarray, flying: np.ndarray, standing: np.ndarray,
                 tank: Bodies) -> np.ndarray:
    """The top-down picture: the floor, bricks and steel, each base in its team's colour (dark once
    destroyed), the tanks with a tick along their heading (faded once out), the shells in flight."""
    from arena_league.envs.physics2d.picture import draw_body

    R = WALL_RADIUS
    canvas = Canvas(-HALF - R, HALF + R, -HALF - R, HALF + R, size=416, background=(90, 90, 90))
    canvas.rect(-HALF, -HALF, HALF, HALF, fill=_FLOOR)
    for row, col in zip(*np.nonzero(kinds)):
        x, y = tile_centre(int(row), int(col))
        kind = int(kinds[row, col])
        if kind != BASE:
            canvas.rect(x - TILE / 2, y - TILE / 2, x + TILE / 2, y + TILE / 2, fill=_TILE_COLOURS[kind],
                        outline=(60, 30, 15) if kind == BRICK else (110, 110, 120))
    for team, tile in enumerate(base_tiles()):
        x, y = tile_centre(*tile)
        colour = TEAM_COLOURS[team] if standing[team] else tuple(c // 3 for c in TEAM_COLOURS[team])
        canvas.rect(x - 0.4 * TILE, y - 0.4 * TILE, x + 0.4 * TILE, y + 0.4 * TILE, fill=colour, outline=(250, 250, 250))
    for seat, team in enumerate(team_of):
        colour = TEAM_COLOURS[team] if active[seat] else tuple((c + 2 * 90) // 3 for c in TEAM_COLOURS[team])
        draw_body(canvas, tank, *tank_xy[seat], tuple(heading[seat]), colour, tick_px=3)
    for (x, y), up in zip(shells, flying):
        if up:
            canvas.circle(x, y, 0.12, fill=(250, 250, 250))
    return canvas.array()


def maze_scene(ts: int, kinds: np.ndarray, tank_xy: np.ndarray, heading: np.ndarray, active: np.ndarray,
               team_of: np.ndarray, shells: np.ndarray, flying: np.ndarray, standing: np.ndarray) -> list[dict[str, Any]]:
    """The replay scene's entities: ``maze`` (floor and outer wall), ``tiles`` (bricks and steel),
    ``base/<team>``, ``agent/<seat>``, ``shells``."""
    thick = 2 * WALL_RADIUS
    wall = (0.35, 0.35, 0.35, 1.0)
    out = [scene.entity("maze", ts, cubes=[
        scene.cube(0, 0, -0.05, (2 * HALF, 2 * HALF, 0.1), (0.12, 0.12, 0.12, 1.0)),
        scene.cube(0, HALF + thick / 2, 0.25, (2 * HALF + 2 * thick, thick, 0.5), wall),
        scene.cube(0, -HALF - thick / 2, 0.25, (2 * HALF + 2 * thick, thick, 0.5), wall),
        scene.cube(HALF + thick / 2, 0, 0.25, (thick, 2 * HALF, 0.5), wall),
        scene.cube(-HALF - thick / 2, 0, 0.25, (thick, 2 * HALF, 0.5), wall)])]
    colours = {BRICK: (0.67, 0.31, 0.16, 1.0), STEEL: (0.65, 0.67, 0.7, 1.0)}
    cubes = []
    for row, col in zip(*np.nonzero(kinds)):
        kind = int(kinds[row, col])
        if kind != BASE:
            x, y = tile_centre(int(row), int(col))
            cubes.append(scene.cube(x, y, 0.25, (TILE, TILE, 0.5), colours[kind]))
    out.append(scene.entity("tiles", ts, cubes=cubes))
    for team, tile in enumerate(base_tiles()):
        x, y = tile_centre(*tile)
        height = 0.6 if standing[team] else 0.1
        out.append(scene.entity(f"base/{team}", ts, cubes=[
            scene.cube(x, y, height / 2, (0.8 * TILE, 0.8 * TILE, height), scene.team_colour(team))]))
    for seat, team in enumerate(team_of):
        x, y = (float(c) for c in tank_xy[seat])
        yaw = math.atan2(float(heading[seat, 1]), float(heading[seat, 0]))
        colour = scene.team_colour(int(team), 1.0 if active[seat] else 0.35)
        out.append(scene.entity(f"agent/{seat}", ts, cylinders=[scene.disc(x, y, 2 * TANK_RADIUS, colour, height=0.4)],
                                arrows=[scene.arrow(x, y, 0.4, yaw, 0.7, colour)]))
    d = 0.2
    out.append(scene.entity("shells", ts, spheres=[
        scene.sphere(float(x), float(y), 0.2, (d, d, d), (0.97, 0.97, 0.97, 1.0))
        for (x, y), up in zip(shells, flying) if up]))
    return out
