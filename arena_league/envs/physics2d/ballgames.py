"""What the two-team ball games on a walled field with a goal at each end share (Soccer, AirHockey).

Both games seat two teams on a field mirrored in ``x`` (team 0 attacks ``+x``, team 1 ``-x``),
push one ball (a puck) by the seats' thrust against a linear drag, observe the same runs of cells
in the seat frame, keep the same global state, measure the same things about the ball and build
the same default social tree. This module holds those pieces, each a function of the game's own
constants:

- :class:`BallGameRules`: the rules' common part (the ``goal_width`` and ``kickoff_jitter``
  options' values, the compass moves, the score, the seats' mirrored frames, the kick-off, the
  global state and the default tree);
- :func:`observation_layout` and :func:`observation_matrix`: the observation's runs (own body, the
  ball, the two goals, every other seat) and the matrix that fills them from the work vector;
- :func:`seat_force_matrix` and :func:`measure_matrix`: a seat's thrust against drag, and the
  linear parts of the measures (the way to the ball, the velocity, the contact force, the ball's
  progress toward the attacked goal);
- :func:`state_layout` and :func:`field_state`: every body's ``x, y, vx, vy``, then the score;
- :func:`win_loss_over_team_progress`: the default social tree;
- :func:`drive_through`: the scripted seats' last stretch, to a spot and through the ball;
- :func:`draw_goal_field` and :func:`goal_field_entities`: the top-down picture and the replay scene.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from arena_league.envs import scene
from arena_league.envs.physics2d.cells import CellLayout, Run
from arena_league.envs.physics2d.geometry import Point, goal_field_outline, pushed_outline
from arena_league.envs.physics2d.rules import COMPASS_MOVE_NAMES, COMPASS_MOVES, Physics2DRules, mirror_signs
from arena_league.envs.physics2d.world import ONE, World
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

__all__ = ["BallGameRules", "FieldLook", "draw_goal_field", "drive_through", "field_state", "goal_field_entities",
           "measure_matrix", "observation_layout", "observation_matrix", "seat_force_matrix", "state_layout",
           "win_loss_over_team_progress"]

Bounds = tuple[float, float]
PairBounds = tuple[Bounds, Bounds]
Primitives = dict[str, list[dict[str, Any]]]


class BallGameRules(Physics2DRules):
    """The common part of a two-team ball game's rules. A game declares the options
    ``goal_width`` and ``kickoff_jitter`` among its ``options``, its observation scales
    (:attr:`position_scale`, :attr:`velocity_unit`) and :meth:`state_bounds`, and builds its
    ``layout`` and ``world`` (the ball the body after the seats) in ``__init__`` after this one,
    and its ``_measure_still_state`` (the measures of the bodies as they stand)."""

    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "target_distance", "velocity_to_target", "energy", "force", "speed", "object_progress",
         "outcome"}
    )
    default_max_cycles: ClassVar[int] = 300
    #: The body kind of the ball (the body after the seats).
    ball: ClassVar[str] = "ball"
    position_scale: ClassVar[float]
    velocity_unit: ClassVar[float]

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs: Any) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        self.goal_half_width = self.settings["goal_width"] / 2
        self.kickoff_jitter = self.settings["kickoff_jitter"]
        self.n_actions = len(COMPASS_MOVE_NAMES)
        self.act_dim = 2
        self.action_meanings = COMPASS_MOVE_NAMES
        self.state_dim = 4 * self.n_agents + 6
        self.score = np.zeros(2, dtype=np.int64)
        self._team_sign = mirror_signs(self.team_of)  # the x sign of each seat's frame
        self._move_energy = (COMPASS_MOVES**2).sum(axis=1)
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())

    def kickoff(self, formation: Sequence[Point]) -> tuple[np.ndarray, np.ndarray]:
        """Every seat's and the ball's kick-off position, drawn from ``self.rng``: team 0 at the
        ``formation``'s spots, team 1 at theirs mirrored, each spot jittered by up to
        ``kickoff_jitter`` in both coordinates, and the ball on the centre spot jittered in ``y``."""
        jitter = self.kickoff_jitter
        slots = np.asarray(formation, dtype=np.float64)
        team0 = slots + self.rng.uniform(-jitter, jitter, slots.shape)
        team1 = slots + self.rng.uniform(-jitter, jitter, slots.shape)
        team1[:, 0] *= -1.0
        return np.concatenate([team0, team1]), np.array([0.0, self.rng.uniform(-jitter, jitter)])

    def still_slots(self) -> None:
        """The slots a step fills before the physics as they stand with no step behind: no thrust,
        every seat's velocity (slot ``"v_before"``) and the ball's x (``"<ball>_x_before"``) as they are."""
        world = self.world
        world.work[world.at("v_before"): world.at(ONE)] = 0.0
        world.work[world.at(f"{self.ball}_x_before")] = world.work[world.pos(world.index(self.ball), 0)]
        world.view("v_before")[:] = world.table[: self.n_agents, 2:4].reshape(-1)

    def place_bodies(self, seats: str, seat_xy: Any, seat_velocity: Any | None, ball: str, ball_xy: Any,
                     ball_velocity: Any | None) -> None:
        """What a game's ``place`` does: the seats (bodies of kind ``seats``) and the ``ball`` put at
        world positions and velocities (zero when None), once :meth:`check_placement` accepts them,
        the call recorded for replay and the measures taken of the bodies as they stand."""
        seat_xy = np.asarray(seat_xy, dtype=np.float64).reshape(self.n_agents, 2)
        seat_velocity = (np.zeros((self.n_agents, 2)) if seat_velocity is None
                         else np.asarray(seat_velocity, dtype=np.float64).reshape(self.n_agents, 2))
        ball_xy = np.array(ball_xy, dtype=np.float64).reshape(2)
        if self.world.space is None:
            raise RuntimeError("call reset(seed) before place()")
        self.check_placement(seat_xy, ball_xy)
        self._record("place", seat_xy.copy(), ball_xy.copy(), seat_velocity.copy(),
                     None if ball_velocity is None else np.array(ball_velocity, dtype=np.float64))
        self.world.place(seats, seat_xy, seat_velocity)
        self.world.place(ball, ball_xy, ball_velocity)
        self.world.read()
        self._measure_still_state()

    def check_placement(self, seat_xy: np.ndarray, ball_xy: np.ndarray) -> None:
        """Raise a ValueError where the seats (``(n, 2)``) or the ball may not stand; any place will do here."""

    def state(self) -> np.ndarray:
        return field_state(self.world, self.n_agents + 1, self.position_scale, self.velocity_unit, self.score,
                           self._state_low, self._state_high)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        return win_loss_over_team_progress(n_teams, players_per_team)


def observation_layout(ball: str, position: PairBounds, ball_relative: PairBounds, ball_position: PairBounds,
                       velocity: Bounds, goals: tuple[PairBounds, PairBounds],
                       others: Sequence[PairBounds]) -> CellLayout:
    """The observation's runs in the seat frame: the active flag, own position and velocity, the
    ball (``ball`` names it) relative to the seat, where it is and how it moves, the attacked and
    the defended goal's mouth relative to the seat (``goals``), then every other seat (teammates
    first, then opponents, each in seat order; ``others`` bounds each one's relative position)."""
    runs = [Run("active", 1, (0, 1), "own active flag (always 1)"),
            Run("position", 2, position, "own position"),
            Run("velocity", 2, velocity, "own velocity"),
            Run(f"{ball}_relative", 2, ball_relative, f"{ball} position relative to the seat"),
            Run(ball, 2, ball_position, f"{ball} position"),
            Run(f"{ball}_velocity", 2, velocity, f"{ball} velocity"),
            Run("attacked_goal", 2, goals[0], "centre of the attacked mouth, relative"),
            Run("defended_goal", 2, goals[1], "centre of the defended mouth, relative")]
    for k, relative in enumerate(others):
        runs += [Run(f"other_{k}", 2, relative, "another seat's position relative to the seat"),
                 Run(f"other_{k}_velocity", 2, velocity, "that seat's velocity")]
    return CellLayout(runs)


def observation_matrix(world: World, layout: CellLayout, ball: str, team_of: np.ndarray, team_sign: np.ndarray,
                       position_scale: float, velocity_scale: float, goal_x: float) -> np.ndarray:
    """The observations of every seat (seat after seat, rows of ``layout``) as one matrix over the
    work vector: each seat's frame mirrors ``x`` by its ``team_sign``; the goals' mouths are at
    ``(goal_x, 0)`` (attacked) and ``(-goal_x, 0)`` (defended) in the seat frame."""
    n = len(team_of)
    A = np.zeros((n, layout.size, len(world.work)))
    b, one = world.index(ball), world.at(ONE)
    ps, vs = position_scale, velocity_scale
    pos, vel, at = world.pos, world.vel, layout.at
    for i in range(n):
        sign = (team_sign[i], 1.0)
        team = team_of[i]
        others = [j for j in range(n) if j != i and team_of[j] == team]
        others += [j for j in range(n) if team_of[j] != team]
        A[i, at("active"), one] = 1.0
        for ax in range(2):
            s = sign[ax]
            A[i, at("position", ax), pos(i, ax)] = s * ps
            A[i, at("velocity", ax), vel(i, ax)] = s * vs
            A[i, at(f"{ball}_relative", ax), pos(b, ax)] = s * ps
            A[i, at(f"{ball}_relative", ax), pos(i, ax)] -= s * ps
            A[i, at(ball, ax), pos(b, ax)] = s * ps
            A[i, at(f"{ball}_velocity", ax), vel(b, ax)] = s * vs
            A[i, at("attacked_goal", ax), pos(i, ax)] = -s * ps
            A[i, at("defended_goal", ax), pos(i, ax)] = -s * ps
            for k, j in enumerate(others):
                A[i, at(f"other_{k}", ax), pos(j, ax)] = s * ps
                A[i, at(f"other_{k}", ax), pos(i, ax)] -= s * ps
                A[i, at(f"other_{k}_velocity", ax), vel(j, ax)] = s * vs
        A[i, at("attacked_goal"), one] = goal_x * ps
        A[i, at("defended_goal"), one] = -goal_x * ps
    return A.reshape(n * layout.size, len(world.work))


def seat_force_matrix(world: World, thrust: float, drag: float, thrust_signs: np.ndarray) -> np.ndarray:
    """Every body's applied force over the work vector: each seat's ``thrust`` times its unit
    thrust (slot ``"thrust"``, turned into the world by ``thrust_signs``, one per cell) against
    ``drag`` times its velocity before the step (slot ``"v_before"``); zero for the other bodies."""
    F = world.matrix(2 * world.n_bodies)
    for k in range(len(thrust_signs)):
        F[k, world.at("thrust", k)] = thrust * thrust_signs[k]
        F[k, world.at("v_before", k)] = -drag
    return F


def measure_matrix(world: World, ball: str, team_sign: np.ndarray, thrust_signs: np.ndarray, mass: float,
                   dt: float, damping: float, thrust: float, drag: float) -> np.ndarray:
    """The linear parts of the measures as one matrix over the work vector (``7 n`` rows).

    Rows: ``[to_ball (x, -y), velocity (x, y), contact force (x, y)]`` of every seat, read as
    complex numbers (``to_ball`` conjugated), then every seat's ``object_progress`` (the ball's x
    this step, slot ``"<ball>_x_before"`` before it, toward the attacked goal). The contact force is
    the impulse the solver added beyond damping and the applied force (Chipmunk integrates
    ``v' = v * damping**dt + f / m * dt`` before solving contacts), divided by ``dt``.
    """
    n = len(team_sign)
    M = world.matrix(7 * n)
    b = world.index(ball)
    # velocity kept from before the step, drag included (force = thrust * unit - drag * v)
    keep = damping**dt - drag * dt / mass
    for i in range(n):
        for ax in range(2):
            conj = 1.0 if ax == 0 else -1.0
            M[2 * i + ax, world.pos(b, ax)] = conj
            M[2 * i + ax, world.pos(i, ax)] = -conj
            M[2 * n + 2 * i + ax, world.vel(i, ax)] = 1.0
            row = 4 * n + 2 * i + ax
            M[row, world.vel(i, ax)] = mass / dt
            M[row, world.at("v_before", 2 * i + ax)] = -keep * mass / dt
            M[row, world.at("thrust", 2 * i + ax)] = -thrust * thrust_signs[2 * i + ax]
        M[6 * n + i, world.pos(b, 0)] = team_sign[i]
        M[6 * n + i, world.at(f"{ball}_x_before")] = -team_sign[i]
    return M


def state_layout(bodies: Sequence[tuple[Bounds, Bounds, Bounds, Bounds]]) -> CellLayout:
    """The global state's runs: every body's ``x, y, vx, vy`` (one bounds each), then the goals
    scored by each team, in [0, 1] (the first goal ends the match)."""
    return CellLayout([*[Run(f"body_{k}", 4, bounds) for k, bounds in enumerate(bodies)], Run("score", 2, (0, 1))])


def field_state(world: World, n_bodies: int, position_scale: float, velocity_unit: float, score: np.ndarray,
                low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The global state (world frame): the first ``n_bodies`` bodies' scaled ``x, y, vx, vy``, then
    the score, clipped to ``low, high``, as float32."""
    table = world.work[: 4 * n_bodies].reshape(n_bodies, 4)
    scaled = table * np.array([position_scale, position_scale, 1 / velocity_unit, 1 / velocity_unit])
    state = np.concatenate([scaled.reshape(-1), score.astype(np.float64)])
    return state.clip(low, high, out=state).astype(np.float32)


def win_loss_over_team_progress(n_teams: int, players_per_team: int) -> dict:
    """Root CP ``win_loss`` (scale 100) over one CL ``team_progress`` node (scale 10) per team,
    each agent leaf IS ``target`` (scale 1: progress toward the ball)."""
    teams = []
    for team in range(n_teams):
        seats = range(team * players_per_team, (team + 1) * players_per_team)
        teams.append({"scheme": "CL", "reward": "team_progress", "scale": 10, "children": [
            {"agent": f"player_{seat}", "scheme": "IS", "reward": "target", "scale": 1} for seat in seats]})
    return {"scheme": "CP", "reward": "win_loss", "scale": 100, "children": teams}


def drive_through(me: np.ndarray, velocity: np.ndarray, ball: np.ndarray, target: np.ndarray, contact: float,
                  low: Any, high: Any, detours: Any, strikers: np.ndarray, coast: bool,
                  action_type: str) -> np.ndarray:
    """Scripted seats' actions (rows: seats, world-frame 2-vectors in the seat frame): each runs to
    its ``target`` spot (within ``low``, ``high``), the seats in ``detours`` going round the ball
    where the straight way there runs into it (``contact``: the distance of a touch), and a
    ``striker`` lined up behind the ball drives through it. Each steers its velocity, not just its
    position, so as not to overshoot; with ``coast``, a striker driving through does not brake.
    Discrete actions are the compass move nearest the heading (noop for a weak one)."""
    rel = me - ball
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
    blocked = detours & (np.linalg.norm(ball - (me + t[:, None] * path), axis=1) < contact + 0.05)
    around = np.clip(ball + side * (contact + 0.3) - push * (contact + 0.3), low, high)
    waypoint = np.where(blocked[:, None], around, target)
    aligned = strikers & (along < -0.5 * contact) & (lateral_len < 0.35 * contact)
    waypoint = np.where(aligned[:, None], ball + push * 0.6, waypoint)

    heading = waypoint - me
    distance = np.linalg.norm(heading, axis=1, keepdims=True)
    heading = heading / np.maximum(distance, 1e-9) * np.minimum(1.0, distance / 0.3)
    heading -= np.where(aligned & coast, 0.0, 0.2)[:, None] * velocity
    length = np.linalg.norm(heading, axis=1)
    if action_type == "continuous":
        return np.clip(heading / np.maximum(length, 1.0)[:, None], -1.0, 1.0).astype(np.float32)
    angle = np.arctan2(heading[:, 1], heading[:, 0])
    move = 1 + np.round(angle / (np.pi / 4)).astype(np.int64) % 8
    return np.where(length < 0.3, 0, move).astype(np.int64)


@dataclass(frozen=True)
class FieldLook:
    """How a goal field is drawn top-down: the walls drawn ``wall`` thick beyond the outline,
    ``margin`` round the field (beyond the goal boxes at the ends), the colours, the centre line's
    width and circle, and the ball's rim (None: none)."""

    wall: float
    margin: float
    wall_colour: tuple[int, int, int]
    surface_colour: tuple[int, int, int]
    marking_colour: tuple[int, int, int]
    line_px: int
    centre_circle: float
    ball_rim: tuple[int, int, int] | None


def draw_goal_field(look: FieldLook, half_length: float, half_width: float, goal_half_width: float,
                    goal_depth: float, chamfer: float, seats_xy: np.ndarray, team_of: np.ndarray, seat_radius: float,
                    ball_xy: Sequence[float], ball_radius: float) -> np.ndarray:
    """The top-down picture (400 pixels wide): the walls, the surface with its centre line and
    circle, each goal box in the colour of the team defending it, the seats in their teams'
    colours and the ball in white."""
    L, W, D, G = half_length, half_width, goal_depth, goal_half_width
    margin = D + look.margin
    canvas = Canvas(-L - margin, L + margin, -W - look.margin, W + look.margin, size=400, background=(70, 70, 70))
    outline: list[Point] = goal_field_outline(L, W, G, D, chamfer)
    canvas.draw.polygon([canvas.px(x, y) for x, y in pushed_outline(outline, look.wall)], fill=look.wall_colour)
    canvas.draw.polygon([canvas.px(x, y) for x, y in outline], fill=look.surface_colour)
    for side, team in ((1, 1), (-1, 0)):  # goal box coloured by the team defending it
        colour = TEAM_COLOURS[team]
        canvas.rect(min(side * L, side * (L + D)), -G, max(side * L, side * (L + D)), G,
                    fill=tuple(int(0.5 * c + 0.5 * 240) for c in colour))
    canvas.line(0.0, -W, 0.0, W, fill=look.marking_colour, width_px=look.line_px)
    canvas.circle(0.0, 0.0, look.centre_circle, fill=None, outline=look.marking_colour)
    for seat, (x, y) in enumerate(seats_xy):
        canvas.circle(x, y, seat_radius, fill=TEAM_COLOURS[team_of[seat]], outline=(20, 20, 20))
    canvas.circle(ball_xy[0], ball_xy[1], ball_radius, fill=(250, 250, 250), outline=look.ball_rim)
    return canvas.array()


def goal_field_entities(timestamp_ns: int, field: str, surface: list[dict[str, Any]], half_length: float,
                        half_width: float, goal_depth: float, goal_width: float, state: np.ndarray,
                        team_of: np.ndarray, seat_shape: Callable[[float, float, tuple], Primitives],
                        ball: str, ball_shape: Callable[[float, float], Primitives]) -> list[dict[str, Any]]:
    """The replay scene from the global ``state``: entity ``field`` (the ``surface`` cubes and
    both goal boxes in the colour of the team defending each), ``agent/<seat>`` (a
    ``seat_shape`` each, in its team's colour), the ``ball`` (``ball_shape``) and the ``score``
    (text). A shape is the primitives of its entity, ``{"spheres": [...]}``; positions in the
    state are divided by ``half_length``."""
    ts, length, depth, n = timestamp_ns, half_length, goal_depth, len(team_of)
    state = np.asarray(state, dtype=np.float64)
    out = [scene.entity(field, ts, cubes=[
        *surface,
        # goal x = -L is defended by team 0, x = +L by team 1
        scene.cube(-length - depth / 2, 0, -0.05, (depth, goal_width, 0.1), scene.team_colour(0, 0.6)),
        scene.cube(length + depth / 2, 0, -0.05, (depth, goal_width, 0.1), scene.team_colour(1, 0.6))])]
    for seat in range(n):
        x, y = state[4 * seat] * length, state[4 * seat + 1] * length
        out.append(scene.entity(f"agent/{seat}", ts, **seat_shape(x, y, scene.team_colour(int(team_of[seat])))))
    bx, by = state[4 * n] * length, state[4 * n + 1] * length
    out.append(scene.entity(ball, ts, **ball_shape(bx, by)))
    goals = state[4 * n + 4: 4 * n + 6]
    out.append(scene.entity("score", ts, texts=[scene.text(0, half_width + 0.6, 0.2,
                                                           f"{int(goals[0])} : {int(goals[1])}")]))
    return out
