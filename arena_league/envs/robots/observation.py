"""The robot block that opens every robot game's observation, cell by cell.

Each seat sees the world in its *seat frame*: the world frame turned about the vertical axis by
``pi * team`` (two-team games), so every seat starts on the ``-x`` side facing ``+x`` and one
policy can play any seat (the ant is symmetric under that turn, so actions need no change).

====== ==========================================================================================
cell   meaning
====== ==========================================================================================
0      own active flag (0 once the seat arrived or the rules took it out of play)
1-2    gait clock: ``cos, sin`` of ``2 pi * step / CLOCK_PERIOD`` (a phase for rhythmic gaits)
3      torso height above the floor (m)
4-6    torso forward axis (unit vector, seat frame)
7-9    torso up axis (unit vector, seat frame); cell 9 is its vertical part, negative once fallen
10-12  torso velocity (seat frame) / ``VELOCITY_UNIT`` (3 m/s)
13-15  torso angular velocity in the torso's own frame / ``ANGULAR_UNIT`` (10 rad/s)
16-23  joint angles (rad), action order: hip then ankle of the front-left, back-left,
       back-right and front-right legs
24-31  joint velocities / ``ANGULAR_UNIT``
32-34  contact force other robots and props exert on the seat (seat frame), in units of
       ``FORCE_UNIT`` (2) robot weights, clipped to [-1, 1]
35-37  contact force of the floor on the seat, same units, clipped to [-1, 1]
38-39  own position (seat frame) / ``POSITION_UNIT`` (4 m)
40-41  the seat's target (each game's manual says what it is) relative to the seat, seat frame,
       / ``POSITION_UNIT``
====== ==========================================================================================

Sensors are read at the start of the last physics sub-step of a step (see ``envs.robots.scene``).
"""

from __future__ import annotations

import numpy as np

ACTIVE = 0
CLOCK = slice(1, 3)
HEIGHT = 3
FORWARD = slice(4, 7)
UP = slice(7, 10)
UP_Z = 9
VELOCITY = slice(10, 13)
ANGULAR_VELOCITY = slice(13, 16)
JOINT_ANGLES = slice(16, 24)
JOINT_VELOCITIES = slice(24, 32)
PUSH_FORCE = slice(32, 35)
FLOOR_FORCE = slice(35, 38)
CONTACT = slice(32, 38)
POSITION = slice(38, 40)
TARGET = slice(40, 42)
#: Size of the robot block; a game's own cells follow.
ROBOT_CELLS = 42

#: Steps per cycle of the gait clock (0.5 s at 0.05 s per step).
CLOCK_PERIOD = 10
POSITION_UNIT = 4.0
VELOCITY_UNIT = 3.0
ANGULAR_UNIT = 10.0
FORCE_UNIT = 2.0

#: ``cos, sin`` of the clock phase for each step modulo the period.
CLOCK_TABLE = np.stack([np.cos(2 * np.pi * np.arange(CLOCK_PERIOD) / CLOCK_PERIOD),
                        np.sin(2 * np.pi * np.arange(CLOCK_PERIOD) / CLOCK_PERIOD)], axis=1)
CLOCK_TABLE[np.abs(CLOCK_TABLE) < 1e-12] = 0.0
