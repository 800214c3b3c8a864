"""A 2D field's walls and bodies drawn as declared: the top-down picture and the replay scene read
the shapes (disc or square, radius) from the same :class:`~arena_league.envs.physics2d.world.Bodies`
and :class:`~arena_league.envs.physics2d.world.Walls` the physics is built from, so the picture
cannot drift from the field. A game draws its own ground, markings and colours around them.
"""

from __future__ import annotations

from typing import Any

from arena_league.envs import scene
from arena_league.envs.physics2d.world import Bodies, Walls
from arena_league.envs.rendering import Canvas

__all__ = ["draw_body", "draw_walls", "scene_body"]

Colour = tuple[int, int, int]


def draw_walls(canvas: Canvas, walls: Walls, fill: Colour, width_px: int) -> None:
    """Every wall segment's centre line, in declared order."""
    for (ax, ay), (bx, by) in walls.segments:
        canvas.line(ax, ay, bx, by, fill=fill, width_px=width_px)


def draw_body(canvas: Canvas, kind: Bodies, x: float, y: float, heading: tuple[float, float], fill: Colour,
              outline: Colour = (20, 20, 20), tick: Colour = (255, 255, 255), tick_px: int = 2) -> None:
    """One body of ``kind`` centred at ``(x, y)``: a disc, or a square turned to ``heading`` (its
    cos, sin), with a tick from the centre along the heading to the edge."""
    c, s = heading
    r = kind.radius
    if kind.square:
        corners = [(x + c * u - s * v, y + s * u + c * v) for u, v in ((r, r), (-r, r), (-r, -r), (r, -r))]
        canvas.draw.polygon([canvas.px(px, py) for px, py in corners], fill=fill, outline=outline)
    else:
        canvas.circle(x, y, r, fill=fill, outline=outline)
    canvas.line(x, y, x + c * r, y + s * r, fill=tick, width_px=tick_px)


def scene_body(kind: Bodies, x: float, y: float, yaw: float, colour: tuple[float, ...]) -> dict[str, Any]:
    """The shapes of one body of ``kind`` for a replay scene entity, resting on the ground: a
    sphere, or a cube turned by ``yaw``."""
    r = kind.radius
    if kind.square:
        return {"cubes": [scene.cube(x, y, r, (2 * r, 2 * r, 2 * r), colour, yaw)]}
    return {"spheres": [scene.sphere(x, y, r, (2 * r,) * 3, colour)]}
