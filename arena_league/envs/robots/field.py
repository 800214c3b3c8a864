"""The field between two lines that RunToGoal and YouShallNotPass are played on, and the sidestep
their heuristics take round an opponent.

The field is flat, with a line across it at each end, ``x = -field_length / 2`` and
``x = +field_length / 2`` (the option :data:`FIELD_LENGTH`); the top-down picture shows it with a
metre of margin. Games on it subclass :class:`LinedField` and place their robots on it.
"""

from __future__ import annotations

import numpy as np

from arena_league.envs.options import Option
from arena_league.envs.robots import observation as cells
from arena_league.envs.robots.game import RobotGameRules
from arena_league.envs.robots.scene import SceneLayout

__all__ = ["AVOID_AHEAD", "AVOID_SIDE", "FIELD_LENGTH", "LinedField", "avoid"]

FIELD_LENGTH = Option("field_length", float, 5.0, "distance between the two lines, in m", low=3.0, high=10.0)
#: A runner steps aside when the opponent is closer than this ahead of it, and this near its line
#: of run.
AVOID_AHEAD = 1.6
AVOID_SIDE = 1.0


class LinedField(RobotGameRules):
    """Two ants on the field between two lines (the game declares ``FIELD_LENGTH`` among its options)."""

    @property
    def half_length(self) -> float:
        return self.settings["field_length"] / 2

    def scene_layout(self) -> SceneLayout:
        h = self.half_length
        return SceneLayout(robots=("ant", "ant"), teams=(0, 1),
                           markings=(("line", (-h, -3.0, -h, 3.0)), ("line", (h, -3.0, h, 3.0))))

    def view_extent(self) -> tuple[float, float, float, float]:
        h = self.half_length + 1.0
        return (-h, h, -h, h)


def avoid(obs_opponent: np.ndarray, heading: np.ndarray, strength: float = 1.0) -> np.ndarray:
    """A sideways step (seat frame, ``[N, 2]``) away from an opponent that stands in the way of a
    run along ``heading`` (``[N, 2]`` unit vectors); ``obs_opponent`` are its observation cells."""
    rel = obs_opponent[:, 0:2] * cells.POSITION_UNIT
    ahead = np.einsum("ij,ij->i", rel, heading)
    side_axis = np.stack([-heading[:, 1], heading[:, 0]], axis=1)
    side = np.einsum("ij,ij->i", rel, side_axis)
    in_way = (ahead > 0.0) & (ahead < AVOID_AHEAD) & (np.abs(side) < AVOID_SIDE)
    away = np.where(side >= 0.0, -1.0, 1.0)  # step to the side the opponent is not on
    weight = np.where(in_way, strength * (1.0 - np.abs(side) / AVOID_SIDE), 0.0)
    return (away * weight)[:, None] * side_axis
