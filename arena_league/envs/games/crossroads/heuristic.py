"""Crossroads' scripted play: the heuristic, from the observation alone (the game's manual,
"Heuristic", says what it does). Imported by the game's rules only."""

from __future__ import annotations

import numpy as np

from arena_league.envs.games.crossroads import (
    ACTION_MEANINGS,
    AGENT_RADIUS,
    ARM_LENGTH,
    DT,
    ROAD_HALF_WIDTH,
    TURN_RATE,
    crossroads_observation,
)

__all__ = ["heuristic"]

#: The heuristic swerves around active agents ahead closer than this (centre to centre).
AVOID_RANGE = 2.0
_NOOP, _FORWARD, _LEFT, _RIGHT = (ACTION_MEANINGS.index(name)
                                  for name in ("noop", "forward", "turn_left", "turn_right"))
#: The observation's cells of the seat itself, and of every other seat after them.
_OWN_CELLS = crossroads_observation(1).size
_OTHER_CELLS = crossroads_observation(2).size - _OWN_CELLS


def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
    """Steer toward the target (from off the own road, toward the crossing first), keep to
    the right of active agents close ahead, turn toward the resulting direction, then drive."""
    obs = np.asarray(obs, dtype=np.float64)
    position = obs[:, 0:2] * ARM_LENGTH
    heading = obs[:, 4:6]
    aim = obs[:, 6:8] / np.maximum(obs[:, 8:9], 1e-9)
    # Pushed into a cross road (beyond the own road's edge, not yet past the crossing): the
    # straight line to the target would run into a wall corner, so head for the centre first.
    off_road = (np.abs(position[:, 1]) > ROAD_HALF_WIDTH - AGENT_RADIUS) & (position[:, 0] < ROAD_HALF_WIDTH)
    to_centre = -position / np.maximum(np.hypot(position[:, 0], position[:, 1]), 1e-9)[:, None]
    aim = np.where(off_road[:, None], to_centre, aim)
    # Active agents within AVOID_RANGE ahead on the way push the aim to the right of the line
    # toward them, so two agents meeting head-on both swerve right and pass each other.
    others = obs[:, _OWN_CELLS:].reshape(len(obs), -1, _OTHER_CELLS)
    offset = others[:, :, 0:2] * (2 * ARM_LENGTH)
    gap = np.maximum(np.hypot(offset[:, :, 0], offset[:, :, 1]), 1e-9)
    toward = offset / gap[:, :, None]
    ahead = np.einsum("nkc,nc->nk", toward, aim) > 0.5  # ahead on the way, whatever the heading
    weight = np.clip((AVOID_RANGE - gap) / (AVOID_RANGE - 2 * AGENT_RADIUS), 0.0, 1.0)
    weight *= ahead * (others[:, :, 4] > 0.5)
    right_of = np.stack([toward[:, :, 1], -toward[:, :, 0]], axis=2)
    aim = aim + np.einsum("nk,nkc->nc", weight, right_of - 0.5 * toward)
    error = np.arctan2(heading[:, 0] * aim[:, 1] - heading[:, 1] * aim[:, 0],
                       heading[:, 0] * aim[:, 0] + heading[:, 1] * aim[:, 1])
    active = obs[:, 9] > 0.5
    if action_type == "discrete":
        half_turn = 0.5 * TURN_RATE * DT
        action = np.where(error > half_turn, _LEFT, np.where(error < -half_turn, _RIGHT, _FORWARD))
        return np.where(active, action, _NOOP).astype(np.int64)
    turn = np.clip(error / (TURN_RATE * DT), -1.0, 1.0)
    thrust = np.clip(np.cos(error), 0.0, 1.0)
    return (np.stack([thrust, turn], axis=1) * active[:, None]).astype(np.float32)
