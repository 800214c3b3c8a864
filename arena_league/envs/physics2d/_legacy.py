"""What the 2D games used before the engine declared fields as data; removed once every game is a
declaration over :mod:`arena_league.envs.physics2d.world`."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pymunk

__all__ = ["add_discs", "add_walls", "checked_kwargs"]


def add_walls(space: pymunk.Space, segments: Any, radius: float, elasticity: float, friction: float) -> None:
    """Static segments (``((x0, y0), (x1, y1))`` each) of one radius and material, added in order."""
    walls = []
    for a, b in segments:
        seg = pymunk.Segment(space.static_body, a, b, radius)
        seg.elasticity = elasticity
        seg.friction = friction
        walls.append(seg)
    space.add(*walls)


def checked_kwargs(game: str, kwargs: Mapping[str, Any], table: Mapping[str, tuple]) -> dict[str, Any]:
    """A 2D game's ``kwargs`` checked against ``table`` (name -> ``(low, high, default)`` for a
    number, ``(low, high, default, int)`` for an integer; a fifth entry, a note such as ``" (to win
    the match)"``, follows the name in the error), each name given its value or its default. An
    unknown name, or a value of another type or out of bounds, raises a ValueError that names the
    game, the kwarg, the bounds and the default."""
    def kind(entry: tuple) -> str:
        return "int" if len(entry) > 3 and entry[3] is int else "float"

    unknown = sorted(set(kwargs) - set(table))
    if unknown:
        raise ValueError(f"{game} got unknown game kwargs {unknown}; valid: "
                         + ", ".join(f"{name} ({kind(entry)} in [{entry[0]}, {entry[1]}], default {entry[2]})"
                                     for name, entry in table.items()))
    settings = {}
    for name, (low, high, default, *rest) in table.items():
        value = kwargs.get(name, default)
        integer = bool(rest) and rest[0] is int
        types = (int, np.integer) if integer else (int, float, np.integer, np.floating)
        if isinstance(value, bool) or not isinstance(value, types) or not low <= value <= high:
            raise ValueError(f"{game} {name}{rest[1] if len(rest) > 1 else ''} must be "
                             f"{'an int' if integer else 'a number'} in [{low}, {high}] (default {default}), "
                             f"not {value!r}")
        settings[name] = int(value) if integer else float(value)
    return settings


def add_discs(space: pymunk.Space, centres: Any, mass: float, radius: float, elasticity: float,
              friction: float) -> list[pymunk.Body]:
    """Discs that do not rotate (an agent, a mallet), one per centre, added in order; their bodies."""
    bodies = []
    for xy in centres:
        body = pymunk.Body(mass, float("inf"))
        body.position = float(xy[0]), float(xy[1])
        shape = pymunk.Circle(body, radius)
        shape.elasticity = elasticity
        shape.friction = friction
        space.add(body, shape)
        bodies.append(body)
    return bodies
