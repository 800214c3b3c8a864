"""FightForFood's scripted play: the heuristic and the search agent that plans over a model of the
pen, from the observation alone (the rules offer them as ``heuristic`` and ``search``; the game's
manual is the package's docstring).

Heuristic
    From the observation alone. For every pellet still there it compares the seat's distance with
    the nearest other agent's (teammates count, so that teammates split the food), and heads for
    the pellet of least ``d_own + 2 * max(0, d_own - d_other + 0.1)``: the nearest one it reaches
    first, else the least contested. Distances are judged from where every body will be after the
    step (pymunk moves a body by its present velocity before the thrust acts; judged from where
    they are, a seat between two pellets turns from one to the other every step). It steers at
    full thrust, damping its sideways drift, and does not shove rivals on purpose.

Search agent (``scripted:search-wW-rR-hH[-eE][-v2]``, :func:`plan_moves`)
    A planner over a model of the pen, from the observation alone (it holds the whole state). Its
    candidates are the ``W`` pellets the heuristic likes best. For each it plays ``R`` rollouts of
    ``H`` steps of a point-mass model: every body moves by its velocity, then thrusts at full
    strength as the heuristic steers it, under the game's damping and drag; the nearest agent within
    reach of a pellet eats it. The seat heads for the candidate until it is gone and then plays the
    heuristic; every other agent plays the heuristic, its pellet costs jittered by a uniform draw of
    up to ``E`` times the pen's side (6) in each rollout (``E`` = 0: one rollout says all). A
    rollout's value is the food the seat's team ate less the best other team's, each pellet left at
    the horizon counting a half for the team whose agent is nearest; the seat steers, as the
    heuristic does, for the candidate of the highest mean value (ties: the heuristic's order). Its
    draws come from a generator seeded by the seat's uniform, so a match replays exactly. ``W`` = 1
    is the heuristic.

    Two versions. The first (no suffix; the searchers of the ``base-v1`` population) leaves contacts
    out and steers every body in any direction. The second (``-v2``) models what the first left
    out: with discrete actions every body thrusts along one of the eight moves of the action table,
    as the heuristic's rounded heading does; agents that touch rebound (restitution 0.25, equal
    masses, overlaps pushed apart) and the walls stop them (restitution 0.4), so the planner sees a
    rival it would bump and a shove that clears a pellet. Against the heuristic (2T1P, discrete, 100
    matches, seats alternating; ``python benchmarks/search_agents.py FightForFood-2T1P-v1 ...``):
    ``search-w8-r1-h40`` won 64, drew 33 and lost 3, ``search-w8-r1-h40-v2`` won 91 and drew 9;
    ``search-w4-r1-h40`` 57, 40 and 3, its ``-v2`` 79 and 21. Two heuristics mirror each other to a
    6 to 6 draw; the planner finds the pellet that breaks the tie.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from arena_league.envs.games.fightforfood.pen import (
    AGENT_DRAG,
    AGENT_MASS,
    AGENT_RADIUS,
    DT,
    EAT_DISTANCE,
    ELASTICITY,
    FOOD_RANGE,
    HALF_SIZE,
    SPACE_DAMPING,
    THRUST,
    VELOCITY_UNIT,
)
from arena_league.envs.physics2d import COMPASS_MOVES

__all__ = ["SEARCH_BUDGET_MEANING", "SEARCH_VERSIONS", "heuristic", "plan_moves"]

#: What a FightForFood search agent's budget means (the population provenance quotes it).
SEARCH_BUDGET_MEANING = ("the W pellets the heuristic likes best, each tried first in R rollouts of H steps of a "
                         "point-mass model of the pen where the others play the heuristic, their pellet costs "
                         "jittered by up to E of the pen's side; -v2 models the contacts between agents and with "
                         "the walls, and the eight moves of the discrete action table")
#: The search agent's versions ("Search agent" above).
SEARCH_VERSIONS = (1, 2)

_VELOCITY_KEPT = SPACE_DAMPING ** DT  # the share of its velocity a body keeps over one step
# pymunk's restitution of a contact is the product of the two shapes' elasticities
_AGENT_RESTITUTION = ELASTICITY["agent"] ** 2
_WALL_RESTITUTION = ELASTICITY["agent"] * ELASTICITY["wall"]
_REACH = HALF_SIZE - AGENT_RADIUS  # the walls keep an agent's centre within this of the centre
#: obs_dim - 3 * food of each layout: tells the heuristic the layout from the observation's length.
_OBS_BASE = {(2, 1): 12, (2, 2): 20, (4, 1): 22}


def _observation_layout(obs_dim: int) -> tuple[int, int, int]:
    """``(n_teams, players_per_team, food)`` of the observation length ``obs_dim``."""
    for (teams, players), base in _OBS_BASE.items():
        food, rest = divmod(obs_dim - base, 3)
        if rest == 0 and food % teams == 0 and FOOD_RANGE[0] <= food <= FOOD_RANGE[1]:
            return teams, players, food
    raise ValueError(f"FightForFood heuristic: an observation of {obs_dim} cells is not FightForFood's "
                     "(6 + n_teams + 3 * food + 4 * (n_agents - 1) cells)")


@dataclass(frozen=True)
class _Seen:
    """What the heuristic and the search read from FightForFood observations (``N`` rows)."""

    layout: tuple[int, int, int]  # n_teams, players per team, food
    place: np.ndarray  # [N, 2], the seat's own position
    velocity: np.ndarray  # [N, 2], the seat's own
    to_pellet: np.ndarray  # [N, food, 2], pellet - seat
    there: np.ndarray  # [N, food], still-there flags
    others: np.ndarray  # [N, others, 4], each other seat's offset and velocity cells as observed
    ahead: np.ndarray  # [N, food, 2], pellet - seat after this step's drift
    others_ahead: np.ndarray  # [N, others, 2], each other seat - seat after this step's drift


def _seen(obs: np.ndarray) -> _Seen:
    """The observation read as the heuristic reads it. The physics moves every body by its present
    velocity before the thrust acts: offsets are judged from where the bodies will be after this step."""
    obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
    n_teams, players, food = _observation_layout(obs.shape[1])
    velocity = obs[:, 3:5] * VELOCITY_UNIT
    first = 6 + n_teams
    pellets = obs[:, first: first + 3 * food].reshape(-1, food, 3)
    to_pellet = pellets[:, :, 0:2] * HALF_SIZE
    others = obs[:, first + 3 * food:].reshape(-1, n_teams * players - 1, 4)
    drift = velocity[:, None, :] * DT
    return _Seen((n_teams, players, food), obs[:, 1:3] * HALF_SIZE, velocity, to_pellet, pellets[:, :, 2] > 0.5,
                 others, to_pellet - drift, others[:, :, 0:2] * HALF_SIZE + others[:, :, 2:4] * (VELOCITY_UNIT * DT) - drift)


def _pellet_costs(to_pellet: np.ndarray, others: np.ndarray, there: np.ndarray) -> np.ndarray:
    """The heuristic's cost of every pellet, ``[..., food]``, from the seat's offsets to the pellets
    ``[..., food, 2]``, the other agents' offsets from the seat ``[..., others, 1, 2]`` and the
    still-there flags: its own distance, plus twice what it lags the nearest other agent (teammates
    too: they split the food) by more than -0.1; inf for eaten pellets."""
    own_distance = np.linalg.norm(to_pellet, axis=-1)
    other_distance = np.linalg.norm(to_pellet[..., None, :, :] - others, axis=-1).min(axis=-2)
    cost = own_distance + 2.0 * np.maximum(0.0, own_distance - other_distance + 0.1)
    return np.where(there, cost, np.inf)


def _steer(velocity: np.ndarray, way: np.ndarray, any_left: np.ndarray, action_type: str) -> np.ndarray:
    """The heuristic's action toward offset ``way`` (``[N, 2]``): full thrust along it, less the
    sideways drift of ``velocity``; noop (or no thrust) where no food is left."""
    distance = np.linalg.norm(way, axis=1, keepdims=True)
    direction = way / np.maximum(distance, 1e-9)
    drift = velocity - np.einsum("ij,ij->i", velocity, direction)[:, None] * direction
    heading = np.where(any_left[:, None], direction - 0.5 * drift, 0.0)
    length = np.linalg.norm(heading, axis=1)
    if action_type == "continuous":
        return np.clip(heading / np.maximum(length, 1e-9)[:, None], -1.0, 1.0).astype(np.float32)
    return np.where(length < 1e-6, 0, _move_of(heading)).astype(np.int64)


def _move_of(heading: np.ndarray) -> np.ndarray:
    """The discrete move (1 to 8) nearest each heading ``[..., 2]``."""
    angle = np.arctan2(heading[..., 1], heading[..., 0])
    return 1 + np.round(angle / (np.pi / 4)).astype(np.int64) % 8


def _contacts(pos: np.ndarray, vel: np.ndarray, own: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The search model's contacts (version 2), after a step: agents ``[..., A, 2]`` (positions in the
    seat's frame, relative to the seat's place ``own`` at the start) that overlap and close in rebound
    as equal masses do and are pushed apart; an agent past a wall is put back on it, its speed into
    the wall reversed and scaled by the wall's restitution."""
    n_agents = pos.shape[-2]
    for i in range(n_agents):
        for j in range(i + 1, n_agents):
            apart = pos[..., j, :] - pos[..., i, :]
            distance = np.linalg.norm(apart, axis=-1, keepdims=True)
            normal = apart / np.maximum(distance, 1e-9)
            closing = ((vel[..., j, :] - vel[..., i, :]) * normal).sum(axis=-1, keepdims=True)
            touching = distance < 2 * AGENT_RADIUS
            impulse = np.where(touching & (closing < 0), -(1 + _AGENT_RESTITUTION) * closing / 2, 0.0) * normal
            vel[..., i, :] -= impulse
            vel[..., j, :] += impulse
            overlap = np.where(touching, AGENT_RADIUS - distance / 2, 0.0) * normal
            pos[..., i, :] -= overlap
            pos[..., j, :] += overlap
    place = pos + own
    out = np.abs(place) > _REACH
    side = np.sign(place)
    vel = np.where(out & (vel * side > 0), -_WALL_RESTITUTION * vel, vel)
    pos = np.where(out, side * _REACH - own, pos)
    return pos, vel


def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
    """The heuristic's action per observation row (the manual's "Heuristic")."""
    seen = _seen(obs)
    choice = _pellet_costs(seen.ahead, seen.others_ahead[:, :, None, :], seen.there).argmin(axis=1)
    return _steer(seen.velocity, seen.ahead[np.arange(len(choice)), choice], seen.there.any(axis=1), action_type)


def plan_moves(obs: np.ndarray, uniforms: np.ndarray, *, width: int, rollouts: int, horizon: int,
               epsilon: float, action_type: str = "discrete", version: int = 1) -> np.ndarray:
    """The FightForFood search agent's action per observation row (module docstring, "Search
    agent"): ``float32[N, obs_dim]`` and one uniform per seat to ``int64[N]`` (or ``float32[N, 2]``)."""
    if version not in SEARCH_VERSIONS:
        raise ValueError(f"FightForFood's search has versions {SEARCH_VERSIONS}, not {version!r}")
    seen = _seen(obs)
    n_teams, players, food = seen.layout
    n, n_agents = len(seen.there), n_teams * players
    velocity, there, to_pellet, others = seen.velocity, seen.there, seen.to_pellet, seen.others
    if n == 0 or width == 1 or not there.any():  # one candidate: the heuristic's own pellet
        return heuristic(obs, action_type)
    # the pen in the seat's frame, the seat at the origin: agents [N, A, 2] (the seat first)
    position = np.concatenate([np.zeros((n, 1, 2)), others[:, :, 0:2] * HALF_SIZE], axis=1)
    speed = np.concatenate([velocity[:, None, :], others[:, :, 2:4] * VELOCITY_UNIT], axis=1)
    team = np.arange(n_agents) // players  # the seat's team is 0, the others' in turn order
    # candidates: the W pellets the heuristic likes best (judged as the heuristic judges them)
    ahead = seen.ahead
    order = np.argsort(_pellet_costs(ahead, seen.others_ahead[:, :, None, :], there), axis=1, kind="stable")
    width = min(width, food)
    candidate = order[:, :width]  # [N, W]
    # the rollouts: batch rows (seat, candidate, rollout)
    batch = (n, width, rollouts)
    expand = (slice(None), None, None)
    pos = np.broadcast_to(position[expand], (*batch, n_agents, 2)).copy()
    vel = np.broadcast_to(speed[expand], (*batch, n_agents, 2)).copy()
    food_at = np.broadcast_to(to_pellet[expand], (*batch, food, 2))
    left = np.broadcast_to(there[expand], (*batch, food)).copy()
    first_leg = np.broadcast_to(candidate[:, :, None], batch).copy()  # the seat's pellet until it is gone
    # each seat's own draws, from its uniform: its choice does not depend on the rest of the batch
    draws = np.zeros((n, 1, rollouts, n_agents, food))
    if epsilon > 0:
        seeds = (np.asarray(uniforms, dtype=np.float64).reshape(n) * 2**53).astype(np.int64)
        draws[:] = np.stack([np.random.default_rng(int(seed)).random((1, rollouts, n_agents, food)) for seed in seeds])
    jitter = epsilon * 2 * HALF_SIZE * draws * (np.arange(n_agents) > 0)[:, None]  # the others' costs only
    eaten = np.zeros((*batch, n_teams))
    place = seen.place[:, None, None, None, :]  # the seat's place, against the batch's agents (version 2's walls)
    for _ in range(horizon):
        pos += vel * DT  # the physics moves every body by its velocity before the thrust acts
        offsets = food_at[..., None, :, :] - pos[..., :, None, :]  # [N, W, R, A, F, 2]
        rival = pos[..., None, :, :] - pos[..., :, None, :]  # [N, W, R, A, A, 2]: agent j from agent i
        rival += np.where(np.eye(n_agents, dtype=bool)[..., None], 1e6, 0.0)  # not oneself
        cost = _pellet_costs(offsets, rival[..., None, :], left[..., None, :]) + jitter
        choice = cost.argmin(axis=-1)  # [N, W, R, A]
        choice[..., 0] = np.where(np.take_along_axis(left, first_leg[..., None], axis=-1)[..., 0], first_leg,
                                  choice[..., 0])
        way = np.take_along_axis(offsets, choice[..., None, None], axis=-2)[..., 0, :]
        direction = way / np.maximum(np.linalg.norm(way, axis=-1, keepdims=True), 1e-9)
        drift = vel - (vel * direction).sum(axis=-1, keepdims=True) * direction
        heading = direction - 0.5 * drift
        heading /= np.maximum(np.linalg.norm(heading, axis=-1, keepdims=True), 1e-9)
        if version > 1 and action_type == "discrete":
            heading = COMPASS_MOVES[_move_of(heading)]
        vel = vel * _VELOCITY_KEPT + DT * (THRUST * heading - AGENT_DRAG * vel) / AGENT_MASS
        # eating: the nearest agent within reach of a pellet still there eats it (no one moved since
        # the offsets were taken)
        reach = np.linalg.norm(offsets, axis=-1)  # [N, W, R, A, F]
        nearest = reach.argmin(axis=-2)
        eats = left & (reach.min(axis=-2) < EAT_DISTANCE)
        for t in range(n_teams):
            eaten[..., t] += (eats & (team[nearest] == t)).sum(axis=-1)
        left &= ~eats
        if version > 1:
            pos, vel = _contacts(pos, vel, place)
    # at the horizon (where the last step's reach was taken), the pellets left count a half for the
    # team whose agent is nearest
    for t in range(n_teams):
        eaten[..., t] += 0.5 * (left & (team[reach.argmin(axis=-2)] == t)).sum(axis=-1)
    margin = eaten[..., 0] - (eaten[..., 1:].max(axis=-1) if n_teams > 1 else 0.0)
    value = margin.mean(axis=2) - 1e-3 * np.arange(width)  # ties go to the heuristic's order
    chosen = candidate[np.arange(n), value.argmax(axis=1)]
    return _steer(velocity, ahead[np.arange(n), chosen], there.any(axis=1), action_type)
