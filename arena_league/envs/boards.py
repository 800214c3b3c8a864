"""What the grid games played on batched boards share (Snake, Boomer, CaptureFlag).

Such a game keeps its rules once, in a whole-array engine of many boards, and reaches it two ways:
its :class:`~arena_league.envs.core.GameRules` plays board 0 of a one-board engine
(:class:`OneBoard`; CaptureFlag's plays a scalar copy of one board, checked against it), and its
``batched_matches`` plays one match per board of a wide one (:class:`BoardSlots`).
:func:`reset_keys` checks the boards and keys a ``reset`` is given, and :func:`grow` is the
4-neighbour step of the flood fills their map makers and distance fields use.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["BoardSlots", "OneBoard", "grow", "reset_keys"]


class OneBoard:
    """A rules mixin (listed before ``GameRules``) for a match that is board 0 of ``self.engine``,
    whose step leaves the step's events in ``self._events``."""

    engine: Any
    _events: list[dict]

    def team_result(self) -> np.ndarray:
        return self.engine.team_scores()[0]

    def events(self) -> list[dict]:
        return list(self._events)

    def observe(self) -> np.ndarray:
        return self.engine.observe()[0]

    def state(self) -> np.ndarray:
        return self.engine.state()[0]


def reset_keys(every: np.ndarray, rng: np.random.Generator, boards: Any = None, keys: Any = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """``(boards, keys)`` of an engine's ``reset(boards, keys)``: the boards indexed (``every`` board
    by default) and one ``uint64`` key each, drawn from ``rng`` unless given."""
    sel = every if boards is None else np.asarray(boards, dtype=np.int64).reshape(-1)
    if keys is None:
        keys = rng.integers(0, 2**64, size=sel.size, dtype=np.uint64)
    keys = np.asarray(keys, dtype=np.uint64).reshape(-1)
    if keys.shape != sel.shape:
        raise ValueError(f"reset got {keys.size} keys for {sel.size} boards; give one uint64 key per board")
    return sel, keys


class BoardSlots:
    """A ``batched_matches`` mixin for a match engine whose slot ``k`` is board ``k`` of
    ``self.boards``, whose observation is the boards' own and whose every action is legal."""

    boards: Any

    def observe(self) -> np.ndarray:
        return self.boards.observe()

    def action_mask(self) -> None:
        return None  # every action is always legal

    def state(self) -> np.ndarray:
        """``float32[n_slots, state_dim]``: every match's global state, as the rules give it."""
        return self.boards.state()

    def team_result(self, slot: int) -> np.ndarray:
        return self.boards.team_scores(np.array([slot]))[0]

    def pair_points(self, slot: int) -> np.ndarray:
        """What each team scored toward its pair: the team result, as the rules' ``pair_points``."""
        return self.team_result(slot)


def grow(reached: np.ndarray, open_: np.ndarray) -> np.ndarray:
    """``bool[B, R, C]``: the cells of ``open_`` that ``reached`` holds or touches along a side."""
    grown = reached.copy()
    grown[:, 1:] |= reached[:, :-1]
    grown[:, :-1] |= reached[:, 1:]
    grown[:, :, 1:] |= reached[:, :, :-1]
    grown[:, :, :-1] |= reached[:, :, 1:]
    grown &= open_
    return grown
