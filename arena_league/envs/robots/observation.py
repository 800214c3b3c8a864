"""The robot block that opens every robot game's observation, cell by cell.

Each seat sees the world in its *seat frame*: the world frame turned about the vertical axis by
``pi * team`` (two-team games), so every seat starts on the ``-x`` side facing ``+x`` and one
policy can play any seat (the ant is symmetric under that turn, so actions need no change).

====== ==========================================================================================
cell   meaning
====== ==========================================================================================
0      own active flag (0 once the seat arrived or the rules took it out of play)
1      match time (s) / ``TIME_UNIT`` (20 s): a clock for rhythmic gaits and for pacing
2      torso height above the floor (m)
3-5    torso forward axis (unit vector, seat frame)
6-8    torso up axis (unit vector, seat frame); cell 8 is its vertical part, negative once fallen
9-11   torso velocity (seat frame) / ``VELOCITY_UNIT`` (3 m/s)
12-14  torso angular velocity in the torso's own frame / ``ANGULAR_UNIT`` (10 rad/s)
15-22  joint angles (rad), action order: hip then ankle of the front-left, back-left,
       back-right and front-right legs
23-30  joint velocities / ``ANGULAR_UNIT``
31-33  contact force other robots and props exert on the seat (seat frame), in units of
       ``FORCE_UNIT`` (2) robot weights, clipped to [-1, 1]
34-36  contact force of the floor on the seat, same units, clipped to [-1, 1]
37-38  own position (seat frame) / ``POSITION_UNIT`` (4 m)
39-40  the seat's target (each game's manual says what it is) relative to the seat, seat frame,
       / ``POSITION_UNIT``
41-42  gait clock: cosine and sine of ``2 pi t / CLOCK_PERIOD`` (0.5 s) for the match time ``t``
       of cell 1, the phase of a trot at two strides a second (a policy reads a rhythm off
       these directly; off the bare time it would need a very steep function)
====== ==========================================================================================

Sensors are read at the start of the last physics sub-step of a step (see ``envs.robots.scene``).
"""

from __future__ import annotations

ACTIVE = 0
TIME = 1
HEIGHT = 2
FORWARD = slice(3, 6)
UP = slice(6, 9)
UP_Z = 8
VELOCITY = slice(9, 12)
ANGULAR_VELOCITY = slice(12, 15)
JOINT_ANGLES = slice(15, 23)
JOINT_VELOCITIES = slice(23, 31)
PUSH_FORCE = slice(31, 34)
FLOOR_FORCE = slice(34, 37)
CONTACT = slice(31, 37)
POSITION = slice(37, 39)
TARGET = slice(39, 41)
CLOCK = slice(41, 43)
#: Size of the robot block; a game's own cells follow.
ROBOT_CELLS = 43

TIME_UNIT = 20.0
#: Seconds per turn of the gait clock (cells 41-42): the scripted trot's cycle (``envs.robots.gait``).
CLOCK_PERIOD = 0.5
POSITION_UNIT = 4.0
VELOCITY_UNIT = 3.0
ANGULAR_UNIT = 10.0
FORCE_UNIT = 2.0
