"""BlowBlow's scripted play (see the Heuristic section of the game's manual): from the observation
alone, push the rival nearest the edge radially outward, by shoving and by blowing."""

from __future__ import annotations

import numpy as np

from arena_league.envs.games.blowblow.platform import (
    AGENT_RADIUS,
    BLOW_ACTION,
    DT,
    OTHER_CELLS,
    OWN_CELLS,
    VELOCITY_UNIT,
)
from arena_league.envs.physics2d import COMPASS_MOVES

__all__ = ["push_off"]


def push_off(obs: np.ndarray, action_type: str) -> np.ndarray:
    """Every seat's action, one row of ``obs`` each."""
    obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
    n_agents, rest = divmod(obs.shape[1] - 1, OTHER_CELLS)
    if rest or n_agents not in (2, 4):
        raise ValueError(f"BlowBlow heuristic: an observation of {obs.shape[1]} cells is not BlowBlow's "
                         f"({OTHER_CELLS} * n_agents + 1 cells, n_agents 2 or 4)")
    rows = np.arange(len(obs))
    on = obs[:, 0] > 0.5
    R = np.maximum(obs[:, 1] * 4.0, 1e-9)
    me = obs[:, 2:4] * R[:, None]
    velocity = obs[:, 4:6] * VELOCITY_UNIT
    ready = obs[:, 8] < 1e-6
    # the opponents: the last n_agents / 2 of the other seats
    first = OWN_CELLS + OTHER_CELLS * (n_agents // 2 - 1)
    blocks = obs[:, first: first + OTHER_CELLS * (n_agents // 2)].reshape(len(obs), -1, OTHER_CELLS)
    there = blocks[:, :, 0] > 0.5
    # the physics moves every body by its present velocity before the thrust acts: judge from
    # where the bodies will be after this step
    me_next = me + velocity * DT
    rivals = me[:, None, :] + blocks[:, :, 1:3] * R[:, None, None] + blocks[:, :, 3:5] * (VELOCITY_UNIT * DT)
    to_rivals = rivals - me_next[:, None, :]
    rival_distance = np.linalg.norm(to_rivals, axis=2)
    rival_radius = np.linalg.norm(rivals, axis=2)
    cost = np.where(there, rival_distance + 2.0 * (R[:, None] - rival_radius), np.inf)
    choice = cost.argmin(axis=1)
    rival = rivals[rows, choice]
    to_rival = to_rivals[rows, choice]
    distance = rival_distance[rows, choice]
    # pushed straight away from the centre; a rival at the centre, straight away from the seat
    toward = to_rival / np.maximum(distance, 1e-9)[:, None]
    from_centre = np.linalg.norm(rival, axis=1, keepdims=True)
    outward = np.where(from_centre > 0.3, rival / np.maximum(from_centre, 1e-9), toward)
    # run to a spot on the centre's side of the rival, then charge through it radially outward
    contact = 2 * AGENT_RADIUS
    spot = rival - outward * (contact + 0.25)
    behind = np.einsum("ij,ij->i", me_next - rival, outward)  # < 0: on the centre's side
    lateral = (me_next - rival) - behind[:, None] * outward
    lateral_length = np.linalg.norm(lateral, axis=1)
    lined_up = (behind < -0.5 * contact) & (lateral_length < 0.6 * contact)
    # when the rival stands between the seat and its spot, go round it on the seat's side
    side = np.where(lateral_length[:, None] > 1e-6, lateral / np.maximum(lateral_length, 1e-9)[:, None],
                    np.stack([-outward[:, 1], outward[:, 0]], axis=1))
    around = rival + side * (contact + 0.3) - outward * 0.3
    blocked = (behind > -0.5 * contact) & (lateral_length < contact + 0.25)
    waypoint = np.where(lined_up[:, None], rival + outward * 0.6, np.where(blocked[:, None], around, spot))
    way = waypoint - me_next
    heading = way / np.maximum(np.linalg.norm(way, axis=1, keepdims=True), 1e-9)
    drift = velocity - np.einsum("ij,ij->i", velocity, heading)[:, None] * heading
    heading = heading - 0.4 * drift
    # near the edge, back toward the centre
    radius = np.linalg.norm(me_next, axis=1)
    inward = -me_next / np.maximum(radius, 1e-9)[:, None]
    danger = np.clip((radius - (R - 0.6)) / 0.4, 0.0, 1.0)[:, None]
    heading = (1.0 - danger) * heading + danger * (2.0 * inward - 0.3 * velocity)
    direction = heading / np.maximum(np.linalg.norm(heading, axis=1), 1e-9)[:, None]
    if action_type == "continuous":
        move = direction
    else:
        k = np.round(np.arctan2(heading[:, 1], heading[:, 0]) / (np.pi / 4)).astype(np.int64) % 8
        move = COMPASS_MOVES[1 + k]
    # blow along the heading (a continuous thrust sets it first) when it points at the rival and
    # the blow pushes the rival outward, safely
    blows_along = move if action_type == "continuous" else obs[:, 6:8]
    aimed = np.einsum("ij,ij->i", blows_along, toward) > np.cos(np.radians(25.0))
    pushes_out = np.einsum("ij,ij->i", blows_along, outward) > 0.2
    recoiled = np.linalg.norm(me_next - blows_along * 0.5, axis=1) < R - 0.6
    blow = on & ready & there.any(axis=1) & aimed & pushes_out & recoiled & (distance < 2.0)
    if action_type == "continuous":
        return np.concatenate([np.where(on[:, None], move, 0.0), np.where(blow, 1.0, -1.0)[:, None]],
                              axis=1).astype(np.float32)
    return np.where(on, np.where(blow, BLOW_ACTION, 1 + k), 0).astype(np.int64)
