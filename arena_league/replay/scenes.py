"""Top-down 3D scenes of every game, as Foxglove ``SceneUpdate`` messages (JSON form).

A game's rules may describe their own scene with a ``scene() -> list[dict]`` method returning
Foxglove ``SceneEntity`` dicts; none does yet, so this module holds one adapter per game built from
the game's documented global state layout (``env.state()``, see each game module's docstring) and
its geometry constants:

* Crossroads: the two roads (flat cubes), every agent (a sphere, or a cube with
  ``agent_shape="box"``, faded once arrived) with a heading arrow, and each target (a flat disc of
  the arrival radius);
* Soccer: the field and both goal boxes, every agent and the ball (spheres), the score (text);
* GoBang: the board and its stones (flat spheres, black and white), the last move marked;
* Snake: the walled grid, every snake's body cells (cubes, the head taller) and the food (spheres).

The world is the game's own plane at z = 0, x right, y up, in the frame ``"arena"``; board games
put cell (row, col) at (col + 0.5, size - row - 0.5). Team colours are those of the top-down
pictures (:data:`arena_league.envs.rendering.TEAM_COLOURS`). Entity ids are stable across steps
(``"agent/0"``, ``"ball"``), so each update replaces the previous one in Foxglove's 3D panel.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from arena_league.envs.rendering import TEAM_COLOURS

__all__ = ["FRAME_ID", "SCENE_ADAPTERS", "scene_entities", "scene_update"]

FRAME_ID = "arena"

Colour = tuple[float, float, float, float]


def _team_colour(team: int, alpha: float = 1.0) -> Colour:
    r, g, b = TEAM_COLOURS[int(team) % len(TEAM_COLOURS)]
    return (r / 255.0, g / 255.0, b / 255.0, alpha)


def _rgba(colour: Colour) -> dict[str, float]:
    return {"r": float(colour[0]), "g": float(colour[1]), "b": float(colour[2]), "a": float(colour[3])}


def _pose(x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> dict[str, Any]:
    return {"position": {"x": float(x), "y": float(y), "z": float(z)},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2.0), "w": math.cos(yaw / 2.0)}}


def _vec(x: float, y: float, z: float) -> dict[str, float]:
    return {"x": float(x), "y": float(y), "z": float(z)}


def cube(x: float, y: float, z: float, size: tuple[float, float, float], colour: Colour,
         yaw: float = 0.0) -> dict[str, Any]:
    return {"pose": _pose(x, y, z, yaw), "size": _vec(*size), "color": _rgba(colour)}


def sphere(x: float, y: float, z: float, diameters: tuple[float, float, float], colour: Colour) -> dict[str, Any]:
    return {"pose": _pose(x, y, z), "size": _vec(*diameters), "color": _rgba(colour)}


def disc(x: float, y: float, diameter: float, colour: Colour, height: float = 0.02) -> dict[str, Any]:
    return {"pose": _pose(x, y, height / 2.0), "size": _vec(diameter, diameter, height), "bottom_scale": 1.0,
            "top_scale": 1.0, "color": _rgba(colour)}


def arrow(x: float, y: float, z: float, yaw: float, length: float, colour: Colour) -> dict[str, Any]:
    return {"pose": _pose(x, y, z, yaw), "shaft_length": 0.7 * length, "shaft_diameter": 0.08 * length,
            "head_length": 0.3 * length, "head_diameter": 0.2 * length, "color": _rgba(colour)}


def text(x: float, y: float, z: float, words: str, colour: Colour = (0.1, 0.1, 0.1, 1.0)) -> dict[str, Any]:
    return {"pose": _pose(x, y, z), "billboard": True, "font_size": 14.0, "scale_invariant": True,
            "color": _rgba(colour), "text": words}


def entity(entity_id: str, timestamp_ns: int, **primitives: list[dict[str, Any]]) -> dict[str, Any]:
    """A ``foxglove.SceneEntity`` dict in the ``"arena"`` frame; keyword arguments are its primitive
    lists (``cubes``, ``spheres``, ``cylinders``, ``arrows``, ``lines``, ``texts``)."""
    sec, nsec = divmod(int(timestamp_ns), 1_000_000_000)
    kinds = ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models")
    unknown = set(primitives) - set(kinds)
    if unknown:
        raise ValueError(f"unknown primitive kinds {sorted(unknown)}; valid: {', '.join(kinds)}")
    return {"timestamp": {"sec": sec, "nsec": nsec}, "frame_id": FRAME_ID, "id": entity_id,
            "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False, "metadata": [],
            **{kind: list(primitives.get(kind, ())) for kind in kinds}}


# --- one adapter per game -------------------------------------------------------------------------
def _crossroads(rules: Any, state: np.ndarray, ts: int) -> list[dict[str, Any]]:
    from arena_league.envs.games import crossroads as game

    arm, half_width, radius = game.ARM_LENGTH, game.ROAD_HALF_WIDTH, game.AGENT_RADIUS
    road = (0.55, 0.55, 0.55, 1.0)
    out = [entity("roads", ts, cubes=[cube(0, 0, -0.05, (2 * arm, 2 * half_width, 0.1), road),
                                      cube(0, 0, -0.05, (2 * half_width, 2 * arm, 0.1), road)])]
    cells = state.reshape(rules.n_agents, 9)
    for seat, row in enumerate(cells):
        x, y = row[0] * arm, row[1] * arm
        yaw = math.atan2(float(row[5]), float(row[4]))
        team = int(rules.team_of[seat])
        colour = _team_colour(team, 1.0 if row[8] > 0.5 else 0.35)
        body = ({"cubes": [cube(x, y, radius, (2 * radius, 2 * radius, 2 * radius), colour, yaw)]}
                if getattr(rules, "agent_shape", "circle") == "box"
                else {"spheres": [sphere(x, y, radius, (2 * radius,) * 3, colour)]})
        out.append(entity(f"agent/{seat}", ts, arrows=[arrow(x, y, 2 * radius, yaw, 1.2, colour)], **body))
        target_diameter = 2 * float(getattr(rules, "arrival_radius", 1.0))
        out.append(entity(f"target/{seat}", ts, cylinders=[disc(row[6] * arm, row[7] * arm, target_diameter,
                                                                _team_colour(team, 0.3))]))
    return out


def _soccer(rules: Any, state: np.ndarray, ts: int) -> list[dict[str, Any]]:
    from arena_league.envs.games import soccer as game

    length, width, depth = game.HALF_LENGTH, game.HALF_WIDTH, game.GOAL_DEPTH
    goal_width = 2 * float(getattr(rules, "goal_half_width", game.DEFAULT_GOAL_WIDTH / 2))
    n = rules.n_agents
    grass = (0.35, 0.65, 0.35, 1.0)
    out = [entity("field", ts, cubes=[
        cube(0, 0, -0.05, (2 * length, 2 * width, 0.1), grass),
        # goal x = -L is defended by team 0, x = +L by team 1
        cube(-length - depth / 2, 0, -0.05, (depth, goal_width, 0.1), _team_colour(0, 0.6)),
        cube(length + depth / 2, 0, -0.05, (depth, goal_width, 0.1), _team_colour(1, 0.6))])]
    unit = length  # positions are stored divided by HALF_LENGTH
    for seat in range(n):
        x, y = state[4 * seat] * unit, state[4 * seat + 1] * unit
        d = 2 * game.AGENT_RADIUS
        out.append(entity(f"agent/{seat}", ts, spheres=[sphere(x, y, d / 2, (d, d, d),
                                                               _team_colour(int(rules.team_of[seat])))]))
    bx, by = state[4 * n] * unit, state[4 * n + 1] * unit
    d = 2 * game.BALL_RADIUS
    out.append(entity("ball", ts, spheres=[sphere(bx, by, d / 2, (d, d, d), (0.97, 0.97, 0.97, 1.0))]))
    goals = state[4 * n + 4: 4 * n + 6]
    out.append(entity("score", ts, texts=[text(0, width + 0.6, 0.2, f"{int(goals[0])} : {int(goals[1])}")]))
    return out


def _board_xy(cell: int, size: int) -> tuple[float, float]:
    row, col = divmod(int(cell), size)
    return col + 0.5, size - row - 0.5


def _gobang(rules: Any, state: np.ndarray, ts: int) -> list[dict[str, Any]]:
    size = int(rules.size)
    board = state[: size * size]
    out = [entity("board", ts, cubes=[cube(size / 2, size / 2, -0.05, (size, size, 0.1), (0.87, 0.72, 0.43, 1.0))],
                  lines=[{"type": 2, "pose": _pose(0, 0), "thickness": 0.03, "scale_invariant": False,
                          "points": [p for k in range(size) for p in (
                              _vec(0.5, k + 0.5, 0.001), _vec(size - 0.5, k + 0.5, 0.001),
                              _vec(k + 0.5, 0.5, 0.001), _vec(k + 0.5, size - 0.5, 0.001))],
                          "color": _rgba((0.35, 0.24, 0.12, 1.0)), "colors": [], "indices": []}])]
    stones = []
    for cell in np.flatnonzero(board):
        x, y = _board_xy(int(cell), size)
        colour = (0.1, 0.1, 0.1, 1.0) if board[cell] > 0 else (0.96, 0.96, 0.96, 1.0)
        stones.append(sphere(x, y, 0.1, (0.88, 0.88, 0.25), colour))
    out.append(entity("stones", ts, spheres=stones))
    last = int(rules.engine.last_action[0]) if hasattr(rules, "engine") else -1
    marks = []
    if 0 <= last < size * size and board[last] != 0:
        x, y = _board_xy(last, size)
        marks.append(sphere(x, y, 0.25, (0.25, 0.25, 0.1), (0.86, 0.16, 0.16, 1.0)))
    out.append(entity("last_move", ts, spheres=marks))
    return out


def _snake(rules: Any, state: np.ndarray, ts: int) -> list[dict[str, Any]]:
    size, n = int(rules.size), rules.n_agents
    cells = size * size
    wall = (0.3, 0.3, 0.3, 1.0)
    out = [entity("grid", ts, cubes=[
        cube(size / 2, size / 2, -0.05, (size, size, 0.1), (0.94, 0.94, 0.92, 1.0)),
        cube(size / 2, -0.1, 0.25, (size + 0.4, 0.2, 0.5), wall),
        cube(size / 2, size + 0.1, 0.25, (size + 0.4, 0.2, 0.5), wall),
        cube(-0.1, size / 2, 0.25, (0.2, size, 0.5), wall),
        cube(size + 0.1, size / 2, 0.25, (0.2, size, 0.5), wall)])]
    for seat in range(n):
        plane = state[seat * cells:(seat + 1) * cells]
        colour = _team_colour(int(rules.team_of[seat]))
        body = []
        for cell in np.flatnonzero(plane):
            x, y = _board_xy(int(cell), size)
            height = 0.9 if plane[cell] > 0.75 else 0.6
            body.append(cube(x, y, height / 2, (0.9, 0.9, height), colour))
        out.append(entity(f"snake/{seat}", ts, cubes=body))
    food = state[n * cells:(n + 1) * cells]
    out.append(entity("food", ts, spheres=[sphere(*_board_xy(int(c), size), 0.35, (0.7, 0.7, 0.7), (1.0, 0.0, 0.78, 1.0))
                                           for c in np.flatnonzero(food)]))
    return out


#: Scene adapters by game name (``GameRules.name``), for games whose rules have no ``scene()``.
SCENE_ADAPTERS: dict[str, Callable[[Any, np.ndarray, int], list[dict[str, Any]]]] = {
    "Crossroads": _crossroads,
    "Soccer": _soccer,
    "GoBang": _gobang,
    "Snake": _snake,
}


def scene_entities(rules: Any, timestamp_ns: int) -> list[dict[str, Any]]:
    """The scene entities of the match ``rules`` hold now: the rules' own ``scene()`` when they
    have one, else this module's adapter for the game."""
    own = getattr(rules, "scene", None)
    if callable(own):
        return list(own())
    adapter = SCENE_ADAPTERS.get(rules.name)
    if adapter is None:
        raise ValueError(f"no scene adapter for {rules.name}: give its rules a scene() method returning "
                         f"foxglove.SceneEntity dicts, or add an adapter to SCENE_ADAPTERS "
                         f"(games with one: {', '.join(sorted(SCENE_ADAPTERS))})")
    return adapter(rules, np.asarray(rules.state(), dtype=np.float64), timestamp_ns)


def scene_update(rules: Any, timestamp_ns: int) -> dict[str, Any]:
    """A ``foxglove.SceneUpdate`` message (as a dict) of the match ``rules`` hold now."""
    return {"deletions": [], "entities": scene_entities(rules, timestamp_ns)}
