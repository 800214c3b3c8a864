"""The link between a pymunk space and numpy arrays: the 2D engine's batch transfers and physics step.

Crossroads and Soccer keep their bodies' state in numpy arrays and move it in and out of pymunk
(Chipmunk2D) several times per env step. Going body by body through pymunk's Python objects
(``Body.position``, ``Body.velocity = ...``) costs a Python attribute access, a ``Vec2d`` and a cffi
call per value, which for a handful of bodies is most of an env step. Pymunk's batch module instead
walks every body (or every cached arbiter) of a space in C and copies the requested fields to or
from one flat float array. This module is the games' only way into pymunk's batch transfers and
their physics step, and it has two ways through, which run the same Chipmunk functions on the same
data and so give the same numbers, bit for bit:

direct (the default, where pymunk's cffi handles are reachable)
    The batch iterators and ``cpSpaceStep`` are called straight through pymunk's private cffi
    module (``pymunk._chipmunk_cffi``) on the space's C handle (``Space._space``), with the request
    structs built once per link. The public batch functions build a request struct and look up the
    iterator on every call, which for a few bodies costs several times the transfer itself, and
    ``Space.step`` wraps ``cpSpaceStep`` in Python bookkeeping for objects added or removed from
    callbacks, post-step callbacks and a mass check of newly added bodies. The public path makes
    a Crossroads env step about a quarter slower, a Soccer one about a tenth.
public
    ``pymunk.batch.get_space_bodies``, ``set_space_bodies``, ``get_space_arbiters`` and
    ``Space.step``: used when the private handles are not reachable (another pymunk build or
    release), or for every link made while :data:`FORCE_PUBLIC_API` is true.

The direct step therefore assumes what the games guarantee: no collision handlers that add or
remove objects or register post-step callbacks, and dynamic bodies of finite, positive mass (it
skips the assertion ``Space.step`` makes about bodies added since the last step). Bind again after
adding or removing bodies or shapes.

Filling and reusing a space
    :func:`add_to` and :func:`remove_from` put bodies and shapes in a space and take them out as
    ``Space.add`` and ``Space.remove`` do, keeping pymunk's records, without their per-object
    checks. :func:`restart` sets an emptied space's counters back to zero and :func:`renew` a
    removed body's state to a new one's, so that a world refills the previous match's space rather
    than making a new one: a BattleCity match adds dozens of boxes, whose Python costs were most
    of a reset. The matches are the same bit for bit (tests compare them with new spaces).

Layout
    Bodies are visited in the order they were added to the space (the space's static body joins
    the first time ``space.static_body`` is touched); :attr:`SpaceLink.body_ids` lists them. Per
    body, the cells of the requested fields follow pymunk's order: position x, y, angle, velocity
    x, y, angular velocity, force x, y, torque (:func:`body_cells` counts them).

Arrays
    The body arrays are float64 numpy arrays the caller owns, so that a game can lay them inside
    a larger vector and gather observations from it without a copy. Pymunk writes through an array
    that it grows with ``realloc`` one push before it is full, which on numpy memory would corrupt
    the heap: :meth:`SpaceLink.bind` refuses a read array without room for every body plus
    :data:`SPARE_CELLS`, and sizes the link's own contact arrays from the number of shape pairs
    that can touch.
"""

from __future__ import annotations

import weakref
from typing import Any, ClassVar

import numpy as np
import pymunk
import pymunk.batch
from pymunk.batch import BodyFields

__all__ = ["DIRECT_AVAILABLE", "FORCE_PUBLIC_API", "SPARE_CELLS", "BodyFields", "SpaceLink", "add_to", "body_cells",
           "can_restart", "remove_from", "renew", "restart", "space_link"]

#: Set to True to make every link created afterwards use pymunk's public API only.
FORCE_PUBLIC_API = False

#: Free cells a read array must keep beyond the data of every body: pymunk reallocates an array
#: before a push that would fill it (at two free cells for a vector), so one would do; four is
#: a margin.
SPARE_CELLS = 4

#: Float cells per body of every body field (BODY_ID goes to the int array, not here).
_FIELD_CELLS = ((BodyFields.POSITION, 2), (BodyFields.ANGLE, 1), (BodyFields.VELOCITY, 2),
                (BodyFields.ANGULAR_VELOCITY, 1), (BodyFields.FORCE, 2), (BodyFields.TORQUE, 1))
_BODY_FLOAT_FIELDS = sum(field.value for field, _ in _FIELD_CELLS)
#: Per cached arbiter: the ids of its two bodies (int array) and its total impulse x, y (floats).
_CONTACT_FIELDS = (pymunk.batch.ArbiterFields.BODY_A_ID | pymunk.batch.ArbiterFields.BODY_B_ID
                   | pymunk.batch.ArbiterFields.TOTAL_IMPULSE)
_CONTACT_BYTES = 2 * np.dtype(np.float64).itemsize  # float cells of one arbiter, in bytes


def _probe_direct() -> tuple[Any, ...] | None:
    """pymunk's cffi handles the direct path needs, or None where they are not reachable."""
    try:
        from pymunk._chipmunk_cffi import ffi, lib
    except ImportError:
        return None
    try:
        handles = (ffi, lib, lib.cpSpaceEachBody, lib.cpSpaceEachCachedArbiter,
                   ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched"),
                   ffi.addressof(lib, "pmSpaceBodySetIteratorFuncBatched"),
                   ffi.addressof(lib, "pmSpaceArbiterIteratorFuncBatched"))
        ffi.new("pmBatchedData *")
        if not isinstance(getattr(pymunk.Space(), "_space", None), ffi.CData):
            return None
        if not isinstance(getattr(pymunk.batch.Buffer(), "_float_arr", None), ffi.CData):
            return None
    except (AttributeError, ffi.error):
        return None
    return handles


_DIRECT = _probe_direct()
#: Whether pymunk's cffi handles are reachable, so that links take the direct path by default.
DIRECT_AVAILABLE = _DIRECT is not None
if _DIRECT is not None:
    _ffi, _lib, _EACH_BODY, _EACH_ARBITER, _GET_BODIES, _SET_BODIES, _GET_ARBITERS = _DIRECT



def _probe_fill() -> tuple[Any, ...] | None:
    """What :func:`add_to`, :func:`remove_from` and :func:`restart` need of pymunk's internals (its
    records of a space's shapes and bodies, and Chipmunk's counters), or None where they differ."""
    if _DIRECT is None:
        return None
    try:
        from pymunk._util import _dead_ref
        lib = _DIRECT[1]
        calls = (lib.cpSpaceAddShape, lib.cpSpaceRemoveShape, lib.cpSpaceAddBody, lib.cpSpaceRemoveBody,
                 lib.cpSpaceSetShapeIDCounter, lib.cpSpaceSetTimestamp, lib.cpSpaceSetCurrentTimeStep,
                 lib.cpBodyUpdatePosition)
        space = pymunk.Space()
        body = pymunk.Body(1.0, 1.0)
        shape = pymunk.Circle(body, 1.0)
        records = (space._shapes, space._bodies, space._bodies_to_check, shape._shape, body._body)
        if not (isinstance(records[0], dict) and isinstance(records[1], dict) and isinstance(records[2], set)):
            return None
        space.add(body, shape)
        if shape._space() is not space or body._space() is not space:
            return None
    except (ImportError, AttributeError, TypeError):
        return None
    return (_dead_ref, *calls)


_FILL = _probe_fill()
if _FILL is not None:
    # what a new body's fields hold, set straight through Chipmunk (as pymunk's setters do)
    _RENEWED = ((_lib.cpBodySetAngle, 0.0), (_lib.cpBodySetPosition, (0.0, 0.0)),
                (_lib.cpBodySetVelocity, (0.0, 0.0)), (_lib.cpBodySetAngularVelocity, 0.0),
                (_lib.cpBodySetForce, (0.0, 0.0)), (_lib.cpBodySetTorque, 0.0))


def body_cells(fields: BodyFields) -> int:
    """Float cells one body takes in a batch array for ``fields``."""
    return sum(cells for field, cells in _FIELD_CELLS if field in fields)


def _float_buffer(floats: np.ndarray, name: str) -> pymunk.batch.Buffer:
    if not (isinstance(floats, np.ndarray) and floats.dtype == np.float64 and floats.ndim == 1
            and floats.flags.c_contiguous and floats.flags.writeable):
        raise ValueError(f"{name} must be a writeable, contiguous 1-D float64 numpy array")
    buffer = pymunk.batch.Buffer()
    buffer.set_float_buf(floats)
    return buffer


def _check_fields(fields: BodyFields, name: str) -> None:
    if not fields.value or fields.value & ~_BODY_FLOAT_FIELDS:
        raise ValueError(f"{name} must be a non-empty combination of the float body fields "
                         f"(position, angle, velocity, angular velocity, force, torque), not {fields}")


def _contact_pairs(space: pymunk.Space) -> int:
    """How many cached arbiters ``space`` can hold: one per pair of shapes on different bodies of
    which at least one is dynamic (Chipmunk never collides shapes of one body, or two shapes
    neither of whose bodies is dynamic)."""
    per_body: dict[int, int] = {}
    still_per_body: dict[int, int] = {}
    for shape in space.shapes:
        body = shape.body
        per_body[body.id] = per_body.get(body.id, 0) + 1
        if body.body_type != pymunk.Body.DYNAMIC:
            still_per_body[body.id] = still_per_body.get(body.id, 0) + 1
    shapes, still = sum(per_body.values()), sum(still_per_body.values())
    different_bodies = (shapes * shapes - sum(k * k for k in per_body.values())) // 2
    still_pairs = (still * still - sum(k * k for k in still_per_body.values())) // 2
    return different_bodies - still_pairs


class SpaceLink:
    """Moves every body's fields between one pymunk space and numpy arrays, and steps the space.

    This class goes through pymunk's public API; :func:`space_link` makes links, which take the
    direct path where they can. ``read_floats`` receives ``read`` of every body on
    :meth:`read_bodies`; ``write_floats`` holds ``write`` of every body for :meth:`write_bodies`
    (Chipmunk clears forces after every step, so a force is written before each one). With
    ``contacts``, :meth:`read_contacts` fills :attr:`contact_ids` and :attr:`contact_impulses`.
    """

    #: Whether this link calls Chipmunk through pymunk's cffi handles.
    direct: ClassVar[bool] = False

    def __init__(self, read: BodyFields, read_floats: np.ndarray, write: BodyFields | None = None,
                 write_floats: np.ndarray | None = None, contacts: bool = False) -> None:
        _check_fields(read, "read")
        if (write is None) != (write_floats is None):
            raise ValueError("give write and write_floats together, or neither")
        self.read_fields = read
        self.read_cells = body_cells(read)
        self._read_floats = read_floats
        self._read_buffer = _float_buffer(read_floats, "read_floats")
        self.write_fields = write
        self.write_cells = 0
        self._write_floats = write_floats
        self._write_buffer: pymunk.batch.Buffer | None = None
        if write is not None and write_floats is not None:
            _check_fields(write, "write")
            self.write_cells = body_cells(write)
            self._write_buffer = _float_buffer(write_floats, "write_floats")
        self.contacts = contacts
        #: Per cached arbiter after :meth:`read_contacts`: the ids of its bodies a, b.
        self.contact_ids = np.zeros(0, dtype=np.uintp)
        #: Per cached arbiter after :meth:`read_contacts`: its total impulse x, y (zero for an
        #: arbiter kept from an earlier step whose shapes no longer touch).
        self.contact_impulses = np.zeros(0)
        self._contact_buffer = pymunk.batch.Buffer()
        self._ids_buffer = pymunk.batch.Buffer()  # pymunk's own memory: free to grow
        #: Ids (``Body.id``) of the bodies in the order the link visits them.
        self.body_ids: list[int] = []
        self.space: pymunk.Space | None = None

    def bind(self, space: pymunk.Space) -> None:
        """Link ``space`` (and keep it alive); checks that the arrays have room for its bodies."""
        # Empty the space this link held before, through pymunk, so that its C space is freed with
        # nothing attached. Left to the garbage collector, its bodies and shapes (which refer to
        # one another) were freed in no fixed order, and a process-pool worker sometimes aborted in
        # pymunk's space finalizer ("Cannot remove a body that was not added to the space"): in
        # about one run in four of the sandboxed process-pool test, none in 12 with this.
        previous = self.space
        if previous is not None and previous is not space:
            previous.remove(*previous.shapes, *previous.bodies)
        self._ids_buffer.clear()
        pymunk.batch.get_space_bodies(space, BodyFields.BODY_ID, self._ids_buffer)
        body_ids = list(memoryview(self._ids_buffer.int_buf()).cast("P"))
        need = self.read_cells * len(body_ids) + SPARE_CELLS
        if len(self._read_floats) < need:
            raise ValueError(f"read_floats holds {len(self._read_floats)} cells; {len(body_ids)} bodies "
                             f"need {need} ({self.read_cells} each plus {SPARE_CELLS} spare)")
        if self._write_floats is not None and len(self._write_floats) < self.write_cells * len(body_ids):
            raise ValueError(f"write_floats holds {len(self._write_floats)} cells; {len(body_ids)} bodies "
                             f"need {self.write_cells * len(body_ids)}")
        if self.contacts:
            cells = 2 * _contact_pairs(space) + SPARE_CELLS
            if len(self.contact_impulses) < cells:
                self.contact_impulses = np.zeros(cells)
                self.contact_ids = np.zeros(cells, dtype=np.uintp)
                self._contact_buffer.set_float_buf(self.contact_impulses)
                self._contact_buffer.set_int_buf(self.contact_ids)
        self.body_ids = body_ids
        self.space = space

    def read_bodies(self) -> None:
        """Copy the read fields of every body into ``read_floats``, from its start."""
        self._read_buffer.clear()
        pymunk.batch.get_space_bodies(self.space, self.read_fields, self._read_buffer)

    def write_bodies(self) -> None:
        """Set the write fields of every body from ``write_floats``, from its start."""
        pymunk.batch.set_space_bodies(self.space, self.write_fields, self._write_buffer)

    def step(self, dt: float) -> None:
        """Advance the space by ``dt`` seconds."""
        self.space.step(dt)

    def read_contacts(self) -> int:
        """Fill :attr:`contact_ids` and :attr:`contact_impulses` with every cached arbiter, two
        cells each, in Chipmunk's (address-keyed) order; returns how many arbiters."""
        self._contact_buffer.clear()
        pymunk.batch.get_space_arbiters(self.space, _CONTACT_FIELDS, self._contact_buffer)
        return len(self._contact_buffer.float_buf()) // _CONTACT_BYTES


class _DirectSpaceLink(SpaceLink):
    """The same transfers as :class:`SpaceLink`, straight through pymunk's cffi handles."""

    direct: ClassVar[bool] = True

    def __init__(self, read: BodyFields, read_floats: np.ndarray, write: BodyFields | None = None,
                 write_floats: np.ndarray | None = None, contacts: bool = False) -> None:
        super().__init__(read, read_floats, write, write_floats, contacts)
        self._read_array = self._read_buffer._float_arr
        self._read_request = self._request(read, self._read_buffer)
        if self._write_buffer is not None:
            self._write_array = self._write_buffer._float_arr
            self._write_request = self._request(write, self._write_buffer)
        # set_float_buf / set_int_buf in bind re-point these same arrays, so the request holds
        self._contact_floats = self._contact_buffer._float_arr
        self._contact_ints = self._contact_buffer._int_arr
        self._contact_request = self._request(_CONTACT_FIELDS, self._contact_buffer)
        self._handle = None
        self._space_step = _lib.cpSpaceStep

    @staticmethod
    def _request(fields: BodyFields | pymunk.batch.ArbiterFields, buffer: pymunk.batch.Buffer) -> Any:
        """The C request the batch iterators take: the fields and the buffer's two arrays."""
        request = _ffi.new("pmBatchedData *")
        request.fields = fields.value
        request.floatArray = buffer._float_arr
        request.intArray = buffer._int_arr
        return request

    def bind(self, space: pymunk.Space) -> None:
        super().bind(space)
        self._handle = space._space
        self._space_step = _lib.cpHastySpaceStep if space.threaded else _lib.cpSpaceStep  # as Space.step

    def read_bodies(self) -> None:
        self._read_array.num = 0
        _EACH_BODY(self._handle, _GET_BODIES, self._read_request)

    def write_bodies(self) -> None:
        self._write_array.num = 0  # the setter reads from the start of the array
        _EACH_BODY(self._handle, _SET_BODIES, self._write_request)

    def step(self, dt: float) -> None:
        self._space_step(self._handle, dt)

    def read_contacts(self) -> int:
        self._contact_floats.num = self._contact_ints.num = 0
        _EACH_ARBITER(self._handle, _GET_ARBITERS, self._contact_request)
        return self._contact_floats.num // 2


def space_link(read: BodyFields, read_floats: np.ndarray, write: BodyFields | None = None,
               write_floats: np.ndarray | None = None, contacts: bool = False) -> SpaceLink:
    """A link (see :class:`SpaceLink`), direct where pymunk's cffi handles are reachable and
    :data:`FORCE_PUBLIC_API` is false; :meth:`SpaceLink.bind` it to a space before use."""
    cls = _DirectSpaceLink if DIRECT_AVAILABLE and not FORCE_PUBLIC_API else SpaceLink
    return cls(read, read_floats, write, write_floats, contacts)


def can_restart() -> bool:
    """Whether :func:`restart` is available (pymunk's internals as this module expects them, and
    :data:`FORCE_PUBLIC_API` false): a world may then reuse one space from match to match."""
    return _FILL is not None and not FORCE_PUBLIC_API


def add_to(space: pymunk.Space, *objects: pymunk.Body | pymunk.Shape) -> None:
    """``space.add(*objects)`` (bodies first, then shapes, each in the order given) for the objects
    a world or a tile map made for ``space``: on the direct path Chipmunk's add is called with
    pymunk's records of the space kept as ``Space.add`` keeps them, but without its checks, whose
    Python costs several times the add itself (a maze adds dozens of boxes each match)."""
    if not can_restart():
        space.add(*objects)
        return
    _, add_shape, _, add_body, *_ = _FILL
    owner = weakref.ref(space)
    handle = space._space
    shapes, bodies = space._shapes, space._bodies
    for thing in objects:
        if isinstance(thing, pymunk.Body):
            object.__setattr__(thing, "_space", owner)
            bodies[thing] = None
            add_body(handle, thing._body)
    for thing in objects:
        if not isinstance(thing, pymunk.Body):
            object.__setattr__(thing, "_space", owner)
            shapes[thing] = None
            add_shape(handle, thing._shape)


def remove_from(space: pymunk.Space, *objects: pymunk.Body | pymunk.Shape) -> None:
    """``space.remove(*objects)`` (each in ``space``), in the order given, on the direct path as
    :func:`add_to` (pymunk's remove also keeps each removed shape until the next public step, which
    a direct step never takes)."""
    if not can_restart():
        space.remove(*objects)
        return
    dead, _, remove_shape, _, remove_body, *_ = _FILL
    handle = space._space
    shapes, bodies, unchecked = space._shapes, space._bodies, space._bodies_to_check
    for thing in objects:
        object.__setattr__(thing, "_space", dead)
        if isinstance(thing, pymunk.Body):
            del bodies[thing]
            unchecked.discard(thing)
            remove_body(handle, thing._body)
        else:
            del shapes[thing]
            remove_shape(handle, thing._shape)


def restart(space: pymunk.Space) -> None:
    """Set Chipmunk's shape-id counter, timestamp and last time step of ``space``, emptied of every
    shape and of every body but its static one, back to a fresh space's zeros. Chipmunk orders its
    collision work by shape ids and bounding-box trees, and an emptied tree refilled in the same
    order is the tree a fresh space builds, so the space then fills and steps as a fresh one would,
    bit for bit (a body kept from the last match is renewed first: :func:`renew`)."""
    if not can_restart():
        raise RuntimeError("restart needs pymunk's internals as arena_league expects them (pymunk>=7,<8) and "
                           "FORCE_PUBLIC_API false; build a fresh pymunk.Space instead")
    if space.shapes or any(body.body_type != pymunk.Body.STATIC for body in space.bodies):
        raise ValueError("restart an empty space: remove every shape and every body but the static one first")
    *_, set_counter, set_stamp, set_dt, _ = _FILL
    set_counter(space._space, 0)
    set_stamp(space._space, 0)
    set_dt(space._space, 0.0)


def renew(body: pymunk.Body) -> None:
    """Give a dynamic ``body``, out of any space, the state of a new one: at rest at the origin,
    angle zero, no force, and no bias velocity (the push apart of overlapping shapes that Chipmunk's
    solver leaves for the next position update, which only that update clears: one of zero time
    here, which moves nothing). Needs :func:`can_restart`."""
    if not can_restart():
        raise RuntimeError("renew needs pymunk's internals as arena_league expects them (pymunk>=7,<8) and "
                           "FORCE_PUBLIC_API false; make a new body instead")
    if body.space is not None:
        raise ValueError("renew a body out of its space: remove it first")
    handle = body._body
    _FILL[-1](handle, 0.0)
    for setter, value in _RENEWED:
        setter(handle, value)
