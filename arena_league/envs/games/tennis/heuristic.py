"""Tennis's scripted play, from the observation alone (imported by :class:`TennisRules` only).

The seat predicts the ball's flight over the next 1.5 s (exactly as
the physics steps move it in the air, and one bounce off the floor). When the ball is its
team's to play (the other team played it, or it is the own toss) and it is the teammate best
placed (the nearest to the ball, a racket in front of the ball counting as further), it weighs
strokes: a moment to meet the ball on its side (every 0.1 s, before the ball lands on a toss or
once it has bounced in, else before it lands a second time), and a racket velocity (a direction
from +x to up, and a speed; for discrete actions only the compass directions E, NE and N, which
it can swing exactly). A racket that meets the ball along their relative velocity strikes it on
that line however early or late it comes, and the ball leaves at ``v + 1.65 (u - v)`` (ball
velocity ``v``, racket velocity ``u``; restitution 0.81, a racket ten times the ball's mass): the
seat picks the stroke whose shot clears the net by 0.25 and lands nearest 2.6 beyond it, the
ball at a comfortable height (about 1.1) and soon, with the racket able to stand ready on the
stroke's line in time. It waits on that line behind the spot of contact, then runs through the
spot at full thrust from the moment that brings it there at the stroke's speed (a racket at
rest reaches speed ``v`` after ``-ln(1 - v / V) / 3.6`` s at full thrust, ``V`` its top speed).
A seat with no ball to play goes to its spot (the back spot, or the front one for the
teammate nearer the net). It assumes the default court.
"""

from __future__ import annotations

import numpy as np

from arena_league.envs.games.tennis.court import (
    _FORMATIONS,
    BALL_MASS,
    BALL_RADIUS,
    BARRIER_RADIUS,
    CONTACT,
    ELASTICITY,
    FENCE_X,
    FRICTION,
    GRAVITY,
    HALF_LENGTH,
    NET_HEIGHT,
    POSITION_UNIT,
    RACKET_DRAG,
    RACKET_MASS,
    RACKET_RADIUS,
    RACKET_TOP_SPEED,
    REACH_HEIGHT,
    SPACE_DAMPING,
    SUBSTEP,
    THRUST,
    VELOCITY_UNIT,
)

__all__ = ["heuristic"]

#: The heuristic's look-ahead: physics steps of the ball's predicted flight (1.5 s); it weighs
#: meeting the ball after every ``_STRIDE``-th of them.
_LOOKAHEAD = 30
_STRIDE = 2
#: Restitution and friction of the ball on the floor and on a racket (products of the shapes' values).
_FLOOR_RESTITUTION = ELASTICITY["ball"] * ELASTICITY["floor"]
_FLOOR_FRICTION = FRICTION["ball"] * FRICTION["floor"]
_RACKET_RESTITUTION = ELASTICITY["ball"] * ELASTICITY["racket"]
#: What a head-on stroke gives the ball of the closing velocity: (1 + restitution) times the
#: racket's share of the two masses (the racket is ten times as heavy).
_STROKE = (1.0 + _RACKET_RESTITUTION) * RACKET_MASS / (RACKET_MASS + BALL_MASS)
#: Where the heuristic's shots should land beyond the net, how far above the net they must pass,
#: and the height it likes to strike the ball at.
_AIM_X = 2.6
_NET_MARGIN = 0.25
_STRIKE_HEIGHT = 1.1
#: The directions of the racket's swing it weighs (angles above +x, seat frame): every 15 degrees
#: from +x to up for continuous actions; for discrete ones the compass directions E, NE and N,
#: which it swings exactly.
_SWING_ANGLES = {"continuous": np.radians(np.arange(0.0, 91.0, 15.0)), "discrete": np.radians([0.0, 45.0, 90.0])}
_SWING_DIRECTIONS = {kind: np.stack([np.cos(a), np.sin(a)], axis=1) for kind, a in _SWING_ANGLES.items()}
#: A racket at rest running at full thrust: its speed after ``t`` seconds is ``V (1 - exp(-rate t))``
#: under drag and damping (``V`` its top speed).
_SWING_RATE = (RACKET_DRAG - RACKET_MASS * np.log(SPACE_DAMPING)) / RACKET_MASS


def _run_speed(time: np.ndarray) -> np.ndarray:
    """Speed of a racket ``time`` seconds into a run at full thrust from rest."""
    return RACKET_TOP_SPEED * (1.0 - np.exp(-_SWING_RATE * time))


def _run_distance(time: np.ndarray) -> np.ndarray:
    """Distance a racket covers in ``time`` seconds of a run at full thrust from rest."""
    return RACKET_TOP_SPEED * time - _run_speed(time) / _SWING_RATE


#: The racket speeds it weighs, and the time and distance a run needs to reach each.
_SWING_SPEEDS = np.linspace(0.6, 0.92 * RACKET_TOP_SPEED, 8)
_RUN_TIME = -np.log(1.0 - _SWING_SPEEDS / RACKET_TOP_SPEED) / _SWING_RATE
_RUN_UP = _run_distance(_RUN_TIME)
#: The gains of its steering toward where the racket should be, and how fast it should move.
_POSITION_GAIN = 20.0
_VELOCITY_GAIN = 5.0
#: Where the racket's centre can go in the seat frame (x, then y), a little inside the barriers.
_REACH_LOW = np.array([-FENCE_X + RACKET_RADIUS + 0.05, RACKET_RADIUS + 0.03])
_REACH_HIGH = np.array([-(RACKET_RADIUS + BARRIER_RADIUS) - 0.03, REACH_HEIGHT - RACKET_RADIUS - 0.05])
#: Where a racket waits while the other team has the ball: the back spot, or the front one for the
#: teammate nearer the net.
_BACK_SPOT, _FRONT_SPOT = np.array(_FORMATIONS[2][0]), np.array(_FORMATIONS[2][1])


def _flight_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients of a free flight's physics steps ``(S1 h, S2 h^2, D, G h)``: after ``k`` steps of
    ``h``, with ``d`` the damping of one step, Chipmunk (which moves a body by its velocity before it
    updates that velocity) has the ball at ``p + S1[k] h v + S2[k] h^2 a`` moving at
    ``D[k] v + G[k] h a``."""
    d = SPACE_DAMPING**SUBSTEP
    powers = d ** np.arange(_LOOKAHEAD + 1)
    gained = (1.0 - powers) / (1.0 - d)  # the sum of d**j for j < k
    s1 = np.concatenate([[0.0], np.cumsum(powers)[:-1]])
    s2 = np.concatenate([[0.0], np.cumsum(gained)[:-1]])
    return s1 * SUBSTEP, s2 * SUBSTEP**2, powers, gained * SUBSTEP


_S1, _S2, _DECAY, _GAIN = _flight_tables()
_DOWN = np.array([0.0, -GRAVITY])


def _fly(p: np.ndarray, v: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Free flights from ``p``, ``v`` (``[N, 2]``) after ``k`` (``[N, K]``) physics steps."""
    position = p[:, None, :] + _S1[k][..., None] * v[:, None, :] + _S2[k][..., None] * _DOWN
    return position, _DECAY[k][..., None] * v[:, None, :] + _GAIN[k][..., None] * _DOWN


def _predict_flight(ball: np.ndarray, velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ball's positions and velocities after each of the next ``_LOOKAHEAD`` physics steps
    (``[N, K, 2]`` each, step 0 now), bouncing once off the floor, and how many times it has landed
    by each step (``[N, K]``: 0, 1, or 2 once it lands again)."""
    k = np.broadcast_to(np.arange(_LOOKAHEAD + 1), (len(ball), _LOOKAHEAD + 1))
    position, speed = _fly(ball, velocity, k)
    low = position[:, :, 1] < BALL_RADIUS
    low[:, 0] = False
    bounces = low.any(axis=1)
    first = np.where(bounces, low.argmax(axis=1), _LOOKAHEAD)
    rows = np.arange(len(ball))
    # the bounce: the vertical speed turned back, the horizontal one braked by the floor's friction
    v_in = speed[rows, first - 1]
    brake = _FLOOR_FRICTION * (1.0 + _FLOOR_RESTITUTION) * np.abs(v_in[:, 1])
    v_out = np.stack([np.sign(v_in[:, 0]) * np.maximum(np.abs(v_in[:, 0]) - brake, 0.0),
                      -_FLOOR_RESTITUTION * v_in[:, 1]], axis=1)
    after = np.maximum(k - first[:, None], 0)
    again, again_speed = _fly(position[rows, first], v_out, after)
    later = (k > first[:, None]) & bounces[:, None]
    position = np.where(later[..., None], again, position)
    speed = np.where(later[..., None], again_speed, speed)
    second = np.cumsum(later & (position[:, :, 1] < BALL_RADIUS) & (after > 1), axis=1) > 0
    landings = ((k >= first[:, None]) & bounces[:, None]).astype(np.int64) + second
    return position, speed, landings


def _shots(contact: np.ndarray, incoming: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Head-on strokes at balls met at ``contact`` moving at ``incoming`` (``[N, K, 2]``, seat
    frame) by a racket moving at every speed of ``_SWING_SPEEDS`` in every one of ``directions``:
    where the struck ball lands (``[N, K, A, S]``; air drag roughly allowed for), whether it clears
    the net by ``_NET_MARGIN``, and the line of impact (racket to ball, ``[N, K, A, S, 2]``).

    A racket that meets the ball along their relative velocity strikes it on that line, however
    early or late it comes: the ball leaves at ``v + _STROKE * (u - v)`` (racket velocity ``u``)."""
    racket = directions[:, None, :] * _SWING_SPEEDS[None, :, None]  # [A, S, 2]
    closing = racket[None, None] - incoming[:, :, None, None, :]
    size = np.sqrt(np.einsum("...i,...i->...", closing, closing))
    line = closing / np.maximum(size, 1e-9)[..., None]
    v_out = 0.95 * (incoming[:, :, None, None, :] + _STROKE * closing)  # 0.95: about what air drag takes
    x0, y0 = contact[:, :, None, None, 0], contact[:, :, None, None, 1]
    vx, vy = v_out[..., 0], v_out[..., 1]
    t_land = (vy + np.sqrt(vy * vy + 2.0 * GRAVITY * np.maximum(y0 - BALL_RADIUS, 0.0))) / GRAVITY
    t_net = -x0 / np.maximum(vx, 1e-6)
    at_net = y0 + vy * t_net - 0.5 * GRAVITY * t_net * t_net
    clears = (vx > 0.3) & (at_net > NET_HEIGHT + BALL_RADIUS + _NET_MARGIN) & (t_net < t_land)
    return x0 + vx * t_land, clears, line


def _legal_flight(obs: np.ndarray, toss: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ball's predicted flight seen from each row's seat (positions and velocities, ``[N, K,
    2]``) and the physics steps at whose end its racket may strike it (``[N, K]``, every
    ``_STRIDE``-th): on its side at a reachable height, before the ball lands on a toss or once it
    has bounced in, else before it lands a second time, the first landing in the own court."""
    position, speed, landings = _predict_flight(obs[:, 7:9] * POSITION_UNIT, obs[:, 9:11] * VELOCITY_UNIT)
    in_court = (landings == 1) & (position[:, :, 0] < 0.0) & (position[:, :, 0] > -HALF_LENGTH)
    bounced_in = np.cumsum(in_court, axis=1) > 0
    at_most_once = (toss | (obs[:, 12] > 0.5))[:, None]
    legal = np.where(at_most_once, landings == 0, (landings == 0) | ((landings == 1) & bounced_in))
    legal &= (position[:, :, 1] > 0.35) & (position[:, :, 1] < 2.2) & (position[:, :, 0] < -0.1)
    legal[:, np.arange(_LOOKAHEAD + 1) % _STRIDE != 0] = False
    legal[:, 0] = False
    return position, speed, legal


def _strokes(me: np.ndarray, velocity: np.ndarray, position: np.ndarray, speed: np.ndarray, legal: np.ndarray,
             directions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The best stroke of each seat at the predicted ball (``[N, K, 2]``; at every ``_STRIDE``-th
    physics step where ``legal``): whether it found one, its moment (physics steps from now), its
    direction and speed (indices) and the racket's spot at contact (``[N, 2]``)."""
    n = len(me)
    moments = np.arange(0, _LOOKAHEAD + 1, _STRIDE)
    moments = moments[legal[:, moments].any(axis=0)]  # (weighing only the moments some row may strike at)
    position, speed, legal = position[:, moments], speed[:, moments], legal[:, moments]
    landing, clears, line = _shots(position, speed, directions)
    spot = position[:, :, None, None, :] - line * CONTACT  # the racket's centre at contact
    ready = spot - directions[None, None, :, None, :] * _RUN_UP[:, None]

    def inside(p: np.ndarray) -> np.ndarray:
        return ((p[..., 0] > _REACH_LOW[0]) & (p[..., 0] < _REACH_HIGH[0]) & (p[..., 1] > _REACH_LOW[1])
                & (p[..., 1] < _REACH_HIGH[1]))

    # the racket should stand ready behind the spot by the moment less the run's time, or be on the
    # run already (near the line there, behind the spot within the run-up, moving along it):
    # lateness costs, as does a run-up that starts out of reach
    t = moments * SUBSTEP
    gap = ready - me[:, None, None, None, :]
    to_ready = np.sqrt(np.einsum("...i,...i->...", gap, gap))
    late = np.maximum(to_ready / RACKET_TOP_SPEED - np.maximum(t[:, None, None] - _RUN_TIME, 0.0), 0.0)
    offset = spot - me[:, None, None, None, :]
    d = directions[None, None, :, None, :]
    ahead = (offset * d).sum(axis=-1)
    aside = np.abs(offset[..., 0] * d[..., 1] - offset[..., 1] * d[..., 0])
    moving = (velocity @ directions.T)[:, None, :, None]
    running = (aside < 0.15) & (ahead > -0.05) & (ahead <= _RUN_UP + 0.1) & (moving > 0.3)
    late = np.where(running, 0.0, late)
    good = legal[:, :, None, None] & clears & inside(spot) & (landing > 0.5) & (landing < HALF_LENGTH - 0.3)
    cost = (np.abs(landing - _AIM_X) + 0.5 * np.abs(position[:, :, None, None, 1] - _STRIKE_HEIGHT)
            + 0.3 * t[:, None, None] + 4.0 * late + 2.0 * ~inside(ready))
    cost = np.where(good, cost, np.inf).reshape(n, -1)
    best = cost.argmin(axis=1)
    found = np.isfinite(cost[np.arange(n), best])
    k, a, w = np.unravel_index(best, good.shape[1:])
    return found, moments[k], a, w, spot[np.arange(n), k, a, w]


def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
    """Every row's action from its observation alone (see the Heuristic section of the manual)."""
    obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
    n_others, rest = divmod(obs.shape[1] - 17, 4)
    if rest or n_others not in (1, 3):
        raise ValueError(f"Tennis heuristic: an observation of {obs.shape[1]} cells is not Tennis's "
                         "(17 + 4 * (n_agents - 1) cells)")
    n_mates = (n_others + 1) // 2 - 1
    me = obs[:, 1:3] * POSITION_UNIT
    velocity = obs[:, 3:5] * VELOCITY_UNIT
    ball = obs[:, 7:9] * POSITION_UNIT
    toss = obs[:, 13] > 0.5
    # the ball is the seat's team's to play when the other team played it last, or on its own toss
    to_play = (obs[:, 11] < 0.5) | toss

    # roles: the teammate best placed plays the ball (the nearest, a racket in front of the ball
    # counting as further: it strikes toward +x); the others keep their spots
    def placing(xy: np.ndarray) -> np.ndarray:
        return np.hypot(*(ball - xy).T) + 1.5 * np.maximum(xy[:, 0] - ball[:, 0] + 0.3, 0.0)

    own_placing = placing(me)
    home = np.tile(_BACK_SPOT, (len(obs), 1))
    for mate in range(n_mates):
        mate_xy = me + obs[:, 17 + 4 * mate: 19 + 4 * mate] * POSITION_UNIT
        to_play &= placing(mate_xy) >= own_placing
        home[me[:, 0] > mate_xy[:, 0]] = _FRONT_SPOT
    target = home
    target_velocity = np.zeros_like(me)
    running = np.zeros(len(obs), dtype=bool)
    direction = np.zeros_like(me)

    p = np.flatnonzero(to_play)
    if len(p):
        position, speed, legal = _legal_flight(obs[p], toss[p])
        playable = legal.any(axis=1)
        p, position, speed, legal = p[playable], position[playable], speed[playable], legal[playable]
    if len(p):
        directions = _SWING_DIRECTIONS[action_type]
        found, k, a, w, spot = _strokes(me[p], velocity[p], position, speed, legal, directions)
        p, k, a, w, spot = p[found], k[found], a[found], w[found], spot[found]
        # the stroke: stand ready behind the spot, then run through it at full thrust from the
        # moment that brings the racket there at the stroke's speed, steering onto the run
        direction[p] = directions[a]
        elapsed = np.maximum(_RUN_TIME[w] - k * SUBSTEP, 0.0)  # time into the run
        target[p] = spot - direction[p] * (_RUN_UP[w] - _run_distance(elapsed))[:, None]
        target_velocity[p] = direction[p] * _run_speed(elapsed)[:, None]
        running[p] = elapsed > 0.0
    target = np.clip(target, _REACH_LOW, _REACH_HIGH)
    heading = (_POSITION_GAIN * (target - me) + _VELOCITY_GAIN * (target_velocity - velocity)) / THRUST
    heading += np.where(running[:, None], direction, 0.0)  # the run's full thrust
    length = np.hypot(heading[:, 0], heading[:, 1])
    if action_type == "continuous":
        return np.clip(heading / np.maximum(length, 1.0)[:, None], -1.0, 1.0).astype(np.float32)
    angle = np.arctan2(heading[:, 1], heading[:, 0])
    move = 1 + np.round(angle / (np.pi / 4)).astype(np.int64) % 8
    return np.where(length < 0.3, 0, move).astype(np.int64)


