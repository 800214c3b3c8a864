"""The base of a 2D game's rules, and what the 2D games share: seat frames, compass moves, options.

:class:`Physics2DRules` checks the layout and the game's declared options, records the calls that
pickling replays (pymunk's contact caches cannot be copied, see
:class:`~arena_league.envs.core.ReplayedMatch`), and gives the common tools: observations clipped
to their declared bounds, the seats' frames (a two-team field mirrored in x, :func:`mirror_signs`;
an n-team field turned about its centre, :func:`team_turns`), the compass moves a discrete action
names, and the teams ranked by score (:func:`team_ranks`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from arena_league.envs.core import GameRules, ReplayedMatch
from arena_league.envs.physics2d.cells import CellLayout

__all__ = ["COMPASS_MOVES", "COMPASS_MOVE_NAMES", "Physics2DRules", "SeatThrust", "mirror_signs", "team_ranks", "team_turns"]

#: The 2D games' discrete moves, in the seat frame: noop, then a unit thrust counter-clockwise from
#: ``+x`` (E), 45 degrees apart.
COMPASS_MOVE_NAMES = ("noop", "E", "NE", "N", "NW", "W", "SW", "S", "SE")
COMPASS_MOVES = np.array([(0.0, 0.0)] + [(np.cos(k * np.pi / 4), np.sin(k * np.pi / 4)) for k in range(8)])
COMPASS_MOVES[np.abs(COMPASS_MOVES) < 1e-12] = 0.0
COMPASS_MOVES.flags.writeable = False


class SeatThrust:
    """Sets each seat's thrust, in its own frame, from its action, and its ``energy`` measure.

    ``thrust`` is the seats' thrust slot read as complex numbers ``x + iy`` (one per seat). A
    discrete action names a compass move at full strength (energy 1, noop 0); a continuous one is
    the thrust itself, scaled back to length 1 when longer, so diagonals are no stronger (energy its
    squared length, at most 1).
    """

    def __init__(self, thrust: np.ndarray, action_type: str) -> None:
        self.thrust = thrust
        self.pairs = thrust.view(np.float64).reshape(-1, 2)
        self.length = np.zeros(len(thrust))
        self.discrete = action_type == "discrete"
        self.moves = np.ascontiguousarray(COMPASS_MOVES).view(np.complex128).reshape(-1)
        self.move_energy = (COMPASS_MOVES**2).sum(axis=1)
        self._flat = self.pairs.reshape(-1)
        #: Each move's ``[x, y]`` and length (numpy's complex abs, which is not Python's hypot), as
        #: Python floats.
        self.move_pairs = COMPASS_MOVES.tolist()
        self.move_lengths = np.abs(self.moves).tolist()
        self._move_energy = self.move_energy.tolist()
        self._scaled = False
        self._ones = np.ones(len(thrust))
        self._divisor = np.zeros(len(thrust), dtype=np.complex128)
        self._divisor_real = self._divisor.real

    def set(self, actions: np.ndarray, energy: np.ndarray) -> None:
        thrust = self.thrust
        if self.discrete:
            self.moves.take(actions, out=thrust)
            self.move_energy.take(actions, out=energy)
            return
        self.pairs[:] = actions
        length = np.abs(thrust, out=self.length)
        np.square(length, out=energy)
        # (a Python max of a few cells is cheaper than the two ufuncs when no thrust is too long)
        self._scaled = max(energy.tolist()) > 1.0
        if self._scaled:
            # (arrays of ones and a complex divisor: a scalar or a float divisor costs numpy a cast)
            np.minimum(energy, self._ones, out=energy)
            np.maximum(length, self._ones, out=self._divisor_real)
            np.divide(thrust, self._divisor, out=thrust)

    def listed(self) -> tuple[list[float], list[float]]:
        """After a continuous :meth:`set`: the thrust (``x, y`` seat after seat) and each seat's
        thrust length (numpy's ``abs`` of :attr:`thrust`), as Python floats."""
        length = np.abs(self.thrust, out=self.length) if self._scaled else self.length
        return self._flat.tolist(), length.tolist()

    def set_moves(self, actions: list[int], energy: np.ndarray) -> None:
        """A discrete :meth:`set` from the actions as a list of ints, bit for bit (on a few seats,
        cheaper than numpy's takes)."""
        pairs = []
        for action in actions:
            pairs += self.move_pairs[action]
        self._flat[:] = pairs
        move_energy = self._move_energy
        energy[:] = [move_energy[action] for action in actions]


def mirror_signs(team_of: np.ndarray) -> np.ndarray:
    """The x sign of each seat's frame in a two-team game played on a field mirrored in x: +1
    for team 0 (the world frame), -1 for team 1, so that every seat attacks ``+x``."""
    return np.where(team_of == 0, 1.0, -1.0)


def team_turns(n_teams: int) -> np.ndarray:
    """``float64[n_teams, 2, 2]``: the rotation by ``t * 360 / n_teams`` degrees for each team ``t``
    of a field with the layout's rotational symmetry (team ``t``'s side is team 0's turned so),
    exact for the half and quarter turns (entries 0 and +-1). A seat's frame is the world turned
    back by its team's turn: the transpose."""
    angles = 2.0 * np.pi * np.arange(n_teams) / n_teams
    cos, sin = np.round(np.cos(angles), 12), np.round(np.sin(angles), 12)
    return np.stack([np.stack([cos, -sin], axis=1), np.stack([sin, cos], axis=1)], axis=1) + 0.0


def team_ranks(score: np.ndarray) -> np.ndarray:
    """Each team's result from its ``score`` (more is better): the number of teams it beat plus
    half the number it tied with (1 / 0.5 / 0 with two teams; ``n_teams - 1`` for a clear first)."""
    beaten = (score[:, None] > score[None, :]).sum(axis=1)
    tied = (score[:, None] == score[None, :]).sum(axis=1) - 1
    return beaten + 0.5 * tied


class Physics2DRules(ReplayedMatch, GameRules):
    """Rules over the 2D engine; a game declares its ``options`` and builds its
    :class:`~arena_league.envs.physics2d.world.World` in ``__init__`` after calling this one.

    After this constructor, ``self.settings`` holds every option's value by name.
    """

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs: Any) -> None:
        self.check_layout(n_teams, players_per_team, action_type)
        self.settings = self.checked_options(kwargs)
        super().__init__(n_teams, players_per_team, action_type)
        self._arguments = ((n_teams, players_per_team, action_type), dict(kwargs))
        self._calls = []
        self._events: list[dict] = []

    def clip_bounds(self, layout: CellLayout) -> tuple[np.ndarray, np.ndarray]:
        """Every seat's observation bounds of ``layout``, flattened seat after seat, as float64
        (what :meth:`observe` clips the product of the observation matrix to)."""
        low, high = layout.bounds()
        return np.tile(low.astype(np.float64), self.n_agents), np.tile(high.astype(np.float64), self.n_agents)

    @staticmethod
    def clip_into(values: np.ndarray, low: np.ndarray, high: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``values`` clipped to ``[low, high]`` through ``out``, as float32: an observation the
        game's step computed with its measures (two ufuncs clip a few cells faster than np.clip)."""
        clipped = np.minimum(values, high, out=out)
        return np.maximum(clipped, low, out=clipped).astype(np.float32)

    def other_seats(self, seat: int) -> list[int]:
        """The other seats in the order ``seat`` observes them: teammates first, then opponents,
        each in seat order."""
        team = self.team_of[seat]
        mates = [j for j in range(self.n_agents) if j != seat and self.team_of[j] == team]
        return mates + [j for j in range(self.n_agents) if self.team_of[j] != team]

    def events(self) -> list[dict]:
        return list(self._events)
