"""RunToGoal: two ants race, in opposite directions, to the far side of the field (MuJoCo physics).

Bansal et al., "Emergent Complexity via Multi-Agent Competition" (ICLR 2018), Run to Goal; one of
the robot games of the Arena platform (Song et al., AAAI 2020). Id: ``RunToGoal-2T1P-v1``.

Field
    A flat floor with two goal lines across it, at ``x = -field_length / 2`` and
    ``x = +field_length / 2`` (default 5 m apart). Team 0's ant starts on the line at ``-x`` and
    runs for the line at ``+x``; team 1's the other way, so the two meet in the middle.

Start
    Each ant stands on its start line facing the far one, position and heading jittered by up to
    ``start_jitter`` (m and rad), joint angles by up to 0.05 rad; every draw from the match seed.

Actions
    Continuous only: eight joint torques in [-1, 1] (see ``envs.robots.ant``);
    ``mj_step(nstep=frame_skip)`` per step (0.05 s).

Observation (``float32``, seat frame: team 1 sees the world turned by 180 degrees, so each seat
runs toward ``+x``)
    ====== ========== ==========================================================================
    cell   bounds     meaning
    ====== ========== ==========================================================================
    0-42              the robot block (``envs.robots.observation``, with its bounds); the target
                      (cells 39-40) is the nearest point of the seat's goal line: ``(goal - x, 0)``
    43     [0, 1.25]  half the field length / 4 (the goal line's ``x`` in the seat frame)
    44-45  [-20, 20]  opponent position relative to the seat / 4
    46-47  [-4, 4]    opponent velocity / 3
    48-49  [-1, 1]    opponent forward axis (horizontal part)
    50     [-1, 1]    vertical part of the opponent's up axis (negative once it fell)
    ====== ========== ==========================================================================

    ``obs_dim = 51``. Every cell is clipped to its bounds, the observation space (the robot block's
    manual says where they come from).

Global state (``float32``, world frame)
    per ant ``x/4, y/4, z, forward x, forward y, up z, vx/3, vy/3``: ``state_dim = 16``; bounds
    [-10, 10] for positions, [0, 4] m for the height, [-1, 1] for the axes and [-4, 4] for
    velocities, clipped.

Measures
    ``active`` (false once the seat arrived), ``arrived`` (its torso crossed its goal line),
    ``target_distance``, ``velocity_to_target`` and ``facing_target`` toward its goal line
    (distance to the line; speed across it), ``energy``, ``force``, ``speed``, ``fallen`` and
    ``outcome``.

Episode end
    The first ant whose torso crosses its goal line wins and ends the match; both on the same step
    is a draw. A fallen ant may still get up; a match cut at ``max_cycles`` (default 400 steps,
    20 s) is a draw. ``team_result``: 1 win, 0.5 draw, 0 loss. Events: ``{"kind": "arrive",
    "seat": i}``.

Default social tree
    Root CP ``win_loss`` (scale 100) over the two agent leaves, each IS ``robot_motion`` (scale 1:
    speed toward the goal line minus falling, control and contact costs; annealed by
    ``set_anneal(alpha)``, see ``envs.robots.rewards``).

Heuristic
    Trots toward its goal line, stepping sideways round the opponent when it is just ahead.

Game kwargs
    ``field_length`` (float in [3, 10], default 5.0), ``start_jitter`` (float in [0, 0.5], default
    0.2), ``frame_skip`` (int in [1, 20], default 5), ``anneal`` (float in [0, 1], default 1.0);
    declared in ``RunToGoalRules.options`` (``arena-league games RunToGoal-2T1P-v1`` lists them).

Playing it (``arena-league play``)
    Steer your ant by direction on the arena as drawn (``envs.robots.controls``): ``w`` up, ``a``
    left, ``s`` down, ``d`` right, two letters for a diagonal (``wd``), ``x`` to stand, optionally
    followed by the steps to hold it (``d 10``; default 5); Enter repeats. The scripted trot walks
    that way.

Rendering
    A top-down picture of the arena (``envs.robots.render``): the goal lines, and each ant's torso
    in its team's colour (darker once fallen) with its legs. ``render_mode="rgb_array"`` returns
    it; ``"human"`` shows it in a window.

Replay scene
    The floor, the two goal lines and each ant in 3D (``envs.robots.render.replay_scene``).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from arena_league.envs.options import Option
from arena_league.envs.robots import observation as cells
from arena_league.envs.robots.field import FIELD_LENGTH, LinedField, avoid
from arena_league.envs.robots.gait import trot
from arena_league.envs.robots.game import BASE_MEASURES, MatchState, StartPose, start_jitter
from arena_league.envs.robots.scene import Affine, Readout

OPPONENT = slice(cells.ROBOT_CELLS + 1, cells.ROBOT_CELLS + 8)
class RunToGoalRules(LinedField):
    """RunToGoal on a MuJoCo floor; see the module docstring for the manual."""

    name: ClassVar[str] = "RunToGoal"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1),)
    measures_provided: ClassVar[frozenset[str]] = BASE_MEASURES | {"arrived"}
    default_max_cycles: ClassVar[int] = 400
    summary: ClassVar[str] = "Two ants race in opposite directions to the far side (MuJoCo)"
    game_options: ClassVar[tuple[Option, ...]] = (FIELD_LENGTH, start_jitter(0.5))

    def goal_x(self, seat: int) -> float:
        """World ``x`` of the seat's goal line."""
        return self.half_length if self.team_of[seat] == 0 else -self.half_length

    def start_pose(self, rng: np.random.Generator) -> StartPose:
        j = self.settings["start_jitter"]
        h = self.half_length
        xy = np.array([[-h, 0.0], [h, 0.0]]) + rng.uniform(-j, j, (2, 2))
        yaw = np.array([0.0, np.pi]) + rng.uniform(-j, j, 2)
        return StartPose(xy, yaw, np.zeros((0, 2)), np.zeros(0))

    def target_term(self, seat: int) -> Affine:
        # the nearest point of the goal line: the goal's x, the seat's own y
        y = self.terms.robot(seat, "pos")[1]
        return Affine.stack([self.terms.const([self.goal_x(seat)]), y])

    def game_cell_bounds(self) -> tuple[tuple[float, float, int], ...]:
        return ((0.0, 1.25, 1), *cells.OTHER_ROBOT_BOUNDS)

    def game_cells(self, seat: int) -> Affine:
        return Affine.stack([self.terms.const([self.half_length / cells.POSITION_UNIT]),
                             self.other_robot_cells(seat, 1 - seat)])

    def game_readout(self, readout: Readout) -> None:
        # distance still to run, along the seat's running direction (<= 0: arrived)
        readout.add("remaining", Affine.stack([
            (self.terms.const([self.goal_x(i)]) - self.terms.robot(i, "pos")[0]) * (1.0 if self.team_of[i] == 0 else -1.0)
            for i in range(2)]))

    def judge(self, st: MatchState, live: np.ndarray | None) -> None:
        crossed = np.less_equal(st.lin[:, self._slices["remaining"]], 0.0, out=st.flags)
        if live is not None:
            crossed &= live[:, None]
        if not crossed.any():
            return
        st.arrived |= crossed
        st.active &= ~crossed
        st.any_inactive = True
        ended = crossed.any(axis=1)
        winner = np.where(crossed[:, 0] & ~crossed[:, 1], 0, np.where(crossed[:, 1] & ~crossed[:, 0], 1, -1))
        for b in np.flatnonzero(ended):
            st.events[b] += [{"kind": "arrive", "seat": int(i)} for i in np.flatnonzero(crossed[b])]
        self.end_matches(st, ended, winner)

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
        forward = np.zeros((len(obs), 2))
        forward[:, 0] = 1.0  # every seat runs toward +x in its own frame
        return trot(obs, forward + avoid(obs[:, OPPONENT], forward))


RULES = RunToGoalRules
