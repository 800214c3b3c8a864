"""A 2D game's field declared as data, and the world that plays it: a pymunk space per match, its
bodies' state in one named work vector, the batch transfers and the physics step.

A game declares a :class:`Field`: the space's constants and its parts, walls (:class:`Walls`) and
kinds of round or square bodies (:class:`Bodies`), in the order they are added to each match's
fresh space (the order decides Chipmunk's contact order, so it is part of the game's rules). A
:class:`World` lays one float64 work vector out from it: the bodies' block first (every body's read
fields, in the order pymunk's batch visits them: the declared bodies, then the static body if any
walls are declared), room pymunk's batch array needs, then the game's own named slots (a seat's
velocity before the step, its thrust, a constant 1, ...). Observations, measures and applied
forces are matrices over that vector, addressed by body and slot names (:meth:`World.pos`,
:meth:`World.at`), so a step is a few numpy calls whatever the game.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymunk

from arena_league.envs.physics2d.link import (
    BodyFields,
    SpaceLink,
    add_to,
    body_cells,
    can_restart,
    remove_from,
    renew,
    restart,
    space_link,
)

__all__ = ["ONE", "Bodies", "Field", "Material", "Walls", "World"]

#: The name of a one-cell slot that always holds 1.0 (the constant column of affine maps).
ONE = "one"

#: The filter of a new shape: in every category, colliding with every category.
_ANY = pymunk.ShapeFilter()

#: Pymunk's batch array grows (reallocates) when fewer than 3 free cells are left: room left after
#: the bodies' block.
BODY_SPARE = 8


@dataclass(frozen=True)
class Material:
    """Surface of a shape; ``None`` leaves pymunk's default (0, no filter) unset, which also saves
    the cost of setting it on every match's fresh space."""

    elasticity: float | None = None
    friction: float | None = None
    filter: pymunk.ShapeFilter | None = None

    def apply(self, shape: pymunk.Shape) -> None:
        if self.elasticity is not None:
            shape.elasticity = self.elasticity
        if self.friction is not None:
            shape.friction = self.friction
        if self.filter is not None:
            shape.filter = self.filter


@dataclass(frozen=True)
class Walls:
    """Static segments ``((x0, y0), (x1, y1))`` of one radius and material, added in one call."""

    segments: tuple[tuple[tuple[float, float], tuple[float, float]], ...]
    radius: float
    material: Material = Material()
    #: Add each segment with its own ``space.add`` (the same space either way; kept for games whose
    #: recorded matches were built so).
    one_by_one: bool = False


@dataclass(frozen=True)
class Bodies:
    """``count`` dynamic bodies of one kind, named ``name`` (``"agent"``, ``"ball"``).

    ``material`` is one material or one per body (a team's filter, say). A body that does not
    ``rotate`` has an infinite moment (contacts push it but never spin it); ``square`` makes each a
    box of side ``2 * radius`` instead of a circle.
    """

    name: str
    count: int
    radius: float
    mass: float
    material: Material | tuple[Material, ...] = Material()
    rotates: bool = False
    square: bool = False

    def material_of(self, k: int) -> Material:
        return self.material[k] if isinstance(self.material, tuple) else self.material

    def make(self, k: int) -> tuple[pymunk.Body, pymunk.Shape]:
        moment = pymunk.moment_for_circle(self.mass, 0.0, self.radius) if self.rotates else math.inf
        body = pymunk.Body(self.mass, moment)
        if self.square:
            shape: pymunk.Shape = pymunk.Poly.create_box(body, (2 * self.radius, 2 * self.radius))
        else:
            shape = pymunk.Circle(body, self.radius)
        self.material_of(k).apply(shape)
        return body, shape


@dataclass(frozen=True)
class Field:
    """A game's space: its constants and its parts, added in order to each match's fresh space."""

    dt: float
    damping: float
    collision_slop: float
    parts: tuple[Walls | Bodies, ...]
    collision_bias: float | None = None
    #: Physics steps per env step (each of ``dt``).
    substeps: int = 1

    @property
    def bodies(self) -> tuple[Bodies, ...]:
        return tuple(part for part in self.parts if isinstance(part, Bodies))

    @property
    def has_walls(self) -> bool:
        return any(isinstance(part, Walls) for part in self.parts)


_FIELD_ORDER = ((BodyFields.POSITION, ("x", "y")), (BodyFields.ANGLE, ("angle",)),
                (BodyFields.VELOCITY, ("vx", "vy")), (BodyFields.ANGULAR_VELOCITY, ("spin",)),
                (BodyFields.FORCE, ("fx", "fy")), (BodyFields.TORQUE, ("torque",)))


class World:
    """The live side of a :class:`Field`: the work vector, the link and each match's space.

    ``slots`` are the game's own named runs of the work vector after the bodies' block, in order
    (``(name, cells)``; :data:`ONE` for the constant 1). ``read`` fields are copied from every body
    after each step into the bodies' block; ``write`` fields are set from :attr:`applied` before
    it (Chipmunk clears forces after every step, so a force is written before each one), after
    :attr:`force_matrix` (if the game sets one) fills :attr:`applied` from the work vector.
    ``applied`` names a slot that holds :attr:`applied` inside the work vector (so that the game's
    matrices can read the forces); the force matrix then reads only the cells before that slot
    (:attr:`force_source`).
    """

    def __init__(self, field: Field, slots: Sequence[tuple[str, int]] = (),
                 read: BodyFields = BodyFields.POSITION | BodyFields.VELOCITY,
                 write: BodyFields | None = BodyFields.FORCE, contacts: bool = False, spare: int = BODY_SPARE,
                 applied: str | None = None) -> None:
        self.field = field
        self.slots = tuple(slots)
        self.read_fields = read
        self.write_fields = write
        self.contacts = contacts
        self.spare = spare
        self._dt = field.dt
        self._more_substeps = field.substeps - 1
        self.names = [kind.name for kind in self.field.bodies for _ in range(kind.count)]
        self.n_bodies = len(self.names) + (1 if self.field.has_walls else 0)
        self.cells = body_cells(read)
        self._cell_of = {}
        cell = 0
        for flag, names in _FIELD_ORDER:
            if flag in read:
                for name in names:
                    self._cell_of[name] = cell
                    cell += 1
        self._first: dict[str, int] = {}
        for index, name in enumerate(self.names):
            self._first.setdefault(name, index)
        at = self.cells * self.n_bodies + self.spare
        self._offsets = {}
        for name, size in self.slots:
            self._offsets[name] = (at, at + size)
            at += size
        self.work = np.zeros(at)
        if ONE in self._offsets:
            self.work[self._offsets[ONE][0]] = 1.0
        #: Every body's read fields, one row per body in link order (a view of the work vector).
        self.table = self.work[: self.cells * self.n_bodies].reshape(self.n_bodies, self.cells)
        self.applied: np.ndarray | None = None
        #: The cells :attr:`force_matrix` multiplies: the whole work vector, or the cells before the
        #: ``applied`` slot.
        self.force_source = self.work
        if applied is not None:
            self.applied = self.view(applied)
            if write is None or len(self.applied) != body_cells(write) * self.n_bodies:
                raise ValueError(f"slot {applied!r} holds the applied {write} of every body: give it "
                                 f"{body_cells(write or BodyFields.FORCE) * self.n_bodies} cells")
            self.force_source = self.work[: self._offsets[applied][0]]
        elif write is not None:
            self.applied = np.zeros(body_cells(write) * self.n_bodies)
        #: The applied force of every body as a matrix over :attr:`force_source` (rows: the write
        #: cells of every body), or None where the game writes :attr:`applied` itself.
        self.force_matrix: np.ndarray | None = None
        self.link: SpaceLink = space_link(read, self.work, write, self.applied, contacts)
        #: The second link :meth:`place_all` writes through, made on its first call.
        self._placement_link: SpaceLink | None = None
        self._placement: np.ndarray | None = None
        self.space: pymunk.Space | None = None
        self.bodies: dict[str, list[pymunk.Body]] = {}
        # each Walls part's segments on the current space, made with it and added again on reuse
        self._walls: list[list[pymunk.Shape]] = []
        # each kind's bodies and their shapes on the current space, renewed for the next match on reuse
        self._made: dict[str, list[tuple[pymunk.Body, pymunk.Shape]]] = {}
        self._reuses = self.link.direct and not contacts and can_restart()

    # --- addresses ---------------------------------------------------------------------------
    def index(self, name: str, k: int = 0) -> int:
        """The link index of the ``k``-th body of kind ``name``."""
        return self._first[name] + k

    def column(self, body: int, cell: str) -> int:
        """The work-vector column of ``cell`` (``"x"``, ``"vy"``, ``"angle"``) of body ``body``."""
        return self.cells * body + self._cell_of[cell]

    def pos(self, body: int, axis: int) -> int:
        return self.column(body, "xy"[axis])

    def vel(self, body: int, axis: int) -> int:
        return self.column(body, ("vx", "vy")[axis])

    def at(self, slot: str, k: int = 0) -> int:
        """The column of cell ``k`` of slot ``slot``."""
        return self._offsets[slot][0] + k

    def view(self, slot: str) -> np.ndarray:
        start, end = self._offsets[slot]
        return self.work[start:end]

    def complex_view(self, slot: str) -> np.ndarray:
        """Slot ``slot`` read as complex numbers ``x + iy`` (pairs of cells)."""
        return self.view(slot).view(np.complex128)

    def matrix(self, rows: int) -> np.ndarray:
        """A zero matrix of ``rows`` rows over the work vector."""
        return np.zeros((rows, len(self.work)))

    # --- the match ---------------------------------------------------------------------------
    def build(self, positions: Mapping[str, Any], velocities: Mapping[str, Any] | None = None,
              angles: Mapping[str, Any] | None = None) -> pymunk.Space:
        """A space for a new match, as fresh as a new one (no cached contacts survive from the
        previous match, so a seed gives the same match whatever was played before): every part
        added in declared order, each kind of body at ``positions[name]`` (``(count, 2)``), with
        optional velocities and angles. Reads the bodies into the work vector.

        Where the link can (:func:`~arena_league.envs.physics2d.link.can_restart`, and no contacts
        are read, whose order follows Chipmunk's arbiter table), the previous match's space is
        emptied and restarted rather than made again, its walls and bodies kept to add again: bit for bit the
        same matches, for a fraction of the cost of a new space and its shapes."""
        velocities = velocities or {}
        angles = angles or {}
        f = self.field
        space = self.space
        reuse = space is not None and self._reuses
        if reuse:
            remove_from(space, *space.shapes, *space.bodies)
            restart(space)
        else:
            space = pymunk.Space()
            space.damping = f.damping
            space.collision_slop = f.collision_slop
            if f.collision_bias is not None:
                space.collision_bias = f.collision_bias
            self._walls, self._made = [], {}
        self.bodies = {}
        walls = iter(self._walls if reuse else ())
        for part in f.parts:
            if isinstance(part, Walls):
                segments = next(walls, None)
                if segments is None:
                    segments = []
                    for a, b in part.segments:
                        segment = pymunk.Segment(space.static_body, a, b, part.radius)
                        part.material.apply(segment)
                        segments.append(segment)
                    self._walls.append(segments)
                if part.one_by_one:
                    for segment in segments:
                        add_to(space, segment)
                else:
                    add_to(space, *segments)
                continue
            xy = np.asarray(positions[part.name], dtype=np.float64).reshape(part.count, 2)
            velocity = velocities.get(part.name)
            angle = angles.get(part.name)
            placed = []
            made = self._made.setdefault(part.name, [])
            for k in range(part.count):
                if reuse:
                    body, shape = made[k]
                    renew(body)
                    shape.filter = part.material_of(k).filter or _ANY  # (a game may have taken it out of play)
                else:
                    body, shape = part.make(k)
                    made.append((body, shape))
                body.position = float(xy[k, 0]), float(xy[k, 1])
                if velocity is not None:
                    body.velocity = float(velocity[k][0]), float(velocity[k][1])
                if angle is not None:
                    body.angle = float(angle[k])
                add_to(space, body, shape)
                placed.append(body)
            self.bodies[part.name] = placed
        self.space = space
        if not reuse:  # (a refilled space holds the same bodies in the same order: the links hold)
            self.link.bind(space)
            if self._placement_link is not None:
                self._placement_link.bind(space)
            expected = [body.id for kind in f.bodies for body in self.bodies[kind.name]]
            if f.has_walls:
                expected.append(space.static_body.id)
            if self.link.body_ids != expected:
                raise RuntimeError("pymunk.batch visits the bodies in an unexpected order; the 2D games support "
                                   "pymunk 7 (pip install 'pymunk>=7,<8')")
        self.link.read_bodies()
        return space

    def place(self, name: str, xy: Any, velocity: Any | None = None) -> None:
        """Move every body of kind ``name`` to ``xy`` (``(count, 2)``) with ``velocity`` (zero when
        None); call :meth:`read` after the last move."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        velocity = np.zeros_like(xy) if velocity is None else np.asarray(velocity, dtype=np.float64).reshape(-1, 2)
        for body, p, v in zip(self.bodies[name], xy, velocity):
            body.position = float(p[0]), float(p[1])
            body.velocity = float(v[0]), float(v[1])

    def place_all(self, positions: Mapping[str, Any], velocities: Mapping[str, Any] | None = None) -> None:
        """Move every body of every kind to ``positions[name]`` (``(count, 2)``) with
        ``velocities[name]`` (zero when absent) in one batch write through a second link, and read
        them back: the same Chipmunk setters as :meth:`place`, at a fraction of its cost, for a game
        that lays out a new start mid-match (the static body keeps its zero position and velocity)."""
        if self._placement_link is None:
            fields = BodyFields.POSITION | BodyFields.VELOCITY
            self._placement = np.zeros((self.n_bodies, 4))
            self._placement_link = space_link(fields, np.zeros(4 * self.n_bodies + self.spare), fields,
                                              self._placement.reshape(-1))
            self._placement_link.bind(self.space)
        rows = self._placement
        velocities = velocities or {}
        for kind in self.field.bodies:
            first = self._first[kind.name]
            rows[first: first + kind.count, 0:2] = positions[kind.name]
            velocity = velocities.get(kind.name)
            rows[first: first + kind.count, 2:4] = 0.0 if velocity is None else velocity
        self._placement_link.write_bodies()
        self.link.read_bodies()

    def read(self) -> None:
        """Copy every body's read fields into the work vector."""
        self.link.read_bodies()

    def step(self, after_each: Callable[[], object] | None = None) -> None:
        """One env step of physics: the applied forces (from :attr:`force_matrix`, if set) written
        before each of ``substeps`` steps of ``dt``, the bodies read back. ``after_each``, if
        given, is called after every physics step (to read that step's contacts, say)."""
        link = self.link
        forces = self.force_matrix
        if forces is not None:
            np.dot(forces, self.force_source, out=self.applied)
        link.write_bodies()
        link.step(self._dt)
        if after_each is not None:
            after_each()
        if self._more_substeps:  # (a test is cheaper than an empty loop on the hot path)
            for _ in range(self._more_substeps):
                link.write_bodies()
                link.step(self._dt)
                if after_each is not None:
                    after_each()
        link.read_bodies()
