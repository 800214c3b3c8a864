"""Scripted ant controllers computed from the observation alone: a steered trot and a stand.

The games' heuristics (the 'skilled' end of social-tree verification and the built-in scripted
agent) choose a walking direction in the seat frame; :func:`trot` turns it into joint torques.

The trot is an open-loop oscillator with feedback steering, read off the observation's robot block
(``envs.robots.observation``): the diagonal leg pairs (front-left with back-right, back-left with
front-right) alternate, half a cycle apart, the cycle's phase read off the match time in the
observation (``GAIT_PERIOD`` 0.5 s). In the stance half of its cycle a leg's hip
sweeps its foot backward along the wanted direction, ``hip = H * (t_k . d) * cos(psi)`` with
``t_k`` the direction the foot moves for a positive hip angle and ``d`` the wanted direction in the
torso frame (recomputed every step from the torso's forward axis, so the ant walks toward a target
whatever way it faces); its ankle lowers and lifts the foot a quarter cycle later,
``ankle = mid - B * cos(psi)``. A PD law tracks these angles: ``u = clip(kp (q* - q) - kd q', -1, 1)``.
The ant walks about 0.8 m/s in any direction and, on flat ground, does not fall.
"""

from __future__ import annotations

import numpy as np

from arena_league.envs.robots import observation as cells
from arena_league.envs.robots.ant import ANT, LEG_AXES
from arena_league.envs.robots.scene import TIMESTEP

#: Seconds per gait cycle; the sensors' instant is one physics sub-step before the step ends.
GAIT_PERIOD = cells.CLOCK_PERIOD
SENSOR_LAG = TIMESTEP
#: Hip sweep and ankle lift amplitudes (rad), the ankle's mid angle, and the PD gains.
HIP_SWEEP = 0.5
ANKLE_LIFT = 0.2
ANKLE_MID = ANT.standing_ankle
KP = 2.5
KD = 0.2
#: For a positive hip angle each foot moves along ``LEG_TANGENTS[k]`` (torso frame).
LEG_TANGENTS = np.stack([-LEG_AXES[:, 1], LEG_AXES[:, 0]], axis=1)
#: Phase offset of each leg: the two diagonal pairs half a cycle apart.
LEG_PHASE = np.array([0.0, np.pi, 0.0, np.pi])
STANDING = np.tile([0.0, ANKLE_MID], 4)


def _pd(obs: np.ndarray, target: np.ndarray, kp: float = KP) -> np.ndarray:
    q = obs[:, cells.JOINT_ANGLES]
    qdot = obs[:, cells.JOINT_VELOCITIES] * cells.ANGULAR_UNIT
    return np.clip(kp * (target - q) - KD * qdot, -1.0, 1.0).astype(np.float32)


def stand(obs: np.ndarray) -> np.ndarray:
    """Torques that hold the standing pose (hips centred, ankles mid-range), ``float32[N, 8]``."""
    obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
    return _pd(obs, STANDING)


def trot(obs: np.ndarray, direction: np.ndarray, *, kp: float = KP, period: float = GAIT_PERIOD) -> np.ndarray:
    """Torques that trot toward ``direction`` (``[N, 2]``, seat frame), ``float32[N, 8]``.

    A direction of length 1 or more takes full strides; a shorter one proportionally shorter
    strides (zero: the ant stands). ``kp`` (the PD law's stiffness) and ``period`` (seconds per
    gait cycle, read off the match time) give other trots: a softer, quicker one (``kp`` 1.75,
    ``period`` 0.4) pushes PushBox's box faster.
    """
    obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
    direction = np.asarray(direction, dtype=np.float64).reshape(-1, 2)
    forward = obs[:, cells.FORWARD.start: cells.FORWARD.start + 2]
    heading = forward / np.maximum(np.linalg.norm(forward, axis=1, keepdims=True), 1e-9)
    # the wanted direction in the torso frame: rotate by minus the heading
    body = np.stack([heading[:, 0] * direction[:, 0] + heading[:, 1] * direction[:, 1],
                     heading[:, 0] * direction[:, 1] - heading[:, 1] * direction[:, 0]], axis=1)
    length = np.linalg.norm(body, axis=1, keepdims=True)
    body = body / np.maximum(length, 1.0)  # longer than 1: full strides
    time = obs[:, cells.TIME] * cells.TIME_UNIT + SENSOR_LAG
    psi = (2.0 * np.pi / period) * time[:, None] + LEG_PHASE[None, :]
    sweep = body @ LEG_TANGENTS.T  # [N, 4]
    stride = np.minimum(length, 1.0)
    hip = HIP_SWEEP * sweep * np.cos(psi)
    ankle = ANKLE_MID - ANKLE_LIFT * stride * np.cos(psi)
    target = np.stack([hip, ankle], axis=2).reshape(len(obs), 8)
    return _pd(obs, target, kp)
