"""FightForFood: agents shove each other off a limited supply of food pellets (pymunk physics).

One of the competitive games of the Arena platform (Song et al., "Arena: A General Evaluation
Platform and Building Toolkit for Multi-Agent Intelligence", AAAI 2020): agents fight for limited
food; when the food is exhausted, the episode ends. Ids: ``FightForFood-2T1P-v1``,
``FightForFood-2T2P-v1``, ``FightForFood-4T1P-v1``.

Pen
    A walled square, ``x`` and ``y`` in [-3, 3] (inner faces of the walls). Food pellets are
    points of radius 0.1 lying on the floor: agents pass over them, and nothing else touches them.

Bodies and physics
    Agents are circles of radius 0.25 and mass 1 that do not rotate. Collisions between agents and
    with the walls are solved by pymunk (Chipmunk2D), one ``space.step`` of ``dt = 0.1`` per env
    step, with little rebound (restitution 0.25 between agents, 0.4 against a wall; friction 0.3):
    a body that runs into a rival shoves it along. Every body loses 60 % of its velocity per second
    (space damping 0.4); an agent's thrust of at most 6 is opposed by a drag of ``3.1 * velocity``,
    which caps its speed at about 1.5 units/s. Two agents pushing head on at full thrust stand still;
    one that comes at a rival from the side moves it off its line.

Symmetry and the start
    Every match has the layout's rotational symmetry, so that no team starts nearer the food than
    another: the ``n_teams`` teams are turned about the centre by ``360 / n_teams`` degrees from each
    other (two teams face each other across the pen; four sit one on each side). Team 0 stands on
    the ``x < 0`` side: one agent at ``(-2.2, 0)`` (1P) or two at ``(-2.2, 0.8)`` and ``(-2.2,
    -0.8)`` (2P), each jittered by up to ``start_jitter`` in both coordinates; team ``t`` stands on
    those spots turned by ``t * 360 / n_teams`` degrees counter-clockwise (team ``t``'s seat ``k``
    on the image of team 0's seat ``k``). The ``food`` pellets come in ``food / n_teams`` groups: a
    point drawn uniformly with ``x`` and ``y`` in [-2.6, 2.6] and its images under the same turns,
    redrawn until every pellet lies at least 0.6 from every other and 0.8 from every start spot.
    Every draw comes from the match seed.

Seat frame
    Each seat sees the pen, and acts, in its own frame: the world turned back by its team's turn
    (``-t * 360 / n_teams`` degrees; the world frame for team 0). In its own frame every seat starts
    on the ``x < 0`` side, so one policy can play any seat, and a seat of team ``t`` sees in the
    turned match exactly what the seat of team 0 it stands for sees (pellets included: the pellet
    slots of each group are listed starting from the seat's own image).

Actions
    Discrete (default), 9 actions, directions in the seat frame (``E`` = ``+x`` = toward the pen's
    centre from the start, ``N`` = ``+y``), each a thrust of full strength:
    ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE``.
    Continuous: ``[fx, fy]`` in [-1, 1], the thrust in the seat frame as a fraction of full
    strength; a vector longer than 1 is scaled back to length 1 (diagonals are no stronger).

Eating
    After each physics step, an agent whose centre lies within 0.35 (its radius plus a pellet's) of
    a pellet's centre eats it: the pellet is gone and the agent's team gains 1. When several agents
    touch one pellet on the same step, the one whose centre is nearest eats it; agents exactly as
    near share it equally (each team gains its share). An agent may eat several pellets in one step.

Observation (``float32``, seat frame; positions divided by 3, velocities by 3)
    ============ ======================= ==========================================================
    cell         bounds                  meaning
    ============ ======================= ==========================================================
    0            [0, 1]                  own active flag (always 1 in FightForFood)
    1-2          [-1, 1]                 own position ``x, y``
    3-4          [-2, 2]                 own velocity ``vx, vy``
    5 .. 4+T     [0, 1]                  food eaten by each team as a share of ``food``: the own
                                         team first, then the others in turn order (team ``t+1``,
                                         ``t+2``, ... modulo ``T = n_teams``)
    5+T          [0, 1]                  food left in the pen, as a share of ``food``
    6+T ..       [-2, 2]; [0, 1]         every pellet (``food`` of them, 3 cells each): its position
                                         relative to the seat (pellet - own, 2 cells) and a flag, 1
                                         while it is still there; all three 0 once it is eaten.
                                         Pellets come group by group; within a group the seat's own
                                         image first, then the images turned by one, two, ... turns
    6+T+3F ..    [-2, 2]; [-2, 2]        every other seat, teammates first (seat order), then the
                                         other teams in turn order (each in seat order): position
                                         relative to the seat (2 cells) then velocity (2 cells)
    ============ ======================= ==========================================================

    ``obs_dim = 6 + n_teams + 3 * food + 4 * (n_agents - 1)``: with the default 12 pellets, 48 for
    2T1P, 56 for 2T2P and 58 for 4T1P.

    Bounds: the walls keep every agent's centre within [-2.75, 2.75] in both coordinates (the inner
    faces at 3 less its radius) and every pellet lies within [-2.6, 2.6], so positions lie in [-1,
    1] and differences in [-2, 2]. Velocities are bounded by ``VELOCITY_BOUND`` = 2 (6 units/s,
    four times an agent's top speed; only a pile-up pushes a body that fast). A cell beyond its
    bounds is clipped to them. These bounds are the env's observation space.

Global state (``float32``, world frame, same scales)
    every seat's ``x, y, vx, vy`` in seat order; every pellet's ``x, y`` (where it lies or lay) and
    its still-there flag; the food eaten by each team and the food left, as shares of ``food``:
    ``state_dim = 4 * n_agents + 3 * food + n_teams + 1``. Bounds as for the observation's
    absolute cells, flags and shares in [0, 1].

Measures
    ``active`` (always true), ``resource_gain`` (food the seat ate this step: 1 a pellet, a share
    of one when it was shared), ``target_distance`` (distance from the seat's centre to the nearest
    pellet still there after the step; on the step that eats the last pellet, to the nearest of
    those there before it), ``velocity_to_target`` (the seat's velocity along the direction to that
    pellet), ``energy`` (squared thrust length, 0..1: 1 for every discrete move, 0 for noop),
    ``force`` (magnitude of the contact force on the seat this step: the impulse pymunk's solver
    applied to it, from agents and walls, divided by ``dt``), ``speed`` and ``outcome`` (the team's
    result mapped to [-1, 1]: +1 first, -1 last, 0 a two-team draw; 0 until the match ends).
    Events: ``{"kind": "eat", "seat": i, "pellet": k, "share": s}``, one per seat that ate.

Episode end
    The match ends when the last pellet is eaten; a match cut at ``max_cycles`` (default 300 steps,
    30 s of play) ends as it stands, the food left uneaten. Teams are ranked by the food they ate:
    ``team_result`` is the number of teams a team beat plus half the number it tied with
    (``n_teams - 1 - position``, ties sharing their places): 1 win, 0.5 draw, 0 loss with two teams;
    3, 2, 1, 0 from first to last with four.

Default social tree
    Root CP ``resource_share`` (scale 100: a child's food this step minus the children's mean);
    each agent leaf is IS ``target`` (scale 1: progress toward the nearest pellet; the distance
    jumps when the pellet is eaten and the next one becomes the target, so the shaping telescopes
    to the distance at the start less the distance at the end). With two players a team, the
    root's children are one CL ``team_target`` node (scale 10: the team's mean progress toward its
    members' nearest pellets) per team over its two leaves; with one, the leaves themselves.

Heuristic and search agent (``scripted:heuristic``, ``scripted:search-wW-rR-hH[-eE][-v2]``)
    From the observation alone: the heuristic heads for the pellet it reaches first, else the least
    contested; the search agent tries the ``W`` pellets it likes best in rollouts of a model of the
    pen. :mod:`.heuristic`'s docstring says how, and how the search's two versions fare.

Options
    ``food`` (int in [4, 24], a multiple of the number of teams, default 12), ``start_jitter``
    (float in [0, 0.5], default 0.3).

Playing it (``arena-league play``)
    A coarse text view of the top-down picture (team digits, ``o`` food; the view's edge is the
    pen's). A move is an action's number or name, a compass direction *on the pen as drawn* (``E`` =
    right, whichever seat you play: the move is turned into your seat frame for you); Enter repeats
    the last move.
    In a browser, the arrow keys or W A S D (two at once: diagonally). Discrete actions only.

Rendering
    A top-down picture of the pen (400 pixels wide): the walls, the floor, the pellets still there
    in white and the agents in their teams' colours. ``render_mode="rgb_array"`` returns it;
    ``"human"`` shows it in a window.

Copies
    The rules pickle and copy (``pickle``, ``copy.deepcopy``) by playing the match again from its
    seed and the actions (and ``place`` calls) since, as pymunk's contact caches cannot be copied;
    a copy goes on bit for bit as the original does.

Replay scene
    The pen (floor and walls), every agent (discs), the pellets still there (spheres) and the food
    eaten by each team (text): entities ``pen``, ``agent/<seat>``, ``food``, ``score``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from arena_league.envs.controls import TurnedCompassControls
from arena_league.envs.games.fightforfood.heuristic import SEARCH_BUDGET_MEANING, SEARCH_VERSIONS, plan_moves
from arena_league.envs.games.fightforfood.heuristic import heuristic as scripted_heuristic
from arena_league.envs.games.fightforfood.pen import (
    EAT_DISTANCE,
    FOOD_RANGE,
    check_placement,
    draw_food,
    force_matrix,
    measure_matrix,
    observation_matrix,
    pen_observation,
    pen_picture,
    pen_scene,
    pen_state,
    pen_world,
    start_spots,
    state_matrix,
)
from arena_league.envs.options import Option
from arena_league.envs.physics2d import (
    COMPASS_MOVE_NAMES,
    Physics2DRules,
    SeatThrust,
    team_ranks,
    team_turns,
)
from arena_league.envs.social import team_tree

OPTIONS = (Option("food", int, 12, "food pellets in the pen, a multiple of the number of teams", *FOOD_RANGE),
           Option("start_jitter", float, 0.3, "largest random offset of each start spot", 0.0, 0.5))

#: Where an eaten pellet is sought: so far out of the pen that it is never the nearest nor touched.
_FAR = complex(1e6, 1e6)


class FightForFoodRules(Physics2DRules):
    """FightForFood in a walled pymunk pen; see the module docstring for the manual."""

    name: ClassVar[str] = "FightForFood"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2), (4, 1))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "resource_gain", "target_distance", "velocity_to_target", "energy", "force", "speed", "outcome"}
    )
    default_max_cycles: ClassVar[int] = 300
    summary: ClassVar[str] = ("Agents shove each other off limited food pellets; the match ends when the food is "
                              "gone (pymunk; most food wins)")
    options = OPTIONS

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        food = self.food = self.settings["food"]
        self.start_jitter = self.settings["start_jitter"]
        if food % n_teams:
            low, high = FOOD_RANGE
            raise ValueError(f"FightForFood food must be an int in [{low}, {high}] and a multiple of the number of "
                             f"teams ({n_teams} in {n_teams}T{players_per_team}P), so that every team's side gets "
                             f"the same pellets; not {food!r}")
        n = self.n_agents
        self.n_actions = len(COMPASS_MOVE_NAMES)
        self.act_dim = 2
        self.action_meanings = COMPASS_MOVE_NAMES
        self.layout = pen_observation(n_teams, food, n)
        self.obs_dim = self.layout.size
        self.state_dim = 4 * n + 3 * food + n_teams + 1
        self.turns = team_turns(n_teams)
        # unit thrust of every move in the seat frame (x + iy): the matrices turn it into the world
        # which pellet each team sees in each slot: within a group, its own image first
        groups = np.arange(food // n_teams)[:, None] * n_teams
        self.slot_pellet = np.stack([(groups + (np.arange(n_teams) + t) % n_teams).reshape(-1) for t in range(n_teams)])
        self._obs_low, self._obs_high = (bound.reshape(n, self.obs_dim) for bound in self.clip_bounds(self.layout))
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())
        self._layout_work_vector()

    def _layout_work_vector(self) -> None:
        """The world's work vector holds everything a step reads, and one matrix product of it gives
        the measures' linear parts and every observation at once (few numpy calls: the hot path is
        Python-bound); the results land in preallocated arrays, seen through views made here."""
        n, food = self.n_agents, self.food
        world = self.world = pen_world(n, self.n_teams, food)
        self._work = world.work
        self._left_at = world.at("left")
        self._agent_pos = world.table[:n, 0:2]
        # complex views (x + iy) of the 2-vectors: fewer, cheaper numpy calls on the hot path
        agents_c = world.table[:n].view(np.complex128)
        self._agent_pos_column = agents_c[:, 0:1]
        self._agent_vel_c = agents_c[:, 1]
        self._v_before_c = world.complex_view("v_before")
        self._seat_thrust = SeatThrust(world.complex_view("thrust"), self.action_type)
        self._pellet_xy = world.view("pellet").reshape(food, 2)
        self._pellet_c = world.complex_view("pellet")
        self._present = world.view("present")
        self._eaten = world.view("eaten")
        world.force_matrix = force_matrix(world, self.team_of, self.turns)
        # measures (4 n rows) then observations (n * obs_dim rows), one product per step; the rows of
        # an eaten pellet's relative position are zeroed in the match's copy (its flag is 0 already)
        self._full_matrix = np.concatenate([measure_matrix(world, self.team_of, self.turns),
                                            observation_matrix(world, self.layout, self.team_of, self.turns,
                                                               self.slot_pellet)])
        self._matrix = self._full_matrix.copy()
        self._linear = np.zeros(len(self._matrix))
        self._measure_vectors_c = self._linear[: 4 * n].view(np.complex128)  # conj(velocity), contact force
        self._velocity_conj_c = self._measure_vectors_c[:n]
        self._obs_rows = self._linear[4 * n:].reshape(n, self.obs_dim)
        self._obs_work = np.zeros((n, self.obs_dim))
        # per seat, the matrix rows of each pellet's relative position (two each)
        self._pellet_rows = np.zeros((n, food, 2), dtype=np.intp)
        for seat in range(n):
            slots = np.argsort(self.slot_pellet[self.team_of[seat]])  # the slot of each pellet
            first = 4 * n + seat * self.obs_dim + self.layout.at("pellet_0") + 3 * slots
            self._pellet_rows[seat] = np.stack([first, first + 1], axis=1)
        self._state_matrix = state_matrix(world, n, food, self.n_teams)
        # The measures are arrays updated in place every step (the Measures contract allows it),
        # most of them views of these buffers, so that a step allocates almost nothing.
        self._norms = np.zeros(2 * n)  # speed, contact force
        self._diff = np.zeros((n, food), dtype=np.complex128)  # pellet - seat, every pair
        self._distance = np.zeros((n, food))
        # where each pellet is sought: where it lies while it is there, far out of the pen once eaten
        self._target_c = np.zeros(food, dtype=np.complex128)
        self._nearest = np.zeros(n, dtype=np.intp)
        self._nearest_flat = np.zeros(n, dtype=np.intp)
        self._row_start = np.arange(n, dtype=np.intp) * food
        self._to_target_c = np.zeros(n, dtype=np.complex128)
        self._along_c = np.zeros(n, dtype=np.complex128)  # conj(v) * d: its real part is v . d
        self._along = self._along_c.real
        self._gained = False  # whether resource_gain holds a non-zero value to clear
        m = self.measures
        m.speed, m.force = self._norms[:n], self._norms[n:]

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        starts = start_spots(self.rng, self.players_per_team, self.start_jitter, self.turns)
        pellets = draw_food(self.rng, self.turns, starts, self.food)
        self.world.build({"agent": starts})
        self._set_food(pellets, np.ones(self.food, dtype=bool))
        self._eaten[:] = 0.0
        self._work[self._left_at] = float(self.food)
        self._measure_still_state()
        self.measures.active[:] = True
        self.measures.outcome[:] = 0.0
        self.game_over = False
        self._events = []

    def _set_food(self, pellet_xy: np.ndarray, present: np.ndarray) -> None:
        """Lay the pellets (world positions) with their still-there flags, and what follows from them."""
        self._pellet_xy[:] = pellet_xy
        self._present[:] = present
        self._target_c[:] = np.where(present, self._pellet_c, _FAR)
        np.copyto(self._matrix, self._full_matrix)
        self._matrix[self._pellet_rows[:, ~present].reshape(-1)] = 0.0

    def _measure_still_state(self) -> None:
        """Measures of the bodies as they stand, with no step behind them (no force, no food)."""
        world = self.world
        world.work[world.at("v_before"): world.at("pellet")] = 0.0
        self._v_before_c[:] = self._agent_vel_c
        self.measures.energy[:] = 0.0
        self.measures.resource_gain[:] = 0.0
        self._gained = False
        self._measure_distances()
        self._update_measures(touching_allowed=True)
        self.measures.force[:] = 0.0

    def _measure_distances(self) -> None:
        """Every seat's distance to every pellet (far for those eaten), and to the nearest (its target)."""
        np.subtract(self._target_c, self._agent_pos_column, out=self._diff)
        np.abs(self._diff, out=self._distance)
        self._nearest_pellet()

    def _nearest_pellet(self) -> None:
        self._distance.argmin(axis=1, out=self._nearest)
        np.add(self._nearest, self._row_start, out=self._nearest_flat)
        self._distance.take(self._nearest_flat, out=self.measures.target_distance)

    def _update_measures(self, touching_allowed: bool = False) -> None:
        """One product of the work vector gives the velocities, contact forces and observations
        (:meth:`observe` clips them); the speeds and forces are the lengths of its complex cells,
        and the velocity toward the target its dot product with the way there. After a step that
        leaves food, no seat touches its target, so the distance divided by is not 0
        (``touching_allowed`` guards the other cases)."""
        m = self.measures
        np.dot(self._matrix, self._work, out=self._linear)
        np.abs(self._measure_vectors_c, out=self._norms)
        to_target = self._diff.take(self._nearest_flat, out=self._to_target_c)
        # Re(conj(v) * d) is the dot product of the velocity v and the way d to the pellet
        np.multiply(self._velocity_conj_c, to_target, out=self._along_c)
        distance = np.maximum(m.target_distance, 1e-9) if touching_allowed else m.target_distance
        np.divide(self._along, distance, out=m.velocity_to_target)

    def step(self, actions: np.ndarray) -> None:
        self._record("step", actions.copy())
        self._seat_thrust.set(actions, self.measures.energy)
        self._v_before_c[:] = self._agent_vel_c

        self.world.step()  # thrust against a linear drag

        if self._gained:
            self.measures.resource_gain[:] = 0.0
            self._gained = False
        if self._events:
            self._events = []
        self._measure_distances()
        # (a few cells: a Python min is cheaper than numpy's reduction)
        if min(self.measures.target_distance.tolist()) < EAT_DISTANCE:
            self._eat()
        self._update_measures(touching_allowed=self.game_over)

    def _eat(self) -> None:
        """Every pellet a seat touches goes to the nearest seat touching it (shared on a tie)."""
        touching = self._distance < EAT_DISTANCE
        gain = self.measures.resource_gain
        eaten = np.flatnonzero(touching.any(axis=0))
        for pellet in eaten.tolist():
            seats = np.flatnonzero(touching[:, pellet])
            near = self._distance[seats, pellet]
            winners = seats[near == near.min()]
            share = 1.0 / len(winners)
            for seat in winners.tolist():
                gain[seat] += share
                self._eaten[self.team_of[seat]] += share
                self._events.append({"kind": "eat", "seat": seat, "pellet": pellet, "share": share})
        self._gained = True
        self._present[eaten] = 0.0
        self._target_c[eaten] = _FAR
        self._matrix[self._pellet_rows[:, eaten].reshape(-1)] = 0.0
        self._work[self._left_at] -= len(eaten)
        if self._work[self._left_at] <= 0.0:
            # the last pellet is gone: the target stays the nearest of those there before the step
            self.game_over = True
            self._set_outcome()
            return
        self._distance[:, eaten] = np.inf
        self._nearest_pellet()

    def _set_outcome(self) -> None:
        result = self.team_result()
        self.measures.outcome[:] = (2.0 * result / (self.n_teams - 1) - 1.0)[self.team_of]

    def observe(self) -> np.ndarray:
        return self.clip_into(self._obs_rows, self._obs_low, self._obs_high, self._obs_work)  # taken with the measures

    def state(self) -> np.ndarray:
        state = self._state_matrix @ self._work
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return pen_state(self.n_agents, self.food, self.n_teams).bounds()

    def finish(self) -> None:
        self._record("finish")
        # a match cut at max_cycles ends as it stands: the food left is nobody's
        self._set_outcome()

    def team_result(self) -> np.ndarray:
        return team_ranks(self._eaten)  # ranked by food

    @property
    def food_eaten(self) -> np.ndarray:
        """``float64[n_teams]``: the food each team has eaten (a copy)."""
        return self._eaten.copy()

    @property
    def food_left(self) -> int:
        """Pellets still in the pen."""
        return int(self._work[self._left_at])

    def pellets(self) -> tuple[np.ndarray, np.ndarray]:
        """``(xy, present)``: every pellet's world position and whether it is still there (copies)."""
        return self._pellet_xy.copy(), self._present > 0.5

    def place(self, agent_xy: np.ndarray, agent_velocity: np.ndarray | None = None,
              pellet_xy: np.ndarray | None = None, present: np.ndarray | None = None) -> None:
        """Put the agents at given world positions and velocities, and optionally the pellets at
        given positions with given still-there flags (for tests and scripted scenarios); the match
        continues from there, each team keeping the food it has eaten. Every agent and pellet must
        lie inside the pen, and at least one pellet must be left."""
        if self.world.space is None:
            raise RuntimeError("call reset(seed) before place()")
        agent_xy = np.asarray(agent_xy, dtype=np.float64).reshape(self.n_agents, 2)
        agent_velocity = (np.zeros((self.n_agents, 2)) if agent_velocity is None
                          else np.asarray(agent_velocity, dtype=np.float64).reshape(self.n_agents, 2))
        old_xy, old_present = self.pellets()
        pellet_xy = old_xy if pellet_xy is None else np.asarray(pellet_xy, dtype=np.float64).reshape(self.food, 2)
        present = old_present if present is None else np.asarray(present, dtype=bool).reshape(self.food)
        check_placement(agent_xy, pellet_xy, present)
        self._record("place", agent_xy.copy(), agent_velocity.copy(), pellet_xy.copy(), present.copy())
        self.world.place("agent", agent_xy, agent_velocity)
        self.world.read()
        self._set_food(pellet_xy, present)
        self._work[self._left_at] = float(present.sum())
        self._events = []
        self._measure_still_state()

    def render_topdown(self) -> np.ndarray:
        xy, present = self.pellets()
        return pen_picture(self._agent_pos, self.team_of, xy[present])

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        xy, present = self.pellets()
        return pen_scene(timestamp_ns, self._agent_pos, self.team_of, xy[present], self._eaten)

    def human_controls(self, seat: int) -> FightForFoodControls:
        return FightForFoodControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        return team_tree(n_teams, players_per_team, "resource_share")

    heuristic = staticmethod(scripted_heuristic)
    search = staticmethod(plan_moves)
    search_budget_meaning: ClassVar[str] = SEARCH_BUDGET_MEANING
    search_versions: ClassVar[tuple[int, ...]] = SEARCH_VERSIONS


class FightForFoodControls(TurnedCompassControls):
    """Compass moves on the pen as drawn (E = right), turned into the seat's frame."""

    move = "move on the pen as drawn"
    key_hint = "Arrow keys or W A S D run on the pen as drawn (two at once: diagonally); let go to stop pushing."


RULES = FightForFoodRules
