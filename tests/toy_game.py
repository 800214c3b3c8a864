"""PuckPush: each team pushes one puck over the line in the other team's half (a toy 2D game).

Written by following ``docs/adding-a-game.md`` over the 2D engine (:mod:`arena_league.envs.physics2d`),
to show that a game is a declaration; it lives in the tests, not in the catalog, and joins it only
inside :func:`arena_league.envs.catalog.registered_rules` (``tests/test_toy_game.py``). Ids:
``PuckPush-2T1P-v1``, ``PuckPush-2T2P-v1``.

Field
    A walled rectangle, ``x`` in [-3, 3] and ``y`` in [-2, 2] (inner faces of the walls). Team 0
    scores when the puck's centre passes ``x = +line`` (default 2.4), team 1 when it passes
    ``x = -line``.

Bodies and physics
    Agents are discs of radius 0.25 and mass 1 that do not spin; the puck is a disc of radius 0.2
    and mass 0.5. One pymunk step of 0.1 s per env step; space damping 0.5; an agent's thrust of at
    most 5 is opposed by a drag of ``2.5 * velocity`` (top speed 2 units/s).

Kick-off
    The puck at the centre, each team in its own half, every ``y`` jittered by up to
    ``kickoff_jitter`` from the match seed.

Seat frame
    Team 1 sees and acts in the world mirrored in ``x``, so every seat pushes toward ``+x``.

Actions
    Discrete: ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE`` (seat frame, full thrust).
    Continuous: ``[fx, fy]`` in [-1, 1], the thrust as a fraction of full, at most length 1.

Observation (``float32``, seat frame; positions divided by 3, velocities by 3)
    ``active`` (1), ``position`` (2), ``velocity`` (2), ``puck_relative`` (2), ``puck_velocity``
    (2), ``to_line`` (1: the attacked line's ``x`` minus the puck's), then every other seat's
    position relative to the seat (2 each; teammates first). Bounds: the walls bound positions,
    velocities are clipped to [-2, 2] (6 units/s).

Global state
    Every seat's then the puck's ``x, y, vx, vy`` (world frame, same scales), then each team's
    score (0 or 1).

Measures
    ``active``, ``target_distance`` (to the puck), ``energy`` (squared thrust), ``object_progress``
    (the puck's ``x`` step toward the attacked line) and ``outcome`` (+1 / -1 for the scoring /
    conceding team, 0 for a draw).

Episode end
    A score ends the match; a match cut at ``max_cycles`` (default 200) is a draw.

Default social tree
    Root CP ``win_loss`` (scale 100) over one CL ``team_progress`` node (scale 10) per team over IS
    ``target`` leaves (scale 1).

Heuristic
    Run to a spot behind the puck (going round it when in front), then drive through it toward
    ``+x``.

Game kwargs
    ``line`` (float in [1.0, 2.6], default 2.4), ``kickoff_jitter`` (float in [0, 0.5], default 0.3).

Playing it
    Compass moves on the field as drawn, mirrored for team 1 (arrow keys or W A S D in a browser).

Copies
    By replaying the match (:class:`~arena_league.envs.core.ReplayedMatch`, through
    :class:`~arena_league.envs.physics2d.Physics2DRules`).

Replay scene
    ``field`` (the floor and both lines), ``agent/<seat>`` and ``puck``.
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
from arena_league.envs.physics2d.geometry import wall_segments
from arena_league.envs.rendering import TEAM_COLOURS, Canvas

HALF_LENGTH, HALF_WIDTH, WALL_RADIUS = 3.0, 2.0, 0.2
AGENT_RADIUS, AGENT_MASS, PUCK_RADIUS, PUCK_MASS = 0.25, 1.0, 0.2, 0.5
DT, DAMPING, THRUST, DRAG = 0.1, 0.5, 5.0, 2.5
SCALE, VELOCITY_UNIT, VELOCITY_BOUND = 1.0 / HALF_LENGTH, 3.0, 2.0
OPTIONS = (Option("line", float, 2.4, "distance from the centre to each team's scoring line", 1.0, 2.6),
           Option("kickoff_jitter", float, 0.3, "largest random offset of each kick-off y", 0.0, 0.5))


def puck_field(n_agents: int) -> Field:
    outline = [(-HALF_LENGTH, -HALF_WIDTH), (HALF_LENGTH, -HALF_WIDTH), (HALF_LENGTH, HALF_WIDTH),
               (-HALF_LENGTH, HALF_WIDTH)]
    return Field(dt=DT, damping=DAMPING, collision_slop=0.01, parts=(
        Walls(tuple(wall_segments(outline, WALL_RADIUS)), WALL_RADIUS, Material(0.8, 0.3)),
        Bodies("agent", n_agents, AGENT_RADIUS, AGENT_MASS, Material(0.5, 0.3)),
        Bodies("puck", 1, PUCK_RADIUS, PUCK_MASS, Material(0.8, 0.3))))


def puck_observation(n_agents: int, line: float) -> CellLayout:
    x, y, v = HALF_LENGTH * SCALE, HALF_WIDTH * SCALE, VELOCITY_BOUND
    relative = ((-2 * x, 2 * x), (-2 * y, 2 * y))
    runs = [Run("active", 1, (0, 1), "own active flag"), Run("position", 2, ((-x, x), (-y, y)), "own position"),
            Run("velocity", 2, (-v, v), "own velocity"), Run("puck_relative", 2, relative, "puck - own position"),
            Run("puck_velocity", 2, (-v, v), "puck velocity"),
            Run("to_line", 1, ((line - HALF_LENGTH) * SCALE, (line + HALF_LENGTH) * SCALE), "line x - puck x")]
    runs += [Run(f"other_{k}", 2, relative, "another seat - own position") for k in range(n_agents - 1)]
    return CellLayout(runs)


class PuckPushRules(Physics2DRules):
    """PuckPush over the 2D engine; see the module docstring for the manual."""

    name: ClassVar[str] = "PuckPush"
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "target_distance", "energy", "object_progress", "outcome"})
    default_max_cycles: ClassVar[int] = 200
    summary: ClassVar[str] = "Teams push one puck over the line in the other half (a toy 2D game)"
    options = OPTIONS

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs: Any) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        n = self.n_agents
        self.line, self.jitter = self.settings["line"], self.settings["kickoff_jitter"]
        self.n_actions, self.act_dim, self.action_meanings = len(COMPASS_MOVE_NAMES), 2, COMPASS_MOVE_NAMES
        self.layout = puck_observation(n, self.line)
        self.obs_dim, self.state_dim = self.layout.size, 4 * (n + 1) + 2
        self.score = np.zeros(2, dtype=np.int64)
        self._frame = np.stack([mirror_signs(self.team_of), np.ones(n)], axis=1)  # multiplies (x, y)
        world = self.world = World(puck_field(n), slots=(("thrust", 2 * n), ("puck_x_before", 1), (ONE, 1)))
        self._puck = world.index("puck")
        world.force_matrix = world.matrix(2 * world.n_bodies)  # thrust against a linear drag
        for i in range(n):
            for ax in range(2):
                world.force_matrix[2 * i + ax, world.at("thrust", 2 * i + ax)] = THRUST
                world.force_matrix[2 * i + ax, world.vel(i, ax)] = -DRAG
        self._obs_matrix = self._observation_map()
        self._obs_low, self._obs_high = self.clip_bounds(self.layout)
        self._state_low, self._state_high = (b.astype(np.float64) for b in self.state_bounds())

    def _observation_map(self) -> np.ndarray:
        """Every seat's observation as one matrix over the world's work vector."""
        n, world, cells, puck = self.n_agents, self.world, self.layout, self._puck
        A = np.zeros((n, self.obs_dim, len(world.work)))
        vs = 1.0 / VELOCITY_UNIT
        for i in range(n):
            others = [j for j in range(n) if j != i and self.team_of[j] == self.team_of[i]]
            others += [j for j in range(n) if self.team_of[j] != self.team_of[i]]
            A[i, cells.at("active"), world.at(ONE)] = 1.0
            for ax in range(2):
                s = self._frame[i, ax]
                A[i, cells.at("position", ax), world.pos(i, ax)] = s * SCALE
                A[i, cells.at("velocity", ax), world.vel(i, ax)] = s * vs
                A[i, cells.at("puck_relative", ax), world.pos(puck, ax)] = s * SCALE
                A[i, cells.at("puck_relative", ax), world.pos(i, ax)] = -s * SCALE
                A[i, cells.at("puck_velocity", ax), world.vel(puck, ax)] = s * vs
                for k, j in enumerate(others):
                    A[i, cells.at(f"other_{k}", ax), world.pos(j, ax)] = s * SCALE
                    A[i, cells.at(f"other_{k}", ax), world.pos(i, ax)] = -s * SCALE
            A[i, cells.at("to_line"), world.at(ONE)] = self.line * SCALE
            A[i, cells.at("to_line"), world.pos(puck, 0)] = -self._frame[i, 0] * SCALE
        return A.reshape(n * self.obs_dim, len(world.work))

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        p = self.players_per_team
        xs = np.repeat([-1.5, 1.5], p)
        ys = np.tile(np.linspace(-0.8, 0.8, p) if p > 1 else [0.0], 2) + self.rng.uniform(-self.jitter, self.jitter,
                                                                                           2 * p)
        self.world.build({"agent": np.stack([xs, ys], axis=1),
                          "puck": [0.0, self.rng.uniform(-self.jitter, self.jitter)]})
        self.world.view("thrust")[:] = 0.0
        self.measures.active[:] = True
        self.measures.outcome = np.zeros(self.n_agents)
        self.measures.object_progress = np.zeros(self.n_agents)
        self.measures.energy = np.zeros(self.n_agents)
        self.measures.target_distance = self._to_puck()
        self.score[:] = 0
        self.game_over = False
        self._events = []

    def _to_puck(self) -> np.ndarray:
        table = self.world.table
        return np.linalg.norm(table[self._puck, 0:2] - table[: self.n_agents, 0:2], axis=1)

    def step(self, actions: np.ndarray) -> None:
        self._record("step", actions.copy())
        work, world = self.world.work, self.world
        if self.action_type == "discrete":
            thrust = COMPASS_MOVES[actions]
        else:
            thrust = actions / np.maximum(np.linalg.norm(actions, axis=1), 1.0)[:, None]
        world.view("thrust")[:] = (thrust * self._frame).reshape(-1)
        puck_x = world.pos(self._puck, 0)
        work[world.at("puck_x_before")] = work[puck_x]
        world.step()
        m = self.measures
        m.energy = np.square(thrust).sum(axis=1)
        m.object_progress = self._frame[:, 0] * (work[puck_x] - work[world.at("puck_x_before")])
        m.target_distance = self._to_puck()
        self._events = []
        if abs(work[puck_x]) > self.line:
            scorer = 0 if work[puck_x] > 0 else 1
            self.score[scorer] = 1
            m.outcome = np.where(self.team_of == scorer, 1.0, -1.0)
            self.game_over = True
            self._events = [{"kind": "score", "team": scorer}]

    def observe(self) -> np.ndarray:
        obs = self._obs_matrix @ self.world.work
        obs.clip(self._obs_low, self._obs_high, out=obs)
        return obs.astype(np.float32).reshape(self.n_agents, self.obs_dim)

    def state(self) -> np.ndarray:
        table = self.world.table[: self.n_agents + 1, 0:4]
        scaled = table * np.array([SCALE, SCALE, 1 / VELOCITY_UNIT, 1 / VELOCITY_UNIT])
        state = np.concatenate([scaled.reshape(-1), self.score.astype(np.float64)])
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        x, y, v = HALF_LENGTH * SCALE, HALF_WIDTH * SCALE, VELOCITY_BOUND
        body = ((-x, x), (-y, y), (-v, v), (-v, v))
        return CellLayout([*[Run(f"body_{k}", 4, body) for k in range(self.n_agents + 1)],
                           Run("score", 2, (0, 1))]).bounds()

    def finish(self) -> None:
        self._record("finish")
        self.measures.outcome = np.zeros(self.n_agents)  # a match cut at max_cycles is a draw

    def team_result(self) -> np.ndarray:
        if self.score[0] == self.score[1]:
            return np.array([0.5, 0.5])
        return self.score.astype(np.float64)

    # --- what the layers above see -------------------------------------------------------------
    def render_topdown(self) -> np.ndarray:
        L, W, R = HALF_LENGTH, HALF_WIDTH, WALL_RADIUS
        canvas = Canvas(-L - 2 * R, L + 2 * R, -W - 2 * R, W + 2 * R, size=360, background=(200, 200, 200))
        canvas.rect(-L, -W, L, W, fill=(60, 140, 60))
        for team, x in ((0, self.line), (1, -self.line)):  # the line each team pushes the puck over
            canvas.line(x, -W, x, W, fill=TEAM_COLOURS[team], width_px=3)
        for seat, (x, y) in enumerate(self.world.table[: self.n_agents, 0:2]):
            canvas.circle(x, y, AGENT_RADIUS, fill=TEAM_COLOURS[self.team_of[seat]], outline=(20, 20, 20))
        px, py = self.world.table[self._puck, 0:2]
        canvas.circle(px, py, PUCK_RADIUS, fill=(250, 250, 250), outline=(20, 20, 20))
        return canvas.array()

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        ts, table = timestamp_ns, self.world.table
        lines = [scene.lines([(x, -HALF_WIDTH, 0.01), (x, HALF_WIDTH, 0.01)], scene.team_colour(team), 0.05)
                 for team, x in ((0, self.line), (1, -self.line))]
        out = [scene.entity("field", ts, cubes=[scene.cube(0, 0, -0.05, (2 * HALF_LENGTH, 2 * HALF_WIDTH, 0.1),
                                                           (0.35, 0.65, 0.35, 1.0))], lines=lines)]
        for seat in range(self.n_agents):
            x, y = table[seat, 0:2]
            out.append(scene.entity(f"agent/{seat}", ts, cylinders=[
                scene.disc(x, y, 2 * AGENT_RADIUS, scene.team_colour(int(self.team_of[seat])), height=0.3)]))
        px, py = table[self._puck, 0:2]
        out.append(scene.entity("puck", ts, cylinders=[scene.disc(px, py, 2 * PUCK_RADIUS, (0.97, 0.97, 0.97, 1.0))]))
        return out

    def human_controls(self, seat: int) -> MirroredCompassControls:
        return MirroredCompassControls(self, seat)

    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        teams = [{"scheme": "CL", "reward": "team_progress", "scale": 10, "children": [
            {"agent": f"player_{seat}", "scheme": "IS", "reward": "target", "scale": 1}
            for seat in range(team * players_per_team, (team + 1) * players_per_team)]} for team in range(n_teams)]
        return {"scheme": "CP", "reward": "win_loss", "scale": 100, "children": teams}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64)
        me = obs[:, 1:3] * HALF_LENGTH
        puck = me + obs[:, 5:7] * HALF_LENGTH
        contact = AGENT_RADIUS + PUCK_RADIUS
        behind = puck - (contact + 0.15, 0.0)
        # in front of the puck: go round it on the seat's side first
        side = np.where(me[:, 1] >= puck[:, 1], 1.0, -1.0)
        around = np.stack([puck[:, 0] - contact - 0.3, puck[:, 1] + side * (contact + 0.3)], axis=1)
        in_front = me[:, 0] > puck[:, 0] - contact
        aligned = ~in_front & (np.abs(me[:, 1] - puck[:, 1]) < 0.1)
        waypoint = np.where(in_front[:, None], around, np.where(aligned[:, None], puck + np.array([0.6, 0.0]), behind))
        heading = waypoint - me
        distance = np.linalg.norm(heading, axis=1)
        heading = heading / np.maximum(distance, 1e-9)[:, None] - 0.2 * obs[:, 3:5] * VELOCITY_UNIT
        if action_type == "continuous":
            return np.clip(heading / np.maximum(np.linalg.norm(heading, axis=1), 1.0)[:, None], -1, 1).astype(
                np.float32)
        move = 1 + np.round(np.arctan2(heading[:, 1], heading[:, 0]) / (np.pi / 4)).astype(np.int64) % 8
        return np.where(distance < 0.05, 0, move).astype(np.int64)


RULES = PuckPushRules
