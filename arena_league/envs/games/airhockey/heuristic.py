"""AirHockey's scripted play: the heuristic, from the observation alone (the game's manual,
"Heuristic", says what it does). Imported by the game's rules only."""

from __future__ import annotations

import numpy as np

from arena_league.envs.games.airhockey import (
    BARRIER_RADIUS,
    CORNER_CHAMFER,
    DEFAULT_GOAL_WIDTH,
    ELASTICITY,
    HALF_LENGTH,
    HALF_WIDTH,
    MALLET_RADIUS,
    MALLET_TOP_SPEED,
    PUCK_RADIUS,
    VELOCITY_UNIT,
)
from arena_league.envs.physics2d.ballgames import drive_through

__all__ = ["heuristic"]


def _rebound_y(y: np.ndarray) -> np.ndarray:
    """Where a puck's straight path, whose ``y`` would be ``y`` without the side rails, lies once
    it has rebounded from them (each rebound mirrors the path; the corners' chamfers ignored)."""
    half = HALF_WIDTH - PUCK_RADIUS
    folded = np.mod(y + half, 4 * half)
    return np.where(folded > 2 * half, 4 * half - folded, folded) - half


def _clearance(start: np.ndarray, end: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Per row, the least distance from the ``points`` (``[N, K, 2]``) to the segment from
    ``start`` to ``end`` (``[N, 2]`` each)."""
    way = (end - start)[:, None, :]
    offset = points - start[:, None, :]
    t = np.clip((offset * way).sum(axis=2) / np.maximum((way * way).sum(axis=2), 1e-9), 0.0, 1.0)
    return np.linalg.norm(offset - t[..., None] * way, axis=2).min(axis=1)


def _shot(puck: np.ndarray, mouth: np.ndarray, opponents: np.ndarray) -> np.ndarray:
    """Where to send the puck, per row: at the ``mouth`` straight, or at the point of a side rail
    from which it rebounds into the mouth, whichever way passes furthest from the ``opponents``
    (the straight shot preferred by 0.4). A rebound keeps only the rail's restitution (0.9) of the
    puck's speed across the rail, so the path after it is flatter: the mouth's mirror image, at
    which the puck is sent, lies 1 / 0.9 times as far beyond the rail as the mouth is inside it."""
    half = HALF_WIDTH - PUCK_RADIUS
    restitution = ELASTICITY["puck"] * ELASTICITY["rail"]
    straight = _clearance(puck, mouth, opponents) + 0.4
    aims, scores = [mouth], [straight]
    for side in (1.0, -1.0):
        mirrored_y = side * half + (side * half - mouth[:, 1]) / restitution
        share = (side * half - puck[:, 1]) / (mirrored_y - puck[:, 1])
        rail = np.stack([puck[:, 0] + share * (mouth[:, 0] - puck[:, 0]), np.full(len(puck), side * half)], axis=1)
        # a rebound from the corner's chamfer goes astray
        clear = rail[:, 0] < HALF_LENGTH - CORNER_CHAMFER - 0.3
        score = np.minimum(_clearance(puck, rail, opponents), _clearance(rail, mouth, opponents))
        aims.append(rail)
        scores.append(np.where(clear, score, -np.inf))
    best = np.argmax(np.stack(scores, axis=1), axis=1)
    return np.stack(aims, axis=1)[np.arange(len(puck)), best]



def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
    """Every seat's action from its observation (rows of ``obs``): strike, block or keep goal."""
    obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
    n_agents = (obs.shape[1] - 15) // 4 + 1
    n_mates = n_agents // 2 - 1  # AirHockey always has two teams
    me = obs[:, 1:3] * HALF_LENGTH
    velocity = obs[:, 3:5] * VELOCITY_UNIT
    puck_now = obs[:, 7:9] * HALF_LENGTH
    puck_velocity = obs[:, 9:11] * VELOCITY_UNIT
    goal = me + obs[:, 11:13] * HALF_LENGTH
    own_goal = me + obs[:, 13:15] * HALF_LENGTH
    # lead the sliding puck by about the time the mallet needs to get there (at most 0.6 s)
    eta = np.minimum(np.linalg.norm(puck_now - me, axis=1) / MALLET_TOP_SPEED, 0.6)
    puck_limit = np.array([HALF_LENGTH - PUCK_RADIUS, HALF_WIDTH - PUCK_RADIUS])
    puck = np.clip(puck_now + puck_velocity * eta[:, None], -puck_limit, puck_limit)
    contact = MALLET_RADIUS + PUCK_RADIUS
    rel = me - puck
    # the seat's half in its frame: clear of the rails, the goal-mouth bar and the centre line
    low = np.array([-HALF_LENGTH + MALLET_RADIUS + BARRIER_RADIUS, -HALF_WIDTH + MALLET_RADIUS])
    high = np.array([-(MALLET_RADIUS + BARRIER_RADIUS) - 0.02, HALF_WIDTH - MALLET_RADIUS])
    in_reach = puck[:, 0] < high[0] + contact - 0.05

    # roles: the teammate nearest the puck strikes; the others keep goal
    my_distance = np.linalg.norm(rel, axis=1)
    rank = np.zeros(len(obs), dtype=np.int64)
    for k in range(n_mates):
        mate = me + obs[:, 15 + 4 * k: 17 + 4 * k] * HALF_LENGTH
        rank += np.linalg.norm(mate - puck, axis=1) < my_distance
    striking = (rank == 0) & in_reach
    first = 15 + 4 * n_mates
    opponents = me[:, None, :] + np.stack(
        [obs[:, first + 4 * k: first + 4 * k + 2] for k in range(n_mates + 1)], axis=1) * HALF_LENGTH
    # a puck in the own half sliding at the own goal's mouth (off the side rails too), with the
    # striker not between it and the goal, is blocked on its path in front of the goal
    coming = puck_velocity[:, 0] < -0.3
    slope = puck_velocity[:, 1] / np.where(coming, puck_velocity[:, 0], -1.0)
    at_goal_line = _rebound_y(puck_now[:, 1] + slope * (own_goal[:, 0] - puck_now[:, 0]))
    dangerous = coming & (puck_now[:, 0] < 0.0) & (np.abs(at_goal_line) < DEFAULT_GOAL_WIDTH / 2 + 0.2)
    blocking = (rank == 0) & dangerous & (me[:, 0] > puck_now[:, 0] - contact)
    block_x = np.maximum(low[0], np.minimum(own_goal[:, 0] + 0.6, puck_now[:, 0] - contact - 0.2))
    block_spot = np.stack([block_x, _rebound_y(puck_now[:, 1] + slope * (block_x - puck_now[:, 0]))], axis=1)
    striking &= ~blocking
    # out of reach, wait on the line from the own goal to the puck: the striker well out, a
    # keeper close in
    guard = puck - own_goal
    guard /= np.maximum(np.linalg.norm(guard, axis=1, keepdims=True), 1e-9)
    guard_spot = own_goal + guard * np.where(rank == 0, 1.5, 0.9)[:, None]

    # the striker runs to a spot behind the puck on the line from the goal mouth through it,
    # then drives through; where that spot lies outside the half, the nearest spot inside
    # sets the shot's direction. A puck deep in the own end is first cleared away from the
    # own goal (the striker then stands between the two).
    aim = _shot(puck, goal + np.array([0.3, 0.0]), opponents) - puck
    aim /= np.maximum(np.linalg.norm(aim, axis=1, keepdims=True), 1e-9)
    deep = puck[:, 0] - own_goal[:, 0] < 1.2
    aim = np.where(deep[:, None], guard, aim)
    behind_spot = puck - aim * (contact + 0.5)  # a run-up, to strike hard
    target = np.where(blocking[:, None], block_spot, guard_spot)
    target = np.clip(np.where(striking[:, None], behind_spot, target), low, high)
    # a striker driving through goes at full thrust
    return drive_through(me, velocity, puck, target, contact, low, high, striking, striking, True, action_type)
