"""Outlines and walls of 2D fields: the chamfered pitch with goal boxes of the ball games, and the
walls whose inner faces follow an outline."""

from __future__ import annotations

import numpy as np

__all__ = ["Segment", "goal_field_outline", "pushed_outline", "wall_segments"]

Point = tuple[float, float]
Segment = tuple[Point, Point]


def goal_field_outline(half_length: float, half_width: float, goal_half_width: float, goal_depth: float,
                       chamfer: float) -> list[Point]:
    """Inner boundary of a rectangular pitch ``[-half_length, half_length] x [-half_width,
    half_width]`` with 45-degree chamfers of ``chamfer`` at its corners and a goal box
    ``goal_depth`` deep behind a mouth ``2 * goal_half_width`` wide at each end, counter-clockwise."""
    L, W, G, D, c = half_length, half_width, goal_half_width, goal_depth, chamfer
    return [(-L + c, -W), (L - c, -W), (L, -W + c), (L, -G), (L + D, -G), (L + D, G), (L, G),
            (L, W - c), (L - c, W), (-L + c, W), (-L, W - c), (-L, G), (-L - D, G), (-L - D, -G),
            (-L, -G), (-L, -W + c)]


def pushed_outline(outline: list[Point], offset: float) -> list[Point]:
    """``outline`` (counter-clockwise) with every edge pushed outward by ``offset``, each corner
    where its two neighbouring edges' pushed lines meet."""
    pts = np.asarray(outline, dtype=np.float64)
    edges = np.roll(pts, -1, axis=0) - pts
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / np.linalg.norm(edges, axis=1, keepdims=True)
    corners = []
    for k in range(len(pts)):
        # vertex k joins edge k-1 and edge k; intersect their pushed lines
        n0, n1 = normals[k - 1], normals[k]
        p0, p1 = pts[k] + offset * n0, pts[k] + offset * n1
        d0 = edges[k - 1]
        denom = d0[0] * edges[k][1] - d0[1] * edges[k][0]
        t = ((p1 - p0)[0] * edges[k][1] - (p1 - p0)[1] * edges[k][0]) / denom
        corners.append(tuple(p0 + t * d0))
    return corners


def wall_segments(outline: list[Point], radius: float) -> list[Segment]:
    """Centre lines of the wall segments of ``radius`` whose inner faces follow ``outline``."""
    corners = pushed_outline(outline, radius)
    return [(corners[k], corners[(k + 1) % len(corners)]) for k in range(len(corners))]
