"""The robot block that opens every robot game's observation, cell by cell.

Each seat sees the world in its *seat frame*: the world frame turned about the vertical axis by
``pi * team`` (two-team games), so every seat starts on the ``-x`` side facing ``+x`` and one
policy can play any seat (the ant is symmetric under that turn, so actions need no change).

====== ============= ===========================================================================
cell   bounds        meaning
====== ============= ===========================================================================
0      [0, 1]        own active flag (0 once the seat arrived or the rules took it out of play)
1      [0, 10]       match time (s) / ``TIME_UNIT`` (20 s): a clock for rhythmic gaits and for
                     pacing
2      [0, 4]        torso height above the floor (m)
3-5    [-1, 1]       torso forward axis (unit vector, seat frame)
6-8    [-1, 1]       torso up axis (unit vector, seat frame); cell 8 is its vertical part,
                     negative once fallen
9-11   [-4, 4]       torso velocity (seat frame) / ``VELOCITY_UNIT`` (3 m/s)
12-14  [-5, 5]       torso angular velocity in the torso's own frame / ``ANGULAR_UNIT`` (10 rad/s)
15-22  [-pi, pi]     joint angles (rad), action order: hip then ankle of the front-left,
                     back-left, back-right and front-right legs
23-30  [-5, 5]       joint velocities / ``ANGULAR_UNIT``
31-33  [-1, 1]       contact force other robots and props exert on the seat (seat frame), in
                     units of ``FORCE_UNIT`` (2) robot weights
34-36  [-1, 1]       contact force of the floor on the seat, same units
37-38  [-10, 10]     own position (seat frame) / ``POSITION_UNIT`` (4 m)
39-40  [-20, 20]     the seat's target (each game's manual says what it is) relative to the seat,
                     seat frame, / ``POSITION_UNIT``
41-42  [-1, 1]       gait clock: cosine and sine of ``2 pi t / CLOCK_PERIOD`` (0.5 s) for the match
                     time ``t`` of cell 1, the phase of a trot at two strides a second (a policy
                     reads a rhythm off these directly; off the bare time it would need a very
                     steep function)
====== ============= ===========================================================================

Sensors are read at the start of the last physics sub-step of a step (see ``envs.robots.scene``).

Bounds
    Every cell is clipped to its bounds (the observation space of the env). Unit vectors, flags and
    the clock are bounded by nature; the hinge angles by the ant's joint ranges, well inside
    ``[-pi, pi]``; contact forces are clipped at two body weights. The floor is open, so the rest
    are limits no ant comes near in a match: ``TIME_LIMIT`` (200 s of match time), ``HEIGHT_LIMIT``
    (4 m), ``VELOCITY_LIMIT`` (12 m/s), ``ANGULAR_LIMIT`` (50 rad/s) and ``FIELD_LIMIT`` (40 m from
    the centre for positions, twice that for one position relative to another). Game cells that
    describe another robot (:data:`OTHER_ROBOT_BOUNDS`) use the same limits.
"""

from __future__ import annotations

import math

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

#: Limits of the cells that nothing in the scene bounds, in the cells' units (see "Bounds").
TIME_LIMIT = 10.0
HEIGHT_LIMIT = 4.0
VELOCITY_LIMIT = 4.0
ANGULAR_LIMIT = 5.0
FIELD_LIMIT = 10.0

#: Bounds of the robot block, as runs ``(low, high, cells)`` in cell order.
ROBOT_BLOCK_BOUNDS: tuple[tuple[float, float, int], ...] = (
    (0.0, 1.0, 1), (0.0, TIME_LIMIT, 1), (0.0, HEIGHT_LIMIT, 1), (-1.0, 1.0, 6),
    (-VELOCITY_LIMIT, VELOCITY_LIMIT, 3), (-ANGULAR_LIMIT, ANGULAR_LIMIT, 3), (-math.pi, math.pi, 8),
    (-ANGULAR_LIMIT, ANGULAR_LIMIT, 8), (-1.0, 1.0, 6), (-FIELD_LIMIT, FIELD_LIMIT, 2),
    (-2 * FIELD_LIMIT, 2 * FIELD_LIMIT, 2), (-1.0, 1.0, 2),
)
#: Bounds of the seven cells describing another robot: its position relative to the seat, its
#: velocity, its forward axis (horizontal part) and the vertical part of its up axis.
OTHER_ROBOT_BOUNDS: tuple[tuple[float, float, int], ...] = (
    (-2 * FIELD_LIMIT, 2 * FIELD_LIMIT, 2), (-VELOCITY_LIMIT, VELOCITY_LIMIT, 2), (-1.0, 1.0, 3),
)
#: Bounds of a robot's eight global state cells: ``x/4, y/4, z, forward x, forward y, up z, vx/3, vy/3``.
ROBOT_STATE_BOUNDS: tuple[tuple[float, float, int], ...] = (
    (-FIELD_LIMIT, FIELD_LIMIT, 2), (0.0, HEIGHT_LIMIT, 1), (-1.0, 1.0, 3), (-VELOCITY_LIMIT, VELOCITY_LIMIT, 2),
)
#: Bounds of a box's four global state cells: ``x/4, y/4, vx/3, vy/3``.
BOX_STATE_BOUNDS: tuple[tuple[float, float, int], ...] = (
    (-FIELD_LIMIT, FIELD_LIMIT, 2), (-VELOCITY_LIMIT, VELOCITY_LIMIT, 2),
)
