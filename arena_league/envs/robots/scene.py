"""Scenes of the robot games: N robots plus props composed into one MuJoCo model with ``MjSpec``.

A :class:`SceneLayout` (a frozen, hashable description: the robots, their teams, the pushable
boxes and the floor markings) is compiled once per process by :func:`compile_scene` (cached), and
every match of that layout reuses the same ``MjModel`` with its own ``MjData``, reset per episode.

Collision filtering (MuJoCo's ``contype``/``conaffinity`` bits): bit 0 is the floor and the
boxes; robot ``i`` owns bit ``i + 1`` and collides with bit 0 and every other robot's bit but not
its own, so an ant's legs never collide with each other (Gym's ant has no self-collision either),
while ants push each other and the boxes. Floor markings (ring, lines, target discs) are visual
only. Physics: ``timestep`` 0.01 s, Euler integration, MuJoCo's Newton solver with pyramidal
friction cones; the implicit joint damping of Euler (``eulerdamp``) and the BVH mid-phase of
collision detection are switched off: the joints' armature keeps explicit damping stable, bodies
hold at most five primitive geoms, and together they cost about 10 % of a step.

Everything a game reads comes from MuJoCo sensors (see ``envs.robots.ant`` for a robot's; the
scene adds ``r<i>/floor_contact`` per robot, ``box<b>/pos``, ``/linvel``, ``/xaxis`` per box, the
match time ``clock`` and ``unit``, a constant 1),
evaluated by MuJoCo at the start of the last physics sub-step of a step: one consistent snapshot,
10 ms before the step ends. (MuJoCo evaluates sensors at every sub-step; the sub-steps before the
last run on ``Scene.quiet_model``, a copy of the model with sensors switched off: same physics,
5 % less work per step.) :class:`Terms` exposes them as affine maps
of the sensor vector, which the games combine into observation and measure matrices.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from functools import cache

import mujoco
import numpy as np

from arena_league.envs.rendering import TEAM_COLOURS
from arena_league.envs.robots.ant import CONTACT_FORCE_NET, JOINTS, LEGS, ROBOTS

#: Collision bit of the floor and the boxes; robot ``i`` owns bit ``i + 1``.
WORLD_BIT = 1
#: Physics sub-step (seconds).
TIMESTEP = 0.01
GRAVITY = 9.81
#: Visual markings: (kind, numbers). ``("ring", (radius,))`` centred on the origin,
#: ``("line", (x0, y0, x1, y1))``, ``("disc", (x, y, radius))``.
Marking = tuple[str, tuple[float, ...]]
MARKING_RGBA = (0.95, 0.95, 0.95, 1.0)


def robot_prefix(index: int) -> str:
    return f"r{index}/"


def box_prefix(index: int) -> str:
    return f"box{index}/"


def team_rgba(team: int) -> tuple[float, float, float, float]:
    """The RGBA colour of a team (``envs.rendering.TEAM_COLOURS``)."""
    r, g, b = TEAM_COLOURS[team % len(TEAM_COLOURS)]
    return (r / 255.0, g / 255.0, b / 255.0, 1.0)


@dataclass(frozen=True)
class SceneLayout:
    """What a scene holds. Robots are listed in seat order, ``teams`` gives each one's team (its
    colour); boxes (cubes of half-size ``box_half``) take the colour of ``box_teams``."""

    robots: tuple[str, ...]
    teams: tuple[int, ...]
    box_teams: tuple[int, ...] = ()
    box_half: float = 0.3
    box_mass: float = 0.5
    #: Sliding friction of the boxes (they win the friction of their contacts by priority).
    box_friction: float = 0.4
    markings: tuple[Marking, ...] = ()
    floor_half: float = 10.0

    def __post_init__(self) -> None:
        unknown = sorted(set(self.robots) - set(ROBOTS))
        if unknown:
            raise ValueError(f"unknown robot(s) {unknown}; the robot library has: {', '.join(sorted(ROBOTS))}")
        if len(self.teams) != len(self.robots):
            raise ValueError("a scene layout gives one team per robot")
        if len(self.robots) > 30:
            raise ValueError("a scene holds at most 30 robots (one collision bit each)")


@dataclass(frozen=True)
class Scene:
    """A compiled layout: the model and where each robot's and box's numbers live."""

    layout: SceneLayout
    model: mujoco.MjModel
    #: the same model with sensors switched off, for the sub-steps whose sensors nobody reads
    quiet_model: mujoco.MjModel
    #: sensor name -> indices into ``MjData.sensordata``
    sensor_index: dict[str, np.ndarray]
    #: qpos / qvel address of each robot's free joint and of its hinge joints (action order)
    root_qpos: np.ndarray
    root_qvel: np.ndarray
    joint_qpos: np.ndarray  # [n_robots, n_joints]
    joint_qvel: np.ndarray
    box_qpos: np.ndarray
    box_qvel: np.ndarray
    #: robot weight (N), for force units
    weight: np.ndarray
    #: body ids for drawing: torso, hips, shins of each robot; each box
    torso_body: np.ndarray
    hip_body: np.ndarray  # [n_robots, 4]
    shin_body: np.ndarray  # [n_robots, 4]
    box_body: np.ndarray
    #: from each leg's shin body to its foot tip, in the shin's frame [4, 3]
    foot_vector: np.ndarray

    @property
    def n_robots(self) -> int:
        return len(self.layout.robots)

    @property
    def n_sensordata(self) -> int:
        return int(self.model.nsensordata)

    def terms(self) -> Terms:
        return Terms(self)


def build_scene_spec(layout: SceneLayout) -> mujoco.MjSpec:
    """The ``MjSpec`` of a layout: floor, markings, boxes, and one robot per seat attached by prefix."""
    spec = mujoco.MjSpec()
    spec.modelname = "arena_league_robots"
    spec.compiler.degree = False
    opt = spec.option
    opt.timestep = TIMESTEP
    opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    opt.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    # no implicit joint damping (the joints' armature keeps explicit damping stable) and no BVH
    # mid-phase (each body has at most five primitive geoms): together about 10 % of a step
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP | mujoco.mjtDisableBit.mjDSBL_MIDPHASE
    geom = mujoco.mjtGeom
    half = layout.floor_half
    spec.worldbody.add_geom(name="floor", type=geom.mjGEOM_PLANE, size=[half, half, 0.1],
                            contype=WORLD_BIT, conaffinity=WORLD_BIT, rgba=[0.35, 0.45, 0.35, 1.0])
    _add_markings(spec, layout.markings)
    n = len(layout.robots)
    robot_bits = sum(1 << (i + 1) for i in range(n))
    for b, team in enumerate(layout.box_teams):
        prefix = box_prefix(b)
        body = spec.worldbody.add_body(name=f"{prefix}body", pos=[0.0, 0.0, layout.box_half])
        body.add_freejoint(name=f"{prefix}root")
        h = layout.box_half
        body.add_geom(name=f"{prefix}geom", type=geom.mjGEOM_BOX, size=[h, h, h], mass=layout.box_mass,
                      contype=WORLD_BIT, conaffinity=WORLD_BIT | robot_bits, priority=1,
                      friction=[layout.box_friction, 0.005, 0.0001],
                      rgba=list(0.55 * np.array(team_rgba(team)) + 0.45 * np.array([0.9, 0.8, 0.6, 1.0])))
    for i, (kind, team) in enumerate(zip(layout.robots, layout.teams)):
        builder = ROBOTS[kind][0]
        robot = builder(rgba=team_rgba(team))
        own = 1 << (i + 1)
        for g in robot.geoms:
            g.contype = own
            g.conaffinity = WORLD_BIT | (robot_bits & ~own)
        frame = spec.worldbody.add_frame(pos=[0.0, 3.0 * i, 0.0])  # reset places the robots
        spec.attach(robot, prefix=robot_prefix(i), frame=frame)
    _add_scene_sensors(spec, layout)
    return spec


def _add_markings(spec: mujoco.MjSpec, markings: tuple[Marking, ...]) -> None:
    geom = mujoco.mjtGeom
    visual = {"contype": 0, "conaffinity": 0, "rgba": list(MARKING_RGBA), "group": 2}
    for k, (kind, numbers) in enumerate(markings):
        if kind == "ring":
            # one flat disc, lighter than the floor: every visual geom costs the broad phase
            (radius,) = numbers
            spec.worldbody.add_geom(name=f"ring{k}", type=geom.mjGEOM_CYLINDER, pos=[0.0, 0.0, 0.001],
                                    size=[radius, 0.001, 0], **{**visual, "rgba": [0.55, 0.62, 0.5, 1.0]})
        elif kind == "line":
            x0, y0, x1, y1 = numbers
            length = float(np.hypot(x1 - x0, y1 - y0))
            spec.worldbody.add_geom(name=f"line{k}", type=geom.mjGEOM_BOX, pos=[(x0 + x1) / 2, (y0 + y1) / 2, 0.002],
                                    euler=[0.0, 0.0, float(np.arctan2(y1 - y0, x1 - x0))],
                                    size=[length / 2, 0.04, 0.002], **visual)
        elif kind == "disc":
            x, y, radius = numbers
            spec.worldbody.add_geom(name=f"disc{k}", type=geom.mjGEOM_CYLINDER, pos=[x, y, 0.002],
                                    size=[radius, 0.002, 0], **{**visual, "rgba": [0.95, 0.85, 0.3, 1.0]})
        else:
            raise ValueError(f"unknown floor marking {kind!r}; markings are 'ring', 'line' or 'disc'")


def _add_scene_sensors(spec: mujoco.MjSpec, layout: SceneLayout) -> None:
    kinds, obj = mujoco.mjtSensor, mujoco.mjtObj
    # the match time, and a constant 1 (the x of a site fixed at (1, 0, 0)): with them every
    # readout, constants and clock included, is one linear map of the sensor vector
    spec.add_sensor(name="clock", type=kinds.mjSENS_CLOCK)
    spec.worldbody.add_site(name="unit", pos=[1.0, 0.0, 0.0])
    spec.add_sensor(name="unit", type=kinds.mjSENS_FRAMEPOS, objtype=obj.mjOBJ_SITE, objname="unit")
    for i in range(len(layout.robots)):
        p = robot_prefix(i)
        contact = spec.add_sensor(name=f"{p}floor_contact", type=kinds.mjSENS_CONTACT, objtype=obj.mjOBJ_XBODY,
                                  objname=f"{p}torso", reftype=obj.mjOBJ_GEOM, refname="floor")
        contact.intprm[:3] = CONTACT_FORCE_NET
    for b in range(len(layout.box_teams)):
        p = box_prefix(b)
        for name, kind in (("pos", kinds.mjSENS_FRAMEPOS), ("linvel", kinds.mjSENS_FRAMELINVEL),
                           ("xaxis", kinds.mjSENS_FRAMEXAXIS)):
            spec.add_sensor(name=f"{p}{name}", type=kind, objtype=obj.mjOBJ_XBODY, objname=f"{p}body")


@cache
def compile_scene(layout: SceneLayout) -> Scene:
    """The compiled scene of ``layout`` (built once per layout and process)."""
    model = build_scene_spec(layout).compile()
    quiet_model = copy.copy(model)  # a deep copy (mj_copyModel): same sizes, same physics
    quiet_model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_SENSOR
    sensor_index = {}
    for k in range(model.nsensor):
        adr, dim = int(model.sensor_adr[k]), int(model.sensor_dim[k])
        sensor_index[model.sensor(k).name] = np.arange(adr, adr + dim)
    n = len(layout.robots)

    def joint_adr(name: str) -> tuple[int, int]:
        j = model.joint(name)
        return int(j.qposadr[0]), int(j.dofadr[0])

    roots = [joint_adr(f"{robot_prefix(i)}root") for i in range(n)]
    hinges = [[joint_adr(f"{robot_prefix(i)}{j}") for j in JOINTS] for i in range(n)]
    boxes = [joint_adr(f"{box_prefix(b)}root") for b in range(len(layout.box_teams))]
    torso = np.array([model.body(f"{robot_prefix(i)}torso").id for i in range(n)], dtype=np.int64)
    hip = np.array([[model.body(f"{robot_prefix(i)}{leg}_hip").id for leg in LEGS] for i in range(n)], dtype=np.int64)
    shin = np.array([[model.body(f"{robot_prefix(i)}{leg}_shin").id for leg in LEGS] for i in range(n)], dtype=np.int64)
    feet = []
    if n:
        for leg in LEGS:
            g = model.geom(f"{robot_prefix(0)}{leg}_foot")
            feet.append(2.0 * g.size[1] * _geom_axis(model, g.id))  # capsule: half-length in size[1]
    weight = np.array([model.body_subtreemass[t] * GRAVITY for t in torso])
    # compiled sizes are frozen with the model: make the index arrays read-only too
    for array in sensor_index.values():
        array.flags.writeable = False
    return Scene(
        layout=layout,
        model=model,
        quiet_model=quiet_model,
        sensor_index=sensor_index,
        root_qpos=np.array([r[0] for r in roots], dtype=np.int64),
        root_qvel=np.array([r[1] for r in roots], dtype=np.int64),
        joint_qpos=np.array([[h[0] for h in row] for row in hinges], dtype=np.int64).reshape(n, len(JOINTS)),
        joint_qvel=np.array([[h[1] for h in row] for row in hinges], dtype=np.int64).reshape(n, len(JOINTS)),
        box_qpos=np.array([b[0] for b in boxes], dtype=np.int64),
        box_qvel=np.array([b[1] for b in boxes], dtype=np.int64),
        weight=weight,
        torso_body=torso,
        hip_body=hip,
        shin_body=shin,
        box_body=np.array([model.body(f"{box_prefix(b)}body").id for b in range(len(layout.box_teams))],
                          dtype=np.int64),
        foot_vector=np.array(feet) if feet else np.zeros((0, 3)),
    )


def _geom_axis(model: mujoco.MjModel, geom_id: int) -> np.ndarray:
    """The local z axis of a geom in its body's frame (a capsule lies along it), from the tip's side."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, model.geom_quat[geom_id])
    axis = mat.reshape(3, 3)[:, 2]
    centre = model.geom_pos[geom_id]
    # the capsule runs from the body origin through its centre: orient the axis that way
    return axis if axis @ centre >= 0 else -axis


# --- affine readouts of the sensor vector ---------------------------------------------------------

@dataclass
class Affine:
    """``y = M @ s + c``: ``k`` numbers as an affine function of the sensor vector ``s``."""

    M: np.ndarray  # [k, n_sensordata]
    c: np.ndarray  # [k]

    def __add__(self, other: Affine) -> Affine:
        return Affine(self.M + other.M, self.c + other.c)

    def __sub__(self, other: Affine) -> Affine:
        return Affine(self.M - other.M, self.c - other.c)

    def __neg__(self) -> Affine:
        return Affine(-self.M, -self.c)

    def __mul__(self, factor: float) -> Affine:
        return Affine(self.M * factor, self.c * factor)

    __rmul__ = __mul__

    def __getitem__(self, rows) -> Affine:
        return Affine(np.atleast_2d(self.M[rows]), np.atleast_1d(self.c[rows]))

    def __len__(self) -> int:
        return len(self.c)

    def rotated(self, angle: float) -> Affine:
        """The first two rows (an ``x, y`` vector) turned by ``angle`` about the vertical axis;
        the other rows (``z``) unchanged."""
        c, s = np.cos(angle), np.sin(angle)
        rot = np.eye(len(self.c))
        rot[:2, :2] = [[c, -s], [s, c]]
        rot[np.abs(rot) < 1e-15] = 0.0
        return Affine(rot @ self.M, rot @ self.c)

    @staticmethod
    def stack(parts: list[Affine]) -> Affine:
        return Affine(np.concatenate([p.M for p in parts]), np.concatenate([p.c for p in parts]))


class Terms:
    """The sensors of a scene as :class:`Affine` maps (world frame unless said)."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.size = scene.n_sensordata

    def sensor(self, name: str) -> Affine:
        index = self.scene.sensor_index.get(name)
        if index is None:
            raise KeyError(f"the scene has no sensor {name!r}; sensors: {', '.join(sorted(self.scene.sensor_index))}")
        M = np.zeros((len(index), self.size))
        M[np.arange(len(index)), index] = 1.0
        return Affine(M, np.zeros(len(index)))

    def robot(self, i: int, name: str) -> Affine:
        """A robot's sensor (``pos``, ``xaxis``, ``zaxis``, ``linvel``, ``angvel``, ``qpos_<joint>``,
        ``qvel_<joint>``, ``contact``, ``floor_contact``)."""
        return self.sensor(f"{robot_prefix(i)}{name}")

    def joints(self, i: int, kind: str) -> Affine:
        """``qpos`` or ``qvel`` of the robot's joints, in action order."""
        return Affine.stack([self.robot(i, f"{kind}_{j}") for j in JOINTS])

    def floor_force(self, i: int) -> Affine:
        """Contact force the floor exerts on robot ``i`` (N)."""
        return -self.robot(i, "floor_contact")

    def push_force(self, i: int) -> Affine:
        """Contact force other robots and the boxes exert on robot ``i`` (N): all contacts minus
        the floor's."""
        return self.robot(i, "floor_contact") - self.robot(i, "contact")

    def box(self, b: int, name: str) -> Affine:
        return self.sensor(f"{box_prefix(b)}{name}")

    @property
    def unit_index(self) -> int:
        """Where the constant 1 sits in the sensor vector."""
        return int(self.scene.sensor_index["unit"][0])

    def readout(self) -> Readout:
        return Readout(self.size, self.unit_index)

    def time(self) -> Affine:
        """The match time (s) at the sensors' instant."""
        return self.sensor("clock")

    def const(self, values) -> Affine:
        values = np.asarray(values, dtype=np.float64).reshape(-1)
        return Affine(np.zeros((len(values), self.size)), values.copy())

    def zeros(self, k: int) -> Affine:
        return self.const(np.zeros(k))


class Readout:
    """Named row blocks of one affine map of the sensor vector. :meth:`build` folds the constant
    part into the column of the scene's ``unit`` sensor (a constant 1), so the readout is one
    matrix product ``M @ sensordata``."""

    def __init__(self, size: int, unit_index: int) -> None:
        self.size = size
        self.unit_index = unit_index
        self._parts: list[Affine] = []
        self.slices: dict[str, slice] = {}
        self.rows = 0

    def add(self, name: str, term: Affine) -> slice:
        if name in self.slices:
            raise ValueError(f"readout block {name!r} is defined twice")
        sl = slice(self.rows, self.rows + len(term))
        self._parts.append(term)
        self.slices[name] = sl
        self.rows += len(term)
        return sl

    def build(self) -> np.ndarray:
        """``M``, a C-contiguous ``[rows, n_sensordata]`` array with the constants folded in."""
        if not self._parts:
            return np.zeros((0, self.size))
        whole = Affine.stack(self._parts)
        matrix = np.ascontiguousarray(whole.M)
        matrix[:, self.unit_index] += whole.c
        return matrix
