"""Contact forces read from pymunk's arbiters: per body of one kind, the magnitudes of the contact
impulses the solver applied over an env step's physics steps, summed exactly.

A game whose ``force`` measure is the contact force on each of its bodies makes its
:class:`~arena_league.envs.physics2d.world.World` with ``contacts=True``, gives
:meth:`ContactImpulses.collect` to :meth:`World.step <arena_league.envs.physics2d.world.World.step>`
(which calls it after every physics step, as Chipmunk keeps only the last step's impulses) and
reads the sums with :meth:`ContactImpulses.forces` once the step is done. Every touching arbiter
counts the magnitude of its total impulse once for each of its two bodies (walls and other kinds
count for no one). Arbiters come out of a hash set keyed by addresses, so the sums are formed with
``math.fsum``, exact and so independent of their order.
"""

from __future__ import annotations

import math

import numpy as np

from arena_league.envs.physics2d.world import World

__all__ = ["ContactImpulses"]


class ContactImpulses:
    """The contact impulses of the bodies of kind ``kind`` of ``world``; :meth:`bind` after each
    :meth:`World.build <arena_league.envs.physics2d.world.World.build>`."""

    def __init__(self, world: World, kind: str) -> None:
        if not world.contacts:
            raise ValueError("ContactImpulses reads arbiters: make the World with contacts=True")
        self._world = world
        self._kind = kind
        self._link = world.link
        count = next(part.count for part in world.field.bodies if part.name == kind)
        self._of_body: dict[int, int] = {}  # pymunk body id -> index among the kind's bodies
        self._impulses: list[list[float]] = [[] for _ in range(count)]  # per body, this env step
        self._touched = False  # whether any arbiter touched since the last forces()
        self._nonzero = False  # whether the last forces() wrote a nonzero sum

    def bind(self) -> None:
        """Start a new match on the world's fresh space: no impulses yet."""
        self._of_body = {body.id: k for k, body in enumerate(self._world.bodies[self._kind])}
        for impulses in self._impulses:
            impulses.clear()
        self._touched = self._nonzero = False

    def collect(self) -> None:
        """After a physics step: note the magnitude of every touching arbiter's impulse for each
        of its bodies of the kind."""
        link = self._link
        n_arbiters = link.read_contacts()
        if not n_arbiters:
            return
        impulses = link.contact_impulses[:2 * n_arbiters]
        if not np.count_nonzero(impulses):  # nothing touching (cached arbiters report zero)
            return
        self._touched = True
        # Few arbiters touch at once: a loop over them beats a dozen numpy calls.
        body_ids = link.contact_ids[:2 * n_arbiters].tolist()
        impulse = impulses.tolist()
        index_of, impulses_of = self._of_body.get, self._impulses
        for i in range(0, 2 * n_arbiters, 2):
            if impulse[i] or impulse[i + 1]:
                magnitude = math.hypot(impulse[i], impulse[i + 1])
                for k in (index_of(body_ids[i]), index_of(body_ids[i + 1])):
                    if k is not None:
                        impulses_of[k].append(magnitude)

    def forces(self, out: np.ndarray, dt: float) -> None:
        """Write each body's summed impulses since the last call, divided by ``dt``, into ``out``
        (left alone when it already holds the zeros of a step without contacts)."""
        if self._touched:
            for k, impulses in enumerate(self._impulses):
                out[k] = math.fsum(impulses) / dt
                impulses.clear()
            self._touched = False
            self._nonzero = True
        elif self._nonzero:
            out[:] = 0.0
            self._nonzero = False
