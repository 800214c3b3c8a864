"""PushBox: two teams of two ants each push their own box onto a shared target (MuJoCo physics).

Arena's ArenaCrawlerPush, the social-tree example of Song et al., "Arena: A General Evaluation
Platform and Building Toolkit for Multi-Agent Intelligence" (AAAI 2020): individual motor skill
(IS), teammates sharing their box's progress (CL), and teams competing for the order of arrival
(CP). Id: ``PushBox-2T2P-v1``. The ants are those of Bansal et al. (ICLR 2018), see
``envs.robots.ant``.

Field
    A flat floor with a round target of radius ``target_radius`` (default 0.6 m) at the origin.
    Each team has a box (a cube of half-size 0.3 m, mass 1 kg, sliding friction 0.6: one ant can just slide it, two
    push it steadily) in its
    colour: team 0's starts ``box_distance`` (default 2 m) from the target on the ``-x`` side,
    team 1's as far on the ``+x`` side.

Start
    Each team's ants stand 1.4 m behind their box (seen from the target), 1.1 m apart, facing the
    target; ant and box positions and headings are jittered by up to ``start_jitter`` (m and rad),
    joint angles by up to 0.05 rad; every draw comes from the match seed.

Actions
    Continuous only: eight joint torques in [-1, 1] per ant (see ``envs.robots.ant``);
    ``mj_step(nstep=frame_skip)`` per step (0.05 s).

Observation (``float32``, seat frame: team 1 sees the world turned by 180 degrees, so every seat
starts on the ``-x`` side facing the target)
    ====== ========== ==========================================================================
    cell   bounds     meaning
    ====== ========== ==========================================================================
    0-42              the robot block (``envs.robots.observation``, with its bounds); the target
                      (cells 39-40) is the team's own box: its centre relative to the seat
    43     [0, 1]     target radius / 4
    44-45  [-10, 10]  the target's centre relative to the seat / 4
    46-47  [-4, 4]    own box velocity / 3
    48-49  [-10, 10]  own box to the target: target centre minus box centre / 4
    50-51  [-20, 20]  the other team's box relative to the seat / 4
    52-58             the teammate: position relative to the seat / 4 (2, [-20, 20]), velocity / 3
                      (2, [-4, 4]), forward axis (2, [-1, 1]), vertical part of its up axis (1,
                      [-1, 1])
    59-72             the two opponents, in seat order, the same seven cells each
    ====== ========== ==========================================================================

    ``obs_dim = 73``. Every cell is clipped to its bounds, the observation space (the robot block's
    manual says where they come from; a box, like an ant, is taken as within 40 m of the target).

Global state (``float32``, world frame)
    per ant ``x/4, y/4, z, forward x, forward y, up z, vx/3, vy/3``, then per box ``x/4, y/4,
    vx/3, vy/3``: ``state_dim = 40``; bounds [-10, 10] for positions, [0, 4] m for the height,
    [-1, 1] for the axes and [-4, 4] for velocities, clipped.

Measures
    ``active`` and ``arrived`` (a team's two seats arrive together, when its box does),
    ``target_distance``, ``velocity_to_target`` and ``facing_target`` toward the seat's own box,
    ``object_progress`` (how much nearer the target the team's box came this step, m),
    ``energy``, ``force``, ``speed``, ``fallen`` and ``outcome``.

Episode end
    A box arrives when its centre is within ``target_radius`` of the target's; the first team whose
    box arrives wins and ends the match (both on the same step: a draw). A match cut at
    ``max_cycles`` (default 500 steps, 25 s) goes to the team whose box is nearer the target (a
    draw within 1 cm). ``team_result``: 1 win, 0.5 draw, 0 loss. Events: ``{"kind": "arrive",
    "team": t}``.

Default social tree (the paper's example)
    Root CP ``ranking`` (``order: depart``, scale 100: the first box on the target ranks first)
    over one CL ``team_progress`` node per team (scale 10: the team's box progress, shared by both
    ants), whose agent leaves are IS ``robot_motion`` (scale 1: each ant's speed toward its box
    minus falling, control and contact costs; annealed by ``set_anneal(alpha)``, see
    ``envs.robots.rewards``).

Heuristic
    Each ant trots to a spot behind its box on the line from the target through the box (round the
    box when it stands in the way), on its side of its teammate, then pushes the box toward the
    target, steering to keep behind the box's centre.

Tuned heuristics
    The same script with other constants, named with them (``scripted:heuristic-lane0.6-side0.3``):
    ``gap`` (the pushing spot's distance behind the box's face, 0.1 to 1.0 m, the heuristic's
    0.45), ``lane`` (how far from its push line an ant still pushes, 0.1 to 1.5 m, 0.35),
    ``side`` (how far to its own side of the line each ant pushes, 0 to 0.5 m, 0.18), and the
    trot's ``kp`` (joint stiffness, 1 to 4, 2.5) and ``period`` (seconds per cycle, 0.3 to 0.7,
    0.5; see ``envs.robots.gait``). An ant that keeps pushing when the box has turned a little
    loses less time than one that walks back to its spot: ``heuristic-lane0.6-side0.3`` beat the
    heuristic in 69 to 76% of matches (200 to 400 matches under each of three league seeds). A
    softer, quicker trot pushes faster still: ``heuristic-kp1.75-lane0.6-period0.4-side0.3`` beat
    the heuristic in 182 of 200 matches and ``heuristic-lane1`` in 142 of 200 (league seed 11).

Game kwargs
    ``target_radius`` (float in [0.3, 1.2], default 0.6), ``box_distance`` (float in [1.5, 4.0],
    default 2.0), ``start_jitter`` (float in [0, 0.4], default 0.2), ``frame_skip`` (int in
    [1, 20], default 5), ``anneal`` (float in [0, 1], default 1.0);
    declared in ``PushBoxRules.options`` (``arena-league games PushBox-2T2P-v1`` lists them).

Playing it (``arena-league play``)
    Steer your ant by direction on the arena as drawn (``envs.robots.controls``): ``w`` up, ``a``
    left, ``s`` down, ``d`` right, two letters for a diagonal (``wd``), ``x`` to stand, optionally
    followed by the steps to hold it (``d 10``; default 5); Enter repeats. The scripted trot walks
    that way; push your team's box onto the target.

Rendering
    A top-down picture of the arena (``envs.robots.render``): the target disc, both boxes in their
    teams' colours, and each ant's torso in its team's colour (darker once fallen) with its legs.
    ``render_mode="rgb_array"`` returns it; ``"human"`` shows it in a window.

Replay scene
    The floor, the target disc, both boxes (``box/<b>``, in their poses) and each ant in 3D
    (``envs.robots.render.replay_scene``).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from arena_league.envs.options import Option
from arena_league.envs.robots import observation as cells
from arena_league.envs.robots.gait import GAIT_PERIOD, KP, trot
from arena_league.envs.robots.game import BASE_MEASURES, MatchState, RobotGameRules, StartPose, start_jitter
from arena_league.envs.robots.scene import Affine, SceneLayout

BOX_HALF = 0.3
BOX_MASS = 1.0
BOX_FRICTION = 0.6
#: The ants start this far behind their box, this far apart.
ANT_BEHIND = 1.4
ANT_SPREAD = 1.1
#: Cells of the game block.
TARGET_RADIUS = cells.ROBOT_CELLS
TARGET = slice(cells.ROBOT_CELLS + 1, cells.ROBOT_CELLS + 3)
BOX_VELOCITY = slice(cells.ROBOT_CELLS + 3, cells.ROBOT_CELLS + 5)
BOX_TO_TARGET = slice(cells.ROBOT_CELLS + 5, cells.ROBOT_CELLS + 7)
OTHER_BOX = slice(cells.ROBOT_CELLS + 7, cells.ROBOT_CELLS + 9)
TEAMMATE = slice(cells.ROBOT_CELLS + 9, cells.ROBOT_CELLS + 16)
#: The heuristic's pushing spot: this far behind the box's face, and each ant this far to its
#: side of the push line.
PUSH_GAP = 0.45
PUSH_SIDE = 0.18
#: Within this many metres of the push line (and behind the box) an ant pushes.
PUSH_LANE = 0.35


class PushBoxRules(RobotGameRules):
    """PushBox on a MuJoCo floor; see the module docstring for the manual."""

    name: ClassVar[str] = "PushBox"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 2),)
    measures_provided: ClassVar[frozenset[str]] = BASE_MEASURES | {"arrived", "object_progress"}
    default_max_cycles: ClassVar[int] = 500
    summary: ClassVar[str] = "Two teams of two ants race to push their own box onto a shared target (MuJoCo)"
    game_options: ClassVar[tuple[Option, ...]] = (
        Option("target_radius", float, 0.6, "the target's radius, in m", low=0.3, high=1.2),
        Option("box_distance", float, 2.0, "distance from each box's start to the target, in m", low=1.5, high=4.0),
        start_jitter(0.4))
    heuristic_options: ClassVar[dict[str, tuple[float, float]]] = {"gap": (0.1, 1.0), "kp": (1.0, 4.0),
                                                                   "lane": (0.1, 1.5), "period": (0.3, 0.7),
                                                                   "side": (0.0, 0.5)}
    heuristic_options_meaning: ClassVar[str] = (
        f"gap G: each ant's pushing spot is G m behind the box's face (the heuristic's {PUSH_GAP}); lane L: an ant "
        f"pushes within L m of its push line (the heuristic's {PUSH_LANE}); side S: each ant pushes S m to its own "
        f"side of the line (the heuristic's {PUSH_SIDE}); kp K: the trot's joint stiffness (the heuristic's {KP}); "
        f"period P: seconds per trot cycle (the heuristic's {GAIT_PERIOD})")

    @property
    def target_radius(self) -> float:
        return self.settings["target_radius"]

    def scene_layout(self) -> SceneLayout:
        return SceneLayout(robots=("ant",) * 4, teams=(0, 0, 1, 1), box_teams=(0, 1), box_half=BOX_HALF,
                           box_mass=BOX_MASS, box_friction=BOX_FRICTION,
                           markings=(("disc", (0.0, 0.0, self.target_radius)),))

    def start_pose(self, rng: np.random.Generator) -> StartPose:
        j = self.settings["start_jitter"]
        d = self.settings["box_distance"]
        box = np.array([[-d, 0.0], [d, 0.0]]) + rng.uniform(-j, j, (2, 2))
        box_yaw = rng.uniform(-j, j, 2)
        ants = np.array([[-d - ANT_BEHIND, ANT_SPREAD / 2], [-d - ANT_BEHIND, -ANT_SPREAD / 2],
                         [d + ANT_BEHIND, -ANT_SPREAD / 2], [d + ANT_BEHIND, ANT_SPREAD / 2]])
        ants = ants + rng.uniform(-j, j, (4, 2))
        yaw = np.array([0.0, 0.0, np.pi, np.pi]) + rng.uniform(-j, j, 4)
        return StartPose(ants, yaw, box, box_yaw)

    def box_of(self, seat: int) -> int:
        return int(self.team_of[seat])

    def target_term(self, seat: int) -> Affine:
        return self.terms.box(self.box_of(seat), "pos")[0:2]

    def game_cell_bounds(self) -> tuple[tuple[float, float, int], ...]:
        field, velocity = cells.FIELD_LIMIT, cells.VELOCITY_LIMIT
        return ((0.0, 1.0, 1), (-field, field, 2), (-velocity, velocity, 2), (-field, field, 2),
                (-2 * field, 2 * field, 2), *cells.OTHER_ROBOT_BOUNDS * (self.n_agents - 1))

    def game_cells(self, seat: int) -> Affine:
        t = self.terms
        unit = 1.0 / cells.POSITION_UNIT
        me = t.robot(seat, "pos")[0:2]
        box = t.box(self.box_of(seat), "pos")[0:2]
        other_box = t.box(1 - self.box_of(seat), "pos")[0:2]
        target = t.zeros(2)
        mates = [i for i in range(self.n_agents) if i != seat and self.team_of[i] == self.team_of[seat]]
        opponents = [i for i in range(self.n_agents) if self.team_of[i] != self.team_of[seat]]
        return Affine.stack([
            t.const([self.target_radius * unit]),
            self._seat_vector(seat, target - me) * unit,
            self._seat_vector(seat, t.box(self.box_of(seat), "linvel")[0:2]) * (1.0 / cells.VELOCITY_UNIT),
            self._seat_vector(seat, target - box) * unit,
            self._seat_vector(seat, other_box - me) * unit,
            *[self.other_robot_cells(seat, other) for other in mates + opponents],
        ])

    def game_complex(self) -> list:
        # the way from the seat's box to the target: its length is the box's distance to go
        return [("box_to_target", lambda i: -self.terms.box(self.box_of(i), "pos")[0:2])]

    def allocate_memory(self, n_slots: int) -> dict[str, np.ndarray]:
        return {"box_distance": np.zeros((n_slots, self.n_agents))}

    def on_start(self, st: MatchState, slot: int) -> None:
        st.memory["box_distance"][slot] = st.absolute[slot, self.complex_group["box_to_target"]]

    def judge(self, st: MatchState, live: np.ndarray | None) -> None:
        distance = st.absolute[:, self.complex_group["box_to_target"]]
        before = st.memory["box_distance"]
        np.subtract(before, distance, out=st.object_progress)
        before[...] = distance
        arrived = np.less_equal(distance, self.target_radius, out=st.flags)
        if live is not None:
            st.object_progress *= live[:, None]
            arrived &= live[:, None]
        if not arrived.any():
            return
        st.arrived |= arrived
        st.active &= ~arrived
        st.any_inactive = True
        team_in = arrived[:, ::self.players_per_team]  # [B, team]: both seats of a team arrive together
        ended = team_in.any(axis=1)
        winner = np.where(team_in[:, 0] & ~team_in[:, 1], 0, np.where(team_in[:, 1] & ~team_in[:, 0], 1, -1))
        for b in np.flatnonzero(ended):
            st.events[b] += [{"kind": "arrive", "team": int(t)} for t in np.flatnonzero(team_in[b])]
        self.end_matches(st, ended, winner)

    def cut(self, st: MatchState, slot: int) -> None:
        # at the time limit the box nearer the target wins (within 1 cm: a draw)
        left = st.absolute[slot, self.complex_group["box_to_target"], :: self.players_per_team]
        winner = -1 if abs(left[0] - left[1]) < 0.01 else int(np.argmin(left))
        self.end_match(st, slot, winner)

    def view_extent(self) -> tuple[float, float, float, float]:
        h = self.settings["box_distance"] + ANT_BEHIND + 1.2
        return (-h, h, -h, h)

    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        teams = []
        for team in range(n_teams):
            seats = range(team * players_per_team, (team + 1) * players_per_team)
            teams.append({"scheme": "CL", "reward": "team_progress", "scale": 10, "children": [
                {"agent": f"player_{seat}", "scheme": "IS", "reward": "robot_motion", "scale": 1} for seat in seats]})
        return {"scheme": "CP", "reward": "ranking", "scale": 100, "params": {"order": "depart"}, "children": teams}

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str, *, gap: float = PUSH_GAP, lane: float = PUSH_LANE,
                  side: float = PUSH_SIDE, kp: float = KP, period: float = GAIT_PERIOD) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
        unit = cells.POSITION_UNIT
        box = obs[:, cells.TARGET] * unit  # own box, relative to the ant
        box_to_target = obs[:, BOX_TO_TARGET] * unit
        push = box_to_target / np.maximum(np.linalg.norm(box_to_target, axis=1, keepdims=True), 1e-9)
        side_axis = np.stack([-push[:, 1], push[:, 0]], axis=1)
        # each ant pushes a little to its own side of the push line, the side away from its teammate
        mate = obs[:, TEAMMATE][:, 0:2] * unit
        my_side = np.where(np.einsum("ij,ij->i", -mate, side_axis) >= 0.0, 1.0, -1.0)
        me_from_box = -box
        along = np.einsum("ij,ij->i", me_from_box, push)  # < 0: behind the box
        lateral = np.einsum("ij,ij->i", me_from_box, side_axis) - my_side * side
        spot = box - push * (BOX_HALF + gap) + (my_side * side)[:, None] * side_axis
        # pushing: behind the box and near the push line; steer back onto the line
        pushing = (along < -BOX_HALF) & (np.abs(lateral) < lane)
        drive = push - (1.5 * lateral)[:, None] * side_axis
        # otherwise go to the spot; from beside or in front of the box, first round it on the
        # side the ant is on
        around = box + side_axis * (np.where(lateral + my_side * side >= 0.0, 1.0, -1.0)
                                    * (BOX_HALF + 0.55))[:, None] - push * (BOX_HALF + 0.2)
        in_way = along > -BOX_HALF - 0.1
        walk = np.where(in_way[:, None], around, spot)
        walk = walk / np.maximum(np.linalg.norm(walk, axis=1, keepdims=True), 0.25)
        return trot(obs, np.where(pushing[:, None], drive, walk), kp=kp, period=period)


RULES = PushBoxRules
