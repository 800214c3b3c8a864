"""What the two-team ball games on a walled field with a goal at each end share (Soccer, AirHockey).

Both games seat two teams on a field mirrored in ``x`` (team 0 attacks ``+x``, team 1 ``-x``),
push one ball (a puck) by the seats' thrust against a linear drag, observe the same runs of cells
in the seat frame, keep the same global state, measure the same things about the ball and build
the same default social tree. This module holds those pieces, each a function of the game's own
constants:

- :func:`observation_layout` and :func:`observation_matrix`: the observation's runs (own body, the
  ball, the two goals, every other seat) and the matrix that fills them from the work vector;
- :func:`seat_force_matrix` and :func:`measure_matrix`: a seat's thrust against drag, and the
  linear parts of the measures (the way to the ball, the velocity, the contact force, the ball's
  progress toward the attacked goal);
- :func:`state_layout` and :func:`field_state`: every body's ``x, y, vx, vy``, then the score;
- :func:`win_loss_over_team_progress`: the default social tree;
- :func:`draw_goal_field` and :func:`goal_field_entities`: the top-down picture and the replay scene.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from arena_league.envs import scene
from arena_league.envs.physics2d.cells import CellLayout, Run
from arena_league.envs.physics2d.geometry import Point, goal_field_outline, pushed_outline
from arena_league.envs.physics2d.world import ONE, World
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

__all__ = ["FieldLook", "draw_goal_field", "field_state", "goal_field_entities", "measure_matrix",
           "observation_layout", "observation_matrix", "seat_force_matrix", "state_layout",
           "win_loss_over_team_progress"]

Bounds = tuple[float, float]
PairBounds = tuple[Bounds, Bounds]
Primitives = dict[str, list[dict[str, Any]]]


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
