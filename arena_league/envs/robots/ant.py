"""The quadruped ant of the robot games, built with ``mujoco.MjSpec``.

After the Gym/MuJoCo ``Ant`` used by Bansal et al., "Emergent Complexity via Multi-Agent
Competition" (ICLR 2018) for their Sumo, RunToGoal and YouShallNotPass games: a spherical torso
with four two-segment legs set at 45, 135, 225 and 315 degrees, eight hinge joints (a hip about the
vertical axis and an ankle that lifts and lowers the leg), each driven by a torque motor of gear 150
whose control lies in [-1, 1]. Proportions, joint ranges, damping and armature follow Gym's
``ant.xml``: torso radius 0.25, leg capsules of radius 0.08, an upper leg reaching 0.2 + 0.2 along
each diagonal axis and a lower leg 0.4 more, density 5 (a robot of about 0.9 kg).

The ant is its own ``MjSpec`` (a world body holding the free-floating torso, with its actuators and
proprioceptive sensors); a scene (``envs.robots.scene``) attaches one copy per seat under a name
prefix, so that every name below becomes ``<prefix><name>``.

Names (before the prefix):

* bodies ``torso``, ``<leg>_hip``, ``<leg>_shin``; the free joint ``root``;
* joints and actuators ``<leg>_hip``, ``<leg>_ankle`` for ``<leg>`` in :data:`LEGS`, in that
  order: actuator ``k`` drives joint ``k``; a seat's action vector follows the same order;
* geoms ``torso``, ``<leg>_upper`` (fixed to the torso), ``<leg>_thigh``, ``<leg>_foot``;
* sensors (world frame unless said): ``pos``, ``xaxis`` (the forward axis of the torso), ``zaxis``
  (its up axis), ``linvel``, ``angvel`` (in the torso frame), ``qpos_<joint>``, ``qvel_<joint>``
  and ``contact`` (MuJoCo's contact sensor: the net contact force between the ant and everything
  else, as the force the ant exerts, i.e. minus the force it receives).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

#: The legs, counter-clockwise from the front left; each reaches out along ``LEG_AXES[k]``.
LEGS: tuple[str, ...] = ("front_left", "back_left", "back_right", "front_right")
LEG_AXES = np.array([(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]) / np.sqrt(2.0)
#: Joint (and actuator) names in action order: hip then ankle of each leg.
JOINTS: tuple[str, ...] = tuple(f"{leg}_{part}" for leg in LEGS for part in ("hip", "ankle"))
#: Sensors of one ant with their sizes, in the order the robot spec declares them.
SENSORS: tuple[tuple[str, int], ...] = (
    ("pos", 3), ("xaxis", 3), ("zaxis", 3), ("linvel", 3), ("angvel", 3),
    *((f"qpos_{j}", 1) for j in JOINTS), *((f"qvel_{j}", 1) for j in JOINTS), ("contact", 3),
)

#: ``mjSENS_CONTACT`` integer parameters: data = force (bit 1), reduce = net force (3), one slot.
CONTACT_FORCE_NET = (2, 3, 1)


@dataclass(frozen=True)
class AntShape:
    """Proportions and actuation of the ant (Gym ``Ant`` defaults; lengths in metres, angles in
    radians). ``upper`` is the length, along each diagonal axis, of the fixed leg segment on the torso and
    of the thigh; ``foot`` that of the lower leg."""

    torso_radius: float = 0.25
    leg_radius: float = 0.08
    upper: float = 0.2 * np.sqrt(2.0)
    foot: float = 0.4 * np.sqrt(2.0)
    density: float = 5.0
    hip_range: tuple[float, float] = (-np.pi / 6, np.pi / 6)
    ankle_range: tuple[float, float] = (np.pi / 6, 7 * np.pi / 18)
    gear: float = 150.0
    damping: float = 1.0
    armature: float = 1.0
    friction: float = 1.0

    @property
    def standing_ankle(self) -> float:
        """Ankle angle of the standing pose: mid-range, the feet well under the torso's reach."""
        return float(np.mean(self.ankle_range))

    def standing_height(self) -> float:
        """Torso height at which the standing pose's feet just touch a flat floor."""
        return float(self.foot * np.sin(self.standing_ankle) + self.leg_radius)


ANT = AntShape()


def ant_spec(shape: AntShape = ANT, rgba: tuple[float, float, float, float] = (0.8, 0.6, 0.4, 1.0)) -> mujoco.MjSpec:
    """A new ``MjSpec`` holding one ant (torso at the origin, standing pose, no floor).

    Attach it to a scene with ``scene.attach(ant_spec(...), prefix="r0/", frame=...)``; collision
    bits (``contype``/``conaffinity``) are left at MuJoCo's defaults for the scene to set.
    """
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    capsule, sphere = mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_SPHERE
    torso = spec.worldbody.add_body(name="torso")
    torso.add_freejoint(name="root")
    common = {"density": shape.density, "rgba": list(rgba), "friction": [shape.friction, 0.005, 0.0001]}
    torso.add_geom(name="torso", type=sphere, size=[shape.torso_radius, 0, 0], **common)
    hinge = mujoco.mjtJoint.mjJNT_HINGE
    joint_common = {"type": hinge, "limited": mujoco.mjtLimited.mjLIMITED_TRUE, "damping": shape.damping,
                    "armature": shape.armature}
    for leg, axis in zip(LEGS, LEG_AXES):
        ux, uy = axis * shape.upper
        fx, fy = axis * shape.foot
        torso.add_geom(name=f"{leg}_upper", type=capsule, fromto=[0, 0, 0, ux, uy, 0],
                       size=[shape.leg_radius, 0, 0], **common)
        hip = torso.add_body(name=f"{leg}_hip", pos=[ux, uy, 0])
        hip.add_joint(name=f"{leg}_hip", axis=[0, 0, 1], range=list(shape.hip_range), **joint_common)
        hip.add_geom(name=f"{leg}_thigh", type=capsule, fromto=[0, 0, 0, ux, uy, 0],
                     size=[shape.leg_radius, 0, 0], **common)
        shin = hip.add_body(name=f"{leg}_shin", pos=[ux, uy, 0])
        # a positive ankle angle turns the leg downward (right-hand rule about this axis)
        shin.add_joint(name=f"{leg}_ankle", axis=[-axis[1], axis[0], 0], range=list(shape.ankle_range),
                       **joint_common)
        shin.add_geom(name=f"{leg}_foot", type=capsule, fromto=[0, 0, 0, fx, fy, 0],
                      size=[shape.leg_radius, 0, 0], **common)
    for joint in JOINTS:
        motor = spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        motor.gear[0] = shape.gear
        motor.ctrlrange = [-1.0, 1.0]
        motor.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    _add_sensors(spec)
    return spec


def _add_sensors(spec: mujoco.MjSpec) -> None:
    kinds = mujoco.mjtSensor
    body, joint = mujoco.mjtObj.mjOBJ_XBODY, mujoco.mjtObj.mjOBJ_JOINT
    for name, kind in (("pos", kinds.mjSENS_FRAMEPOS), ("xaxis", kinds.mjSENS_FRAMEXAXIS),
                       ("zaxis", kinds.mjSENS_FRAMEZAXIS), ("linvel", kinds.mjSENS_FRAMELINVEL)):
        spec.add_sensor(name=name, type=kind, objtype=body, objname="torso")
    spec.add_sensor(name="angvel", type=kinds.mjSENS_FRAMEANGVEL, objtype=body, objname="torso",
                    reftype=body, refname="torso")
    for j in JOINTS:
        spec.add_sensor(name=f"qpos_{j}", type=kinds.mjSENS_JOINTPOS, objtype=joint, objname=j)
    for j in JOINTS:
        spec.add_sensor(name=f"qvel_{j}", type=kinds.mjSENS_JOINTVEL, objtype=joint, objname=j)
    contact = spec.add_sensor(name="contact", type=kinds.mjSENS_CONTACT, objtype=body, objname="torso")
    contact.intprm[:3] = CONTACT_FORCE_NET


def standing_pose(shape: AntShape = ANT) -> np.ndarray:
    """Joint angles (action order) of the standing pose: hips centred, ankles mid-range."""
    return np.tile([0.0, shape.standing_ankle], len(LEGS))


#: The robot library: name -> (spec builder, shape, standing pose of its joints).
ROBOTS = {"ant": (ant_spec, ANT, standing_pose(ANT))}
