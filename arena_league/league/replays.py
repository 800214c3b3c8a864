"""A stored match replay as the front ends show it: its summary, its top-down view as a GIF, and
the document a browser player draws the match from."""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from arena_league.replay import TOPICS, export_gif, iter_messages, read_replay
from arena_league.replay.captions import team_colour

__all__ = ["SHAPE_KINDS", "frames_bounds", "replay_document", "replay_summary", "scene_shapes", "shape_points", "team_hex"]

#: The kinds of shape in a replay document's frames (see :func:`replay_document`).
SHAPE_KINDS: tuple[str, ...] = ("rect", "circle", "arrow", "line", "text")
#: Decimals kept of every coordinate and size in a replay document.
_DECIMALS = 4
#: Margin added on every side of the world bounds, as a fraction of their larger side.
_MARGIN = 0.03
#: Foxglove's line types: 0 a strip through the points, 1 a closed loop, 2 separate segments.
_LINE_LOOP, _LINE_LIST = 1, 2


def replay_summary(path: str | Path, *, gif: str | Path | None = None, fps: float = 10.0,
                   every: int = 1) -> dict[str, Any]:
    """What the MCAP replay at ``path`` holds (game, match, seats, steps, outcome, events); with
    ``gif``, also writes its top-down view there (one frame in ``every``) and says so under ``"gif"``."""
    document = asdict(read_replay(path))
    if gif is not None:
        frames = export_gif(path, gif, fps=fps, every=every)
        document["gif"] = {"path": str(gif), "frames": frames}
    return document


def replay_document(path: str | Path, *, max_frames: int = 2000) -> dict[str, Any]:
    """The MCAP replay at ``path`` as one JSON-serialisable document a browser player draws.

    The replay's ``/scene`` channel holds the game's top-down scene (``foxglove.SceneUpdate``
    messages, one at reset and one after every step, each the whole scene at that moment). Every
    primitive becomes a flat *shape* seen from above, in world coordinates (x right, y up):

    * ``{"kind": "rect", "x", "y", "w", "h", "yaw"}``: a cube's footprint, centred on (x, y),
      ``w`` along its own x axis and ``h`` along its y axis, turned by ``yaw`` radians
      (counter-clockwise; a tilted cube keeps the yaw of its x axis);
    * ``{"kind": "circle", "x", "y", "r"}``: a sphere or a cylinder (disc) seen from above;
    * ``{"kind": "arrow", "x", "y", "x2", "y2", "width", "head_length", "head_width"}``: from its
      tail (x, y) to its tip (x2, y2), a shaft ``width`` wide and a head ``head_length`` long and
      ``head_width`` wide (lengths as seen from above);
    * ``{"kind": "line", "points": [[x, y], ...], "width", "closed", "segments", "screen"}``: a
      polyline through ``points``, back to the first one when ``closed``; with ``segments``, the
      points are taken in pairs, one separate segment each; ``width`` is in world units, or in
      screen pixels when ``screen``;
    * ``{"kind": "text", "x", "y", "text", "size", "screen"}``: a label centred on (x, y), its
      font ``size`` in screen pixels when ``screen``, else in world units.

    Every shape also has ``"color"`` (a CSS ``"rgba(r,g,b,a)"`` string) and ``"z"``, its height
    (a line's: the mean of its points'); a frame lists its shapes by ``z`` ascending (in recorded
    order where equal), the order to draw them in. Numbers are rounded to four decimals.

    Returns a dict with:

    * ``"match"``: the replay's summary (:meth:`ReplaySummary.to_dict` without the server-side
      ``path``): game, seeds, seats, teams, steps, scores, outcomes, message counts;
    * ``"teams"``: one entry per team, by team number: ``{"team", "color": "#rrggbb", "agents"
      (one name per seat, in seat order), "seats", "score", "outcome"}``, in the colours of the
      captioned pictures;
    * ``"bounds"``: ``[xmin, ymin, xmax, ymax]``, the world rectangle holding every shape of
      every frame, with a small margin, to fit the view to;
    * ``"frames"``: ``{"step": k, "shapes": [...]}`` in step order, from ``step`` 0 (reset) to
      the match's last step;
    * ``"frames_kept_every"``: 1 when every recorded frame is there; when the replay has more
      than ``max_frames`` scene messages, only every k-th is kept (and always the last), at most
      ``max_frames`` in all, and this is k;
    * ``"events"``: the events the game reported, in step order, as recorded:
      ``{"step", "kind", "event"}`` (an empty list when there were none).

    Raises :class:`arena_league.replay.ReplayError` (a ``ValueError``) when ``path`` is not a
    readable, finished arena-league replay, and ``ValueError`` when ``max_frames`` is below 2
    (the first and the last frame are always kept).
    """
    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 2:
        raise ValueError(f"max_frames must be an integer of at least 2 (the first and last frames are always "
                         f"kept), not {max_frames!r}")
    summary = read_replay(path)
    match = summary.to_dict()
    del match["path"]
    recorded = summary.channels.get(TOPICS["scene"], 0)
    every = max(1, math.ceil((recorded - 1) / (max_frames - 1))) if recorded > max_frames else 1

    frames: list[dict[str, Any]] = []
    events: list[dict[str, Any]] = []
    step = -1
    last: dict[str, Any] | None = None
    for topic, message in iter_messages(path, [TOPICS["scene"], TOPICS["events"]]):
        if topic == TOPICS["events"]:
            events.append({"step": message.get("step"), "kind": message.get("kind", ""),
                           "event": message.get("event", {})})
            continue
        step += 1
        last = message
        if step % every == 0 or step == recorded - 1:
            frames.append({"step": step, "shapes": scene_shapes(message)})
    if last is not None and frames[-1]["step"] != step:  # the recorded count was short: keep the last anyway
        frames.append({"step": step, "shapes": scene_shapes(last)})

    return {"match": match, "teams": _teams(summary.seats, summary.teams, summary.scores, summary.outcomes),
            "bounds": frames_bounds(frames), "frames": frames, "frames_kept_every": every, "events": events}


def scene_shapes(update: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The shapes (see :func:`replay_document`) of one ``foxglove.SceneUpdate`` message, by ``z``."""
    shapes: list[dict[str, Any]] = []
    for entity in update.get("entities", ()):
        for cube in entity.get("cubes", ()):
            shapes.append(_rect(cube))
        for cylinder in entity.get("cylinders", ()):
            scale = max(float(cylinder.get("bottom_scale", 1.0)), float(cylinder.get("top_scale", 1.0)))
            shapes.append(_circle(cylinder, scale))
        for sphere in entity.get("spheres", ()):
            shapes.append(_circle(sphere, 1.0))
        for line in entity.get("lines", ()):
            shapes.append(_line(line))
        for arrow in entity.get("arrows", ()):
            shapes.append(_arrow(arrow))
        for label in entity.get("texts", ()):
            shapes.append(_text(label))
    shapes.sort(key=lambda shape: shape["z"])  # stable: equal heights keep the recorded order
    return shapes


# --- primitives to shapes -------------------------------------------------------------------------
def _num(value: float) -> float:
    rounded = round(float(value), _DECIMALS)
    return rounded + 0.0  # no "-0.0" in the JSON


def _colour(colour: Mapping[str, float] | None) -> str:
    colour = colour or {}
    r, g, b = (round(255 * min(1.0, max(0.0, float(colour.get(c, 0.0))))) for c in "rgb")
    alpha = round(min(1.0, max(0.0, float(colour.get("a", 1.0)))), 3)
    return f"rgba({r},{g},{b},{alpha:g})"


def _position(pose: Mapping[str, Any]) -> tuple[float, float, float]:
    position = pose.get("position", {})
    return float(position.get("x", 0.0)), float(position.get("y", 0.0)), float(position.get("z", 0.0))


def _rotate(pose: Mapping[str, Any], x: float, y: float, z: float) -> tuple[float, float, float]:
    """The vector (x, y, z) turned by the pose's orientation (a unit quaternion)."""
    q = pose.get("orientation", {})
    qw, qx, qy, qz = (float(q.get(k, d)) for k, d in (("w", 1.0), ("x", 0.0), ("y", 0.0), ("z", 0.0)))
    # v' = v + 2w (u x v) + 2 u x (u x v), with u the quaternion's vector part
    cx, cy, cz = qy * z - qz * y, qz * x - qx * z, qx * y - qy * x
    dx, dy, dz = qy * cz - qz * cy, qz * cx - qx * cz, qx * cy - qy * cx
    return x + 2 * (qw * cx + dx), y + 2 * (qw * cy + dy), z + 2 * (qw * cz + dz)


def _yaw(pose: Mapping[str, Any]) -> float:
    """The heading of the pose's x axis seen from above, in radians."""
    ax, ay, _ = _rotate(pose, 1.0, 0.0, 0.0)
    return math.atan2(ay, ax) if abs(ax) + abs(ay) > 1e-12 else 0.0


def _rect(cube: Mapping[str, Any]) -> dict[str, Any]:
    pose, size = cube.get("pose", {}), cube.get("size", {})
    x, y, z = _position(pose)
    return {"kind": "rect", "x": _num(x), "y": _num(y), "w": _num(size.get("x", 0.0)),
            "h": _num(size.get("y", 0.0)), "yaw": _num(_yaw(pose)), "color": _colour(cube.get("color")),
            "z": _num(z)}


def _circle(primitive: Mapping[str, Any], scale: float) -> dict[str, Any]:
    size = primitive.get("size", {})
    x, y, z = _position(primitive.get("pose", {}))
    radius = scale * max(float(size.get("x", 0.0)), float(size.get("y", 0.0))) / 2.0
    return {"kind": "circle", "x": _num(x), "y": _num(y), "r": _num(radius),
            "color": _colour(primitive.get("color")), "z": _num(z)}


def _arrow(arrow: Mapping[str, Any]) -> dict[str, Any]:
    pose = arrow.get("pose", {})
    x, y, z = _position(pose)
    dx, dy, _ = _rotate(pose, 1.0, 0.0, 0.0)
    flat = math.hypot(dx, dy)  # a tilted arrow looks shorter from above
    shaft, head = float(arrow.get("shaft_length", 0.0)), float(arrow.get("head_length", 0.0))
    length = shaft + head
    return {"kind": "arrow", "x": _num(x), "y": _num(y), "x2": _num(x + length * dx), "y2": _num(y + length * dy),
            "width": _num(arrow.get("shaft_diameter", 0.0)), "head_length": _num(head * flat),
            "head_width": _num(arrow.get("head_diameter", 0.0)), "color": _colour(arrow.get("color")),
            "z": _num(z)}


def _line(line: Mapping[str, Any]) -> dict[str, Any]:
    pose = line.get("pose", {})
    ox, oy, oz = _position(pose)
    points = list(line.get("points", ()))
    indices = line.get("indices") or []
    if indices:
        points = [points[i] for i in indices]
    world = []
    for point in points:
        px, py, pz = _rotate(pose, float(point.get("x", 0.0)), float(point.get("y", 0.0)), float(point.get("z", 0.0)))
        world.append((ox + px, oy + py, oz + pz))
    kind = int(line.get("type", 0))
    z = sum(p[2] for p in world) / len(world) if world else oz
    return {"kind": "line", "points": [[_num(px), _num(py)] for px, py, _ in world],
            "width": _num(line.get("thickness", 0.0)), "closed": kind == _LINE_LOOP, "segments": kind == _LINE_LIST,
            "screen": bool(line.get("scale_invariant", False)), "color": _colour(line.get("color")), "z": _num(z)}


def _text(label: Mapping[str, Any]) -> dict[str, Any]:
    x, y, z = _position(label.get("pose", {}))
    return {"kind": "text", "x": _num(x), "y": _num(y), "text": str(label.get("text", "")),
            "size": _num(label.get("font_size", 12.0)), "screen": bool(label.get("scale_invariant", False)),
            "color": _colour(label.get("color")), "z": _num(z)}


# --- teams and bounds -----------------------------------------------------------------------------
def team_hex(team: int) -> str:
    """The colour of ``team`` in the pictures, as CSS ``#rrggbb``."""
    return "#{:02x}{:02x}{:02x}".format(*team_colour(team))


def _teams(seats: Sequence[str], teams: Sequence[int], scores: Sequence[float], outcomes: Sequence[str]
           ) -> list[dict[str, Any]]:
    out = []
    for team in sorted(set(teams)):
        members = [seat for seat, t in enumerate(teams) if t == team]
        out.append({"team": team, "color": team_hex(team),
                    "agents": [seats[seat] for seat in members], "seats": members,
                    "score": scores[members[0]], "outcome": outcomes[members[0]]})
    return out


def shape_points(shape: Mapping[str, Any]) -> Iterator[tuple[float, float]]:
    """The points of the world a shape reaches (a rect's corners, a circle's bounding box, an
    arrow's ends, a line's points, a text's anchor)."""
    kind = shape["kind"]
    if kind == "rect":
        cos, sin = math.cos(shape["yaw"]), math.sin(shape["yaw"])
        for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            hx, hy = sx * shape["w"] / 2.0, sy * shape["h"] / 2.0
            yield shape["x"] + cos * hx - sin * hy, shape["y"] + sin * hx + cos * hy
    elif kind == "circle":
        yield shape["x"] - shape["r"], shape["y"] - shape["r"]
        yield shape["x"] + shape["r"], shape["y"] + shape["r"]
    elif kind == "arrow":
        yield shape["x"], shape["y"]
        yield shape["x2"], shape["y2"]
    elif kind == "line":
        yield from ((px, py) for px, py in shape["points"])
    else:
        yield shape["x"], shape["y"]


def frames_bounds(frames: Sequence[Mapping[str, Any]]) -> list[float]:
    """``[xmin, ymin, xmax, ymax]`` around every shape of ``frames``, with a margin."""
    xs: list[float] = []
    ys: list[float] = []
    for frame in frames:
        for shape in frame["shapes"]:
            for x, y in shape_points(shape):
                xs.append(x)
                ys.append(y)
    if not xs:
        return [-1.0, -1.0, 1.0, 1.0]
    xmin, xmax, ymin, ymax = min(xs), max(xs), min(ys), max(ys)
    margin = max(_MARGIN * max(xmax - xmin, ymax - ymin), 0.5 if xmax - xmin == ymax - ymin == 0 else 0.0)
    scale = 10**_DECIMALS
    return [math.floor((xmin - margin) * scale) / scale, math.floor((ymin - margin) * scale) / scale,
            math.ceil((xmax + margin) * scale) / scale, math.ceil((ymax + margin) * scale) / scale]
