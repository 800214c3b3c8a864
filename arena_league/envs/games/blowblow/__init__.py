"""BlowBlow: agents push each other off a round platform, by shoving or by blowing (pymunk physics).

One of the competitive games of the Arena platform (Song et al., "Arena: A General Evaluation
Platform and Building Toolkit for Multi-Agent Intelligence", AAAI 2020): each agent must stay on a
platform and push the opponents off it, by shoving them or blowing at them. Ids:
``BlowBlow-2T1P-v1``, ``BlowBlow-2T2P-v1``.

Platform
    A round platform of radius ``R`` (``platform_radius``, default 3) centred on the origin, with
    no walls: beyond its edge is the void.

Bodies and physics
    Agents are circles of radius 0.25 and mass 1 that do not rotate. Collisions are solved by pymunk
    (Chipmunk2D), one ``space.step`` of ``dt = 0.1`` per env step, with little rebound
    (restitution 0.25 between agents; friction 0.09). Every body loses half its velocity per second
    (space damping 0.5); an agent's thrust of at most 5 is opposed by a drag of ``2 * velocity``,
    which caps its speed at about 1.86 units/s. Two agents pushing head on at full thrust stand
    still; one that comes at a rival from the side moves it off its line.

Heading and blowing
    Every agent has a heading, a unit vector: the direction of its last thrust of at least a tenth
    of full strength (every discrete move sets it), toward the other team at the start. A blow
    sends a puff of air of momentum 1.2 along the heading into a cone of half-angle 30 degrees and
    range 2.5: the blower recoils by 1.2 against its heading, and the nearest other agent on the
    platform (teammates too) whose centre lies in the cone catches the share ``1 - d / 2.5`` of the
    puff (``d`` the distance between centres): an impulse of ``1.2 * (1 - d / 2.5)`` straight away
    from the blower's centre. It shields whoever stands behind it; the air carries off the rest.
    The impulses act during the step's physics (as forces over ``dt``), so the solver answers them:
    a rival pushed into a third agent shoves it. An agent may blow when it is on the platform and 6
    steps have passed since its last blow (the cooldown); otherwise the blow does nothing. Blows are
    made together, from the positions before the step, and leave nothing in flight.

Falling
    After each physics step, an agent whose centre lies farther than ``R`` from the platform's
    centre falls and is out for the rest of the match: it stays where it fell, collides with
    nothing, and its actions are ignored.

Symmetry, the start and the seat frame
    Team 1 stands where team 0 stands turned by half a turn about the centre: team 0 at
    ``(-0.45 R, 0)`` (1P) or ``(-0.45 R, +-0.25 R)`` (2P), each jittered by up to ``start_jitter``
    in both coordinates (draws from the match seed); team 1's seat ``k`` on the image of team 0's
    seat ``k``. Each seat sees the platform, and acts, in its own frame: the world for team 0, the
    world turned by half a turn (``x -> -x``, ``y -> -y``) for team 1. Every seat starts on the
    ``x < 0`` side of its frame with its heading ``+x``, so one policy can play either seat.

Actions
    Discrete (default), 10 actions: the compass moves, directions in the seat frame (``E`` = ``+x``
    = toward the other team at the start, ``N`` = ``+y``), each a thrust of full strength, then a
    blow along the heading (with no thrust that step):
    ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE, 9 blow``.
    Continuous: ``[fx, fy, blow]`` in [-1, 1]: the thrust in the seat frame as a fraction of full
    strength (a vector longer than 1 is scaled back to length 1), and a blow when ``blow > 0``,
    along the heading as this thrust sets it (so a seat may run and blow at once).

Observation (``float32``, seat frame; positions divided by ``R``, velocities by 3)
    ``obs_dim = 8 * n_agents + 1`` (17 for 2T1P, 33 for 2T2P): the seat's on-platform flag, ``R /
    4``, its position, velocity, heading and cooldown (steps left before it may blow, over 6), then
    8 cells per other seat, the teammate first (2P), then the opponents in seat order: flag,
    position relative to the seat, velocity, heading, cooldown. Every cell, its bounds and meaning
    are the runs of :func:`blowblow_observation` (``rules.layout.table()``). A seat that fell sees
    every cell 0, and the 8 cells of a seat that fell are 0 in the others' observations.
    Bounds: a seat on the platform lies within ``R`` of the centre (falls are judged after every
    step), so its position lies in [-1, 1] and its differences to the others' in [-2, 2];
    velocities in [-2, 2] (6 units/s, three times an agent's top speed: only a pile-up, a blow and
    its recoil together push an agent faster), a cell beyond its bounds clipped to them.

Global state (``float32``, world frame, same scales)
    per seat ``flag, x, y, vx, vy, heading x, heading y, cooldown``: ``state_dim = 8 * n_agents``; a
    seat that fell is all 0 (:func:`blowblow_state`).

Measures
    ``active`` and ``alive`` (the seat is on the platform), ``target_distance`` (distance from the
    seat's centre to its target: its opponent in 2T1P; in 2T2P the opponent it marks, the one
    straight ahead of it at the start, and from the step after that one fell the other opponent),
    ``velocity_to_target`` (the seat's velocity along the direction to it), ``facing_target``
    (cosine of the angle between the seat's heading and that direction), ``energy`` (squared thrust
    length, 0..1: 1 for every discrete move, 0 for noop and blow), ``force`` (magnitude of the
    contact force on the seat this step: the impulse pymunk's solver applied to it, from other
    agents, divided by ``dt``; a blow's impulses are not contacts), ``speed`` and ``outcome`` (+1
    win, -1 loss, 0 draw; 0 until the match ends). A seat that fell keeps the target distance and
    facing of the step it fell; its speed and force are 0. Events: ``{"kind": "blow", "seat": i,
    "target": j}`` (``j`` the seat it hit, or None) and ``{"kind": "fall", "seat": i}``.

Episode end
    The match ends when a team has no agent left on the platform: the other team wins, and when the
    last agents of both teams fall on the same step it is a draw. A match cut at ``max_cycles``
    (default 300 steps, 30 s of play) goes to the team with more agents on the platform; with as
    many, to the team whose agents on the platform stand nearer the centre on average (as a judge
    gives a bout to the wrestler who holds the middle of the ring), a draw when both means are
    equal within ``1e-6``. ``team_result``: 1 win, 0.5 draw, 0 loss.

Default social tree
    Root CP ``win_loss`` (scale 100); each agent leaf is IS ``target`` (scale 1: progress toward the
    opponent it marks, whom it must reach to push). With two players a team, the root's children
    are one CL ``team_target`` node (scale 10: the team's mean progress toward its members' marked
    opponents) per team over its two leaves; with one, the leaves themselves.

Heuristic (:mod:`~arena_league.envs.games.blowblow.heuristic`)
    From the observation alone. It picks the opponent on the platform that is nearest once its
    distance to the edge is counted twice, and pushes it straight away from the centre (away from
    the seat when the rival stands at the centre): it runs to a spot on the centre's side of the
    rival, going round it when the rival stands in the way, then charges through it radially
    outward. It blows (instead of moving, in the discrete variant) when it is ready, the rival lies
    within 2 and within 25 degrees of its heading, the blow would push the rival outward, and the
    recoil leaves the seat well inside the edge. Within 0.6 of the edge it turns back toward the
    centre, and it damps its sideways drift.

Game kwargs
    ``platform_radius`` (float in [2, 4], default 3.0), ``start_jitter`` (float in [0, 0.5], default
    0.3); declared in ``BlowBlowRules.options`` (``arena-league games BlowBlow-2T1P-v1`` lists them).

Playing it (``arena-league play``)
    A coarse text view of the top-down picture (team digits, ``*`` a blow or an agent that fell; the
    view's edge is the void). A move is an action's number or name, a compass direction *on the
    platform as drawn* (``E`` = right, whichever seat you play: the move is turned into your seat
    frame for you), or ``b`` to blow along your heading (the direction of your last move); Enter
    repeats the last move. In a browser, the arrow keys or W A S D (two at once: diagonally) and the
    space bar (or B) to blow. Discrete actions only.

Rendering and replay scene
    A top-down picture (400 pixels wide; ``render_mode="rgb_array"`` returns it, ``"human"`` shows
    it): the void, the platform with its edge, the cones of the last step's blows, the agents in
    their teams' colours with a tick along their heading, those that fell darkened where they fell.
    The replay scene: entities ``platform`` (a disc over the dark ground far below),
    ``agent/<seat>`` (discs with an arrow along the heading, faded once fallen), ``blows`` (the last
    step's, arrows across their range) and ``score`` (agents left on the platform per team).

Copies
    The rules pickle and copy by playing the match again from its seed and the actions (and
    ``place`` calls) since, as pymunk's contact caches cannot be copied; a copy goes on bit for bit.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from arena_league.envs.controls import TurnedCompassControls, arrow_keys, key_controls
from arena_league.envs.games.blowblow.platform import (
    AGENT_RADIUS,
    BLOW_ACTION,
    BLOW_COOLDOWN,
    BLOW_IMPULSE,
    BLOW_RANGE,
    CENTRE_TIE,
    COS_HALF_ANGLE,
    DEFAULT_PLATFORM_RADIUS,
    DT,
    GONE_FILTER,
    HEADING_MIN_THRUST,
    OTHER_CELLS,
    SPACE_DAMPING,
    VELOCITY_BOUND,
    VELOCITY_UNIT,
    PlatformRules,
    action_tables,
    blowblow_observation,
    blowblow_state,
    check_placement,
    marked_at_start,
    platform_picture,
    platform_scene,
    start_spots,
)
from arena_league.envs.options import Option
from arena_league.envs.physics2d import COMPASS_MOVE_NAMES, ONE, mirror_signs
from arena_league.envs.social import team_tree

#: What users of the game import from the package (the platform's data among it).
__all__ = ["AGENT_RADIUS", "BLOW_COOLDOWN", "BLOW_IMPULSE", "BLOW_RANGE", "DT", "RULES", "SPACE_DAMPING",
           "VELOCITY_BOUND", "VELOCITY_UNIT", "BlowBlowControls", "BlowBlowRules"]

OPTIONS = (Option("platform_radius", float, DEFAULT_PLATFORM_RADIUS, "radius of the round platform", 2.0, 4.0),
           Option("start_jitter", float, 0.3, "largest random offset of each start position", 0.0, 0.5))


class BlowBlowRules(PlatformRules):
    """BlowBlow on a pymunk platform; see the module docstring for the manual."""

    name: ClassVar[str] = "BlowBlow"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "alive", "target_distance", "velocity_to_target", "facing_target", "energy", "force", "speed",
         "outcome"})
    default_max_cycles: ClassVar[int] = 300
    summary: ClassVar[str] = ("Agents push each other off a round platform, shoving or blowing (pymunk; last team "
                              "on the platform wins)")
    options = OPTIONS

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        self.platform_radius = self.settings["platform_radius"]
        self.start_jitter = self.settings["start_jitter"]
        n = self.n_agents
        self._discrete = action_type == "discrete"
        self.n_actions, self.act_dim, self.action_meanings = BLOW_ACTION + 1, 3, (*COMPASS_MOVE_NAMES, "blow")
        self.layout, self.state_layout = blowblow_observation(n), blowblow_state(n)
        self.obs_dim, self.state_dim = self.layout.size, self.state_layout.size
        # the seat frame of team 1 is the world turned by half a turn: every vector times -1
        self._sign = mirror_signs(self.team_of)
        self._move_table, self._energy_table, self._sets_heading_table = action_tables()
        self._obs_low, self._obs_high = (b.reshape(n, self.obs_dim) for b in self.clip_bounds(self.layout))
        self._state_low, self._state_high = (b.astype(np.float64) for b in self.state_layout.bounds())
        self._marked_at_start = marked_at_start(self.team_of, players_per_team)
        self._layout_work_vector()

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        self.world.build({"agent": start_spots(self.rng, self.players_per_team, self.start_jitter,
                                                 self.platform_radius)})
        n = self.n_agents
        self._work[self.world.at("heading"): self.world.at(ONE)] = 0.0
        self._heading_c[:] = self._sign  # toward the other team: +x in every seat frame
        self._step_count = 0
        self._ready = [0] * n  # the step from which each seat may blow again (a copy of the work's)
        self._on = np.ones(n, dtype=bool)
        self._seats_on = list(range(n))
        self._others_on = [[j for j in range(n) if j != i] for i in range(n)]  # per seat, the others on
        self._team_on = np.full(self.n_teams, self.players_per_team)
        self._turn = self._sign + 0j  # seat frame -> world; 0 once the seat fell (no thrust)
        self._marked = list(self._marked_at_start)
        self._kept = np.zeros(n, dtype=bool)  # seats whose target measures stay as they fell
        self._any_fallen = self.game_over = False
        np.copyto(self._matrix, self._full_matrix)
        self._state_matrix = self._full_state_matrix.copy()
        m = self.measures
        m.active[:] = m.alive[:] = True
        m.outcome[:] = 0.0
        self._events = []
        self._measure_still_state()

    def _measure_still_state(self) -> None:
        """Measures of the bodies as they stand, with no step behind them (no force, no effort)."""
        self._v_before_c[:] = self._agent_vel_c
        self._thrust_c[:] = self._impulse_c[:] = 0.0
        self._blew = False  # whether the impulse cells hold this step's blows, to be cleared
        self.measures.energy[:] = 0.0
        self._update_measures()
        self.measures.force[:] = 0.0

    def step(self, actions: np.ndarray) -> None:
        self._record("step", actions.copy())
        if self._events:
            self._events = []
        energy, move, turns, discrete = self.measures.energy, self._move_c, self._turns_heading, self._discrete
        if discrete:
            self._move_table.take(actions, out=move)
            self._energy_table.take(actions, out=energy)
            self._sets_heading_table.take(actions, out=turns)
            asked = actions.tolist()
            blowing = max(asked) == BLOW_ACTION
        else:
            self._move_xy[:] = actions[:, 0:2]
            length = np.abs(move, out=self._move_length)
            np.square(length, out=energy)
            np.minimum(energy, 1.0, out=energy)
            np.greater_equal(length, HEADING_MIN_THRUST, out=turns)
            asked = actions[:, 2].tolist()
            blowing = max(asked) > 0.0
        if self._any_fallen:  # a seat that fell neither thrusts nor turns
            np.multiply(energy, self._on, out=energy)
            np.logical_and(turns, self._on, out=turns)
        # the thrust in the world frame; a long enough one sets the heading
        thrust = np.multiply(move, self._turn, out=self._thrust_c)
        if discrete:  # every move is of full strength
            np.copyto(self._heading_c, thrust, where=turns)
        else:
            np.divide(thrust, length, out=self._heading_c, where=turns)
            if max(length.tolist()) > 1.0:  # a thrust longer than 1 is scaled back to length 1
                np.maximum(length, 1.0, out=length)
                np.divide(thrust, length, out=thrust)
        if self._blew:
            self._impulse_c.fill(0.0)
            self._blew = False
        if blowing:
            self._blow(asked)
        self._v_before_c[:] = self._agent_vel_c
        self.world.step()  # thrust against a linear drag, and the blows
        self._step_count += 1
        self._work[self._step_at] = self._step_count
        self._update_measures()
        # (a seat that fell has its radius rows zeroed; a Python max is cheaper than numpy's)
        if max(self._radius.tolist()) > self.platform_radius:
            self._fall()

    def _blow(self, asked: list) -> None:
        """Every seat that asks to blow (``asked``: its action, or its blow cell) and may: the puff's
        impulse on the nearest agent in its cone, and the blower's recoil."""
        discrete, step, ready, on = self._discrete, self._step_count, self._ready, self._on
        positions = headings = None
        impulses = self._impulse_c
        for seat, asking in enumerate(asked):
            if (asking != BLOW_ACTION if discrete else asking <= 0.0) or step < ready[seat] or not on[seat]:
                continue
            if positions is None:  # (a few seats: Python's complex numbers are cheaper than numpy's)
                positions, headings = self._position_c.tolist(), self._heading_c.tolist()
            ready[seat] = step + BLOW_COOLDOWN
            self._work[self._ready_at + seat] = ready[seat]
            heading = headings[seat]
            impulses[seat] -= BLOW_IMPULSE * heading
            here, backward = positions[seat], heading.conjugate()
            target, nearest, toward = None, BLOW_RANGE, 0j
            for other in self._others_on[seat]:
                way = positions[other] - here
                along = (way * backward).real  # the way's length along the heading
                if along <= 0.0:
                    continue
                distance = abs(way)
                # in the cone: within range, and within the half-angle of the heading
                if distance < nearest and along >= COS_HALF_ANGLE * distance:
                    target, nearest, toward = other, distance, way
            if target is not None:
                impulses[target] += BLOW_IMPULSE * (1.0 - nearest / BLOW_RANGE) * toward / nearest
            self._events.append({"kind": "blow", "seat": seat, "target": target})
            self._blew = True

    def _update_measures(self) -> None:
        """One product gives the positions, the ways to the targets, the contact forces, the
        velocities and headings (and every observation); one abs their lengths; the velocity and
        heading along the way to the target follow."""
        m = self.measures
        np.dot(self._matrix, self._work, out=self._linear)
        np.abs(self._norm_source, out=self._norms)
        # Re(conj(v) * d) is the dot product of the vectors v and d
        np.multiply(self._velocity_heading_conj, self._to_target_c, out=self._along_c)
        np.divide(self._along_real, m.target_distance, out=self._along)
        if self._any_fallen:
            np.copyto(m.target_distance, self._kept_distance, where=self._kept)
            np.copyto(m.facing_target, self._kept_facing, where=self._kept)

    def _fall(self) -> None:
        """Seats whose centre left the platform are out; the match ends when a team has none left."""
        m = self.measures
        radius = self._radius.tolist()
        for seat in [s for s in self._seats_on if radius[s] > self.platform_radius]:
            self._on[seat] = m.active[seat] = m.alive[seat] = False
            self._seats_on.remove(seat)
            for others in self._others_on:
                if seat in others:
                    others.remove(seat)
            self._team_on[self.team_of[seat]] -= 1
            body = self.world.bodies["agent"][seat]
            for shape in body.shapes:
                shape.filter = GONE_FILTER
            body.velocity = 0.0, 0.0  # it stays where it fell
            self._agent_vel_c[seat] = self._turn[seat] = 0.0
            self._matrix[self._seat_rows[seat]] = 0.0
            self._linear[self._seat_rows[seat]] = 0.0  # this step's observations too
            self._state_matrix[OTHER_CELLS * seat: OTHER_CELLS * (seat + 1)] = 0.0
            self._kept[seat] = True
            self._kept_distance[seat], self._kept_facing[seat] = m.target_distance[seat], m.facing_target[seat]
            self._events.append({"kind": "fall", "seat": seat})
        self._any_fallen = True
        if (self._team_on == 0).any():
            self.game_over = True
            self._set_outcome()
            return
        # who marked a seat that fell marks its teammate still on the platform, from the next step
        for seat in range(self.n_agents):
            if self._on[seat] and not self._on[self._marked[seat]]:
                team = self.team_of[self._marked[seat]]
                self._marked[seat] = next(j for j in self._seats_on if self.team_of[j] == team)
                self._retarget(self._matrix, seat, self._marked[seat])

    def _set_outcome(self) -> None:
        self.measures.outcome[:] = 2.0 * self.team_result()[self.team_of] - 1.0

    def observe(self) -> np.ndarray:
        return self.clip_into(self._obs_rows, self._obs_low, self._obs_high, self._obs_work)

    def state(self) -> np.ndarray:
        state = self._state_matrix @ self._work
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.layout.bounds()

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.state_layout.bounds()

    def finish(self) -> None:
        self._record("finish")
        self._set_outcome()  # to the team with more agents on, then to the one nearer the centre

    def team_result(self) -> np.ndarray:
        on = self._team_on
        if on[0] != on[1]:
            return np.where(on == on.max(), 1.0, 0.0)
        if on[0] == 0:
            return np.array([0.5, 0.5])  # both teams' last agents fell on one step
        radius = np.abs(self._agent_pos_c)
        mean = np.array([radius[(self.team_of == t) & self._on].mean() for t in range(self.n_teams)])
        if abs(mean[0] - mean[1]) <= CENTRE_TIE:
            return np.array([0.5, 0.5])
        return np.where(mean == mean.min(), 1.0, 0.0)

    # --- tools ---------------------------------------------------------------------------------
    @property
    def on_platform(self) -> np.ndarray:
        """``bool[n_agents]``: which seats are still on the platform (a copy)."""
        return self._on.copy()

    def agents(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(xy, velocity, heading)``: every agent's world position, velocity and heading (copies;
        a seat that fell lies where it fell, still)."""
        return tuple(np.stack([c.real, c.imag], axis=1) for c in (self._agent_pos_c, self._agent_vel_c,
                                                                   self._heading_c))

    def cooldown(self) -> np.ndarray:
        """``int64[n_agents]``: steps each seat must still wait before it may blow."""
        return np.maximum(np.array(self._ready) - self._step_count, 0).astype(np.int64)

    def place(self, agent_xy: np.ndarray, agent_velocity: np.ndarray | None = None,
              heading: np.ndarray | None = None) -> None:
        """Put the agents at given world positions and velocities, and optionally turn their
        headings to given angles (radians); for tests and scripted scenarios. The match continues
        from there, cooldowns as they were. Every seat still on the platform must stand on it, at
        least one agent radius from every other; the entries of seats that fell are ignored."""
        if self.world.space is None:
            raise RuntimeError("call reset(seed) before place()")
        n, on = self.n_agents, self._on
        agent_xy = np.asarray(agent_xy, dtype=np.float64).reshape(n, 2)
        agent_velocity = np.zeros((n, 2)) if agent_velocity is None else np.asarray(agent_velocity, dtype=np.float64)
        agent_velocity = agent_velocity.reshape(n, 2)
        heading = None if heading is None else np.asarray(heading, dtype=np.float64).reshape(n)
        check_placement(agent_xy, on, self.agents()[0], self.platform_radius)
        self._record("place", agent_xy.copy(), agent_velocity.copy(), None if heading is None else heading.copy())
        for seat in self._seats_on:
            body = self.world.bodies["agent"][seat]
            body.position = float(agent_xy[seat, 0]), float(agent_xy[seat, 1])
            body.velocity = float(agent_velocity[seat, 0]), float(agent_velocity[seat, 1])
            if heading is not None:
                self._heading_c[seat] = complex(math.cos(heading[seat]), math.sin(heading[seat]))
        self.world.read()
        self._events = []
        self._measure_still_state()

    def render_topdown(self) -> np.ndarray:
        xy, _, heading = self.agents()
        blowers = [e["seat"] for e in self._events if e["kind"] == "blow"]
        return platform_picture(self.platform_radius, xy, heading, self._on, self.team_of, blowers)

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        xy, _, heading = self.agents()
        blowers = [e["seat"] for e in self._events if e["kind"] == "blow"]
        return platform_scene(timestamp_ns, self.platform_radius, xy, heading, self._on, self.team_of, blowers,
                              self._team_on)

    def human_controls(self, seat: int) -> BlowBlowControls:
        return BlowBlowControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        return team_tree(n_teams, players_per_team, "win_loss")

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        from arena_league.envs.games.blowblow.heuristic import push_off  # the package's own scripted play

        return push_off(obs, action_type)


class BlowBlowControls(TurnedCompassControls):
    """Compass moves on the platform as drawn (E = right), turned into the seat's frame, and ``b``
    to blow along the heading."""

    move = "move on the platform as drawn"
    key_hint = ("Arrow keys or W A S D run on the platform as drawn (two at once: diagonally); Space (or B) blows "
                "along your heading, the way you last ran; let go to stop pushing.")

    def parse(self, text: str) -> tuple[int | None, str | None]:
        if text == "b":
            return BLOW_ACTION, None
        action, problem = super().parse(text)
        return action, None if problem is None else problem + "; b blows along your heading"

    def prompt(self, step: int) -> str:
        return (f"step {step}: {self.move} (e, ne, n, nw, w, sw, s, se or noop), or b to blow along your heading "
                "(an action number 0-9; Enter repeats) > ")

    def web(self) -> dict[str, Any]:
        return key_controls({**arrow_keys("n", "w", "s", "e"), " ": "b", "b": "b", "B": "b"}, self.PACE,
                            self.key_hint, release="noop", combine="nsew", accepts=("ne", "nw", "se", "sw"))


RULES = BlowBlowRules
