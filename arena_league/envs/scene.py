"""The pieces of a game's 3D replay scene: Foxglove ``SceneEntity`` dicts (JSON form) and their primitives.

Every game describes the match it holds with ``GameRules.scene_entities(timestamp_ns)``, a list of
``foxglove.SceneEntity`` dicts built from the primitives here; a replay writes them as one
``foxglove.SceneUpdate`` per step, and Foxglove Studio's 3D panel shows them.

The world is the game's own plane at z = 0, x right, y up, in the frame :data:`FRAME_ID`; board
games put cell (row, col) at :func:`board_xy` = (col + 0.5, size - row - 0.5). Team colours are
those of the top-down pictures (:data:`arena_league.envs.rendering.TEAM_COLOURS`). A game keeps
its entity ids stable across steps (``"agent/0"``, ``"ball"``), so each update replaces the
previous one in the 3D panel.

    entity("ball", timestamp_ns, spheres=[sphere(x, y, r, (2 * r,) * 3, (1.0, 1.0, 1.0, 1.0))])
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from arena_league.envs.rendering import TEAM_COLOURS

__all__ = [
    "FRAME_ID",
    "PRIMITIVE_KINDS",
    "Colour",
    "arrow",
    "board_xy",
    "colour_of",
    "cube",
    "disc",
    "entity",
    "lines",
    "pose",
    "rgba",
    "sphere",
    "team_colour",
    "text",
    "vec",
]

#: The frame every entity lives in.
FRAME_ID = "arena"
#: The primitive lists of a ``foxglove.SceneEntity``.
PRIMITIVE_KINDS: tuple[str, ...] = ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts",
                                    "models")
#: Foxglove's line types: a strip through the points, a closed loop, or separate segments (pairs).
_LINE_TYPES = {"strip": 0, "loop": 1, "list": 2}

#: RGBA, each in [0, 1].
Colour = tuple[float, float, float, float]
#: A quaternion ``(w, x, y, z)`` (MuJoCo's order).
Quaternion = tuple[float, float, float, float]


def colour_of(rgb: tuple[int, int, int], alpha: float = 1.0) -> Colour:
    """A picture's 0..255 ``rgb`` colour with opacity ``alpha``."""
    r, g, b = rgb
    return (r / 255.0, g / 255.0, b / 255.0, alpha)


def team_colour(team: int, alpha: float = 1.0) -> Colour:
    """The colour of ``team`` (its colour in the top-down pictures) with opacity ``alpha``."""
    return colour_of(TEAM_COLOURS[int(team) % len(TEAM_COLOURS)], alpha)


def rgba(colour: Colour) -> dict[str, float]:
    """A ``foxglove.Color``."""
    return {"r": float(colour[0]), "g": float(colour[1]), "b": float(colour[2]), "a": float(colour[3])}


def pose(x: float, y: float, z: float = 0.0, yaw: float = 0.0, quaternion: Quaternion | None = None
         ) -> dict[str, Any]:
    """A ``foxglove.Pose`` at (x, y, z), turned by ``yaw`` about the vertical axis, or by
    ``quaternion`` ``(w, x, y, z)`` when given."""
    if quaternion is None:
        turn = {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2.0), "w": math.cos(yaw / 2.0)}
    else:
        w, qx, qy, qz = quaternion
        turn = {"x": float(qx), "y": float(qy), "z": float(qz), "w": float(w)}
    return {"position": {"x": float(x), "y": float(y), "z": float(z)}, "orientation": turn}


def vec(x: float, y: float, z: float) -> dict[str, float]:
    """A ``foxglove.Vector3`` (or ``Point3``)."""
    return {"x": float(x), "y": float(y), "z": float(z)}


def cube(x: float, y: float, z: float, size: tuple[float, float, float], colour: Colour, yaw: float = 0.0,
         quaternion: Quaternion | None = None) -> dict[str, Any]:
    """A box centred on (x, y, z) of side lengths ``size``, turned by ``yaw`` (or ``quaternion``)."""
    return {"pose": pose(x, y, z, yaw, quaternion), "size": vec(*size), "color": rgba(colour)}


def sphere(x: float, y: float, z: float, diameters: tuple[float, float, float], colour: Colour) -> dict[str, Any]:
    """An ellipsoid centred on (x, y, z) with the given diameters along x, y, z."""
    return {"pose": pose(x, y, z), "size": vec(*diameters), "color": rgba(colour)}


def disc(x: float, y: float, diameter: float, colour: Colour, height: float = 0.02) -> dict[str, Any]:
    """A flat cylinder standing on the ground at (x, y)."""
    return {"pose": pose(x, y, height / 2.0), "size": vec(diameter, diameter, height), "bottom_scale": 1.0,
            "top_scale": 1.0, "color": rgba(colour)}


def arrow(x: float, y: float, z: float, yaw: float, length: float, colour: Colour) -> dict[str, Any]:
    """An arrow of ``length`` from (x, y, z) pointing along ``yaw``."""
    return {"pose": pose(x, y, z, yaw), "shaft_length": 0.7 * length, "shaft_diameter": 0.08 * length,
            "head_length": 0.3 * length, "head_diameter": 0.2 * length, "color": rgba(colour)}


def text(x: float, y: float, z: float, words: str, colour: Colour = (0.1, 0.1, 0.1, 1.0)) -> dict[str, Any]:
    """A label at (x, y, z) that always faces the viewer."""
    return {"pose": pose(x, y, z), "billboard": True, "font_size": 14.0, "scale_invariant": True,
            "color": rgba(colour), "text": words}


def lines(points: Sequence[tuple[float, float, float]], colour: Colour, thickness: float, kind: str = "list"
          ) -> dict[str, Any]:
    """Lines in world coordinates, ``thickness`` wide: ``kind`` ``"list"`` (segments between
    consecutive pairs of points), ``"strip"`` (one line through the points) or ``"loop"`` (a strip
    closed back to its first point)."""
    if kind not in _LINE_TYPES:
        raise ValueError(f"unknown line kind {kind!r}; valid: {', '.join(_LINE_TYPES)}")
    return {"type": _LINE_TYPES[kind], "pose": pose(0, 0), "thickness": thickness, "scale_invariant": False,
            "points": [vec(*p) for p in points], "color": rgba(colour), "colors": [], "indices": []}


def board_xy(cell: int, size: int) -> tuple[float, float]:
    """The centre of board cell ``row * size + col`` on the ground: (col + 0.5, size - row - 0.5)."""
    row, col = divmod(int(cell), size)
    return col + 0.5, size - row - 0.5


def entity(entity_id: str, timestamp_ns: int, **primitives: list[dict[str, Any]]) -> dict[str, Any]:
    """A ``foxglove.SceneEntity`` dict in the :data:`FRAME_ID` frame; keyword arguments are its
    primitive lists (``cubes``, ``spheres``, ``cylinders``, ``arrows``, ``lines``, ``texts``)."""
    sec, nsec = divmod(int(timestamp_ns), 1_000_000_000)
    unknown = set(primitives) - set(PRIMITIVE_KINDS)
    if unknown:
        raise ValueError(f"unknown primitive kinds {sorted(unknown)}; valid: {', '.join(PRIMITIVE_KINDS)}")
    return {"timestamp": {"sec": sec, "nsec": nsec}, "frame_id": FRAME_ID, "id": entity_id,
            "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False, "metadata": [],
            **{kind: list(primitives.get(kind, ())) for kind in PRIMITIVE_KINDS}}
