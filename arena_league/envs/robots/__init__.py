"""Robot games on MuJoCo: the robot library, scenes, batched stepping, scripted gaits and pictures.

After Bansal et al., "Emergent Complexity via Multi-Agent Competition" (ICLR 2018) and the robot
games of Arena (Song et al., AAAI 2020). Layers, each its own module:

* ``ant``: the quadruped ant as a ``mujoco.MjSpec`` (the robot library, :data:`ROBOTS`);
* ``scene``: N robots plus props (boxes, floor markings) composed with ``MjSpec.attach`` by
  prefix, compiled once per layout (:func:`compile_scene`), read through affine maps of MuJoCo's
  sensor vector;
* ``observation``: the robot block that opens every robot game's observation;
* ``game``: :class:`RobotGameRules` (the rules every robot game shares, written over arrays of
  matches), the options every robot game takes (``COMMON_OPTIONS``, ``start_jitter``) and
  :class:`RobotMatches` (many matches on a thread pool: the match engine's batched path);
* ``field``: the field between two lines of RunToGoal and YouShallNotPass (:class:`LinedField`,
  its ``field_length`` option) and the sidestep of their heuristics (:func:`avoid`), so that
  neither game imports the other;
* ``gait``: scripted controllers from observations (:func:`trot`, :func:`stand`), used by the
  games' heuristics;
* ``rewards``: the IS reward ``robot_motion`` and its annealing (``set_anneal``);
* ``render``: the top-down projection (no display, no GL) and MuJoCo's renderer where GL exists.

The games themselves are ``envs.games.sumo``, ``runtogoal``, ``youshallnotpass`` and ``pushbox``.
"""

from arena_league.envs.robots.ant import ANT, JOINTS, LEGS, ROBOTS, AntShape, ant_spec, standing_pose
from arena_league.envs.robots.gait import stand, trot
from arena_league.envs.robots.game import (
    FALLEN_UP_Z,
    MatchState,
    RobotGameRules,
    RobotMatches,
    StartPose,
    duel_tree,
)
from arena_league.envs.robots.render import camera_picture, topdown_picture
from arena_league.envs.robots.rewards import RobotMeasures, check_anneal, robot_motion
from arena_league.envs.robots.scene import (
    Affine,
    Readout,
    Scene,
    SceneLayout,
    Terms,
    build_scene_spec,
    compile_scene,
)

__all__ = [
    "ANT",
    "FALLEN_UP_Z",
    "JOINTS",
    "LEGS",
    "ROBOTS",
    "Affine",
    "AntShape",
    "MatchState",
    "Readout",
    "RobotGameRules",
    "RobotMatches",
    "RobotMeasures",
    "Scene",
    "SceneLayout",
    "StartPose",
    "Terms",
    "ant_spec",
    "build_scene_spec",
    "camera_picture",
    "check_anneal",
    "compile_scene",
    "duel_tree",
    "robot_motion",
    "stand",
    "standing_pose",
    "topdown_picture",
    "trot",
]
