"""Observation and state layouts as named runs of cells, with their bounds and meanings.

A game lists its observation (or global state) as :class:`Run` records, in cell order; the layout
gives each run's first cell by name (so the matrices that fill the observation say ``"ball"``,
not 7), the bounds the env's observation space is built from, and the table its manual prints.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

__all__ = ["CellLayout", "Run"]


@dataclass(frozen=True)
class Run:
    """``size`` cells named ``name``; ``bounds`` is one ``(low, high)`` for every cell or one per cell."""

    name: str
    size: int
    bounds: tuple[float, float] | tuple[tuple[float, float], ...]
    meaning: str = ""

    def cell_bounds(self) -> list[tuple[float, float]]:
        if len(self.bounds) == 2 and not isinstance(self.bounds[0], tuple):
            return [self.bounds] * self.size  # type: ignore[list-item]
        if len(self.bounds) != self.size:
            raise ValueError(f"run {self.name}: {len(self.bounds)} bounds for {self.size} cells")
        return list(self.bounds)  # type: ignore[arg-type]


class CellLayout:
    """Runs of cells in order: :meth:`at` a run's first cell, :meth:`bounds` every cell's."""

    def __init__(self, runs: Iterable[Run]) -> None:
        self.runs = tuple(runs)
        self._at: dict[str, int] = {}
        cell = 0
        for run in self.runs:
            if run.name in self._at:
                raise ValueError(f"two runs named {run.name!r}")
            self._at[run.name] = cell
            cell += run.size
        self.size = cell

    def at(self, name: str, k: int = 0) -> int:
        """The index of cell ``k`` of run ``name``."""
        return self._at[name] + k

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` of every cell, float32 (the env's Box bounds)."""
        pairs = [pair for run in self.runs for pair in run.cell_bounds()]
        low = np.array([p[0] for p in pairs], dtype=np.float32)
        high = np.array([p[1] for p in pairs], dtype=np.float32)
        return low, high

    def table(self) -> list[dict]:
        """One row per run: its cells, name, bounds and meaning (for manuals and the docs)."""
        rows = []
        for run in self.runs:
            start = self._at[run.name]
            cells = f"{start}" if run.size == 1 else f"{start}-{start + run.size - 1}"
            bounds = sorted(set(run.cell_bounds()))
            rows.append({"cells": cells, "name": run.name, "bounds": [list(b) for b in bounds],
                         "meaning": run.meaning})
        return rows
