"""Shots fired by seats across a tiled map: the tiles (some of which shots break) as static pymunk
boxes, and the shells themselves, moved exactly along their straight paths outside pymunk.

A game that shoots declares a :class:`TileMap` (a grid of square tiles, each of a kind the game
names: empty, or solid, and among the solid kinds those a shell breaks) and a :class:`Shells` (at
most one shell in flight per seat). :meth:`TileMap.build` adds one static box per run of solid
tiles along a row to a match's fresh space, row by row from the bottom, after the field's declared
parts (so the order is part of the game's rules); :meth:`TileMap.clear` empties a broken tile,
putting the boxes of what is left of its run in place of the run's box. A box made once is kept
and goes into the next matches' spaces (the same shape for Chipmunk, added in the same order).
Shells are points that move at a constant speed: each env step, :meth:`Shells.advance` sweeps
every shell in flight, in
seat order, along its segment for the step, and stops it at the first thing it meets: a solid tile
(found by walking the tiles the segment crosses, in order), a body it may hit (the segment's first
crossing of the body's circle) or the map's edge. A tile a shell breaks is cleared before the next
shell moves. Nothing here draws a random number, and nothing is kept in pymunk but the tiles, so
shells cost nothing in the physics step and replay exactly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import pymunk

from arena_league.envs.controls import key_controls
from arena_league.envs.physics2d.link import add_to, remove_from
from arena_league.envs.physics2d.rules import COMPASS_MOVE_NAMES
from arena_league.envs.physics2d.world import Material

__all__ = ["EMPTY", "FIRE_ACTION", "SHOOTER_ACTIONS", "FireKey", "Hit", "Shells", "ThrustFacing", "TileMap"]

#: The kind of a tile with nothing on it.
EMPTY = 0
#: A shooter's discrete actions: the compass moves, then fire (no thrust; a shell along the heading).
FIRE_ACTION = len(COMPASS_MOVE_NAMES)
SHOOTER_ACTIONS = (*COMPASS_MOVE_NAMES, "fire")


class Hit(NamedTuple):
    """What a shell of seat ``shooter`` met this step, at ``(x, y)``: a body (``seat`` >= 0), a
    tile (``row``, ``col`` and its ``kind``, ``broken`` if the shell broke it) or the map's edge
    (neither). (A named tuple: made on the hot path, where a frozen dataclass costs several times
    as much.)"""

    shooter: int
    x: float
    y: float
    seat: int = -1
    row: int = -1
    col: int = -1
    kind: int = EMPTY
    broken: bool = False


class TileMap:
    """``n_rows`` x ``n_cols`` square tiles of side ``tile``, the lower-left corner of tile ``(0, 0)``
    at ``origin``; ``kinds[row, col]`` (row 0 at the bottom) is :data:`EMPTY` or a solid kind, and
    the kinds in ``breakable`` are broken (cleared) by the shell that hits them."""

    def __init__(self, n_rows: int, n_cols: int, tile: float, origin: tuple[float, float],
                 breakable: Sequence[int], material: Material | None = None) -> None:
        self.n_rows, self.n_cols, self.tile = n_rows, n_cols, float(tile)
        self.origin = (float(origin[0]), float(origin[1]))
        self.breakable = frozenset(int(kind) for kind in breakable)
        self.material = material or Material()
        self.kinds = np.zeros((n_rows, n_cols), dtype=np.int8)
        # (rows of Python ints: the shells' walk reads single tiles, where a list beats numpy)
        self._rows: list[list[int]] = [[EMPTY] * n_cols for _ in range(n_rows)]
        # each run's box and last column, under the run's first tile (row, col)
        self._shapes: dict[tuple[int, int], pymunk.Shape] = {}
        self._last: dict[tuple[int, int], int] = {}
        self._space: pymunk.Space | None = None
        # every box made so far, by (row, first, last), with the number of the static body it is on:
        # a box goes from match to match (onto a new space's static body when the space is new),
        # which spares making its pymunk shape again
        self._boxes: dict[tuple[int, int, int], tuple[pymunk.Shape, int]] = {}
        self._static: pymunk.Body | None = None
        self._static_number = 0

    def centre(self, row: int, col: int) -> tuple[float, float]:
        """The world point at the centre of tile ``(row, col)``."""
        return self.origin[0] + (col + 0.5) * self.tile, self.origin[1] + (row + 0.5) * self.tile

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """``(row, col)`` of the tile under the world point ``(x, y)`` (outside the map when out of range)."""
        return math.floor((y - self.origin[1]) / self.tile), math.floor((x - self.origin[0]) / self.tile)

    def build(self, space: pymunk.Space, kinds: np.ndarray) -> None:
        """Lay ``kinds`` out in ``space``: one static box per run of solid tiles along a row (fewer
        shapes to make each match, and no seams for a body sliding along a wall), runs added row by
        row from the bottom, left to right (the boxes of an earlier layout in the same space leave
        it first)."""
        placed = list(self._shapes.values())
        if placed and placed[0].space is not None:  # (a layout's boxes are all in its space, or none is)
            remove_from(placed[0].space, *placed)
        self.kinds[:] = kinds
        self._rows = self.kinds.tolist()
        self._shapes, self._last = {}, {}
        self._space = space
        if space.static_body is not self._static:
            self._static = space.static_body
            self._static_number += 1
        # each run of solid tiles along a row: where the row turns solid, and where it turns empty again
        solid = np.zeros((self.n_rows, self.n_cols + 2), dtype=np.int8)
        np.not_equal(self.kinds, EMPTY, out=solid[:, 1:-1], casting="unsafe")
        turns = np.diff(solid, axis=1)
        rows, firsts = np.nonzero(turns == 1)
        ends = np.nonzero(turns == -1)[1]
        shapes = [self._run(row, first, end - 1) for row, first, end in zip(rows.tolist(), firsts.tolist(), ends.tolist())]
        if shapes:
            add_to(space, *shapes)

    def _run(self, row: int, first: int, last: int) -> pymunk.Shape:
        """The box over tiles ``first`` to ``last`` of ``row``, noted under its first tile."""
        made = self._boxes.get((row, first, last))
        if made is None:
            x0, y0 = self.origin[0] + first * self.tile, self.origin[1] + row * self.tile
            x1, y1 = self.origin[0] + (last + 1) * self.tile, y0 + self.tile
            box = pymunk.Poly(self._static, [(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
            self.material.apply(box)
            self._boxes[row, first, last] = box, self._static_number
        else:
            box, number = made
            if number != self._static_number:
                box.body = self._static
                self._boxes[row, first, last] = box, self._static_number
        self._shapes[row, first] = box
        self._last[row, first] = last
        return box

    def clear(self, row: int, col: int) -> None:
        """Empty tile ``(row, col)``: the box of its run leaves the space, and the boxes of what is
        left of the run on either side of it come in."""
        tiles = self._rows[row]
        if tiles[col] == EMPTY:
            return
        first = col
        while first > 0 and tiles[first - 1] != EMPTY:
            first -= 1
        last = self._last.pop((row, first))
        remove_from(self._space, self._shapes.pop((row, first)))
        self.kinds[row, col] = EMPTY
        tiles[col] = EMPTY
        parts = ([self._run(row, first, col - 1)] if col > first else []) + (
            [self._run(row, col + 1, last)] if col < last else [])
        if parts:
            add_to(self._space, *parts)

    def first_solid(self, x0: float, y0: float, x1: float, y1: float) -> tuple[float, int, int]:
        """Walk the tiles the segment from ``(x0, y0)`` to ``(x1, y1)`` crosses, in order, and give
        ``(t, row, col)`` of the first solid one it enters (``t`` in [0, 1] along the segment; the
        tile of the start counts when it is solid), ``(t, -1, -1)`` where it leaves the map, or
        ``(inf, -1, -1)`` when it meets neither."""
        tile, (ox, oy) = self.tile, self.origin
        gx, gy = (x0 - ox) / tile, (y0 - oy) / tile
        dx, dy = (x1 - ox) / tile - gx, (y1 - oy) / tile - gy
        col, row = math.floor(gx), math.floor(gy)
        inf = math.inf
        if dx > 0:
            step_col, next_x, delta_x = 1, (col + 1 - gx) / dx, 1 / dx
        elif dx < 0:
            step_col, next_x, delta_x = -1, (gx - col) / -dx, -1 / dx
        else:
            step_col, next_x, delta_x = 0, inf, inf
        if dy > 0:
            step_row, next_y, delta_y = 1, (row + 1 - gy) / dy, 1 / dy
        elif dy < 0:
            step_row, next_y, delta_y = -1, (gy - row) / -dy, -1 / dy
        else:
            step_row, next_y, delta_y = 0, inf, inf
        rows, n_rows, n_cols = self._rows, self.n_rows, self.n_cols
        t = 0.0
        while t <= 1.0:
            if not (0 <= row < n_rows and 0 <= col < n_cols):
                return t, -1, -1
            if rows[row][col] != EMPTY:
                return t, row, col
            if next_x < next_y:
                t, next_x, col = next_x, next_x + delta_x, col + step_col
            else:
                t, next_y, row = next_y, next_y + delta_y, row + step_row
        return inf, -1, -1


class Shells:
    """At most one shell in flight per seat, flying at ``speed`` (world units per second).

    ``can_hit[i, j]`` says whether seat ``i``'s shell hits seat ``j``'s body (a seat's own shell
    never does; a game whose shells pass through teammates says so here); a body is a circle of
    ``body_radius``.

    The state is kept in Python lists (a step reads and writes single seats, where lists beat
    numpy); :attr:`xy`, :attr:`direction`, :attr:`flying` and :attr:`loaded_in` give it as fresh
    arrays, and :meth:`cells` as a work vector's cells.
    """

    def __init__(self, can_hit: np.ndarray, speed: float, body_radius: float, reload_steps: int = 0) -> None:
        self.n = len(can_hit)
        self.can_hit = np.asarray(can_hit, dtype=bool) & ~np.eye(self.n, dtype=bool)
        self._targets = [np.flatnonzero(row).tolist() for row in self.can_hit]
        self.speed, self.body_radius, self.reload_steps = float(speed), float(body_radius), int(reload_steps)
        # x, y of every seat's shell, then its direction likewise, seat after seat
        self._at = [0.0] * (2 * self.n)
        self._way = [0.0] * (2 * self.n)
        #: Whether each seat's shell is in flight (read only).
        self.aloft = [False] * self.n
        #: Steps until each seat's gun is loaded again (0: loaded; read only).
        self.waits = [0] * self.n
        self._reloading = 0

    @property
    def xy(self) -> np.ndarray:
        """``float64[n, 2]``: where each seat's shell is (where it last was once stopped)."""
        return np.array(self._at).reshape(self.n, 2)

    @property
    def direction(self) -> np.ndarray:
        """``float64[n, 2]``: each seat's last shell's direction (a unit vector; 0 before any shot)."""
        return np.array(self._way).reshape(self.n, 2)

    @property
    def flying(self) -> np.ndarray:
        """``bool[n]``: whether each seat's shell is in flight."""
        return np.array(self.aloft, dtype=bool)

    @property
    def loaded_in(self) -> np.ndarray:
        """``int64[n]``: steps until each seat's gun is loaded again (0: loaded)."""
        return np.array(self.waits, dtype=np.int64)

    def in_flight(self) -> bool:
        """Whether any shell is in flight."""
        return True in self.aloft

    def cells(self, hide_idle: bool = False) -> list[float]:
        """Every shell's ``x, y`` (seat after seat), then every direction likewise, then every
        in-flight flag (1.0 or 0.0): a game's work-vector cells. With ``hide_idle``, the position
        and direction of a shell not in flight are multiplied by 0 (as a numpy product with the
        flags would be, signed zeros included)."""
        at, way, flags = self._at, self._way, [1.0 if f else 0.0 for f in self.aloft]
        if hide_idle and 0.0 in flags:
            at, way = at[:], way[:]
            for seat, flag in enumerate(flags):
                if not flag:
                    x, y = 2 * seat, 2 * seat + 1
                    at[x], at[y], way[x], way[y] = at[x] * 0.0, at[y] * 0.0, way[x] * 0.0, way[y] * 0.0
        return at + way + flags

    def reset(self) -> None:
        """No shell in flight, every gun loaded."""
        self._at = [0.0] * (2 * self.n)
        self._way = [0.0] * (2 * self.n)
        self.aloft = [False] * self.n
        self.waits = [0] * self.n
        self._reloading = 0

    def pull_triggers(self, fire: Sequence[bool] | np.ndarray, xy: np.ndarray, direction: np.ndarray,
                      able: Sequence[bool] | np.ndarray) -> list[int]:
        """Every seat in ``fire`` that is ``able``, whose gun is loaded and whose shell is not in
        flight fires from ``xy[seat]`` along ``direction[seat]``, and its gun reloads for
        ``reload_steps`` steps (see :meth:`reload`). Returns the seats that fired, in order."""
        fired = []
        aloft, waits = self.aloft, self.waits
        if isinstance(fire, np.ndarray):
            fire = fire.tolist()
        for seat, pulled in enumerate(fire):
            if pulled and not (aloft[seat] or waits[seat]) and able[seat]:
                self.fire(seat, xy[seat].tolist(), direction[seat].tolist())
                waits[seat] = self.reload_steps
                fired.append(seat)
        self._reloading += len(fired)
        return fired

    def reload(self) -> bool:
        """One step nearer a loaded gun for every seat reloading; whether any was (a game's
        observation of the reload then changed)."""
        if not self._reloading:
            return False
        self.waits = left = [steps - 1 if steps > 0 else 0 for steps in self.waits]
        self._reloading = len(left) - left.count(0)
        return True

    def fire(self, seat: int, xy: Sequence[float], direction: Sequence[float]) -> None:
        """Seat ``seat``'s shell leaves ``xy`` along the unit vector ``direction`` (it moves on the
        next :meth:`advance`)."""
        self._at[2 * seat], self._at[2 * seat + 1] = float(xy[0]), float(xy[1])
        self._way[2 * seat], self._way[2 * seat + 1] = float(direction[0]), float(direction[1])
        self.aloft[seat] = True

    def advance(self, dt: float, tiles: TileMap, body_xy: np.ndarray, targetable: np.ndarray) -> list[Hit]:
        """Move every shell in flight by ``speed * dt``, seat by seat, and stop each at the first
        thing it meets: a body of a seat it may hit that is ``targetable``, a solid tile (broken if
        breakable) or the map's edge. Returns what was hit, in seat order."""
        hits: list[Hit] = []
        aloft = self.aloft
        if True not in aloft:
            return hits
        reach = self.speed * dt
        radius_sq = self.body_radius ** 2
        bodies = body_xy.tolist()
        open_to_hit = targetable.tolist()
        at, way, targets = self._at, self._way, self._targets
        for seat, flying in enumerate(aloft):
            if not flying:
                continue
            x0, y0 = at[2 * seat], at[2 * seat + 1]
            dx, dy = way[2 * seat] * reach, way[2 * seat + 1] * reach
            t_tile, row, col = tiles.first_solid(x0, y0, x0 + dx, y0 + dy)
            t_body, struck = math.inf, -1
            a = dx * dx + dy * dy
            for j in targets[seat]:
                if open_to_hit[j]:
                    # the least t in [0, 1] where the segment is on or in the body's circle, if any
                    bx, by = bodies[j]
                    px, py = x0 - bx, y0 - by
                    c = px * px + py * py - radius_sq
                    if c <= 0.0:
                        t = 0.0
                    else:
                        b = px * dx + py * dy
                        if b >= 0.0 or b * b - a * c < 0.0:
                            continue
                        t = (-b - math.sqrt(b * b - a * c)) / a
                        if t > 1.0:
                            continue
                    if t < t_body:
                        t_body, struck = t, j
            if t_body <= t_tile and struck >= 0:
                aloft[seat] = False
                hits.append(Hit(seat, x0 + t_body * dx, y0 + t_body * dy, seat=struck))
            elif t_tile <= 1.0:
                aloft[seat] = False
                x, y = x0 + t_tile * dx, y0 + t_tile * dy
                if row < 0:
                    hits.append(Hit(seat, x, y))
                    continue
                kind = tiles._rows[row][col]  # (the map's rows as Python ints, as its kinds)
                broken = kind in tiles.breakable
                if broken:
                    tiles.clear(row, col)
                hits.append(Hit(seat, x, y, -1, row, col, kind, broken))
            else:
                at[2 * seat], at[2 * seat + 1] = x0 + dx, y0 + dy
        return hits


class ThrustFacing:
    """Turns every seat pushed harder than ``threshold`` to face the way it is pushed, in the world:
    its heading becomes its thrust (in its own frame) over the thrust's length, times ``frame``
    (``(n, 2)``: the sign each axis of the seat's frame has in the world); the others keep their
    heading (a gun points the way its shooter last moved)."""

    def __init__(self, frame: np.ndarray, threshold: float) -> None:
        self.frame = np.asarray(frame, dtype=np.float64)
        self.threshold = float(threshold)
        # each seat's cells in a flat (x, y) list and its frame's signs
        self._seats = [(2 * seat, 2 * seat + 1, sx, sy) for seat, (sx, sy) in enumerate(self.frame.tolist())]
        self._turns: list[list[tuple[float, float] | None]] = []

    def face(self, thrust: Sequence[float], length: Sequence[float], heading: np.ndarray) -> None:
        """``heading`` (``float64[2 n]``, world, seat after seat) from ``thrust`` (``2 n`` floats,
        seat frames, seat after seat) of ``length`` (``n`` floats)."""
        # (a few seats: Python floats beat numpy calls, and divide and multiply the same way)
        threshold, turned = self.threshold, None
        for (x, y, sx, sy), size in zip(self._seats, length):
            if size > threshold:
                if turned is None:
                    turned = heading.tolist()
                turned[x], turned[y] = thrust[x] / size * sx, thrust[y] / size * sy
        if turned is not None:
            heading[:] = turned

    def learn_moves(self, pairs: Sequence[Sequence[float]], length: Sequence[float]) -> None:
        """Note the heading each seat takes for each of a few fixed thrusts (``pairs[move]``,
        ``[x, y]``, of ``length[move]``), for :meth:`face_moves`."""
        self._turns = [[(x / size * sx, y / size * sy) if size > self.threshold else None
                        for (x, y), size in zip(pairs, length)] for _, _, sx, sy in self._seats]

    def face_moves(self, moves: Sequence[int], heading: np.ndarray) -> None:
        """:meth:`face` for thrusts that are the moves of :meth:`learn_moves` (by index), bit for
        bit (the same quotients, looked up)."""
        turned = None
        for (x, y, _, _), turns, move in zip(self._seats, self._turns, moves):
            turn = turns[move]
            if turn is not None:
                if turned is None:
                    turned = heading.tolist()
                turned[x], turned[y] = turn
        if turned is not None:
            heading[:] = turned


class FireKey:
    """A person's compass controls (mixed in before a :class:`~arena_league.envs.controls.CompassControls`
    class) with ``f`` (or ``fire``) for :data:`FIRE_ACTION`; in a browser, Space or F."""

    #: The browser's hint for the keys.
    key_hint = ("Arrow keys or W A S D move on the view as drawn (two at once: diagonally); Space (or F) fires "
                "along your heading; let go to stop pushing.")

    def parse(self, text: str) -> tuple[int | None, str | None]:
        if text in ("f", "fire"):
            return FIRE_ACTION, None
        action, problem = super().parse(text)  # type: ignore[misc]
        return action, None if problem is None else problem + "; f fires along your heading"

    def prompt(self, step: int) -> str:
        return (f"step {step}: {self.move} (e, ne, n, nw, w, sw, s, se or noop), or f to fire along your heading "  # type: ignore[attr-defined]
                f"(an action number 0-{FIRE_ACTION}; Enter repeats) > ")

    def web(self) -> dict[str, Any]:
        web = super().web()  # type: ignore[misc]
        return key_controls({**web["keys"], " ": "f", "f": "f", "F": "f"}, web["pace"], self.key_hint,
                            release=web["release"], combine=web["combine"], accepts=tuple(web["accepts"]))
