"""YouShallNotPass: a runner ant must cross the field; a blocker ant must stop it (MuJoCo physics).

Bansal et al., "Emergent Complexity via Multi-Agent Competition" (ICLR 2018), You Shall Not Pass;
one of the robot games of the Arena platform (Song et al., AAAI 2020). Id:
``YouShallNotPass-2T1P-v1``. Team 0 (``player_0``) is the runner, team 1 (``player_1``) the
blocker.

Field
    A flat floor with the runner's start line at ``x = -field_length / 2`` and its goal line at
    ``x = +field_length / 2`` (default 5 m apart).

Start
    The runner stands on its start line facing ``+x``; the blocker stands ``blocker_distance``
    (default 2 m) in front of the goal line, facing the runner. Positions and headings are jittered
    by up to ``start_jitter`` (m and rad), joint angles by up to 0.05 rad; all from the match seed.

Actions
    Continuous only: eight joint torques in [-1, 1] (see ``envs.robots.ant``);
    ``mj_step(nstep=frame_skip)`` per step (0.05 s).

Observation (``float32``, seat frame: the blocker sees the world turned by 180 degrees)
    ====== ========== ==========================================================================
    cell   bounds     meaning
    ====== ========== ==========================================================================
    0-42              the robot block (``envs.robots.observation``, with its bounds); the target
                      (cells 39-40) is, for the runner, the nearest point of its goal line, for
                      the blocker, the runner's torso
    43     [-1, 1]    role: +1 runner, -1 blocker
    44     [-20, 20]  the goal line's ``x`` relative to the seat (seat frame) / 4
    45-46  [-20, 20]  opponent position relative to the seat / 4
    47-48  [-4, 4]    opponent velocity / 3
    49-50  [-1, 1]    opponent forward axis (horizontal part)
    51     [-1, 1]    vertical part of the opponent's up axis (negative once it fell)
    ====== ========== ==========================================================================

    ``obs_dim = 52``. Every cell is clipped to its bounds, the observation space (the robot block's
    manual says where they come from).

Global state (``float32``, world frame)
    per ant ``x/4, y/4, z, forward x, forward y, up z, vx/3, vy/3``: ``state_dim = 16``; bounds
    [-10, 10] for positions, [0, 4] m for the height, [-1, 1] for the axes and [-4, 4] for
    velocities, clipped.

Measures
    ``active`` (false once the runner arrived), ``arrived`` (the runner's torso crossed the goal
    line), ``target_distance``, ``velocity_to_target`` and ``facing_target`` toward each seat's
    target (see above), ``energy``, ``force``, ``speed``, ``fallen`` and ``outcome``.

Episode end
    The runner wins as soon as its torso crosses the goal line; the blocker wins as soon as the
    runner falls, and when the match is cut at ``max_cycles`` (default 400 steps, 20 s). A fallen
    blocker plays on (it may get up). ``team_result``: 1 win, 0 loss (no draws). Events:
    ``{"kind": "arrive"|"fall", "seat": 0}``.

Pairs
    Matches are played in pairs (``match_format = "paired"``): two halves from the same seed with
    the roles swapped, each agent running once and blocking once. Each half scores the run
    (``pair_points``: the runner's team scores it, the blocker's team 0). A run that crossed the goal
    line at step ``s`` scores ``1 + (max_cycles - s) / max_cycles``: more than any run that did not
    cross, and more the sooner it crossed (at least 1, below 2). A run that did not cross scores how
    far the runner's torso got from the start line toward the goal line at the end of the half
    (where it fell, or where it stood when the half was cut at ``max_cycles``), rounded to the
    centimetre and as a fraction of the field length, in [0, 1) (a torso behind the start line
    scores 0): runs within a centimetre of each other score the same. The better run wins the pair
    and equal runs draw: each agent's total is its run plus 0 for its blocking half. A pair's
    result, not its halves', is what the league rates.

Default social tree
    Root CP ``win_loss`` (scale 100) over the two agent leaves, each IS ``robot_motion`` (scale 1:
    speed toward the seat's target minus falling, control and contact costs; annealed by
    ``set_anneal(alpha)``, see ``envs.robots.rewards``).

Heuristic
    The runner trots toward the goal line, stepping sideways round the blocker when it is just
    ahead; the blocker trots to a spot just in front of the runner, on the runner's way to the line.

Tuned heuristics
    The same script on another trot, named with its constants (``scripted:heuristic-kp2.25-period0.4``):
    ``kp`` (the trot's joint stiffness, 1 to 4, the heuristic's 2.5) and ``period`` (seconds per
    trot cycle, 0.3 to 0.7, 0.5; see ``envs.robots.gait``). A quicker trot makes a better blocker:
    against the heuristic, ``heuristic-kp2.25-period0.4`` won 97 of 100 matches as the runner and
    stopped the heuristic runner in 38 of 100 (league seed 0; the heuristic's own blocker stops it in
    3), and 192 and 42 of 200 under league seed 1.

Game kwargs
    ``field_length`` (float in [3, 10], default 5.0), ``blocker_distance`` (float in [0.5, 4],
    default 2.0; at most the field length), ``start_jitter`` (float in [0, 0.5], default 0.2),
    ``frame_skip`` (int in [1, 20], default 5), ``anneal`` (float in [0, 1], default 1.0);
    declared in ``YouShallNotPassRules.options`` (``arena-league games YouShallNotPass-2T1P-v1``
    lists them).

Playing it (``arena-league play``)
    Steer your ant by direction on the arena as drawn (``envs.robots.controls``): ``w`` up, ``a``
    left, ``s`` down, ``d`` right, two letters for a diagonal (``wd``), ``x`` to stand, optionally
    followed by the steps to hold it (``d 10``; default 5); Enter repeats. The scripted trot walks
    that way.

Rendering
    A top-down picture of the arena (``envs.robots.render``): the start and goal lines, and each
    ant's torso in its team's colour (darker once fallen) with its legs. ``render_mode="rgb_array"``
    returns it; ``"human"`` shows it in a window.

Replay scene
    The floor, the start and goal lines and each ant in 3D (``envs.robots.render.replay_scene``).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from arena_league.envs.options import Option
from arena_league.envs.robots import observation as cells
from arena_league.envs.robots.field import FIELD_LENGTH, LinedField, avoid
from arena_league.envs.robots.gait import GAIT_PERIOD, KP, trot
from arena_league.envs.robots.game import BASE_MEASURES, MatchState, StartPose, start_jitter
from arena_league.envs.robots.scene import Affine, Readout

RUNNER, BLOCKER = 0, 1
ROLE = cells.ROBOT_CELLS
GOAL_LINE = cells.ROBOT_CELLS + 1
OPPONENT = slice(cells.ROBOT_CELLS + 2, cells.ROBOT_CELLS + 9)
#: The blocker aims this far in front of the runner, on its way to the goal line.
INTERCEPT_LEAD = 0.7
BLOCKER_DISTANCE = Option("blocker_distance", float, 2.0, "distance of the blocker's start in front of the "
                          "runner's goal line, in m; at most field_length", low=0.5, high=4.0)


class YouShallNotPassRules(LinedField):
    """YouShallNotPass on a MuJoCo floor; see the module docstring for the manual."""

    name: ClassVar[str] = "YouShallNotPass"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1),)
    measures_provided: ClassVar[frozenset[str]] = BASE_MEASURES | {"arrived"}
    default_max_cycles: ClassVar[int] = 400
    match_format: ClassVar[str] = "paired"
    summary: ClassVar[str] = "A runner ant must cross the field, a blocker ant must stop it (MuJoCo)"
    game_options: ClassVar[tuple[Option, ...]] = (FIELD_LENGTH, BLOCKER_DISTANCE, start_jitter(0.5))
    heuristic_options: ClassVar[dict[str, tuple[float, float]]] = {"kp": (1.0, 4.0), "period": (0.3, 0.7)}
    heuristic_options_meaning: ClassVar[str] = (
        f"kp K: the trot's joint stiffness (the heuristic's {KP}); period P: seconds per trot cycle (the heuristic's "
        f"{GAIT_PERIOD})")

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "continuous", **options: Any) -> None:
        super().__init__(n_teams, players_per_team, action_type, **options)
        distance, length = self.settings["blocker_distance"], self.settings["field_length"]
        if distance > length:
            raise ValueError(f"YouShallNotPass option blocker_distance must be a number in [{BLOCKER_DISTANCE.low}, "
                             f"field_length = {length}] (default {BLOCKER_DISTANCE.default_words()}: "
                             f"{BLOCKER_DISTANCE.meaning}), not {distance!r}")

    def start_pose(self, rng: np.random.Generator) -> StartPose:
        j = self.settings["start_jitter"]
        h = self.half_length
        xy = np.array([[-h, 0.0], [h - self.settings["blocker_distance"], 0.0]]) + rng.uniform(-j, j, (2, 2))
        yaw = np.array([0.0, np.pi]) + rng.uniform(-j, j, 2)
        return StartPose(xy, yaw, np.zeros((0, 2)), np.zeros(0))

    def target_term(self, seat: int) -> Affine:
        t = self.terms
        if seat == RUNNER:
            return Affine.stack([t.const([self.half_length]), t.robot(RUNNER, "pos")[1]])
        return t.robot(RUNNER, "pos")[0:2]

    def game_cell_bounds(self) -> tuple[tuple[float, float, int], ...]:
        return ((-1.0, 1.0, 1), (-2 * cells.FIELD_LIMIT, 2 * cells.FIELD_LIMIT, 1), *cells.OTHER_ROBOT_BOUNDS)

    def game_cells(self, seat: int) -> Affine:
        t = self.terms
        to_line = Affine.stack([t.const([self.half_length]) - t.robot(seat, "pos")[0], t.zeros(1)])
        return Affine.stack([t.const([1.0 if seat == RUNNER else -1.0]),
                             self._seat_vector(seat, to_line)[0] * (1.0 / cells.POSITION_UNIT),
                             self.other_robot_cells(seat, 1 - seat)])

    def game_readout(self, readout: Readout) -> None:
        t = self.terms
        readout.add("remaining", t.const([self.half_length]) - t.robot(RUNNER, "pos")[0])

    def allocate_memory(self, n_slots: int) -> dict[str, np.ndarray]:
        # what pair_points reads of the run: the step it crossed the goal line at (0: it did not)
        # and how far its torso was from its start line, in m, when the match ended
        return {"crossed_at": np.zeros(n_slots, dtype=np.int64), "run_length": np.zeros(n_slots)}

    def on_start(self, st: MatchState, slot: int) -> None:
        st.memory["crossed_at"][slot] = 0
        st.memory["run_length"][slot] = 0.0

    def _run_length(self, st: MatchState) -> np.ndarray:
        """How far each match's runner torso is from its start line toward its goal line, in m."""
        return self.settings["field_length"] - st.lin[:, self._slices["remaining"]][:, 0]

    def judge(self, st: MatchState, live: np.ndarray | None) -> None:
        crossed = st.lin[:, self._slices["remaining"]][:, 0] <= 0.0
        fell = st.fallen[:, RUNNER] & ~crossed
        ended = crossed | fell
        if live is not None:
            ended &= live
        if not ended.any():
            return
        crossed &= ended
        first = ended & ~st.done  # the run's end is kept once, when the match ends
        st.memory["run_length"][first] = self._run_length(st)[first]
        st.memory["crossed_at"][first & crossed] = st.steps[first & crossed]
        st.arrived[:, RUNNER] |= crossed
        st.active[:, RUNNER] &= ~crossed
        st.any_inactive = True
        for b in np.flatnonzero(ended):
            st.events[b].append({"kind": "arrive" if crossed[b] else "fall", "seat": RUNNER})
        self.end_matches(st, ended, np.where(crossed, RUNNER, BLOCKER))

    def cut(self, st: MatchState, slot: int) -> None:
        # the runner did not get through in time: the blocker wins
        st.memory["run_length"][slot] = self._run_length(st)[slot]
        self.end_match(st, slot, BLOCKER)

    def match_pair_points(self, st: MatchState, slot: int, max_cycles: int) -> np.ndarray:
        """The runner's team scores the run, the blocker's team 0 (the manual's "Pairs")."""
        points = np.zeros(self.n_teams)
        points[RUNNER] = run_score(int(st.memory["crossed_at"][slot]), float(st.memory["run_length"][slot]),
                                   self.settings["field_length"], max_cycles)
        return points

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str, *, kp: float = KP, period: float = GAIT_PERIOD) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64).reshape(-1, np.shape(obs)[-1])
        runner = obs[:, ROLE] > 0
        opponent = obs[:, OPPONENT]
        # the runner runs toward +x in its frame, round the blocker
        forward = np.zeros((len(obs), 2))
        forward[:, 0] = 1.0
        run = forward + avoid(opponent, forward, strength=1.5)
        # the blocker heads for a spot just in front of the runner, toward the runner's goal line
        runner_at = opponent[:, 0:2] * cells.POSITION_UNIT
        line_x = obs[:, GOAL_LINE] * cells.POSITION_UNIT
        toward_line = np.stack([line_x - runner_at[:, 0], np.zeros(len(obs))], axis=1)
        toward_line /= np.maximum(np.linalg.norm(toward_line, axis=1, keepdims=True), 1e-9)
        spot = runner_at + INTERCEPT_LEAD * toward_line
        block = spot / np.maximum(np.linalg.norm(spot, axis=1, keepdims=True), 0.3)
        return trot(obs, np.where(runner[:, None], run, block), kp=kp, period=period)


def run_score(crossed_at: int, run_length: float, field_length: float, max_cycles: int) -> float:
    """A run's score (the manual's "Pairs"): ``1 + (max_cycles - crossed_at) / max_cycles`` for a
    runner that crossed the goal line at step ``crossed_at`` (> 0); otherwise ``run_length`` (m from
    the start line) rounded to the centimetre, as a fraction of ``field_length`` in [0, 1)."""
    if crossed_at > 0:
        return 1.0 + (max_cycles - crossed_at) / max_cycles
    centimetres = min(max(round(run_length * 100.0), 0), int(np.ceil(field_length * 100.0)) - 1)
    return centimetres / (field_length * 100.0)


RULES = YouShallNotPassRules
