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

Heuristic
    From the observation alone. For every pellet still there it compares the seat's distance with
    the nearest other agent's (teammates count, so that teammates split the food), and heads for
    the pellet of least ``d_own + 2 * max(0, d_own - d_other + 0.1)``: the nearest one it reaches
    first, else the least contested. Distances are judged from where every body will be after the
    step (pymunk moves a body by its present velocity before the thrust acts; judged from where
    they are, a seat between two pellets turns from one to the other every step). It steers at
    full thrust, damping its sideways drift, and does not shove rivals on purpose.

Search agent (``scripted:search-wW-rR-hH[-eE][-v2]``, :func:`plan_moves`)
    A planner over a model of the pen, from the observation alone (it holds the whole state). Its
    candidates are the ``W`` pellets the heuristic likes best. For each it plays ``R`` rollouts of
    ``H`` steps of a point-mass model: every body moves by its velocity, then thrusts at full
    strength as the heuristic steers it, under the game's damping and drag; the nearest agent within
    reach of a pellet eats it. The seat heads for the candidate until it is gone and then plays the
    heuristic; every other agent plays the heuristic, its pellet costs jittered by a uniform draw of
    up to ``E`` times the pen's side (6) in each rollout (``E`` = 0: one rollout says all). A
    rollout's value is the food the seat's team ate less the best other team's, each pellet left at
    the horizon counting a half for the team whose agent is nearest; the seat steers, as the
    heuristic does, for the candidate of the highest mean value (ties: the heuristic's order). Its
    draws come from a generator seeded by the seat's uniform, so a match replays exactly. ``W`` = 1
    is the heuristic.

    Two versions. The first (no suffix; the searchers of the ``base-v1`` population) leaves contacts
    out and steers every body in any direction. The second (``-v2``) models what the first left
    out: with discrete actions every body thrusts along one of the eight moves of the action table,
    as the heuristic's rounded heading does; agents that touch rebound (restitution 0.25, equal
    masses, overlaps pushed apart) and the walls stop them (restitution 0.4), so the planner sees a
    rival it would bump and a shove that clears a pellet. Against the heuristic (2T1P, discrete, 100
    matches, seats alternating; ``python benchmarks/search_agents.py FightForFood-2T1P-v1 ...``):
    ``search-w8-r1-h40`` won 64, drew 33 and lost 3, ``search-w8-r1-h40-v2`` won 91 and drew 9;
    ``search-w4-r1-h40`` 57, 40 and 3, its ``-v2`` 79 and 21. Two heuristics mirror each other to a
    6 to 6 draw; the planner finds the pellet that breaks the tie.

Game kwargs
    ``food`` (int in [4, 24], a multiple of the number of teams, default 12), ``start_jitter``
    (float in [0, 0.5], default 0.3).

Playing it (``arena-league play``)
    A coarse text view of the top-down picture (team digits, ``o`` food; the view's edge is the
    pen's). A move is an
    action's number or name, a compass direction *on the pen as drawn* (``E`` = right, whichever
    seat you play: the move is turned into your seat frame for you); Enter repeats the last move.
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

from arena_league.envs import scene
from arena_league.envs.controls import TurnedCompassControls
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
    team_ranks,
    team_turns,
)
from arena_league.envs.rendering import TEAM_COLOURS, Canvas
from arena_league.envs.social import team_tree

#: Half side of the pen (inner faces of the walls).
HALF_SIZE = 3.0
#: Walls are pymunk segments this thick on each side of their centre line.
WALL_RADIUS = 0.3
AGENT_RADIUS = 0.25
AGENT_MASS = 1.0
PELLET_RADIUS = 0.1
#: An agent eats a pellet whose centre lies this near its own: the two touch.
EAT_DISTANCE = AGENT_RADIUS + PELLET_RADIUS
#: Pellets lie within this of the centre in both coordinates, this far apart at least, and this far
#: from every start spot at least.
FOOD_LIMIT = 2.6
FOOD_GAP = 0.6
START_CLEARANCE = 0.8
#: Physics step per env step (seconds).
DT = 0.1
#: Fraction of its velocity a body keeps after one second (pymunk ``Space.damping``).
SPACE_DAMPING = 0.4
#: Full thrust of an agent, and the drag coefficient opposing its velocity.
THRUST = 6.0
AGENT_DRAG = 3.1
#: An agent's top speed, where full thrust meets drag and damping (about 1.5 units/s).
AGENT_TOP_SPEED = THRUST / (AGENT_DRAG - AGENT_MASS * np.log(SPACE_DAMPING))
#: Overlap pymunk tolerates between touching bodies (its default, 0.1, is large at this scale).
COLLISION_SLOP = 0.01
#: Contact restitution is the product of the two shapes' values: 0.25 agent-agent, 0.4 agent-wall.
ELASTICITY = {"agent": 0.5, "wall": 0.8}
FRICTION = 0.3
#: Observation scales: positions are divided by HALF_SIZE, velocities by VELOCITY_UNIT.
POSITION_SCALE = 1.0 / HALF_SIZE
VELOCITY_UNIT = 3.0
#: Bound of the velocity cells, in units of VELOCITY_UNIT (6 units/s, four times an agent's top
#: speed; only a pile-up can push a body faster, and that is clipped).
VELOCITY_BOUND = 2.0

#: What a FightForFood search agent's budget means (the population provenance quotes it).
SEARCH_BUDGET_MEANING = ("the W pellets the heuristic likes best, each tried first in R rollouts of H steps of a "
                         "point-mass model of the pen where the others play the heuristic, their pellet costs "
                         "jittered by up to E of the pen's side; -v2 models the contacts between agents and with "
                         "the walls, and the eight moves of the discrete action table")

DEFAULT_FOOD = 12
FOOD_RANGE = (4, 24)
OPTIONS = (Option("food", int, DEFAULT_FOOD, "food pellets in the pen, a multiple of the number of teams", *FOOD_RANGE),
           Option("start_jitter", float, 0.3, "largest random offset of each start spot", 0.0, 0.5))

#: Start spots of team 0 (the other teams' are turned), per players per team.
_FORMATIONS = {
    1: ((-2.2, 0.0),),
    2: ((-2.2, 0.8), (-2.2, -0.8)),
}
#: Draws of one pellet group before the placement gives up (it never needs nearly so many).
_PLACEMENT_TRIES = 10_000
#: Where an eaten pellet is sought: so far out of the pen that it is never the nearest nor touched.
_FAR = complex(1e6, 1e6)


def pen_field(n_agents: int) -> Field:
    """The walled square pen, then the agents (discs that do not spin), added in that order."""
    edge = HALF_SIZE + WALL_RADIUS
    corners = [(-edge, -edge), (edge, -edge), (edge, edge), (-edge, edge)]
    return Field(dt=DT, damping=SPACE_DAMPING, collision_slop=COLLISION_SLOP, parts=(
        Walls(tuple((corners[k], corners[(k + 1) % 4]) for k in range(4)), WALL_RADIUS,
              Material(ELASTICITY["wall"], FRICTION)),
        Bodies("agent", n_agents, AGENT_RADIUS, AGENT_MASS, Material(ELASTICITY["agent"], FRICTION))))


def pen_observation(n_teams: int, food: int, n_agents: int) -> CellLayout:
    """The observation's runs (seat frame; positions divided by 3, velocities by 3)."""
    v = (-VELOCITY_BOUND, VELOCITY_BOUND)
    runs = [Run("active", 1, (0, 1), "own active flag (always 1)"), Run("position", 2, (-1, 1), "own position"),
            Run("velocity", 2, v, "own velocity"),
            Run("eaten", n_teams, (0, 1), "food eaten by each team, own first, as a share of food"),
            Run("left", 1, (0, 1), "food left, as a share of food")]
    for k in range(food):
        runs += [Run(f"pellet_{k}", 2, (-2, 2), "a pellet relative to the seat (0 once eaten)"),
                 Run(f"pellet_{k}_there", 1, (0, 1), "1 while that pellet is there")]
    for k in range(n_agents - 1):
        runs += [Run(f"other_{k}", 2, (-2, 2), "another seat's position relative to the seat"),
                 Run(f"other_{k}_velocity", 2, v, "that seat's velocity")]
    return CellLayout(runs)


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

        self._turns = team_turns(n_teams)
        # unit thrust of every move in the seat frame (x + iy): the matrices turn it into the world
        self._moves = np.ascontiguousarray(COMPASS_MOVES).view(np.complex128).reshape(-1)
        self._move_energy = (COMPASS_MOVES**2).sum(axis=1)
        # which pellet each team sees in each slot: within a group, its own image first
        groups = np.arange(food // n_teams)[:, None] * n_teams
        self._slot_pellet = np.stack([(groups + (np.arange(n_teams) + t) % n_teams).reshape(-1)
                                      for t in range(n_teams)])
        self._obs_low, self._obs_high = (bound.reshape(n, self.obs_dim) for bound in self.clip_bounds(self.layout))
        self._state_low, self._state_high = (bound.astype(np.float64) for bound in self.state_bounds())
        self._layout_work_vector()

    # --- construction --------------------------------------------------------------------------
    def _layout_work_vector(self) -> None:
        """The world's work vector holds everything a step reads, and one matrix product of it gives
        the measures' linear parts and every observation at once (few numpy calls: the hot path is
        Python-bound); the results land in preallocated arrays, seen through views made here.

        Slots after the bodies' block: the seats' velocities before the step, their unit thrust in
        their own frames (as the actions give it: the matrices turn it into the world), every
        pellet's ``x, y``, every pellet's still-there flag, the food eaten by each team, the food
        left, and a constant 1.
        """
        n, food, teams = self.n_agents, self.food, self.n_teams
        world = self.world = World(pen_field(n), slots=(("v_before", 2 * n), ("thrust", 2 * n), ("pellet", 2 * food),
                                                        ("present", food), ("eaten", teams), ("left", 1), (ONE, 1)))
        self._work = world.work
        self._left_at = world.at("left")
        self._agent_pos = world.table[:n, 0:2]
        # complex views (x + iy) of the 2-vectors: fewer, cheaper numpy calls on the hot path
        agents_c = world.table[:n].view(np.complex128)
        self._agent_pos_column = agents_c[:, 0:1]
        self._agent_vel_c = agents_c[:, 1]
        self._v_before_c = world.complex_view("v_before")
        self._thrust = world.view("thrust").reshape(n, 2)
        self._thrust_c = world.complex_view("thrust")
        self._pellet_xy = world.view("pellet").reshape(food, 2)
        self._pellet_c = world.complex_view("pellet")
        self._present = world.view("present")
        self._eaten = world.view("eaten")
        self._thrust_length = np.zeros(n)  # a thrust's length, then at least 1: its scale-back
        # applied force of every body (zero for the static body), in the world frame
        world.force_matrix = world.matrix(2 * world.n_bodies)
        for i in range(n):
            turn = self._turns[self.team_of[i]]
            for ax in range(2):
                world.force_matrix[2 * i + ax, world.at("thrust", 2 * i): world.at("thrust", 2 * i + 2)] = THRUST * turn[ax]
                world.force_matrix[2 * i + ax, world.at("v_before", 2 * i + ax)] = -AGENT_DRAG
        # measures (4 n rows) then observations (n * obs_dim rows), one product per step; the rows of
        # an eaten pellet's relative position are zeroed in the match's copy (its flag is 0 already)
        self._full_matrix = np.concatenate([self._measure_map(), self._observation_map()])
        self._matrix = self._full_matrix.copy()
        self._linear = np.zeros(len(self._matrix))
        self._measure_vectors_c = self._linear[: 4 * n].view(np.complex128)  # conj(velocity), contact force
        self._velocity_conj_c = self._measure_vectors_c[:n]
        self._obs_rows = self._linear[4 * n:].reshape(n, self.obs_dim)
        self._obs_work = np.zeros((n, self.obs_dim))
        # per seat, the matrix rows of each pellet's relative position (two each)
        self._pellet_rows = np.zeros((n, food, 2), dtype=np.intp)
        for seat in range(n):
            slots = np.argsort(self._slot_pellet[self.team_of[seat]])  # the slot of each pellet
            first = 4 * n + seat * self.obs_dim + self.layout.at("pellet_0") + 3 * slots
            self._pellet_rows[seat] = np.stack([first, first + 1], axis=1)
        self._state_matrix = self._state_map()
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

    def _other_seats(self, seat: int) -> list[int]:
        """The other seats in observation order: teammates, then the other teams in turn order."""
        team = int(self.team_of[seat])
        order = [(team + k) % self.n_teams for k in range(self.n_teams)]
        return [j for t in order for j in np.flatnonzero(self.team_of == t).tolist() if j != seat]

    def _observation_map(self) -> np.ndarray:
        """The observations of every seat as one matrix over the work vector."""
        n, teams, world, cells = self.n_agents, self.n_teams, self.world, self.layout
        A = np.zeros((n, self.obs_dim, len(world.work)))
        ps, vs = POSITION_SCALE, 1.0 / VELOCITY_UNIT
        pos = [[world.pos(i, 0), world.pos(i, 1)] for i in range(n)]
        vel = [[world.vel(i, 0), world.vel(i, 1)] for i in range(n)]
        for i in range(n):
            rows = A[i]
            rotation = self._turns[self.team_of[i]].T  # world -> the seat's frame
            team = int(self.team_of[i])

            def turned(cell: str, columns: list[int], matrix: np.ndarray) -> None:
                rows[cells.at(cell): cells.at(cell) + 2, columns] += matrix  # noqa: B023 (this seat's rows)

            rows[cells.at("active"), world.at(ONE)] = 1.0
            turned("position", pos[i], ps * rotation)
            turned("velocity", vel[i], vs * rotation)
            for k in range(teams):
                rows[cells.at("eaten", k), world.at("eaten", (team + k) % teams)] = 1.0 / self.food
            rows[cells.at("left"), world.at("left")] = 1.0 / self.food
            for slot, pellet in enumerate(self._slot_pellet[team]):
                turned(f"pellet_{slot}", [world.at("pellet", 2 * pellet), world.at("pellet", 2 * pellet + 1)], ps * rotation)
                turned(f"pellet_{slot}", pos[i], -ps * rotation)
                rows[cells.at(f"pellet_{slot}_there"), world.at("present", pellet)] = 1.0
            for k, j in enumerate(self._other_seats(i)):
                turned(f"other_{k}", pos[j], ps * rotation)
                turned(f"other_{k}", pos[i], -ps * rotation)
                turned(f"other_{k}_velocity", vel[j], vs * rotation)
        return A.reshape(n * self.obs_dim, len(world.work))

    def _measure_map(self) -> np.ndarray:
        """The linear parts of the measures as one matrix over the work vector.

        Rows: ``[velocity (x, -y), contact force (x, y)]`` of every seat, read as complex numbers
        (the velocity conjugated: its product with the way to the target gives their dot product). The
        contact force is the impulse the solver added beyond damping and the applied force (Chipmunk
        integrates ``v' = v * damping**dt + f / m * dt`` before solving contacts), divided by ``dt``.
        """
        n, world = self.n_agents, self.world
        M = world.matrix(4 * n)
        # velocity kept from before the step, drag included (force = THRUST * thrust - DRAG * v)
        keep = SPACE_DAMPING**DT - AGENT_DRAG * DT / AGENT_MASS
        for i in range(n):
            turn = self._turns[self.team_of[i]]
            for ax in range(2):
                M[2 * i + ax, world.vel(i, ax)] = 1.0 if ax == 0 else -1.0
                row = 2 * n + 2 * i + ax
                M[row, world.vel(i, ax)] = AGENT_MASS / DT
                M[row, world.at("v_before", 2 * i + ax)] = -keep * AGENT_MASS / DT
                M[row, world.at("thrust", 2 * i): world.at("thrust", 2 * i + 2)] = -THRUST * turn[ax]
        return M

    def _state_map(self) -> np.ndarray:
        """The global state as one matrix over the work vector."""
        n, food, world = self.n_agents, self.food, self.world
        S = world.matrix(self.state_dim)
        for i in range(n):
            for ax in range(2):
                S[4 * i + ax, world.pos(i, ax)] = POSITION_SCALE
                S[4 * i + 2 + ax, world.vel(i, ax)] = 1.0 / VELOCITY_UNIT
        for k in range(food):
            row = 4 * n + 3 * k
            S[row, world.at("pellet", 2 * k)] = S[row + 1, world.at("pellet", 2 * k + 1)] = POSITION_SCALE
            S[row + 2, world.at("present", k)] = 1.0
        row = 4 * n + 3 * food
        for t in range(self.n_teams):
            S[row + t, world.at("eaten", t)] = 1.0 / food
        S[row + self.n_teams, world.at("left")] = 1.0 / food
        return S

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        jitter = self.start_jitter
        slots = np.asarray(_FORMATIONS[self.players_per_team], dtype=np.float64)
        team0 = slots + self.rng.uniform(-jitter, jitter, slots.shape)
        starts = np.concatenate([team0 @ turn.T for turn in self._turns])
        pellets = self._draw_food(starts)
        self.world.build({"agent": starts})
        self._set_food(pellets, np.ones(self.food, dtype=bool))
        self._eaten[:] = 0.0
        self._work[self._left_at] = float(self.food)
        self._measure_still_state()
        self.measures.active[:] = True
        self.measures.outcome[:] = 0.0
        self.game_over = False
        self._events = []

    def _draw_food(self, starts: np.ndarray) -> np.ndarray:
        """``food`` pellet positions: groups of a uniform point and its images under the teams'
        turns, each at least FOOD_GAP from the others and START_CLEARANCE from every start."""
        teams = self.n_teams
        pellets = np.zeros((self.food, 2))
        for group in range(self.food // teams):
            placed = pellets[: group * teams]
            for _ in range(_PLACEMENT_TRIES):
                images = self._turns @ self.rng.uniform(-FOOD_LIMIT, FOOD_LIMIT, 2)
                apart = np.linalg.norm(images[:, None] - images[None], axis=2)[np.triu_indices(teams, 1)]
                if (apart.min() >= FOOD_GAP
                        and np.linalg.norm(images[:, None] - placed[None], axis=2).min(initial=np.inf) >= FOOD_GAP
                        and np.linalg.norm(images[:, None] - starts[None], axis=2).min() >= START_CLEARANCE):
                    pellets[group * teams: (group + 1) * teams] = images
                    break
            else:  # pragma: no cover - the pen has room for far more pellets than the kwarg allows
                raise RuntimeError(f"FightForFood could not place {self.food} pellets")
        return pellets

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
        energy = self.measures.energy
        thrust = self._thrust_c
        if self.action_type == "discrete":
            self._moves.take(actions, out=thrust)
            self._move_energy.take(actions, out=energy)
        else:
            self._thrust[:] = actions
            length = np.abs(thrust, out=self._thrust_length)
            np.square(length, out=energy)
            np.minimum(energy, 1.0, out=energy)
            # a thrust longer than 1 is scaled back to length 1
            np.maximum(length, 1.0, out=length)
            np.divide(thrust, length, out=thrust)
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
        # the product was taken with the measures; two ufuncs clip faster than np.clip
        clipped = np.minimum(self._obs_rows, self._obs_high, out=self._obs_work)
        return np.maximum(clipped, self._obs_low, out=clipped).astype(np.float32)

    def state(self) -> np.ndarray:
        state = self._state_matrix @ self._work
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        v = (-VELOCITY_BOUND, VELOCITY_BOUND)
        return CellLayout([*[Run(f"seat_{k}", 4, ((-1, 1), (-1, 1), v, v)) for k in range(self.n_agents)],
                           *[Run(f"pellet_{k}", 3, ((-1, 1), (-1, 1), (0, 1))) for k in range(self.food)],
                           Run("food", self.n_teams + 1, (0, 1))]).bounds()

    def finish(self) -> None:
        self._record("finish")
        # a match cut at max_cycles ends as it stands: the food left is nobody's
        self._set_outcome()

    def team_result(self) -> np.ndarray:
        return team_ranks(self._eaten)  # ranked by food

    # --- tools ---------------------------------------------------------------------------------
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
        inside = HALF_SIZE - AGENT_RADIUS
        outside = np.flatnonzero((np.abs(agent_xy) > inside).any(axis=1))
        if len(outside):
            seat = int(outside[0])
            raise ValueError(f"agent {seat} at {agent_xy[seat].tolist()} is outside the pen: its centre must lie "
                             f"within [-{inside}, {inside}] in both coordinates")
        if (np.abs(pellet_xy) > FOOD_LIMIT).any():
            raise ValueError(f"every pellet must lie within [-{FOOD_LIMIT}, {FOOD_LIMIT}] in both coordinates")
        if not present.any():
            raise ValueError("at least one pellet must be left: the match ends when the food is exhausted")
        self._record("place", agent_xy.copy(), agent_velocity.copy(), pellet_xy.copy(), present.copy())
        self.world.place("agent", agent_xy, agent_velocity)
        self.world.read()
        self._set_food(pellet_xy, present)
        self._work[self._left_at] = float(present.sum())
        self._events = []
        self._measure_still_state()

    def render_topdown(self) -> np.ndarray:
        H, R = HALF_SIZE, 0.25  # walls drawn 0.25 thick
        canvas = Canvas(-H - R, H + R, -H - R, H + R, size=400, background=(40, 40, 40))
        canvas.rect(-H, -H, H, H, fill=(205, 185, 140))
        xy, present = self.pellets()
        for x, y in xy[present]:
            canvas.circle(x, y, 1.5 * PELLET_RADIUS, fill=(250, 250, 250))  # drawn larger, to be seen
        for seat in range(self.n_agents):
            x, y = self._agent_pos[seat]
            canvas.circle(x, y, AGENT_RADIUS, fill=TEAM_COLOURS[self.team_of[seat]], outline=(20, 20, 20))
        return canvas.array()

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        H, ts, thick = HALF_SIZE, timestamp_ns, 0.2
        wall = (0.3, 0.3, 0.3, 1.0)
        out = [scene.entity("pen", ts, cubes=[
            scene.cube(0, 0, -0.05, (2 * H, 2 * H, 0.1), (0.8, 0.73, 0.55, 1.0)),
            scene.cube(0, H + thick / 2, 0.1, (2 * H + 2 * thick, thick, 0.2), wall),
            scene.cube(0, -H - thick / 2, 0.1, (2 * H + 2 * thick, thick, 0.2), wall),
            scene.cube(H + thick / 2, 0, 0.1, (thick, 2 * H, 0.2), wall),
            scene.cube(-H - thick / 2, 0, 0.1, (thick, 2 * H, 0.2), wall)])]
        for seat in range(self.n_agents):
            x, y = self._agent_pos[seat]
            out.append(scene.entity(f"agent/{seat}", ts, cylinders=[
                scene.disc(float(x), float(y), 2 * AGENT_RADIUS, scene.team_colour(int(self.team_of[seat])),
                           height=0.2)]))
        xy, present = self.pellets()
        d = 2 * PELLET_RADIUS
        out.append(scene.entity("food", ts, spheres=[
            scene.sphere(float(x), float(y), PELLET_RADIUS, (d, d, d), (0.97, 0.97, 0.97, 1.0)) for x, y in xy[present]]))
        score = " : ".join(f"{food:g}" for food in self._eaten)
        out.append(scene.entity("score", ts, texts=[scene.text(0, H + 0.6, 0.2, score)]))
        return out

    def human_controls(self, seat: int) -> FightForFoodControls:
        return FightForFoodControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        return team_tree(n_teams, players_per_team, "resource_share")

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        from arena_league.envs.games.fightforfood.heuristic import heuristic  # the scripted play, on demand

        return heuristic(obs, action_type)

    search_budget_meaning: ClassVar[str] = SEARCH_BUDGET_MEANING
    search_versions: ClassVar[tuple[int, ...]] = (1, 2)

    @staticmethod
    def search(obs: np.ndarray, uniforms: np.ndarray, *, action_type: str, width: int, rollouts: int, horizon: int,
               epsilon: float, version: int = 1) -> np.ndarray:
        from arena_league.envs.games.fightforfood.heuristic import plan_moves

        return plan_moves(obs, uniforms, width=width, rollouts=rollouts, horizon=horizon, epsilon=epsilon,
                          action_type=action_type, version=version)


class FightForFoodControls(TurnedCompassControls):
    """Compass moves on the pen as drawn (E = right), turned into the seat's frame."""

    move = "move on the pen as drawn"
    key_hint = "Arrow keys or W A S D run on the pen as drawn (two at once: diagonally); let go to stop pushing."


RULES = FightForFoodRules
