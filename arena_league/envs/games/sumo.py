"""Sumo: two ants push each other off a round ring (MuJoCo physics).

Bansal et al., "Emergent Complexity via Multi-Agent Competition" (ICLR 2018), Sumo; one of the
robot games of the Arena platform (Song et al., AAAI 2020). Id: ``Sumo-2T1P-v1``.

Arena
    A flat floor with a ring of radius ``ring_radius`` (default 2 m) drawn around the origin. The
    ants are Gym-like quadrupeds (``envs.robots.ant``), one per team, in the team colours.

Start
    The ants stand facing each other at ``x = -1`` (team 0, facing ``+x``) and ``x = +1`` (team 1,
    facing ``-x``), positions and headings jittered by up to ``start_jitter`` (m and rad), joint
    angles by up to 0.05 rad around the standing pose; every draw comes from the match seed.

Actions
    Continuous only: eight joint torques in [-1, 1] (hip then ankle of the front-left, back-left,
    back-right and front-right legs; gear 150). ``mj_step(nstep=frame_skip)`` per step (0.05 s).

Observation (``float32``, seat frame: team 1 sees the world turned by 180 degrees, so each seat
starts at ``-x`` facing ``+x``)
    ====== ========== ==========================================================================
    cell   bounds     meaning
    ====== ========== ==========================================================================
    0-42              the robot block (``envs.robots.observation``, with its bounds); the target
                      (cells 39-40) is the opponent
    43     [0, 1]     ring radius / 4
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
    ``active`` (always true), ``alive`` (false once the seat lost), ``target_distance``,
    ``velocity_to_target`` and ``facing_target`` toward the opponent's torso, ``energy`` (mean
    squared torque), ``force`` (the horizontal contact force of the opponent, in body weights),
    ``speed``, ``fallen`` and ``outcome``.

Episode end
    An ant loses as soon as its torso leaves the ring (horizontal distance from the centre above
    ``ring_radius``) or it falls (its torso's up axis tilts past the horizontal); both on the same
    step is a draw. A match cut at ``max_cycles`` (default 400 steps, 20 s) is a draw.
    ``team_result``: 1 win, 0.5 draw, 0 loss. Events: ``{"kind": "out"|"fall", "seat": i}``.

Default social tree
    Root CP ``win_loss`` (scale 100) over the two agent leaves, each IS ``robot_motion`` (scale 1:
    speed toward the opponent minus falling, control and contact costs; annealed by
    ``set_anneal(alpha)``, see ``envs.robots.rewards``).

Heuristic
    Trots (``envs.robots.gait``) at a point just beyond the opponent, radially outward (so it
    pushes the opponent toward the nearest edge), turning back toward the centre as it nears the
    edge of the ring itself.

Game kwargs
    ``ring_radius`` (float in [1.5, 4.0], default 2.0), ``start_jitter`` (float in [0, 0.5], default
    0.2), ``frame_skip`` (int in [1, 20], default 5), ``anneal`` (float in [0, 1], default 1.0);
    declared in ``SumoRules.options`` (``arena-league games Sumo-2T1P-v1`` lists them).

Playing it (``arena-league play``)
    Steer your ant by direction on the arena as drawn (``envs.robots.controls``): ``w`` up, ``a``
    left, ``s`` down, ``d`` right, two letters for a diagonal (``wd``), ``x`` to stand, optionally
    followed by the steps to hold it (``d 10``; default 5); Enter repeats. The scripted trot walks
    that way. The ring's edge is too thin to draw in text, so every ant's distance from its centre
    is written under the picture.

Rendering
    A top-down picture of the arena (``envs.robots.render``): the ring, and each ant's torso in its
    team's colour (darker once fallen) with its legs. ``render_mode="rgb_array"`` returns it;
    ``"human"`` shows it in a window.

Replay scene
    The floor, the ring (a loop) and each ant in 3D (``envs.robots.render.replay_scene``).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from arena_league.envs.options import Option
from arena_league.envs.robots import observation as cells
from arena_league.envs.robots.gait import trot
from arena_league.envs.robots.game import BASE_MEASURES, MatchState, RobotGameRules, StartPose, start_jitter
from arena_league.envs.robots.scene import Affine, SceneLayout

#: Start position of team 0's ant on the x axis (team 1's is mirrored).
START_X = -1.0
#: Distance from the edge at which the heuristic starts turning back toward the centre.
EDGE_MARGIN = 0.8
#: The heuristic aims this far beyond the opponent, radially outward.
PUSH_THROUGH = 0.25
OPPONENT = slice(cells.ROBOT_CELLS + 1, cells.ROBOT_CELLS + 8)


class SumoRules(RobotGameRules):
    """Sumo on a MuJoCo floor; see the module docstring for the manual."""

    name: ClassVar[str] = "Sumo"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1),)
    measures_provided: ClassVar[frozenset[str]] = BASE_MEASURES | {"alive"}
    default_max_cycles: ClassVar[int] = 400
    summary: ClassVar[str] = "Two ants push each other off a round ring (MuJoCo; falling loses too)"
    game_options: ClassVar[tuple[Option, ...]] = (
        Option("ring_radius", float, 2.0, "the ring's radius, in m", low=1.5, high=4.0), start_jitter(0.5))

    @property
    def ring_radius(self) -> float:
        return self.settings["ring_radius"]

    def scene_layout(self) -> SceneLayout:
        return SceneLayout(robots=("ant", "ant"), teams=(0, 1), markings=(("ring", (self.ring_radius,)),))

    def start_pose(self, rng: np.random.Generator) -> StartPose:
        j = self.settings["start_jitter"]
        xy = np.array([[START_X, 0.0], [-START_X, 0.0]]) + rng.uniform(-j, j, (2, 2))
        yaw = np.array([0.0, np.pi]) + rng.uniform(-j, j, 2)
        return StartPose(xy, yaw, np.zeros((0, 2)), np.zeros(0))

    def target_term(self, seat: int) -> Affine:
        return self.terms.robot(1 - seat, "pos")[0:2]

    def game_cell_bounds(self) -> tuple[tuple[float, float, int], ...]:
        return ((0.0, 1.0, 1), *cells.OTHER_ROBOT_BOUNDS)

    def game_cells(self, seat: int) -> Affine:
        return Affine.stack([self.terms.const([self.ring_radius / cells.POSITION_UNIT]),
                             self.other_robot_cells(seat, 1 - seat)])

    def game_complex(self) -> list:
        return [("position", lambda i: self.terms.robot(i, "pos")[0:2])]

    def judge(self, st: MatchState, live: np.ndarray | None) -> None:
        radius = st.absolute[:, self.complex_group["position"]]
        lost = np.greater(radius, self.ring_radius, out=st.flags)
        lost |= st.fallen
        if live is not None:
            lost &= live[:, None]
        if not lost.any():
            return
        out = radius > self.ring_radius
        st.alive &= ~lost
        ended = lost.any(axis=1)
        # the team still standing in the ring wins; both out at once is a draw
        winner = np.where(lost[:, 0] & ~lost[:, 1], 1, np.where(lost[:, 1] & ~lost[:, 0], 0, -1))
        for b in np.flatnonzero(ended):
            st.events[b] += [{"kind": "out" if out[b, i] else "fall", "seat": int(i)} for i in np.flatnonzero(lost[b])]
        self.end_matches(st, ended, winner)

    def view_extent(self) -> tuple[float, float, float, float]:
        r = self.ring_radius + 1.0
        return (-r, r, -r, r)

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
        me = obs[:, cells.POSITION] * cells.POSITION_UNIT
        ring = obs[:, cells.ROBOT_CELLS] * cells.POSITION_UNIT
        to_opponent = obs[:, OPPONENT][:, 0:2] * cells.POSITION_UNIT
        # drive through the opponent radially outward: aim just beyond it, away from the centre
        opponent = me + to_opponent
        outward = opponent / np.maximum(np.linalg.norm(opponent, axis=1, keepdims=True), 1e-9)
        aim = to_opponent + PUSH_THROUGH * outward
        charge = aim / np.maximum(np.linalg.norm(aim, axis=1, keepdims=True), 1e-9)
        radius = np.linalg.norm(me, axis=1, keepdims=True)
        inward = -me / np.maximum(radius, 1e-9)
        edge = np.clip((radius - (ring[:, None] - EDGE_MARGIN)) / (0.5 * EDGE_MARGIN), 0.0, 1.0)
        return trot(obs, (1.0 - edge) * charge + edge * inward)


RULES = SumoRules
