"""Observations gathered from the work vector: every cell one entry of it, or the difference of
two, times a factor.

Where every seat's frame is the world's turned by a multiple of 90 degrees or mirrored (one nonzero
entry in each row of the frame), every observation cell is such an entry. A gather then costs
three numpy calls whatever the number of seats, where a matrix product over the work vector costs
a multiply-add per cell and column, and it adds no zero terms. The cells are addressed by the work
vector's columns (:meth:`World.pos <arena_league.envs.physics2d.world.World.pos>`,
:meth:`World.at <arena_league.envs.physics2d.world.World.at>`), the game's own slot that always
holds 0.0 standing in for "nothing to subtract".
"""

from __future__ import annotations

import numpy as np

__all__ = ["Gather"]


class Gather:
    """``size`` cells filled as ``(work[plus] - work[minus]) * factor`` by :meth:`fill`; every cell
    is 0.0 until :meth:`put` (or :meth:`put_vector`) says where it comes from. ``zero`` is a column
    of ``work`` that always holds 0.0."""

    def __init__(self, work: np.ndarray, size: int, zero: int) -> None:
        self._work = work
        self._zero = zero
        self.index = np.full((2, size), zero, dtype=np.intp)
        self.factor = np.zeros(size)
        self._flat_index = self.index.reshape(-1)
        self._gathered = np.zeros((2, size))
        self._gathered_flat = self._gathered.reshape(-1)
        self._plus, self._minus = self._gathered
        self._difference = np.zeros(size)

    def put(self, cell: int, plus: int, minus: int | None = None, factor: float = 1.0) -> None:
        """Cell ``cell`` is ``(work[plus] - work[minus]) * factor`` (``work[plus] * factor`` when
        ``minus`` is None)."""
        self.index[0, cell] = plus
        self.index[1, cell] = self._zero if minus is None else minus
        self.factor[cell] = factor

    def put_vector(self, cell: int, frame: np.ndarray, plus: int, minus: int | None = None,
                   factor: float = 1.0) -> None:
        """Cells ``cell`` and ``cell + 1`` are ``frame @ (p - m) * factor``, ``p`` the pair of columns
        from ``plus`` (``x, y``) and ``m`` those from ``minus`` (zero when None); ``frame`` is 2 x 2
        with one nonzero entry in each row."""
        for row in range(2):
            k = int(np.flatnonzero(frame[row])[0])
            self.put(cell + row, plus + k, None if minus is None else minus + k, frame[row, k] * factor)

    def fill(self, out: np.ndarray) -> None:
        """Every cell into ``out`` (1-D, ``size`` cells; a float32 ``out`` gets the float64 values
        rounded)."""
        self._work.take(self._flat_index, out=self._gathered_flat)
        np.subtract(self._plus, self._minus, out=self._difference)
        np.multiply(self._difference, self.factor, out=out, casting="same_kind")
