"""Soccer: two teams push a ball into the other team's goal (pymunk physics).

One of the team games of the Arena platform (Song et al., "Arena: A General Evaluation Platform
and Building Toolkit for Multi-Agent Intelligence", AAAI 2020). Ids: ``Soccer-2T1P-v1``,
``Soccer-2T2P-v1``, ``Soccer-2T3P-v1``.

Field
    A walled rectangle, ``x`` in [-4, 4] and ``y`` in [-2.5, 2.5] (inner faces of the walls), with
    45-degree corner chamfers of 0.6 so that the ball cannot be trapped in a corner. Each end wall
    has a goal mouth 1.6 wide (``goal_width``) centred on ``y = 0``, opening into a walled goal box
    0.6 deep. Team 0 attacks the goal at ``x = +4`` (and defends ``x = -4``); team 1 attacks
    ``x = -4``.

Bodies and physics
    Agents are circles of radius 0.25 and mass 1 that do not rotate; the ball is a circle of radius
    0.2 and mass 0.4. Collisions between agents, ball and walls are solved by pymunk (Chipmunk2D),
    one ``space.step`` of ``dt = 0.1`` per env step (restitution 0.4 agent-ball, 0.72 ball-wall,
    friction 0.3). Every body loses 60 % of its velocity per second (space damping 0.4), so a ball
    struck at 1.5 units/s rolls about 1.6 units; an agent's thrust of at most 6 is opposed by a drag
    of ``3.1 * velocity``, which caps its speed at about 1.5 units/s.

Kick-off
    The ball starts at the centre spot (``y`` jittered by up to ``kickoff_jitter``), each team in
    its own half in a formation whose positions are jittered by up to ``kickoff_jitter`` in both
    coordinates; every draw comes from the match seed.

Seat frame (mirroring)
    Each seat sees the field, and acts, in its own frame: the world frame for team 0, and the world
    mirrored in ``x`` (``x -> -x``, ``y`` unchanged) for team 1. In its own frame every seat attacks
    ``+x``, so one policy can play either side.

Actions
    Discrete (default), 9 actions, directions in the seat frame (``E`` = ``+x`` = toward the goal
    the seat attacks, ``N`` = ``+y``), each a thrust of full strength:
    ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE``.
    Continuous: ``[fx, fy]`` in [-1, 1], the thrust in the seat frame as a fraction of full
    strength; a vector longer than 1 is scaled back to length 1 (diagonals are no stronger).

Observation (``float32``, seat frame; positions divided by 4, velocities by 3)
    ====== ===================================== =================================================
    cell   bounds (x cell, y cell)               meaning
    ====== ===================================== =================================================
    0      [0, 1]                                own active flag (always 1 in Soccer)
    1-2    [-1.15, 1.15], [-0.625, 0.625]        own position ``x, y``
    3-4    [-2, 2]                               own velocity ``vx, vy``
    5-6    [-2.3, 2.3], [-1.25, 1.25]            ball position relative to the seat (ball - own)
    7-8    [-1.15, 1.15], [-0.625, 0.625]        ball position (absolute)
    9-10   [-2, 2]                               ball velocity
    11-12  [-0.15, 2.15], [-0.625, 0.625]        the attacked goal relative to the seat: the centre
                                                 of its mouth on the goal line, ``(4, 0)`` in the
                                                 seat frame, minus the seat's position
    13-14  [-2.15, 0.15], [-0.625, 0.625]        the defended goal relative to the seat:
                                                 ``(-4, 0)`` minus the seat's position
    15+    [-2.3, 2.3], [-1.25, 1.25]; [-2, 2]   every other seat, teammates first then opponents,
                                                 each in seat order: position relative to the seat
                                                 (2 cells) then its velocity (2 cells)
    ====== ===================================== =================================================

    ``obs_dim = 15 + 4 * (n_agents - 1)``: 19 for 2T1P, 27 for 2T2P, 35 for 2T3P.

    Bounds: the walls' inner faces keep every body within ``x`` in [-4.6, 4.6] (the goal boxes
    included) and ``y`` in [-2.5, 2.5], which bounds positions and their differences. Velocities
    are bounded by ``VELOCITY_BOUND`` = 2 (6 m/s, four times an agent's top speed; only a pile-up
    pushes a body that fast): a cell beyond its bounds is clipped to them. These bounds are the
    env's observation space.

Global state (``float32``, world frame, same scales)
    every seat's ``x, y, vx, vy`` in seat order, then the ball's ``x, y, vx, vy``, then the goals
    scored by team 0 and by team 1: ``state_dim = 4 * n_agents + 6``. Bounds as for the
    observation's absolute cells; each score in [0, 1] (the first goal ends the match).

Measures
    ``active`` (always true), ``target_distance`` (distance from the seat's centre to the ball's:
    the ball is every seat's target), ``velocity_to_target`` (the seat's velocity along the
    direction to the ball), ``energy`` (squared thrust length, 0..1: 1 for every discrete move, 0
    for noop), ``force`` (magnitude of the contact force on the seat this step: the impulse pymunk's
    solver applied to it, from agents, ball and walls, divided by ``dt``), ``speed``,
    ``object_progress`` (the ball's displacement this step toward the goal the seat attacks:
    ``+dx`` for team 0, ``-dx`` for team 1) and ``outcome`` (+1 / -1 for the scoring / conceding
    team, 0 for a draw).

Episode end
    A goal (the ball entirely past a goal line inside the mouth) ends the match: the scoring team
    wins. A match cut at ``max_cycles`` (default 300 steps, 30 s of play) is a draw.
    ``team_result``: 1 win, 0.5 draw, 0 loss.

Default social tree
    Root CP ``win_loss`` (scale 100) over one CL ``team_progress`` node (scale 10) per team; each
    agent leaf is IS ``target`` (scale 1: progress toward the ball).

Heuristic
    From the observation alone. The seat nearest the ball among its teammates attacks: it aims from
    the ball into the attacked goal's mouth (a ball on the goal line beside the mouth is first
    brought out in front of it), runs to a spot behind the ball on that line (round the ball when
    the ball is in the way; where the spot is beyond a wall, the nearest spot inside sets the push
    direction), then drives through the ball. Its teammates hold spots on the line from their own
    goal to the ball. It assumes the default goal width.

Game kwargs
    ``goal_width`` (float in [0.6, 4.0], default 1.6), ``kickoff_jitter`` (float in [0, 0.5],
    default 0.3).

Playing it (``arena-league play``)
    A coarse text view of the top-down picture (team digits, ``#``/``+`` walls and markings, ``o``
    the ball). A move is an action's number or name, a compass direction *on the field as drawn*
    (``E`` = right, whichever side you play: team 1's moves are mirrored into its seat frame for
    you); Enter repeats the last move. Discrete actions only.

Rendering
    A top-down picture of the field (400 pixels wide): the walls, the pitch with its centre line
    and circle, each goal box in the colour of the team defending it, the agents in their teams'
    colours and the ball in white. ``render_mode="rgb_array"`` returns it; ``"human"`` shows it in
    a window.

Copies
    The rules pickle and copy (``pickle``, ``copy.deepcopy``) by playing the match again from its
    seed and the actions (and ``place`` calls) since, as pymunk's contact caches cannot be copied;
    a copy goes on bit for bit as the original does.

Replay scene
    The field and both goal boxes (in the colour of the team defending each), every agent and the
    ball (spheres) and the score (text): entities ``field``, ``agent/<seat>``, ``ball``, ``score``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from arena_league.envs import scene
from arena_league.envs.controls import MirroredCompassControls
from arena_league.envs.options import Option
from arena_league.envs.physics2d import (
    COMPASS_MOVE_NAMES,
    COMPASS_MOVES,
    ONE,
    Bodies,
    CellLayout,
    Field,
    Material,
    Physics2DRules,
    Run,
    Walls,
    World,
    mirror_signs,
)
from arena_league.envs.physics2d.geometry import goal_field_outline, pushed_outline, wall_segments
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

#: Half length and half width of the field (inner faces of the walls).
HALF_LENGTH = 4.0
HALF_WIDTH = 2.5
#: Depth of each goal box behind its goal line.
GOAL_DEPTH = 0.6
#: Size of the 45-degree chamfer cut off each corner.
CORNER_CHAMFER = 0.6
#: Walls are pymunk segments this thick on each side of their centre line.
WALL_RADIUS = 0.2
AGENT_RADIUS = 0.25
AGENT_MASS = 1.0
BALL_RADIUS = 0.2
BALL_MASS = 0.4
#: Physics step per env step (seconds).
DT = 0.1
#: Fraction of its velocity a body keeps after one second (pymunk ``Space.damping``).
SPACE_DAMPING = 0.4
#: Full thrust of an agent, and the drag coefficient opposing its velocity.
THRUST = 6.0
AGENT_DRAG = 3.1
#: Overlap pymunk tolerates between touching bodies (its default, 0.1, is large at this scale).
COLLISION_SLOP = 0.01
ELASTICITY = {"agent": 0.5, "ball": 0.8, "wall": 0.9}
FRICTION = 0.3
#: Observation scales: positions are divided by HALF_LENGTH, velocities by VELOCITY_UNIT.
POSITION_SCALE = 1.0 / HALF_LENGTH
VELOCITY_UNIT = 3.0
#: Bound of the velocity cells, in units of VELOCITY_UNIT (6 m/s, four times an agent's top speed;
#: only a pile-up can push a body faster, and that is clipped).
VELOCITY_BOUND = 2.0

DEFAULT_GOAL_WIDTH = 1.6
OPTIONS = (Option("goal_width", float, DEFAULT_GOAL_WIDTH, "width of each goal mouth", 0.6, 4.0),
           Option("kickoff_jitter", float, 0.3, "largest random offset of each kick-off position", 0.0, 0.5))

#: Kick-off slots of team 0 (team 1's are mirrored), per players per team.
_FORMATIONS = {
    1: ((-2.0, 0.0),),
    2: ((-1.5, 0.9), (-1.5, -0.9)),
    3: ((-1.2, 1.2), (-1.2, -1.2), (-2.8, 0.0)),
}


def soccer_field(n_agents: int, goal_half_width: float) -> Field:
    """The walled pitch, the agents (discs that do not spin) and the ball, added in that order."""
    outline = goal_field_outline(HALF_LENGTH, HALF_WIDTH, goal_half_width, GOAL_DEPTH, CORNER_CHAMFER)
    return Field(dt=DT, damping=SPACE_DAMPING, collision_slop=COLLISION_SLOP, parts=(
        Walls(tuple(wall_segments(outline, WALL_RADIUS)), WALL_RADIUS, Material(ELASTICITY["wall"], FRICTION)),
        Bodies("agent", n_agents, AGENT_RADIUS, AGENT_MASS, Material(ELASTICITY["agent"], FRICTION)),
        Bodies("ball", 1, BALL_RADIUS, BALL_MASS, Material(ELASTICITY["ball"], FRICTION), rotates=True)))


def soccer_observation(n_agents: int) -> CellLayout:
    """The observation's runs (seat frame; positions divided by 4, velocities by 3)."""
    x, y, v = (HALF_LENGTH + GOAL_DEPTH) * POSITION_SCALE, HALF_WIDTH * POSITION_SCALE, VELOCITY_BOUND
    goal = HALF_LENGTH * POSITION_SCALE  # a goal's x in the seat frame, the attacked one positive
    position, relative, velocity = ((-x, x), (-y, y)), ((-2 * x, 2 * x), (-2 * y, 2 * y)), (-v, v)
    runs = [Run("active", 1, (0, 1), "own active flag (always 1)"),
            Run("position", 2, position, "own position"),
            Run("velocity", 2, velocity, "own velocity"),
            Run("ball_relative", 2, relative, "ball position relative to the seat"),
            Run("ball", 2, position, "ball position"),
            Run("ball_velocity", 2, velocity, "ball velocity"),
            Run("attacked_goal", 2, ((goal - x, goal + x), (-y, y)), "centre of the attacked mouth, relative"),
            Run("defended_goal", 2, ((-goal - x, -goal + x), (-y, y)), "centre of the defended mouth, relative")]
    for k in range(n_agents - 1):
        runs += [Run(f"other_{k}", 2, relative, "another seat's position relative to the seat"),
                 Run(f"other_{k}_velocity", 2, velocity, "that seat's velocity")]
    return CellLayout(runs)


class SoccerRules(Physics2DRules):
    """Soccer on a walled pymunk field; see the module docstring for the manual."""

    name: ClassVar[str] = "Soccer"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2), (2, 3))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "target_distance", "velocity_to_target", "energy", "force", "speed", "object_progress",
         "outcome"}
    )
    default_max_cycles: ClassVar[int] = 300
    summary: ClassVar[str] = "Teams push a ball into the other goal (pymunk; first goal wins)"
    options = OPTIONS

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        self.goal_half_width = self.settings["goal_width"] / 2
        self.kickoff_jitter = self.settings["kickoff_jitter"]
        n = self.n_agents
        self.n_actions = len(COMPASS_MOVE_NAMES)
        self.act_dim = 2
        self.action_meanings = COMPASS_MOVE_NAMES
        self.layout = soccer_observation(n)
        self.obs_dim = self.layout.size
        self.state_dim = 4 * n + 6
        self.score = np.zeros(2, dtype=np.int64)

        self._team_sign = mirror_signs(self.team_of)  # the x sign of each seat's frame
        self._frame = np.stack([self._team_sign, np.ones(n)], axis=1)  # (n, 2) multiplies x, y
        # world-frame unit thrust of every (team, move), flattened: row team * 9 + move
        moves_world = COMPASS_MOVES[None] * np.array([[[1.0, 1.0]], [[-1.0, 1.0]]])
        self._moves_world = np.ascontiguousarray(moves_world.reshape(-1, 2)).view(np.complex128).reshape(-1)
        self._move_row_offset = self.team_of * len(COMPASS_MOVE_NAMES)
        self._move_energy = (COMPASS_MOVES**2).sum(axis=1)
        self._goal_line = HALF_LENGTH + BALL_RADIUS
        self._tiny = np.full(n, 1e-9)
        self._layout_work_vector()
        self._obs_low, self._obs_high = self.clip_bounds(self.layout)
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())

    # --- construction --------------------------------------------------------------------------
    def _layout_work_vector(self) -> None:
        """The world's work vector holds everything a step reads, so that the observation and the
        measures are each one matrix product of it (few numpy calls: the hot path is Python-bound):
        every body's ``[x, y, vx, vy]``, then the seats' velocities before the step, their
        world-frame unit thrust, the ball's x before the step, and a constant 1."""
        n = self.n_agents
        world = self.world = World(soccer_field(n, self.goal_half_width),
                                   slots=(("v_before", 2 * n), ("thrust", 2 * n), ("ball_x_before", 1), (ONE, 1)))
        ball = world.index("ball")
        self._agent_pos = world.table[:n, 0:2]
        self._ball_state = world.table[ball]
        self._ball_x_at, self._ball_y_at = world.pos(ball, 0), world.pos(ball, 1)
        self._ball_x_before_at = world.at("ball_x_before")
        # complex views (x + iy) of the 2-vectors: fewer, cheaper numpy calls on the hot path
        self._agent_vel_c = world.table[:n].view(np.complex128)[:, 1]
        self._v_before_c = world.complex_view("v_before")
        self._thrust = world.view("thrust").reshape(n, 2)
        self._thrust_c = world.complex_view("thrust")
        self._obs_matrix = self._observation_map()
        self._measure_matrix = self._measure_map()
        # applied force of every body (zero for the ball and the static body)
        world.force_matrix = world.matrix(2 * world.n_bodies)
        for k in range(2 * n):
            world.force_matrix[k, world.at("thrust", k)] = THRUST
            world.force_matrix[k, world.at("v_before", k)] = -AGENT_DRAG

    def _observation_map(self) -> np.ndarray:
        """The observations of every seat as one matrix over the work vector."""
        n, world, cells = self.n_agents, self.world, self.layout
        A = np.zeros((n, self.obs_dim, len(world.work)))
        ball, one = world.index("ball"), world.at(ONE)
        ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
        pos, vel = world.pos, world.vel
        for i in range(n):
            sign = (self._team_sign[i], 1.0)
            team = self.team_of[i]
            others = [j for j in range(n) if j != i and self.team_of[j] == team]
            others += [j for j in range(n) if self.team_of[j] != team]
            A[i, cells.at("active"), one] = 1.0
            for ax in range(2):
                s = sign[ax]
                A[i, cells.at("position", ax), pos(i, ax)] = s * ps
                A[i, cells.at("velocity", ax), vel(i, ax)] = s * vs
                A[i, cells.at("ball_relative", ax), pos(ball, ax)] = s * ps
                A[i, cells.at("ball_relative", ax), pos(i, ax)] -= s * ps
                A[i, cells.at("ball", ax), pos(ball, ax)] = s * ps
                A[i, cells.at("ball_velocity", ax), vel(ball, ax)] = s * vs
                # goals in the seat frame are at (+L, 0) (attacked) and (-L, 0) (defended)
                A[i, cells.at("attacked_goal", ax), pos(i, ax)] = -s * ps
                A[i, cells.at("defended_goal", ax), pos(i, ax)] = -s * ps
                for k, j in enumerate(others):
                    A[i, cells.at(f"other_{k}", ax), pos(j, ax)] = s * ps
                    A[i, cells.at(f"other_{k}", ax), pos(i, ax)] -= s * ps
                    A[i, cells.at(f"other_{k}_velocity", ax), vel(j, ax)] = s * vs
            A[i, cells.at("attacked_goal"), one] = HALF_LENGTH * ps
            A[i, cells.at("defended_goal"), one] = -HALF_LENGTH * ps
        return A.reshape(n * self.obs_dim, len(world.work))

    def _measure_map(self) -> np.ndarray:
        """The linear parts of the measures as one matrix over the work vector.

        Rows: ``[to_ball (x, -y), velocity (x, y), contact force (x, y)]`` of every seat, read as
        complex numbers (``to_ball`` conjugated), then every seat's ``object_progress``. The contact force is the
        impulse the solver added beyond damping and the applied force (Chipmunk integrates
        ``v' = v * damping**dt + f / m * dt`` before solving contacts), divided by ``dt``.
        """
        n, world = self.n_agents, self.world
        M = world.matrix(7 * n)
        ball = world.index("ball")
        # velocity kept from before the step, drag included (force = THRUST * thrust - DRAG * v)
        keep = SPACE_DAMPING**DT - AGENT_DRAG * DT / AGENT_MASS
        for i in range(n):
            for ax in range(2):
                conj = 1.0 if ax == 0 else -1.0
                M[2 * i + ax, world.pos(ball, ax)] = conj
                M[2 * i + ax, world.pos(i, ax)] = -conj
                M[2 * n + 2 * i + ax, world.vel(i, ax)] = 1.0
                row = 4 * n + 2 * i + ax
                M[row, world.vel(i, ax)] = AGENT_MASS / DT
                M[row, world.at("v_before", 2 * i + ax)] = -keep * AGENT_MASS / DT
                M[row, world.at("thrust", 2 * i + ax)] = -THRUST
            M[6 * n + i, self._ball_x_at] = self._team_sign[i]
            M[6 * n + i, world.at("ball_x_before")] = -self._team_sign[i]
        return M

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        p = self.players_per_team
        jitter = self.kickoff_jitter
        slots = np.asarray(_FORMATIONS[p], dtype=np.float64)
        team0 = slots + self.rng.uniform(-jitter, jitter, slots.shape)
        team1 = slots + self.rng.uniform(-jitter, jitter, slots.shape)
        team1[:, 0] *= -1.0
        ball_xy = np.array([0.0, self.rng.uniform(-jitter, jitter)])
        self.world.build({"agent": np.concatenate([team0, team1]), "ball": ball_xy})
        self._measure_still_state()
        self.measures.active[:] = True
        self.measures.outcome = np.zeros(self.n_agents)
        self.score[:] = 0
        self.game_over = False
        self._events = []

    def _measure_still_state(self) -> None:
        """Measures of the bodies as they stand, with no step behind them (no force, no progress)."""
        world = self.world
        world.work[world.at("v_before"): world.at(ONE)] = 0.0
        world.work[world.at("ball_x_before")] = world.work[self._ball_x_at]
        self._v_before_c[:] = self._agent_vel_c
        self._update_measures(np.zeros(self.n_agents))
        self.measures.force = np.zeros(self.n_agents)

    def _update_measures(self, energy: np.ndarray) -> None:
        m = self.measures
        n = self.n_agents
        linear = self._measure_matrix @ self.world.work
        vectors = linear[: 6 * n].view(np.complex128)  # conj(to_ball), velocity, contact force
        norms = np.abs(vectors)
        distance = norms[:n]
        m.target_distance = distance
        m.speed = norms[n: 2 * n]
        m.force = norms[2 * n:]
        # Re(v * conj(d)) is the dot product of the velocity v and the way d to the ball
        m.velocity_to_target = (vectors[n: 2 * n] * vectors[:n]).real / np.maximum(distance, self._tiny)
        m.object_progress = linear[6 * n:]
        m.energy = energy

    def step(self, actions: np.ndarray) -> None:
        self._record("step", actions.copy())
        work = self.world.work
        thrust = self._thrust_c
        if self.action_type == "discrete":
            thrust[:] = self._moves_world.take(actions + self._move_row_offset)
            energy = self._move_energy.take(actions)
        else:
            np.multiply(actions, self._frame, out=self._thrust)
            length = np.abs(thrust)
            longer = np.maximum(length, 1.0)
            thrust /= longer  # a thrust longer than 1 is scaled back to length 1
            energy = np.square(length / longer)
        self._v_before_c[:] = self._agent_vel_c
        work[self._ball_x_before_at] = work[self._ball_x_at]
        self.world.step()  # thrust against a linear drag
        self._update_measures(energy)

        ball_x = work[self._ball_x_at]
        if abs(ball_x) > self._goal_line and abs(work[self._ball_y_at]) < self.goal_half_width:
            scorer = 0 if ball_x > 0 else 1
            self.score[scorer] += 1
            self.measures.outcome = np.where(self.team_of == scorer, 1.0, -1.0)
            self.game_over = True
            self._events = [{"kind": "goal", "team": scorer}]
        elif self._events:
            self._events = []

    def observe(self) -> np.ndarray:
        obs = self._obs_matrix @ self.world.work
        obs.clip(self._obs_low, self._obs_high, out=obs)
        return obs.astype(np.float32).reshape(self.n_agents, self.obs_dim)

    def state(self) -> np.ndarray:
        n = self.n_agents
        table = self.world.work[: 4 * (n + 1)].reshape(n + 1, 4)
        scaled = table * np.array([POSITION_SCALE, POSITION_SCALE, 1 / VELOCITY_UNIT, 1 / VELOCITY_UNIT])
        state = np.concatenate([scaled.reshape(-1), self.score.astype(np.float64)])
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, v = (HALF_LENGTH + GOAL_DEPTH) * POSITION_SCALE, HALF_WIDTH * POSITION_SCALE, VELOCITY_BOUND
        return CellLayout([*[Run(f"body_{k}", 4, ((-x, x), (-y, y), (-v, v), (-v, v))) for k in range(self.n_agents + 1)],
                           Run("score", 2, (0, 1))]).bounds()

    def finish(self) -> None:
        self._record("finish")
        # a match cut at max_cycles without a goal is a draw
        self.measures.outcome = np.zeros(self.n_agents)

    def team_result(self) -> np.ndarray:
        if self.score[0] == self.score[1]:
            return np.array([0.5, 0.5])
        return np.where(self.score == self.score.max(), 1.0, 0.0)

    # --- tools ---------------------------------------------------------------------------------
    def place(self, agent_xy: np.ndarray, ball_xy: np.ndarray, agent_velocity: np.ndarray | None = None,
              ball_velocity: np.ndarray | None = None) -> None:
        """Put the bodies at given world positions and velocities (for tests and scripted
        scenarios); the match continues from there."""
        agent_xy = np.asarray(agent_xy, dtype=np.float64).reshape(self.n_agents, 2)
        agent_velocity = (np.zeros((self.n_agents, 2)) if agent_velocity is None
                          else np.asarray(agent_velocity, dtype=np.float64).reshape(self.n_agents, 2))
        if self.world.space is None:
            raise RuntimeError("call reset(seed) before place()")
        self._record("place", agent_xy.copy(), np.array(ball_xy, dtype=np.float64), agent_velocity.copy(),
                     None if ball_velocity is None else np.array(ball_velocity, dtype=np.float64))
        self.world.place("agent", agent_xy, agent_velocity)
        self.world.place("ball", ball_xy, ball_velocity)
        self.world.read()
        self._measure_still_state()

    def render_topdown(self) -> np.ndarray:
        L, W, D, R = HALF_LENGTH, HALF_WIDTH, GOAL_DEPTH, WALL_RADIUS
        margin = D + 2 * R
        canvas = Canvas(-L - margin, L + margin, -W - 2 * R, W + 2 * R, size=400, background=(70, 70, 70))
        outline = goal_field_outline(L, W, self.goal_half_width, D, CORNER_CHAMFER)
        walls = pushed_outline(outline, 2 * R)
        canvas.draw.polygon([canvas.px(x, y) for x, y in walls], fill=(200, 200, 200))
        canvas.draw.polygon([canvas.px(x, y) for x, y in outline], fill=(60, 140, 60))
        G = self.goal_half_width
        for side, team in ((1, 1), (-1, 0)):  # goal box coloured by the team defending it
            colour = TEAM_COLOURS[team]
            canvas.rect(min(side * L, side * (L + D)), -G, max(side * L, side * (L + D)), G,
                        fill=tuple(int(0.5 * c + 0.5 * 240) for c in colour))
        canvas.line(0.0, -W, 0.0, W, fill=(230, 230, 230), width_px=2)
        canvas.circle(0.0, 0.0, 0.8, fill=None, outline=(230, 230, 230))
        n = self.n_agents
        for seat in range(n):
            x, y = self._agent_pos[seat]
            canvas.circle(x, y, AGENT_RADIUS, fill=TEAM_COLOURS[self.team_of[seat]], outline=(20, 20, 20))
        bx, by = self._ball_state[0:2]
        canvas.circle(bx, by, BALL_RADIUS, fill=(250, 250, 250), outline=(20, 20, 20))
        return canvas.array()

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        length, width, depth, ts = HALF_LENGTH, HALF_WIDTH, GOAL_DEPTH, timestamp_ns
        state = self.state().astype(np.float64)
        goal_width = 2 * self.goal_half_width
        n = self.n_agents
        grass = (0.35, 0.65, 0.35, 1.0)
        out = [scene.entity("field", ts, cubes=[
            scene.cube(0, 0, -0.05, (2 * length, 2 * width, 0.1), grass),
            # goal x = -L is defended by team 0, x = +L by team 1
            scene.cube(-length - depth / 2, 0, -0.05, (depth, goal_width, 0.1), scene.team_colour(0, 0.6)),
            scene.cube(length + depth / 2, 0, -0.05, (depth, goal_width, 0.1), scene.team_colour(1, 0.6))])]
        unit = length  # positions are stored divided by HALF_LENGTH
        for seat in range(n):
            x, y = state[4 * seat] * unit, state[4 * seat + 1] * unit
            d = 2 * AGENT_RADIUS
            out.append(scene.entity(f"agent/{seat}", ts, spheres=[
                scene.sphere(x, y, d / 2, (d, d, d), scene.team_colour(int(self.team_of[seat])))]))
        bx, by = state[4 * n] * unit, state[4 * n + 1] * unit
        d = 2 * BALL_RADIUS
        out.append(scene.entity("ball", ts, spheres=[scene.sphere(bx, by, d / 2, (d, d, d), (0.97, 0.97, 0.97, 1.0))]))
        goals = state[4 * n + 4: 4 * n + 6]
        out.append(scene.entity("score", ts, texts=[scene.text(0, width + 0.6, 0.2,
                                                               f"{int(goals[0])} : {int(goals[1])}")]))
        return out

    def human_controls(self, seat: int) -> SoccerControls:
        return SoccerControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        teams = []
        for team in range(n_teams):
            seats = range(team * players_per_team, (team + 1) * players_per_team)
            teams.append({"scheme": "CL", "reward": "team_progress", "scale": 10, "children": [
                {"agent": f"player_{seat}", "scheme": "IS", "reward": "target", "scale": 1} for seat in seats]})
        return {"scheme": "CP", "reward": "win_loss", "scale": 100, "children": teams}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
        n_agents = (obs.shape[1] - 15) // 4 + 1
        n_mates = n_agents // 2 - 1  # Soccer always has two teams
        me = obs[:, 1:3] * HALF_LENGTH
        velocity = obs[:, 3:5] * VELOCITY_UNIT
        ball = obs[:, 7:9] * HALF_LENGTH + obs[:, 9:11] * (VELOCITY_UNIT * 0.15)  # a little lead
        goal = me + obs[:, 11:13] * HALF_LENGTH
        own_goal = me + obs[:, 13:15] * HALF_LENGTH
        # aim into the mouth; a ball on the goal line beside the mouth is first brought out in front
        beside = (ball[:, 0] - goal[:, 0] > -0.7) & (np.abs(ball[:, 1] - goal[:, 1]) > DEFAULT_GOAL_WIDTH / 2 - 0.1)
        aim = goal + np.where(beside[:, None], (-1.0, 0.0), (0.3, 0.0)) - ball
        aim /= np.maximum(np.linalg.norm(aim, axis=1, keepdims=True), 1e-9)
        contact = AGENT_RADIUS + BALL_RADIUS
        rel = me - ball

        # roles: the teammate nearest the ball attacks it; the others hold spots on the line from
        # their own goal to the ball, nearer their goal the further they are from the ball
        my_distance = np.linalg.norm(rel, axis=1)
        rank = np.zeros(len(obs), dtype=np.int64)
        for k in range(n_mates):
            mate = me + obs[:, 15 + 4 * k: 17 + 4 * k] * HALF_LENGTH
            rank += np.linalg.norm(mate - ball, axis=1) < my_distance
        support_spot = own_goal + (ball - own_goal) * (0.6 / np.maximum(rank, 1))[:, None]

        # the attacker runs to a spot behind the ball on the ball-goal line, then drives through;
        # where that spot lies beyond a wall, the nearest spot inside sets the push direction
        behind_spot = ball - aim * (contact + 0.3)
        target = np.where((rank == 0)[:, None], behind_spot, support_spot)
        limit = np.array([HALF_LENGTH - AGENT_RADIUS, HALF_WIDTH - AGENT_RADIUS])
        target = np.clip(target, -limit, limit)
        push = ball - target
        push /= np.maximum(np.linalg.norm(push, axis=1, keepdims=True), 1e-9)
        along = np.einsum("ij,ij->i", rel, push)  # < 0: the seat is behind the ball
        lateral = rel - along[:, None] * push
        lateral_len = np.linalg.norm(lateral, axis=1)
        side = np.where(lateral_len[:, None] > 1e-6, lateral / np.maximum(lateral_len, 1e-9)[:, None],
                        np.stack([-push[:, 1], push[:, 0]], axis=1))
        # when the straight way there runs into the ball, go round it on the seat's side
        path = target - me
        t = np.clip(np.einsum("ij,ij->i", -rel, path) / np.maximum(np.einsum("ij,ij->i", path, path), 1e-9), 0, 1)
        blocked = np.linalg.norm(ball - (me + t[:, None] * path), axis=1) < contact + 0.05
        around = np.clip(ball + side * (contact + 0.3) - push * (contact + 0.3), -limit, limit)
        waypoint = np.where(blocked[:, None], around, target)
        aligned = (rank == 0) & (along < -0.5 * contact) & (lateral_len < 0.35 * contact)
        waypoint = np.where(aligned[:, None], ball + push * 0.6, waypoint)

        heading = waypoint - me
        distance = np.linalg.norm(heading, axis=1, keepdims=True)
        # steer the velocity, not just the position, so the seat does not overshoot
        heading = heading / np.maximum(distance, 1e-9) * np.minimum(1.0, distance / 0.3) - 0.2 * velocity
        length = np.linalg.norm(heading, axis=1)
        if action_type == "continuous":
            return np.clip(heading / np.maximum(length, 1.0)[:, None], -1.0, 1.0).astype(np.float32)
        angle = np.arctan2(heading[:, 1], heading[:, 0])
        move = 1 + np.round(angle / (np.pi / 4)).astype(np.int64) % 8
        return np.where(length < 0.3, 0, move).astype(np.int64)



class SoccerControls(MirroredCompassControls):
    """Compass moves on the field as drawn (E = right), mirrored for the team that sees the field
    flipped."""

    move = "move on the field as drawn"
    key_hint = "Arrow keys or W A S D run on the field as drawn (two at once: diagonally); let go to stop."


RULES = SoccerRules
