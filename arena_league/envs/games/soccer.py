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
    Walls,
    World,
    ballgames,
)
from arena_league.envs.physics2d.geometry import goal_field_outline, wall_segments

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
#: How the field is drawn: the walls as thick as they are, the ball with a dark rim.
_LOOK = ballgames.FieldLook(wall=2 * WALL_RADIUS, margin=2 * WALL_RADIUS, wall_colour=(200, 200, 200),
                            surface_colour=(60, 140, 60), marking_colour=(230, 230, 230), line_px=2,
                            centre_circle=0.8, ball_rim=(20, 20, 20))


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
    position, relative = ((-x, x), (-y, y)), ((-2 * x, 2 * x), (-2 * y, 2 * y))
    return ballgames.observation_layout("ball", position, relative, position, (-v, v),
                                        (((goal - x, goal + x), (-y, y)), ((-goal - x, -goal + x), (-y, y))),
                                        [relative] * (n_agents - 1))


class SoccerRules(ballgames.BallGameRules):
    """Soccer on a walled pymunk field; see the module docstring for the manual."""

    name: ClassVar[str] = "Soccer"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2), (2, 3))
    summary: ClassVar[str] = "Teams push a ball into the other goal (pymunk; first goal wins)"
    options = OPTIONS
    position_scale = POSITION_SCALE
    velocity_unit = VELOCITY_UNIT

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        n = self.n_agents
        self.layout = soccer_observation(n)
        self.obs_dim = self.layout.size

        self._frame = np.stack([self._team_sign, np.ones(n)], axis=1)  # (n, 2) multiplies x, y
        # world-frame unit thrust of every (team, move), flattened: row team * 9 + move
        moves_world = COMPASS_MOVES[None] * np.array([[[1.0, 1.0]], [[-1.0, 1.0]]])
        self._moves_world = np.ascontiguousarray(moves_world.reshape(-1, 2)).view(np.complex128).reshape(-1)
        self._move_row_offset = self.team_of * len(COMPASS_MOVE_NAMES)
        self._goal_line = HALF_LENGTH + BALL_RADIUS
        self._tiny = np.full(n, 1e-9)
        self._layout_work_vector()
        self._obs_low, self._obs_high = self.clip_bounds(self.layout)

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
        ones = np.ones(2 * n)  # the thrust is in the world frame already
        self._obs_matrix = ballgames.observation_matrix(world, self.layout, "ball", self.team_of, self._team_sign,
                                                        POSITION_SCALE, 1.0 / VELOCITY_UNIT, HALF_LENGTH)
        self._measure_matrix = ballgames.measure_matrix(world, "ball", self._team_sign, ones, AGENT_MASS, DT,
                                                        SPACE_DAMPING, THRUST, AGENT_DRAG)
        # applied force of every body (zero for the ball and the static body)
        world.force_matrix = ballgames.seat_force_matrix(world, THRUST, AGENT_DRAG, ones)

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        agent_xy, ball_xy = self.kickoff(_FORMATIONS[self.players_per_team])
        self.world.build({"agent": agent_xy, "ball": ball_xy})
        self._measure_still_state()
        self.measures.active[:] = True
        self.measures.outcome = np.zeros(self.n_agents)
        self.score[:] = 0
        self.game_over = False
        self._events = []

    def _measure_still_state(self) -> None:
        """Measures of the bodies as they stand, with no step behind them (no force, no progress)."""
        self.still_slots()
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

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, v = (HALF_LENGTH + GOAL_DEPTH) * POSITION_SCALE, HALF_WIDTH * POSITION_SCALE, VELOCITY_BOUND
        return ballgames.state_layout([((-x, x), (-y, y), (-v, v), (-v, v))] * (self.n_agents + 1)).bounds()

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
        self.place_bodies("agent", agent_xy, agent_velocity, "ball", ball_xy, ball_velocity)

    def render_topdown(self) -> np.ndarray:
        return ballgames.draw_goal_field(_LOOK, HALF_LENGTH, HALF_WIDTH, self.goal_half_width, GOAL_DEPTH,
                                         CORNER_CHAMFER, self._agent_pos, self.team_of, AGENT_RADIUS,
                                         self._ball_state[0:2], BALL_RADIUS)

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        grass = [scene.cube(0, 0, -0.05, (2 * HALF_LENGTH, 2 * HALF_WIDTH, 0.1), (0.35, 0.65, 0.35, 1.0))]

        def sphere(x: float, y: float, radius: float, colour: tuple) -> dict[str, Any]:
            return {"spheres": [scene.sphere(x, y, radius, (2 * radius,) * 3, colour)]}

        return ballgames.goal_field_entities(
            timestamp_ns, "field", grass, HALF_LENGTH, HALF_WIDTH, GOAL_DEPTH, 2 * self.goal_half_width,
            self.state(), self.team_of, lambda x, y, colour: sphere(x, y, AGENT_RADIUS, colour),
            "ball", lambda x, y: sphere(x, y, BALL_RADIUS, (0.97, 0.97, 0.97, 1.0)))

    def human_controls(self, seat: int) -> SoccerControls:
        return SoccerControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------
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
        return ballgames.drive_through(me, velocity, ball, target, contact, -limit, limit, True, rank == 0, False,
                                       action_type)


class SoccerControls(MirroredCompassControls):
    """Compass moves on the field as drawn (E = right), mirrored for the team that sees the field
    flipped."""

    move = "move on the field as drawn"
    key_hint = "Arrow keys or W A S D run on the field as drawn (two at once: diagonally); let go to stop."


RULES = SoccerRules
