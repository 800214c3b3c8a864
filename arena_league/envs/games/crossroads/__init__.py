"""Crossroads: teams drive across a crossing to targets on the far side; collisions are physical.

After the Crossroads game of Arena (Song et al., "Arena: A General Evaluation Platform and Building
Toolkit for Multi-Agent Intelligence", AAAI 2020), whose case study shows that the same rules give
a traffic jam under isolated rewards, waiting under one collaborative reward, and blocking under
two collaborative teams that compete.

Arena
    A cross of two roads 5 wide whose arms reach ``ARM_LENGTH`` = 10 from the centre (world box
    [-10, 10]^2, y up), bounded by static pymunk segments. Each team drives from its own arm to
    targets at the end of the opposite one, so the paths cross in the middle: team 0 west -> east,
    team 1 south -> north and, with four teams, team 2 east -> west and team 3 north -> south.

Agents
    Pymunk discs of radius 0.5 (or 1 x 1 boxes) of mass 1 that contacts push and bounce (elasticity
    0.5) but never spin: only the agent turns itself. Each env step (``DT`` = 0.1 s, simulated as
    ``SUBSTEPS`` = 2 pymunk steps) it applies a thrust of up to ``THRUST_FORCE`` = 6 along its
    heading at the start of the step and turns at up to ``TURN_RATE`` = 3 rad/s; damping (a
    coasting agent keeps 10% of its velocity after a second) caps its speed at ``TOP_SPEED`` ~ 2.8.
    Team members start side by side across their arm (``LANE_SPACING`` = 1.2 apart) about 8 from
    the centre, facing roughly down the road; their targets lie in the same order across the far
    end of the opposite arm. Starts, targets and headings are jittered from the seed.

Actions
    ``discrete`` (default): 0 noop, 1 forward, 2 backward, 3 turn left, 4 turn right.
    ``continuous``: ``[thrust, turn]`` in [-1, 1], scaling the forward force (negative reverses)
    and the turning rate (positive turns left, counter-clockwise).

Arrival, end and result
    A seat whose centre comes within ``arrival_radius`` of its target has *arrived*: it becomes
    inactive, stops where it is and collides with nothing. The match ends when every seat has
    arrived, or at ``max_cycles`` (default 300 steps; an agent alone arrives in about 70, heuristic
    teams of four in at most about 150). Teams rank by the step their last member arrived (earlier
    is better; never is last, tied). ``team_result``: with two teams 1 / 0.5 / 0 for first / tie /
    last; with more, the teams beaten plus half those tied with. ``outcome`` maps that score
    linearly to [-1, 1] per seat: +1 first, -1 last, 0 a draw.

Measures (one value per seat, see ``MEASURE_DOCS``)
    ``active``, ``arrived``, ``target_distance`` (frozen on arrival), ``velocity_to_target``,
    ``facing_target``, ``energy`` (mean squared action: 0.5 for a discrete move or turn), ``force``
    (the magnitudes of the contact impulses of pymunk's arbiters on the seat this step, agent-agent
    and agent-wall, summed and divided by ``DT``), ``speed``.

Observation (``float32[10 + 5 * (n_agents - 1)]`` per seat)
    In the seat's *team frame*, the world turned so that the team travels along +x (team 0: the
    world frame; team 1: turned by -90 degrees; ...): every seat sees its start at x ~ -0.8 and its
    target at x ~ +0.8, so one policy plays any seat. With ``L`` = 10 and ``V`` = ``TOP_SPEED``:
    own position / L (cells 0-1), velocity / V (2-3), heading (cos, sin; 4-5), target position
    minus own position / (2 L) (6-7), distance to target / (2 L) (8), active flag (9: 1 playing, 0
    arrived); then 5 cells for every other seat (teammates first, then opponents, each in seat
    order) from ``10 + 5 * k``: its position minus own / (2 L), its velocity minus own / (2 V), its
    active flag. Bounds: velocity cells [-2, 2], the distance [0, sqrt 2], flags [0, 1], every
    other cell [-1, 1] (the walls keep agents and targets inside [-L, L]^2; a velocity cell beyond
    ``VELOCITY_BOUND`` = 2, which only contacts can push an agent to, is clipped). These bounds
    are the env's observation space; ``CrossroadsRules(...).layout.table()`` lists every run of
    cells with its bounds and meaning (``crossroads_observation``).

State (``float32[9 * n_agents]``, world frame)
    Per seat: position / L (2), velocity / V (2), heading (cos, sin), target position / L (2),
    active flag; bounds [-1, 1], velocities [-2, 2] (clipped), the flag [0, 1].

Social trees
    Default (the paper's table): CP ``ranking`` (``order="depart"``, scale 100) over the teams, IS
    ``target`` (scale 1) at every leaf; with several players a team, team nodes NL ``none`` between.
    ``CASE_STUDY_TREES`` (``example_trees`` for 2T2P): ``all_IS``, ``all_CL`` and ``CL_under_CP``.

Heuristic (``heuristic.py``)
    Steer toward the target (toward the crossing first when pushed into a cross road), swerve to
    the right of active agents close ahead, turn toward that direction, then drive.

Game options (``OPTIONS``)
    ``arrival_radius`` (a number in (0, 8), default 1.0): how close to its target a seat's centre
    must come to arrive; ``agent_shape`` (``"circle"``, the default, or ``"box"``).

Playing it (``arena-league play``)
    A text view of the picture (team digits, ``#`` the road's edges); a move is an action's number
    or name (``forward``, ``turn_left``, ...), Enter repeats the last; discrete actions only. In a
    browser, arrows (or W A S D) drive and turn while held.

Picture, replay scene, copies
    The top-down picture (400 pixels square) and the replay scene show the roads and walls
    (``roads``), every agent as declared in its team's colour (faded once arrived) with a tick or an
    arrow along its heading (``agent/<seat>``), each target as a ring or flat disc of the arrival
    radius (``target/<seat>``). The rules pickle and copy by playing the match again from its seed
    and the actions since (pymunk's contact caches cannot be copied): a copy goes on bit for bit.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any, ClassVar

import numpy as np
import pymunk

from arena_league.envs import scene
from arena_league.envs.controls import ActionControls, arrow_keys, key_controls
from arena_league.envs.core import cell_bounds
from arena_league.envs.options import Option
from arena_league.envs.physics2d import SPARE_CELLS, BodyFields, CellLayout, Physics2DRules, Run
from arena_league.envs.physics2d.contacts import ContactImpulses
from arena_league.envs.physics2d.gather import Gather
from arena_league.envs.physics2d.picture import draw_body, draw_walls, scene_body
from arena_league.envs.physics2d.world import Bodies, Field, Material, Walls, World
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

#: The crossing: each arm's reach from the centre, each road's half width.
ARM_LENGTH, ROAD_HALF_WIDTH = 10.0, 2.5
#: Radius of an agent disc (half the side of an agent box), and its mass.
AGENT_RADIUS, AGENT_MASS = 0.5, 1.0
#: Walls are pymunk segments this thick on each side of the road's edge; agents and walls share a
#: restitution and a friction.
WALL_RADIUS, ELASTICITY, FRICTION = 0.05, 0.5, 0.2
#: Seconds of simulation per env step.
DT = 0.1
#: Physics steps per env step. Chipmunk sees a contact only once two shapes overlap; at full
#: speed two agents meeting head-on close 0.55 in 0.1 s, so one step of 0.1 s would let them sink
#: more than half a radius into each other before the contact pushes back. Two halve that.
SUBSTEPS = 2
PHYSICS_DT = DT / SUBSTEPS
#: Overlap tolerated without correction; half of any deeper overlap is fixed per physics step.
COLLISION_SLOP, COLLISION_BIAS = 0.02, 0.5 ** (1.0 / PHYSICS_DT)
#: Force of full thrust, turning rate (rad/s) of a full turn.
THRUST_FORCE, TURN_RATE = 6.0, 3.0
#: Fraction of velocity an agent keeps after one second of coasting.
DAMPING = 0.1
#: Terminal speed under full thrust: the fixed point of
#: ``v = v * DAMPING**PHYSICS_DT + THRUST_FORCE * PHYSICS_DT / AGENT_MASS``.
TOP_SPEED = THRUST_FORCE * PHYSICS_DT / AGENT_MASS / (1.0 - DAMPING**PHYSICS_DT)
#: Distance from the centre of the start and target lines along the road; the uniform jitter of
#: every start and target along the road; team-mates' lanes apart; heading jitter (radians).
START_DISTANCE, ALONG_JITTER, LANE_SPACING, HEADING_JITTER = 8.0, 0.5, 1.2, 0.25
#: Bound of the velocity cells of observations and state, in their units (V, 2 V): thrust alone
#: never takes an agent past ``TOP_SPEED`` and contacts only a little beyond; faster is clipped.
VELOCITY_BOUND = 2.0

OPTIONS = (Option("arrival_radius", float, 1.0, "how close to its target a seat's centre must come to arrive",
                  0.0, START_DISTANCE, open_ends=("low", "high")),
           Option("agent_shape", str, "circle", "a disc of radius 0.5 or a 1 x 1 box", choices=("circle", "box")))

#: Direction of travel of each team: west->east, south->north, east->west, north->south.
_TRAVEL = np.array([(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)])
#: Discrete actions: (thrust, turn) in [-1, 1].
ACTION_MEANINGS = ("noop", "forward", "backward", "turn_left", "turn_right")
_DISCRETE_CONTROL = np.array([(0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)])
#: Per discrete action and activity: (turn rate, thrust force, energy); an inactive seat's row
#: (index + 5) is all zeros, so its action is ignored.
_DISCRETE_TABLE = np.concatenate([
    np.column_stack([_DISCRETE_CONTROL[:, 1] * TURN_RATE, _DISCRETE_CONTROL[:, 0] * THRUST_FORCE,
                     0.5 * (_DISCRETE_CONTROL ** 2).sum(axis=1)]),
    np.zeros((len(ACTION_MEANINGS), 3))])
_STATE_CELLS = 9


def crossroads_field(n_agents: int, agent_shape: str) -> Field:
    """The agents (added, and batch-read, in seat order; contacts push them but never spin them),
    then the road's edges (the cross's corners counter-clockwise from the west arm's end), each
    wall added on its own."""
    L, H = ARM_LENGTH, ROAD_HALF_WIDTH
    outline = [(-L, -H), (-H, -H), (-H, -L), (H, -L), (H, -H), (L, -H),
               (L, H), (H, H), (H, L), (-H, L), (-H, H), (-L, H)]
    material = Material(ELASTICITY, FRICTION)
    return Field(dt=PHYSICS_DT, damping=DAMPING, collision_slop=COLLISION_SLOP, collision_bias=COLLISION_BIAS,
                 substeps=SUBSTEPS, parts=(
                     Bodies("agent", n_agents, AGENT_RADIUS, AGENT_MASS, material, square=agent_shape == "box"),
                     Walls(tuple(zip(outline, outline[1:] + outline[:1])), WALL_RADIUS, material, one_by_one=True)))


def crossroads_observation(n_agents: int) -> CellLayout:
    """The observation's runs (team frame; see the module's table)."""
    unit, v = (-1, 1), (-VELOCITY_BOUND, VELOCITY_BOUND)
    runs = [Run("position", 2, unit, "own position / L"), Run("velocity", 2, v, "own velocity / V"),
            Run("heading", 2, unit, "own heading (cos, sin)"),
            Run("to_target", 2, unit, "target position minus own position / (2 L)"),
            Run("distance", 1, (0, math.sqrt(2)), "distance to target / (2 L)"),
            Run("active", 1, (0, 1), "own active flag")]
    for k in range(n_agents - 1):
        runs += [Run(f"other_{k}", 2, unit, "another seat's position minus own / (2 L)"),
                 Run(f"other_{k}_velocity", 2, v, "its velocity minus own / (2 V)"),
                 Run(f"other_{k}_active", 1, (0, 1), "its active flag")]
    return CellLayout(runs)


#: The paper's Crossroads case study, 2T2P: the same rules under three social trees.
CASE_STUDY_TREES: dict[str, dict] = {
    # Every agent for itself: each is rewarded for its own progress (a traffic jam).
    "all_IS": {"scheme": "IS", "reward": "target", "scale": 1, "children": [f"player_{s}" for s in range(4)]},
    # One collaborative group: everyone shares the mean progress (agents learn to wait).
    "all_CL": {"scheme": "CL", "reward": "team_target", "scale": 1, "children": [f"player_{s}" for s in range(4)]},
    # Two collaborative teams that compete to depart first (agents learn to block).
    "CL_under_CP": {"scheme": "CP", "reward": "ranking", "scale": 100, "params": {"order": "depart"}, "children": [
        {"scheme": "CL", "reward": "team_target", "scale": 1, "children": [f"player_{first + s}" for s in range(2)]}
        for first in (0, 2)]},
}


class CrossroadsControls(ActionControls):
    """The actions by name at a terminal; in a browser, arrows (or W A S D) drive and turn while held."""

    def web(self) -> dict[str, Any]:
        return key_controls(arrow_keys("forward", "turn_left", "backward", "turn_right"), self.PACE,
                            "Hold Up (W) to drive, Down (S) to back up, Left and Right (A, D) to turn; let go to "
                            "coast.", release="noop")


class CrossroadsRules(Physics2DRules):
    """Crossroads rules: pymunk bodies driven to targets across a crossing (see the module)."""

    def human_controls(self, seat: int) -> CrossroadsControls:
        return CrossroadsControls(self, seat)

    @classmethod
    def example_trees(cls, n_teams: int, players_per_team: int) -> dict[str, dict]:
        """The paper's case study (2T2P): all IS, CL over everyone, two CL teams under a CP root."""
        return dict(CASE_STUDY_TREES) if (n_teams, players_per_team) == (2, 2) else {}

    name: ClassVar[str] = "Crossroads"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2), (2, 3), (2, 4), (4, 1))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset({
        "active", "arrived", "target_distance", "velocity_to_target", "facing_target",
        "energy", "force", "speed", "outcome"})
    default_max_cycles: ClassVar[int] = 300
    #: The crossing's measures in world units, for tools that read positions from the state.
    geometry: ClassVar[dict[str, float]] = {"arm_length": ARM_LENGTH, "road_half_width": ROAD_HALF_WIDTH,
                                            "agent_radius": AGENT_RADIUS, "top_speed": TOP_SPEED}
    summary: ClassVar[str] = "teams drive across a crossing to targets on the far side; physical collisions"
    options = OPTIONS

    n_actions, act_dim, action_meanings = len(ACTION_MEANINGS), 2, ACTION_MEANINGS

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs: Any) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        self.arrival_radius, self.agent_shape = self.settings["arrival_radius"], self.settings["agent_shape"]
        n = self.n_agents
        self.layout = crossroads_observation(n)
        self.obs_dim, self.state_dim = self.layout.size, _STATE_CELLS * n
        self._travel = _TRAVEL[self.team_of]  # (n, 2) world direction of travel of each seat
        # The work vector holds all that observations and state gather: the bodies' x, y, angle, vx,
        # vy (read after every step), then per seat [vx, vy, cos, sin], its target, active flag and
        # distance to target, and a constant 0. Turn rate and force are written before each physics step.
        world = self.world = World(
            crossroads_field(n, self.agent_shape),
            slots=(("motion", 4 * n), ("target", 2 * n), ("active", n), ("distance", n), ("zero", 1)),
            read=BodyFields.POSITION | BodyFields.ANGLE | BodyFields.VELOCITY,
            write=BodyFields.ANGULAR_VELOCITY | BodyFields.FORCE, contacts=True, spare=SPARE_CELLS)
        self._work = world.work
        self._agent_kind, self._walls = world.field.parts  # as drawn
        self._contacts = ContactImpulses(world, "agent")
        self._collect_contacts = self._contacts.collect
        agents = world.table[:n]
        self._position, self._angle, self._velocity = agents[:, 0:2], agents[:, 2], agents[:, 3:5]
        self._motion = world.view("motion").reshape(n, 2, 2)  # [velocity, heading]
        self._heading = self._motion[:, 1]
        self._target = world.view("target").reshape(n, 2)
        self._active_z, self._distance = world.view("active"), world.view("distance")
        controls = world.applied.reshape(-1, world.link.write_cells)[:n]
        self._turn_rate, self._force = controls[:, 0], controls[:, 1:3]
        self._observation = self._observation_gather()
        self._state_index, self._state_scale = self._state_gather()
        self._obs_low, self._obs_high = (np.tile(bound, n) for bound in self.observation_bounds())  # seat-major
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())
        # Per-seat gates, changed only when a seat arrives: + n_actions (the all-zero control
        # row), the continuous gains (thrust force, turn rate), half the energy, the arrival
        # radius (-inf after).
        self._inactive_offset = np.zeros(n, dtype=np.int64)
        self._gain, self._half_active, self._arrival_gate = np.zeros((n, 2)), np.zeros(n), np.zeros(n)
        # Scratch arrays reused every step.
        self._action_row = np.zeros(n, dtype=np.int64)
        self._control = np.zeros((n, 3))  # turn rate, thrust force, energy
        self._squares, self._to_target, self._safe_distance = np.zeros((n, 2)), np.zeros((n, 2)), np.zeros(n)
        self._dots = np.zeros((n, 2))  # velocity and heading along the unit vector to the target
        self._arriving = np.zeros(n, dtype=bool)
        # Measures read straight from the arrays above (views, updated in place every step).
        m = self.measures
        m.target_distance = self._distance
        m.velocity_to_target, m.facing_target = self._dots[:, 0], self._dots[:, 1]
        if action_type == "discrete":
            m.energy = self._control[:, 2]
        self._views = self._bind_views()
        self._step_count, self._team_finish = 0, np.full(n_teams, -1, dtype=np.int64)

    # --- construction ------------------------------------------------------------------------
    def _observation_gather(self) -> Gather:
        """The flat seat-major observation gathered from the work vector (team frames are turns by
        multiples of 90 degrees: every cell is one entry, or a difference of two, times a scale)."""
        world, layout, n = self.world, self.layout, self.n_agents
        gather = Gather(world.work, n * self.obs_dim, world.at("zero"))
        L2, V2 = 2 * ARM_LENGTH, 2 * TOP_SPEED
        pos, vel = [world.pos(s, 0) for s in range(n)], [world.at("motion", 4 * s) for s in range(n)]
        for s in range(n):
            (dx, dy), o = self._travel[s], s * self.obs_dim
            R = np.array([[dx, dy], [-dy, dx]])  # world to team frame (travel along +x)
            gather.put_vector(o + layout.at("position"), R, pos[s], None, 1 / ARM_LENGTH)
            gather.put_vector(o + layout.at("velocity"), R, vel[s], None, 1 / TOP_SPEED)
            gather.put_vector(o + layout.at("heading"), R, vel[s] + 2, None, 1.0)
            gather.put_vector(o + layout.at("to_target"), R, world.at("target", 2 * s), pos[s], 1 / L2)
            gather.put(o + layout.at("distance"), world.at("distance", s), None, 1 / L2)
            gather.put(o + layout.at("active"), world.at("active", s), None, 1.0)
            for k, j in enumerate(self.other_seats(s)):
                gather.put_vector(o + layout.at(f"other_{k}"), R, pos[j], pos[s], 1 / L2)
                gather.put_vector(o + layout.at(f"other_{k}_velocity"), R, vel[j], vel[s], 1 / V2)
                gather.put(o + layout.at(f"other_{k}_active"), world.at("active", j), None, 1.0)
        return gather

    def _state_gather(self) -> tuple[np.ndarray, np.ndarray]:
        """Index and scale arrays so that ``state = work[index] * scale`` (world frame)."""
        world, index, scale = self.world, [], []
        for s in range(self.n_agents):
            p, m, t = world.pos(s, 0), world.at("motion", 4 * s), world.at("target", 2 * s)
            index += [p, p + 1, m, m + 1, m + 2, m + 3, t, t + 1, world.at("active", s)]
            scale += [1 / ARM_LENGTH] * 2 + [1 / TOP_SPEED] * 2 + [1.0] * 2 + [1 / ARM_LENGTH] * 2 + [1.0]
        return np.array(index, dtype=np.intp), np.array(scale)

    def _bind_views(self) -> SimpleNamespace:
        """Every array operand of the per-step arithmetic, sliced once (slicing costs as much as
        the arithmetic on arrays this small)."""
        return SimpleNamespace(
            velocity=self._velocity, velocity_x=self._velocity[:, 0], velocity_y=self._velocity[:, 1],
            motion_velocity=self._motion[:, 0], cos=self._heading[:, 0], sin=self._heading[:, 1],
            to_target_x=self._to_target[:, 0], to_target_y=self._to_target[:, 1],
            safe_distance_column=self._safe_distance[:, None], tiny=np.full(self.n_agents, 1e-12),
            to_target_column=self._to_target[:, :, None], dots_column=self._dots[:, :, None],
            control_turn=self._control[:, 0], control_thrust=self._control[:, 1:2],
            control_continuous=self._control[:, 1::-1],  # thrust force, turn rate
            squares_thrust=self._squares[:, 0], squares_turn=self._squares[:, 1])

    # --- the match ---------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = rng = np.random.default_rng(seed)
        n, p = self.n_agents, self.players_per_team
        lanes = (np.arange(p) - (p - 1) / 2) * LANE_SPACING
        # A team's lanes may shift together as far as the road allows.
        slack = ROAD_HALF_WIDTH - AGENT_RADIUS - lanes[-1] - 0.05
        start_lateral = (lanes[None, :] + rng.uniform(-slack, slack, (self.n_teams, 1))).ravel()
        target_lateral = (lanes[None, :] + rng.uniform(-slack, slack, (self.n_teams, 1))).ravel()
        start_along = -START_DISTANCE + rng.uniform(-ALONG_JITTER, ALONG_JITTER, n)
        target_along = START_DISTANCE + rng.uniform(-ALONG_JITTER, ALONG_JITTER, n)
        heading_jitter = rng.uniform(-HEADING_JITTER, HEADING_JITTER, n)
        d = self._travel
        left = np.stack([-d[:, 1], d[:, 0]], axis=1)
        starts = start_along[:, None] * d + start_lateral[:, None] * left
        self._target[:] = target_along[:, None] * d + target_lateral[:, None] * left
        self.world.build({"agent": starts}, angles={"agent": np.arctan2(d[:, 1], d[:, 0]) + heading_jitter})
        self._contacts.bind()
        self._active_z[:], self._inactive_offset[:], self._gain[:] = 1.0, 0, (THRUST_FORCE, TURN_RATE)
        self._half_active[:], self._arrival_gate[:] = 0.5, self.arrival_radius
        for zeros in (self._control, self._turn_rate, self._force):
            zeros[:] = 0.0
        m = self.measures
        m.active[:], m.arrived[:], m.energy[:], m.force[:], m.outcome[:] = True, False, 0.0, 0.0, 0.0
        self._update_kinematics()
        self.game_over, self._step_count, self._events = False, 0, []
        self._team_finish[:] = -1

    def _update_kinematics(self) -> None:
        """From the bodies just read: headings, distances, the measures about the target, speeds."""
        v = self._views
        np.copyto(v.motion_velocity, v.velocity)
        np.cos(self._angle, out=v.cos)
        np.sin(self._angle, out=v.sin)
        np.subtract(self._target, self._position, out=self._to_target)
        np.hypot(v.to_target_x, v.to_target_y, out=self._distance)
        np.maximum(self._distance, v.tiny, out=self._safe_distance)
        np.divide(self._to_target, v.safe_distance_column, out=self._to_target)
        np.matmul(self._motion, v.to_target_column, out=v.dots_column)  # velocity, heading . unit
        np.hypot(v.velocity_x, v.velocity_y, out=self.measures.speed)

    def step(self, actions: np.ndarray) -> None:
        self._record("step", actions.copy())
        self._step_count += 1
        v = self._views
        if self.action_type == "discrete":
            np.add(actions, self._inactive_offset, out=self._action_row)
            _DISCRETE_TABLE.take(self._action_row, axis=0, out=self._control)
        else:
            np.multiply(actions, self._gain, out=v.control_continuous)
            np.multiply(actions, actions, out=self._squares)
            energy = self.measures.energy
            np.add(v.squares_thrust, v.squares_turn, out=energy)
            np.multiply(energy, self._half_active, out=energy)
        np.copyto(self._turn_rate, v.control_turn)
        np.multiply(self._heading, v.control_thrust, out=self._force)
        self.world.step(self._collect_contacts)
        self._update_kinematics()
        self._contacts.forces(self.measures.force, DT)
        if self._events:
            self._events = []
        np.less(self._distance, self._arrival_gate, out=self._arriving)
        if np.count_nonzero(self._arriving):
            self._arrive(np.flatnonzero(self._arriving))

    def _arrive(self, seats: np.ndarray) -> None:
        m = self.measures
        agents = self.world.bodies["agent"]
        for seat in seats.tolist():
            m.active[seat], m.arrived[seat] = False, True
            self._active_z[seat], self._inactive_offset[seat] = 0.0, len(ACTION_MEANINGS)
            self._gain[seat], self._half_active[seat], self._arrival_gate[seat] = 0.0, 0.0, -np.inf
            body = agents[seat]
            for shape in body.shapes:
                shape.filter = pymunk.ShapeFilter(categories=0, mask=0)  # collides with nothing
            body.velocity = (0.0, 0.0)  # and stays where it arrived
            self._velocity[seat] = self._motion[seat, 0] = 0.0
            self._events.append({"kind": "arrive", "seat": seat, "step": self._step_count})
        self._dots[seats, 0] = m.speed[seats] = 0.0
        for team in np.unique(self.team_of[seats]).tolist():
            if self._team_finish[team] < 0 and m.arrived[self.team_of == team].all():
                self._team_finish[team] = self._step_count
        if m.arrived.all():
            self.game_over = True
            m.outcome[:] = self._seat_outcome()

    def observe(self) -> np.ndarray:
        obs = np.empty((self.n_agents, self.obs_dim), dtype=np.float32)
        flat = obs.reshape(-1)
        self._observation.fill(flat)
        flat.clip(self._obs_low, self._obs_high, out=flat)
        return obs

    def state(self) -> np.ndarray:
        state = self._work[self._state_index] * self._state_scale
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        v = VELOCITY_BOUND
        return cell_bounds(*((-1, 1, 2), (-v, v, 2), (-1, 1, 4), (0, 1, 1)) * self.n_agents)

    def finish(self) -> None:
        self._record("finish")
        self.measures.outcome[:] = self._seat_outcome()

    # --- results -----------------------------------------------------------------------------
    def team_result(self) -> np.ndarray:
        finish = np.where(self._team_finish >= 0, self._team_finish, np.iinfo(np.int64).max)
        beaten = (finish[:, None] < finish[None, :]).sum(axis=1)
        tied = (finish[:, None] == finish[None, :]).sum(axis=1) - 1
        return beaten + 0.5 * tied

    def _seat_outcome(self) -> np.ndarray:
        team_outcome = 2.0 * self.team_result() / (self.n_teams - 1) - 1.0
        return team_outcome[self.team_of]

    # --- trees and policies ------------------------------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        teams = [[{"agent": f"player_{t * players_per_team + i}", "scheme": "IS", "reward": "target", "scale": 1}
                  for i in range(players_per_team)] for t in range(n_teams)]
        children = ([members[0] for members in teams] if players_per_team == 1
                    else [{"scheme": "NL", "reward": "none", "children": members} for members in teams])
        return {"scheme": "CP", "reward": "ranking", "scale": 100, "params": {"order": "depart"},
                "children": children}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        """Steer toward the target, keep to the right of active agents close ahead (see the module)."""
        from arena_league.envs.games.crossroads.heuristic import heuristic

        return heuristic(obs, action_type)

    # --- picture -----------------------------------------------------------------------------
    def render_topdown(self) -> np.ndarray:
        L, H = ARM_LENGTH, ROAD_HALF_WIDTH
        canvas = Canvas(-L, L, -L, L, size=400, background=(70, 110, 70))
        canvas.rect(-L, -H, L, H, fill=(200, 200, 195))
        canvas.rect(-H, -L, H, L, fill=(200, 200, 195))
        draw_walls(canvas, self._walls, (40, 40, 40), 3)
        colours = [TEAM_COLOURS[team % len(TEAM_COLOURS)] for team in self.team_of]
        for (tx, ty), colour in zip(self._target, colours):
            canvas.circle(tx, ty, self.arrival_radius, fill=None, outline=colour)
            canvas.circle(tx, ty, 0.12, fill=colour)
        for seat, colour in enumerate(colours):
            faded = colour if self.measures.active[seat] else tuple((c + 255) // 2 for c in colour)
            draw_body(canvas, self._agent_kind, *self._position[seat], self._heading[seat], faded)
        return canvas.array()

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        arm, half_width, ts = ARM_LENGTH, ROAD_HALF_WIDTH, timestamp_ns
        road = (0.55, 0.55, 0.55, 1.0)
        out = [scene.entity("roads", ts, cubes=[scene.cube(0, 0, -0.05, (2 * arm, 2 * half_width, 0.1), road),
                                                scene.cube(0, 0, -0.05, (2 * half_width, 2 * arm, 0.1), road)])]
        for seat, row in enumerate(self.state().astype(np.float64).reshape(self.n_agents, _STATE_CELLS)):
            x, y, yaw = row[0] * arm, row[1] * arm, math.atan2(float(row[5]), float(row[4]))
            team = int(self.team_of[seat])
            colour = scene.team_colour(team, 1.0 if row[8] > 0.5 else 0.35)
            body = scene_body(self._agent_kind, x, y, yaw, colour)
            out.append(scene.entity(f"agent/{seat}", ts, **body,
                                    arrows=[scene.arrow(x, y, 2 * AGENT_RADIUS, yaw, 1.2, colour)]))
            out.append(scene.entity(f"target/{seat}", ts, cylinders=[
                scene.disc(row[6] * arm, row[7] * arm, 2 * self.arrival_radius, scene.team_colour(team, 0.3))]))
        return out


RULES = CrossroadsRules
