"""What every robot game shares: MuJoCo stepping, observations, measures, and many matches at once.

The robot games (Sumo, RunToGoal, YouShallNotPass, PushBox) follow Bansal et al., "Emergent
Complexity via Multi-Agent Competition" (ICLR 2018) and Arena's robot-ant games (Song et al.,
"Arena", AAAI 2020). A game subclasses :class:`RobotGameRules` and supplies its scene, its start
positions, each seat's target, its own observation cells and its judgement (who won, who arrived);
this module does the rest:

* **Actions** are joint torques in [-1, 1], one per actuator (``act_dim = 8`` for the ant), the
  only action type (``"continuous"``). Inactive seats' actions are replaced by zero torque.
* **Stepping**: ``frame_skip`` MuJoCo sub-steps of 0.01 s per match step (5 by default: 0.05 s),
  ``mj_step(quiet_model, data, nstep=frame_skip - 1)`` then ``mj_step(model, data)``: the
  sub-steps whose sensors nobody reads run on a copy of the model with sensors switched off.
* **Observation**: the robot block of ``envs.robots.observation`` (43 cells) then the game's cells;
  observations and the linear parts of the measures are one matrix product of MuJoCo's sensor
  vector per step (its ``clock`` and constant ``unit`` sensors carry time and constants), every
  cell then clipped to its bounds (``observation_bounds``: the robot block's are in
  ``envs.robots.observation``, each game's manual gives its own cells').
* **Measures** (each game's manual names the seat's target): ``target_distance`` (m, horizontal),
  ``velocity_to_target`` (m/s along the horizontal way to the target), ``facing_target`` (the
  torso's forward axis along that way: the cosine of the angle between them while the torso is
  level), ``energy`` (mean squared action), ``force`` (the horizontal contact force other robots
  and props exert on the seat, in units of its weight), ``speed`` (horizontal, m/s), ``fallen``
  (the torso's up axis points below the horizon: ``FALLEN_UP_Z``) and ``outcome``; games add
  more. ``measures.block`` holds the float ones as rows of one array (``envs.robots.rewards``).
* **Annealing** of the dense motor reward: ``set_anneal(alpha)``, see ``envs.robots.rewards``.

Copies: the rules pickle and copy (``pickle``, ``copy.deepcopy``) as their game options plus a
snapshot of the match (MuJoCo's whole ``MjData``, the match arrays, the generator, the annealing
weight and the step the match is cut at); a copy builds new rules and loads the snapshot into them,
so it goes on bit for bit as the original does.

Many matches: the game logic is written over arrays of ``B`` matches (:class:`MatchState`); the
rules play one (``B = 1``), and :class:`RobotMatches` (the match engine's batched path) plays many,
one ``MjData`` each, stepping them on a pool of threads: ``mj_step`` releases Python's GIL, so
threads step matches in parallel. Every match is stepped exactly as the rules step it, so results
are bit-identical to the env path whatever the batch or the thread count. It is every robot game's
``batched_matches``. A paired game's ``pair_points`` (``RobotGameRules.match_pair_points``) read only
the match state, kept in the game's memory, so both paths give the same points too.

A person plays a robot game by walking directions (``envs.robots.controls``); a replay shows the
scene in 3D (``envs.robots.render.replay_scene``).
"""

from __future__ import annotations

import os
from abc import abstractmethod
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco
import numpy as np

from arena_league.envs.core import GameRules, cell_bounds
from arena_league.envs.options import Option
from arena_league.envs.robots import observation as cells
from arena_league.envs.robots.ant import ROBOTS
from arena_league.envs.robots.controls import RobotControls
from arena_league.envs.robots.rewards import RobotMeasures, check_anneal
from arena_league.envs.robots.scene import Affine, Readout, Scene, SceneLayout, compile_scene

#: A torso whose up axis has a vertical component below this has fallen (tilted past 90 degrees).
FALLEN_UP_Z = 0.0
#: Radians of the gait clock per unit of the observation's time cell.
_CLOCK_RATE = 2.0 * np.pi * cells.TIME_UNIT / cells.CLOCK_PERIOD
#: Random spread of the start pose: joint angles (rad) around the standing pose.
JOINT_JITTER = 0.05
#: Torso height above the standing height at the start (the ant drops onto its feet).
DROP = 0.02

#: Measures every robot game emits.
BASE_MEASURES = frozenset({"active", "target_distance", "velocity_to_target", "facing_target", "energy", "force",
                           "speed", "fallen", "outcome"})
#: Measures a robot game may add to ``BASE_MEASURES`` (kept in ``MatchState`` for every game).
_OPTIONAL_MEASURES = frozenset({"arrived", "alive", "object_progress"})
#: Game options every robot game takes, after its own (``RobotGameRules.game_options``).
COMMON_OPTIONS: tuple[Option, ...] = (
    Option("frame_skip", int, 5, "MuJoCo sub-steps of 0.01 s per match step", low=1, high=20),
    Option("anneal", float, 1.0, "weight of the dense motor reward, annealed from 1 to 0 over training "
           "by set_anneal", low=0.0, high=1.0),
)


def start_jitter(high: float) -> Option:
    """The option every robot game offers to spread its start poses: up to ``high`` m and rad."""
    return Option("start_jitter", float, 0.2, "largest random shift of each start position, in m, "
                  "and heading, in rad",
                  low=0.0, high=high)


def duel_tree(dense: str = "robot_motion") -> dict:
    """The default tree of the two-ant duels: CP ``win_loss`` (scale 100) over the two agent leaves,
    each with the IS motor reward (scale 1), as Bansal et al. blend dense and sparse rewards."""
    return {"scheme": "CP", "reward": "win_loss", "scale": 100, "children": [
        {"agent": f"player_{seat}", "scheme": "IS", "reward": dense, "scale": 1} for seat in range(2)]}


@dataclass
class StartPose:
    """Where a match starts (world frame): each robot's torso ``xy`` and heading (and, for
    scripted scenarios, a roll about its forward axis: ``pi`` lays it on its back), each box's."""

    robot_xy: np.ndarray  # [n_robots, 2]
    robot_yaw: np.ndarray  # [n_robots]
    box_xy: np.ndarray  # [n_boxes, 2]
    box_yaw: np.ndarray  # [n_boxes]
    robot_roll: np.ndarray | None = None  # [n_robots]


def _apply(matrix: np.ndarray, term: Affine) -> Affine:
    """``matrix @ term`` (a fixed linear map of a small affine vector)."""
    return Affine(matrix @ term.M, matrix @ term.c)


class MatchState:
    """The per-match arrays of ``B`` matches of one game (row ``b`` is match ``b``), with views
    into the readout (``lin``) that the step fills in place."""

    def __init__(self, n_slots: int, n_agents: int, n_teams: int, act_dim: int, rows: int) -> None:
        B, n = n_slots, n_agents
        self.n_slots = B
        #: steps played by each match (the rules count theirs too: a game's judgement may read it)
        self.steps = np.zeros(B, dtype=np.int64)
        self.done = np.zeros(B, dtype=bool)
        self.active = np.ones((B, n), dtype=bool)
        self.alive = np.ones((B, n), dtype=bool)
        self.arrived = np.zeros((B, n), dtype=bool)
        self.fallen = np.zeros((B, n), dtype=bool)
        self.outcome = np.zeros((B, n))
        self.result = np.full((B, n_teams), 0.5)
        self.object_progress = np.zeros((B, n))
        self.ctrl = np.zeros((B, n, act_dim))
        self.lin = np.zeros((B, rows))
        #: set once a seat of some match left play (arrived or taken out): observations then
        #: copy the active flags instead of the constant 1
        self.any_inactive = False
        self.memory: dict[str, np.ndarray] = {}
        self.events: list[list[dict]] = [[] for _ in range(B)]

    def bind(self, obs_rows: int, obs_dim: int, complex_rows: slice, groups: int, up_z: slice) -> None:
        """Make the views of ``lin`` and the storage the step writes (called once)."""
        B, n = self.active.shape
        lin = self.lin
        self.obs = lin[:, :obs_rows].reshape(B, n, obs_dim)
        self.obs_active = self.obs[:, :, cells.ACTIVE]
        self.obs_time = self.obs[:, :, cells.TIME]
        self.obs_clock = self.obs[:, :, cells.CLOCK]
        self.phase = np.zeros((B, n))
        #: complex numbers x + iy of world-frame vectors, [B, group, seat]: 0 the way to the
        #: target (conjugated: x - iy), 1 the velocity, 2 the forward axis, 3 the horizontal push
        #: force / weight, then the game's own groups
        self.complex = lin[:, complex_rows].view(np.complex128).reshape(B, groups, n)
        self.complex_target = self.complex[:, 0:1]
        self.complex_moving = self.complex[:, 1:3]
        #: the float measures of each match as rows of one block [B, row, seat] (see MOTION_ROWS):
        #: the lengths of the complex groups, then velocity_to_target, facing_target, energy and
        #: fallen as 0/1, so that a weighted sum of measures is one dot product
        self.block = np.zeros((B, groups + 4, n))
        self.absolute = self.block[:, :groups]  # |complex|
        self.target_distance = self.absolute[:, 0]
        self.speed = self.absolute[:, 1]
        self.force = self.absolute[:, 3]
        self.safe_distance = np.ones((B, 1, n))
        self.product = np.zeros((B, 2, n), dtype=np.complex128)
        self.product_real = self.product.real
        self.projection = self.block[:, groups: groups + 2]  # velocity and forward axis along the way
        self.velocity_to_target = self.projection[:, 0]
        self.facing_target = self.projection[:, 1]
        self.energy = self.block[:, groups + 2]
        self.fallen_float = self.block[:, groups + 3]
        self.block_rows = {"target_distance": 0, "speed": 1, "force": 3, "velocity_to_target": groups,
                           "facing_target": groups + 1, "energy": groups + 2, "fallen": groups + 3}
        self.up_z = lin[:, up_z]
        self.ctrl_squared = np.zeros_like(self.ctrl)
        self.flags = np.zeros((B, n), dtype=bool)  # scratch for the games' judgement

    def load(self, other: MatchState) -> None:
        """Take the values of ``other`` (a match state of the same game and size, e.g. unpickled)
        into this one's own arrays, in place, so that every view made by :meth:`bind` (and any
        array its owner shares with it) shows them. Arrays that are views of something else, such
        as the torques in MuJoCo's control buffer, are left to their owner."""
        for name, value in vars(other).items():
            mine = getattr(self, name)
            if isinstance(mine, np.ndarray):
                if mine.base is None:
                    np.copyto(mine, value)
            elif name == "memory":
                for key, array in value.items():
                    np.copyto(mine[key], array)
            elif name == "events":
                self.events = [list(events) for events in value]
            else:
                setattr(self, name, value)

    def restart(self, slot: int) -> None:
        """Fresh per-match values for a new match in ``slot`` (the game resets its memory)."""
        self.steps[slot] = 0
        self.done[slot] = False
        self.active[slot] = True
        self.alive[slot] = True
        self.arrived[slot] = False
        self.outcome[slot] = 0.0
        self.result[slot] = 0.5
        self.ctrl[slot] = 0.0
        self.object_progress[slot] = 0.0
        self.events[slot] = []


class RobotGameRules(GameRules):
    """The shared rules of a robot game (see the module docstring); games implement the hooks."""

    action_types: ClassVar[tuple[str, ...]] = ("continuous",)
    #: Robot of every seat (a key of ``envs.robots.ant.ROBOTS``).
    robot: ClassVar[str] = "ant"
    #: The game's own options; its ``options`` are these then ``COMMON_OPTIONS`` (set for every subclass).
    game_options: ClassVar[tuple[Option, ...]] = ()
    options: ClassVar[tuple[Option, ...]] = COMMON_OPTIONS

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.options = (*cls.game_options, *COMMON_OPTIONS)

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "continuous", **options: Any) -> None:
        if (n_teams, players_per_team) not in self.layouts:
            valid = ", ".join(f"{t}T{p}P" for t, p in self.layouts)
            raise ValueError(f"{self.name} has no {n_teams}T{players_per_team}P layout; valid layouts: {valid}")
        if action_type not in self.action_types:
            raise ValueError(f"{self.name} action_type {action_type!r} is not offered; robot games take joint "
                             f"torques: valid: {', '.join(map(repr, self.action_types))}")
        self.settings = self.checked_options(options)
        super().__init__(n_teams, players_per_team, action_type)
        self.measures = RobotMeasures.allocate(self.n_agents, self.measures_provided)
        self.measures.anneal = self.settings["anneal"]
        self.frame_skip = int(self.settings["frame_skip"])
        self.scene: Scene = compile_scene(self.scene_layout())
        self.model = self.scene.model
        self._quiet_model = self.scene.quiet_model
        self._quiet_substeps = self.frame_skip - 1
        self.shape = ROBOTS[self.robot][1]
        self.standing_pose = ROBOTS[self.robot][2]
        self.act_dim = int(self.model.nu) // self.n_agents
        self.n_actions = 0
        self.terms = self.scene.terms()
        #: Seat frame of each seat: the world turned by this angle about the vertical axis.
        self.seat_angle = np.pi * self.team_of.astype(np.float64) if n_teams == 2 else \
            2 * np.pi * self.team_of.astype(np.float64) / n_teams
        self._build_readouts()
        # bounds of the observation [seat, cell] (every match alike) and of the state, for clipping
        self._obs_low, self._obs_high = (np.tile(bound.astype(np.float64), (self.n_agents, 1))
                                         for bound in self.observation_bounds())
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())
        self.data = mujoco.MjData(self.model)
        self.match = self.new_match_state(1)
        # the match's torques are MuJoCo's own control buffer: one multiply writes them
        self.match.ctrl = self.data.ctrl.reshape(1, self.n_agents, self.act_dim)
        self.match.ctrl_squared = np.zeros_like(self.match.ctrl)
        self._seat_ctrl = self.match.ctrl[0]
        self._active_column = self.match.active[0][:, None]
        self._sensor_vector = self.data.sensordata
        self._lin = self.match.lin[0]
        self._publish_measures()
        self.game_over = False

    # --- game hooks ----------------------------------------------------------------------------
    @abstractmethod
    def scene_layout(self) -> SceneLayout:
        """The scene of this layout (robots in seat order, boxes, floor markings)."""

    @abstractmethod
    def start_pose(self, rng: np.random.Generator) -> StartPose:
        """Start positions of a match, drawn from ``rng`` only."""

    @abstractmethod
    def target_term(self, seat: int) -> Affine:
        """The seat's target point ``x, y`` (world frame) as an affine map of the sensors."""

    @abstractmethod
    def game_cells(self, seat: int) -> Affine:
        """The game's own observation cells of ``seat`` (after the robot block), seat frame."""

    @abstractmethod
    def game_cell_bounds(self) -> tuple[tuple[float, float, int], ...]:
        """Bounds of the game's own cells (every seat alike), as runs ``(low, high, cells)`` in
        cell order; ``observation.OTHER_ROBOT_BOUNDS`` covers :meth:`other_robot_cells`."""

    def game_readout(self, readout: Readout) -> None:
        """Add the rows the game's judgement reads (world frame) to ``readout``."""

    def allocate_memory(self, n_slots: int) -> dict[str, np.ndarray]:
        """Per-match arrays the game keeps between steps."""
        return {}

    def on_start(self, st: MatchState, slot: int) -> None:
        """A new match starts in ``slot`` (its readout is fresh): set the game's memory."""

    @abstractmethod
    def judge(self, st: MatchState, live: np.ndarray | None) -> None:
        """After a step of the ``live`` matches (bool[B]; None: all of them): set ``active``,
        ``arrived``, ``alive``, ``object_progress`` and, for matches that end, ``done``,
        ``outcome`` and ``result`` (see :meth:`end_matches`). A game that takes a seat out of play
        mid-match sets ``st.any_inactive``."""

    def cut(self, st: MatchState, slot: int) -> None:
        """The match in ``slot`` is cut at ``max_cycles``: set its ``outcome`` and ``result``
        (default: a draw; a game that judges the time limit otherwise overrides this)."""
        self.end_match(st, slot, -1)

    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        """Default: :func:`duel_tree`, one agent per team (team games override this)."""
        return duel_tree()

    # --- construction --------------------------------------------------------------------------
    def _seat_vector(self, seat: int, term: Affine) -> Affine:
        """A world-frame vector (``x, y`` first) in the seat's frame."""
        return term.rotated(-float(self.seat_angle[seat]))

    def robot_block(self, seat: int) -> Affine:
        """The 43 robot cells of ``seat`` (``envs.robots.observation``)."""
        t = self.terms
        weight_units = 1.0 / (cells.FORCE_UNIT * self.scene.weight[seat])
        pos = t.robot(seat, "pos")
        to_target = self.target_term(seat) - pos[0:2]
        parts = [
            t.const([1.0]),  # active: seats taken out of play are patched after the product
            t.time() * (1.0 / cells.TIME_UNIT),
            pos[2],
            self._seat_vector(seat, t.robot(seat, "xaxis")),
            self._seat_vector(seat, t.robot(seat, "zaxis")),
            self._seat_vector(seat, t.robot(seat, "linvel")) * (1.0 / cells.VELOCITY_UNIT),
            t.robot(seat, "angvel") * (1.0 / cells.ANGULAR_UNIT),
            t.joints(seat, "qpos"),
            t.joints(seat, "qvel") * (1.0 / cells.ANGULAR_UNIT),
            self._seat_vector(seat, t.push_force(seat)) * weight_units,
            self._seat_vector(seat, t.floor_force(seat)) * weight_units,
            self._seat_vector(seat, pos[0:2]) * (1.0 / cells.POSITION_UNIT),
            self._seat_vector(seat, to_target) * (1.0 / cells.POSITION_UNIT),
            t.const([0.0, 0.0]),  # the gait clock: a function of the time cell, set after the product
        ]
        block = Affine.stack(parts)
        assert len(block) == cells.ROBOT_CELLS
        return block

    def other_robot_cells(self, seat: int, other: int) -> Affine:
        """Seven cells describing robot ``other`` from ``seat``: its position relative to the seat
        (2, / ``POSITION_UNIT``), its velocity (2, / ``VELOCITY_UNIT``), its forward axis (2), all
        in the seat frame, and the vertical part of its up axis (1; negative once it fell)."""
        t = self.terms
        rel = t.robot(other, "pos")[0:2] - t.robot(seat, "pos")[0:2]
        return Affine.stack([
            self._seat_vector(seat, rel) * (1.0 / cells.POSITION_UNIT),
            self._seat_vector(seat, t.robot(other, "linvel")[0:2]) * (1.0 / cells.VELOCITY_UNIT),
            self._seat_vector(seat, t.robot(other, "xaxis")[0:2]),
            t.robot(other, "zaxis")[2],
        ])

    def _build_readouts(self) -> None:
        n = self.n_agents
        t = self.terms
        blocks = [Affine.stack([self.robot_block(i), self.game_cells(i)]) for i in range(n)]
        self.obs_dim = len(blocks[0])
        if any(len(b) != self.obs_dim for b in blocks):
            raise RuntimeError(f"{self.name}: every seat's observation must have the same size")
        readout = t.readout()
        readout.add("obs", Affine.stack(blocks))

        def per_seat(fn) -> Affine:
            return Affine.stack([fn(i) for i in range(n)])

        # world-frame x, y pairs, read as complex numbers (MatchState.complex); the way to the
        # target is stored conjugated, (x, -y), so that products with it are dot products at once
        conjugate = np.diag([1.0, -1.0])
        groups = [("to_target", lambda i: _apply(conjugate, self.target_term(i) - t.robot(i, "pos")[0:2])),
                  ("velocity", lambda i: t.robot(i, "linvel")[0:2]),
                  ("heading", lambda i: t.robot(i, "xaxis")[0:2]),
                  ("push", lambda i: t.push_force(i)[0:2] * (1.0 / self.scene.weight[i])),
                  *self.game_complex()]
        for name, fn in groups:
            readout.add(name, per_seat(fn))
        #: index of each complex group in MatchState.complex / .absolute
        self.complex_group = {name: k for k, (name, _) in enumerate(groups)}
        complex_rows = slice(readout.slices[groups[0][0]].start, readout.slices[groups[-1][0]].stop)
        readout.add("up_z", per_seat(lambda i: t.robot(i, "zaxis")[2]))
        self.game_readout(readout)
        self.readout = readout
        # one matrix-vector product per match (never a matrix-matrix product over many matches:
        # BLAS threads those, and its threads stall when the process is pinned to fewer CPUs)
        self._readout = readout.build()
        s = readout.slices
        self._obs_rows = s["obs"].stop
        self._slices = s
        self._bind = (self._obs_rows, self.obs_dim, complex_rows, len(groups), s["up_z"])
        self._energy_weights = np.full(self.act_dim, 1.0 / self.act_dim)
        self.state_dim = 8 * n + 4 * len(self.scene.layout.box_teams)
        self._state_matrix = self._state_readout().build()

    def game_complex(self) -> list[tuple[str, Any]]:
        """Extra world-frame ``x, y`` vectors of each seat whose length the judgement needs:
        ``(name, seat -> Affine of 2 rows)``; their lengths land in ``MatchState.absolute``."""
        return []

    def new_match_state(self, n_slots: int) -> MatchState:
        """A bound :class:`MatchState` of ``n_slots`` matches of this game."""
        st = MatchState(n_slots, self.n_agents, self.n_teams, self.act_dim, self.readout.rows)
        st.memory = self.allocate_memory(n_slots)
        st.bind(*self._bind)
        return st

    def _state_readout(self) -> Readout:
        t = self.terms
        readout = t.readout()
        parts = []
        for i in range(self.n_agents):
            pos = t.robot(i, "pos")
            parts += [pos[0:2] * (1.0 / cells.POSITION_UNIT), pos[2], t.robot(i, "xaxis")[0:2],
                      t.robot(i, "zaxis")[2], t.robot(i, "linvel")[0:2] * (1.0 / cells.VELOCITY_UNIT)]
        for b in range(len(self.scene.layout.box_teams)):
            parts += [t.box(b, "pos")[0:2] * (1.0 / cells.POSITION_UNIT),
                      t.box(b, "linvel")[0:2] * (1.0 / cells.VELOCITY_UNIT)]
        readout.add("state", Affine.stack(parts))
        return readout

    def _publish_measures(self) -> None:
        """Point the measures at row 0 of the match state (updated in place every step)."""
        self.point_measures(self.measures, self.match, 0)

    def point_measures(self, m: RobotMeasures, st: MatchState, slot: int | None) -> None:
        """Point ``m`` at the arrays of the matches in ``st`` (updated in place every step): at
        row ``slot``, or at every row (arrays ``[B, n_agents]``, ``block`` ``[B, rows,
        n_agents]``) when ``slot`` is None."""
        rows = slice(None) if slot is None else slot
        m.block = st.block[rows]
        m.block_rows = st.block_rows
        for name in ("active", "outcome", "fallen", "target_distance", "velocity_to_target", "facing_target",
                     "energy", "force", "speed", *(_OPTIONAL_MEASURES & self.measures_provided)):
            setattr(m, name, getattr(st, name)[rows])

    # --- the shared step -----------------------------------------------------------------------
    def place(self, data: mujoco.MjData, pose: StartPose, rng: np.random.Generator | None) -> None:
        """Reset ``data`` to ``pose`` (joint angles jittered from ``rng``, if given), at rest."""
        model, scene = self.model, self.scene
        mujoco.mj_resetData(model, data)
        qpos = data.qpos
        height = self.shape.standing_height() + DROP
        for i in range(self.n_agents):
            a = scene.root_qpos[i]
            yaw = float(pose.robot_yaw[i])
            roll = 0.0 if pose.robot_roll is None else float(pose.robot_roll[i])
            qpos[a: a + 3] = (pose.robot_xy[i, 0], pose.robot_xy[i, 1], height)
            # the heading turn about z, then the roll about the torso's own x axis
            cy, sy, cr, sr = np.cos(yaw / 2), np.sin(yaw / 2), np.cos(roll / 2), np.sin(roll / 2)
            qpos[a + 3: a + 7] = (cy * cr, cy * sr, sy * sr, sy * cr)
            jitter = rng.uniform(-JOINT_JITTER, JOINT_JITTER, self.act_dim) if rng is not None else 0.0
            qpos[scene.joint_qpos[i]] = self.standing_pose + jitter
        half = scene.layout.box_half
        for b in range(len(scene.layout.box_teams)):
            a = scene.box_qpos[b]
            yaw = float(pose.box_yaw[b])
            qpos[a: a + 3] = (pose.box_xy[b, 0], pose.box_xy[b, 1], half)
            qpos[a + 3: a + 7] = (np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2))
        mujoco.mj_forward(model, data)

    def simulate(self, data: mujoco.MjData) -> None:
        """One match step of physics on ``data``: ``frame_skip`` sub-steps, sensors on the last."""
        if self._quiet_substeps:
            mujoco.mj_step(self._quiet_model, data, nstep=self._quiet_substeps)
        mujoco.mj_step(self.model, data)

    def read(self, st: MatchState, slot: int, sensordata: np.ndarray) -> None:
        """The readout (observations and the linear parts of the measures) of the match in
        ``slot`` from its sensor vector: one matrix-vector product (BLAS gemv: single-threaded at
        these sizes, and the same arithmetic on every path, so paths agree to the bit)."""
        np.dot(self._readout, sensordata, out=st.lin[slot])

    def update(self, st: MatchState) -> None:
        """The measures of every match from its readout and torques, in place (pure: no game
        memory changes). Few numpy calls on purpose: with two ants this runs beside about 80 us
        of physics per step."""
        np.multiply(st.obs_time, _CLOCK_RATE, out=st.phase)
        np.cos(st.phase, out=st.obs_clock[:, :, 0])
        np.sin(st.phase, out=st.obs_clock[:, :, 1])
        obs = st.obs
        np.minimum(obs, self._obs_high, out=obs)  # every cell within its bounds (the clock from the bare time)
        np.maximum(obs, self._obs_low, out=obs)
        if st.any_inactive:
            st.obs_active[...] = st.active
        np.abs(st.complex, out=st.absolute)
        # velocity and forward axis times the conjugated way to the target: real parts are dot products
        np.multiply(st.complex_moving, st.complex_target, out=st.product)
        np.maximum(st.absolute[:, 0:1], 1e-9, out=st.safe_distance)
        np.divide(st.product_real, st.safe_distance, out=st.projection)
        np.less(st.up_z, FALLEN_UP_Z, out=st.fallen)
        np.less(st.up_z, FALLEN_UP_Z, out=st.fallen_float)
        np.multiply(st.ctrl, st.ctrl, out=st.ctrl_squared)
        np.matmul(st.ctrl_squared, self._energy_weights, out=st.energy)

    def observations(self, st: MatchState) -> np.ndarray:
        """``float32[B, n_agents, obs_dim]`` of every match in ``st``."""
        return st.obs.astype(np.float32)

    # --- GameRules -------------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.place(self.data, self.start_pose(self.rng), self.rng)
        st = self.match
        st.restart(0)
        self.read(st, 0, self._sensor_vector)
        self.update(st)
        self.on_start(st, 0)
        self.game_over = False

    def arrange(self, pose: StartPose) -> None:
        """Put the robots (in their standing pose) and boxes where ``pose`` says, at rest, and go
        on with the match from there (for tests and scripted scenarios); the step count stays."""
        self.place(self.data, pose, None)
        self.read(self.match, 0, self._sensor_vector)
        self.update(self.match)
        self.on_start(self.match, 0)

    def step(self, actions: np.ndarray) -> None:
        st = self.match
        np.multiply(actions, self._active_column, out=self._seat_ctrl)
        data = self.data
        if self._quiet_substeps:
            mujoco.mj_step(self._quiet_model, data, nstep=self._quiet_substeps)
        mujoco.mj_step(self.model, data)
        st.steps[0] += 1
        if st.events[0]:
            st.events[0] = []
        np.dot(self._readout, self._sensor_vector, out=self._lin)
        self.update(st)
        self.judge(st, None)
        if st.any_inactive:  # seats the judgement just took out of play say so at once
            st.obs_active[...] = st.active
        self.game_over = bool(st.done[0])

    def observe(self) -> np.ndarray:
        return self.match.obs[0].astype(np.float32)

    def state(self) -> np.ndarray:
        state = self._state_matrix @ self._sensor_vector
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return cell_bounds(*cells.ROBOT_BLOCK_BOUNDS, *self.game_cell_bounds())

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        n_boxes = len(self.scene.layout.box_teams)
        return cell_bounds(*cells.ROBOT_STATE_BOUNDS * self.n_agents, *cells.BOX_STATE_BOUNDS * n_boxes)

    # --- copies ----------------------------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        return {"arguments": ((self.n_teams, self.players_per_team, self.action_type), dict(self.settings)),
                "data": self.data, "match": self.match, "rng": self.rng, "game_over": self.game_over,
                "anneal": self.measures.anneal, "max_cycles": self.max_cycles}

    def __setstate__(self, state: dict[str, Any]) -> None:
        args, kwargs = state["arguments"]
        self.__init__(*args, **kwargs)
        mujoco.mj_copyData(self.data, self.model, state["data"])
        self.match.load(state["match"])
        self.rng = state["rng"]
        self.game_over = state["game_over"]
        self.measures.anneal = state["anneal"]
        self.max_cycles = state["max_cycles"]

    def finish(self) -> None:
        if not self.match.done[0]:
            self.cut(self.match, 0)
            self.match.done[0] = True

    def team_result(self) -> np.ndarray:
        return self.match.result[0].copy()

    def pair_points(self) -> np.ndarray:
        cap = self.default_max_cycles if self.max_cycles is None else self.max_cycles
        return self.match_pair_points(self.match, 0, cap)

    def match_pair_points(self, st: MatchState, slot: int, max_cycles: int) -> np.ndarray:
        """``pair_points`` of the ended match in ``slot`` of ``st``, cut at ``max_cycles``: what the
        rules (one match) and :class:`RobotMatches` (many) both answer, from the match state only.
        Default: the team result; a paired game overrides it."""
        return st.result[slot].copy()

    def events(self) -> list[dict]:
        return list(self.match.events[0])

    def set_anneal(self, alpha: float) -> None:
        """Weight of the dense motor reward ``robot_motion`` from now on (1 early in training, 0
        late): see ``envs.robots.rewards``. Kept across resets."""
        self.measures.anneal = check_anneal(alpha)

    @property
    def anneal(self) -> float:
        return float(self.measures.anneal)

    def render_topdown(self) -> np.ndarray:
        from arena_league.envs.robots.render import topdown_picture

        return topdown_picture(self.scene, self.data, self.view_extent())

    def view_extent(self) -> tuple[float, float, float, float]:
        """The world box ``x0, x1, y0, y1`` the top-down picture shows."""
        return (-4.0, 4.0, -4.0, 4.0)

    def render_camera(self, width: int = 480, height: int = 360) -> np.ndarray:
        """A perspective picture from MuJoCo's own renderer (needs OpenGL, e.g. ``MUJOCO_GL=egl``);
        raises ``RuntimeError`` where no GL context can be made."""
        from arena_league.envs.robots.render import camera_picture

        return camera_picture(self.model, self.data, width, height)

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        from arena_league.envs.robots.render import replay_scene

        return replay_scene(self.scene, self.data, self.view_extent(), timestamp_ns)

    def human_controls(self, seat: int) -> RobotControls:
        """The ant steered by direction on the arena as drawn (``envs.robots.controls``)."""
        return RobotControls(self, seat)

    # --- the outcome helpers shared by the two-team games --------------------------------------
    def end_match(self, st: MatchState, slot: int, winner_team: int) -> None:
        """End the one match in ``slot``, won by ``winner_team`` (-1: a draw); see :meth:`end_matches`."""
        self.end_matches(st, np.arange(st.n_slots) == slot, np.full(st.n_slots, winner_team))

    def end_matches(self, st: MatchState, ended: np.ndarray, winner_team: np.ndarray) -> None:
        """End the matches where ``ended`` (bool[B]); ``winner_team`` (int[B]) is the winning team
        of each, or -1 for a draw. Sets ``done``, ``outcome`` (+1 / -1 / 0) and ``result``."""
        if not ended.any():
            return
        st.done |= ended
        rows = np.flatnonzero(ended)
        winner = winner_team[rows]
        seat_team = self.team_of[None, :]
        outcome = np.where(winner[:, None] < 0, 0.0, np.where(seat_team == winner[:, None], 1.0, -1.0))
        st.outcome[rows] = outcome
        teams = np.arange(self.n_teams)[None, :]
        st.result[rows] = np.where(winner[:, None] < 0, 0.5, (teams == winner[:, None]).astype(np.float64))


class RobotMatches:
    """Many matches of one robot game stepped together: the match engine's batched path.

    The engine-adapter interface of ``arena_league.matchmaking.batched``: ``start(slot, seed)``,
    ``observe()`` -> ``float32[n_slots, n_agents, obs_dim]``, ``action_mask()`` (None),
    ``acting()``, ``step(actions: float32[n_slots, n_agents, act_dim]) -> bool[n_slots]`` (the
    matches that ended, by the rules or at ``max_cycles``), ``steps(slot)``, ``team_result(slot)``
    and ``pair_points(slot)``.

    Each slot has its own ``MjData``; a step writes every live match's torques, then ``threads``
    workers (default: the CPUs this process may use, at most 8) each step a contiguous share of the
    live matches with ``mj_step`` and take its readout product (both release the GIL); measures
    and judgement then run once over all matches as numpy arrays.

    ``measures`` are every match's measures as the rules hold them (:class:`RobotMeasures` of
    ``[n_slots, n_agents]`` arrays, views of the match state, ``anneal`` the rules'), and
    ``state()`` every match's global state: what a training batch
    (``arena_league.training.engine_batch``) computes rewards from.
    """

    def __init__(self, rules: RobotGameRules, n_slots: int, max_cycles: int, threads: int | None = None) -> None:
        if n_slots < 1:
            raise ValueError(f"n_slots must be at least 1, not {n_slots}")
        if threads is None:
            threads = min(8, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)
        if threads < 1:
            raise ValueError(f"threads must be at least 1, not {threads}")
        self.rules = rules
        self.n_slots = n_slots
        self.n_agents = rules.n_agents
        self.max_cycles = max_cycles
        self.threads = min(threads, n_slots)
        model = rules.model
        self.datas = [mujoco.MjData(model) for _ in range(n_slots)]
        self.match = rules.new_match_state(n_slots)
        self.match.done[:] = True  # idle until started
        self._ctrl_views = [d.ctrl.reshape(rules.n_agents, rules.act_dim) for d in self.datas]
        self._sensor_views = [d.sensordata for d in self.datas]
        self.measures = RobotMeasures(rules.n_agents, anneal=rules.measures.anneal)
        rules.point_measures(self.measures, self.match, None)
        self._pool = ThreadPoolExecutor(self.threads, thread_name_prefix="robot-matches") if self.threads > 1 else None

    def close(self) -> None:
        """Stop the worker threads."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __del__(self) -> None:
        pool = getattr(self, "_pool", None)
        if pool is not None:
            pool.shutdown(wait=False)

    # --- copies: a training run's checkpoint holds its engine mid-match --------------------------
    def __getstate__(self) -> dict[str, Any]:
        return {"arguments": (self.rules, self.n_slots, self.max_cycles, self.threads), "datas": self.datas,
                "match": self.match, "anneal": self.measures.anneal}

    def __setstate__(self, state: dict[str, Any]) -> None:
        # built afresh (its views of the match state and the MuJoCo buffers, its worker threads),
        # then given the saved matches' values in place
        self.__init__(*state["arguments"])
        for data, saved in zip(self.datas, state["datas"], strict=True):
            mujoco.mj_copyData(data, self.rules.model, saved)
        self.match.load(state["match"])
        self.measures.anneal = state["anneal"]

    def start(self, slot: int, seed: int) -> None:
        rules, st = self.rules, self.match
        rng = np.random.default_rng(seed)
        rules.place(self.datas[slot], rules.start_pose(rng), rng)
        st.restart(slot)
        rules.read(st, slot, self._sensor_views[slot])
        rules.update(st)
        rules.on_start(st, slot)

    def observe(self) -> np.ndarray:
        return self.rules.observations(self.match)

    def action_mask(self) -> None:
        return None

    def acting(self) -> np.ndarray:
        return self.match.active & ~self.match.done[:, None]

    def _advance(self, slots: list[int]) -> None:
        rules, st = self.rules, self.match
        for s in slots:
            np.copyto(self._ctrl_views[s], st.ctrl[s])
            rules.simulate(self.datas[s])
            rules.read(st, s, self._sensor_views[s])

    def step(self, actions: np.ndarray) -> np.ndarray:
        rules, st = self.rules, self.match
        live = ~st.done
        np.multiply(actions, (st.active & live[:, None])[:, :, None], out=st.ctrl)
        slots = np.flatnonzero(live).tolist()
        if self._pool is None or len(slots) < 2:
            self._advance(slots)
        else:
            k = self.threads
            shares = [slots[j * len(slots) // k: (j + 1) * len(slots) // k] for j in range(k)]
            for future in [self._pool.submit(self._advance, share) for share in shares if share]:
                future.result()
        st.steps += live
        for s in slots:
            st.events[s] = []
        rules.update(st)
        rules.judge(st, live)
        if st.any_inactive:
            st.obs_active[...] = st.active
        # the env cuts a match at max_cycles: the rules give its result
        cut = live & ~st.done & (st.steps >= self.max_cycles)
        for s in np.flatnonzero(cut):
            rules.cut(st, int(s))
        st.done |= cut
        return live & st.done

    def steps(self, slot: int) -> int:
        return int(self.match.steps[slot])

    def team_result(self, slot: int) -> np.ndarray:
        return self.match.result[slot].copy()

    def pair_points(self, slot: int) -> np.ndarray:
        """What each team of the ended match in ``slot`` scored toward its pair, as the rules'
        ``pair_points()`` gives it."""
        return self.rules.match_pair_points(self.match, slot, self.max_cycles)

    def state(self) -> np.ndarray:
        """``float32[n_slots, state_dim]``: every match's global state, each as the rules' ``state()``
        computes it (one matrix-vector product per match, so the arithmetic is the same)."""
        rules = self.rules
        out = np.empty((self.n_slots, rules.state_dim), dtype=np.float32)
        for slot, sensors in enumerate(self._sensor_views):
            state = rules._state_matrix @ sensors
            out[slot] = state.clip(rules._state_low, rules._state_high, out=state)
        return out


RobotGameRules.batched_matches = RobotMatches  # defined after the rules it steps
