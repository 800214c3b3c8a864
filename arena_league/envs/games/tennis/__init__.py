"""Tennis: two rackets (or two pairs) hit a ball over a net, seen from the side (pymunk physics).

One of the competitive games of the Arena platform (Song et al., "Arena: A General Evaluation
Platform and Building Toolkit for Multi-Agent Intelligence", AAAI 2020), which took it from Unity
ML-Agents: a racket on each side of a net keeps a ball in play; a ball that bounces twice on
one's side, or that one hits out or into the net, is the other side's point. Ids:
``Tennis-2T1P-v1``, ``Tennis-2T2P-v1``.

Court (a side view: ``x`` along the court, ``y`` up)
    The floor is ``y = 0``; the court runs from baseline to baseline, ``x`` in [-4, 4], with a
    run-off of 1 beyond each baseline up to a back fence (inner faces at ``x = +-5``), and a ceiling
    closes the hall at ``y = 6``. The net stands at ``x = 0``, 1 high and 0.16 thick (a segment of
    radius 0.08 whose top reaches ``y = 1``). Team 0 plays on the ``x < 0`` side, team 1 on
    ``x > 0``.

Bodies and physics
    Rackets (the agents) are circles of radius 0.3 and mass 1 that do not rotate; the ball is a
    circle of radius 0.15 and mass 0.1 that does not spin either. Gravity (6 units/s^2, down)
    pulls the ball; the rackets are held, so they do not fall. pymunk (Chipmunk2D) solves the
    collisions in two ``space.step`` calls of ``dt = 0.05`` per env step of 0.1 s, so that a ball
    as fast as about 9 units/s cannot pass through the net between two of them. Every body keeps
    90 % of its velocity per second (space damping 0.9: air drag). The ball rebounds from the
    floor and from a racket with restitution 0.81 (0.9 times 0.9), from the fences and the ceiling
    with 0.54, and from the net with 0.18 (a dead net); contact friction is 0.15 with the floor,
    the fences and the net, 0.225 with a racket. A racket's thrust of at most 10 is opposed by a
    drag of ``3.5 * velocity``, which caps its speed at about 2.8 units/s.

    Each racket is confined to its own side and its reach: the plane of the net (from the floor to
    the reach height), and a reach ceiling at ``y = 2.5``, are segments (radius 0.1) that only
    rackets collide with (pymunk ``ShapeFilter`` categories), with no rebound; so a racket's centre
    stays within ``x`` in [-4.7, -0.4] on team 0's side (mirrored on team 1's) and ``y`` in
    [0.3, 2.2], and rackets of the two teams never meet. The ball passes those barriers freely.
    Teammates do not collide with each other (they play in different lanes of the court, seen
    from the side).

Points
    Each point starts with a serve: the rackets stand on their spots (2T1P: ``(-3, 0.8)``; 2T2P: a
    back racket at ``(-3, 0.8)`` and a low front one at ``(-1.2, 0.5)``; team 1's mirrored), each
    jittered by up to ``start_jitter`` in both coordinates, and the ball is tossed at ``(-2.5, 1.8)``
    on the server's side (mirrored for team 1; ``x`` jittered by up to ``start_jitter``) at 1 unit/s
    upward. The serve alternates between the teams, the first server drawn from the match seed;
    every draw comes from the match seed.

    The team whose racket touched the ball last *played* it (the server, for its toss). A team may
    touch the ball any number of times before it crosses the net. The ball *lands* when it comes
    into contact with the floor or a back fence (a contact that begins: a ball rolling on the floor
    lands once). A point ends, in favour of the team named, when the ball

    * lands before being struck, on a serve: the receiver's (a *fault*);
    * lands on the side of the team that played it before bouncing in on the other side: the
      other team's (*net*: it did not cross the net);
    * lands beyond the other team's baseline (``|x| > 4``) or on its back fence, before bouncing in:
      the other team's (*out*);
    * lands a second time after bouncing in on the receiving side, anywhere: the team that played
      it (*not returned*);
    * stays on one side of the net for 40 steps in a row (4 s): the other team's (*held*; no side
      may keep the ball, on its racket or rolling).

    A racket touching the ball resets the rally: the ball is that team's shot and has not bounced
    in. Contacts are judged after each of the two physics steps of an env step, in order, on every
    one that pushed the ball (its velocity is not that of a free flight), from the bodies' positions
    then, as pymunk's contact test sees them: a racket touches the ball when their centres are
    nearer than the two radii; the ball touches the floor when its bottom is below it, a fence when
    its side is beyond the fence's face. The ball landing comes before a racket's touch when both
    happen at once; when rackets of both teams touch the ball at once, the team on whose side the
    ball's centre lies played it. The ball is on the side its centre is (exactly on ``x = 0``, on
    the side it came from). A point that ends mid-step ends the step's physics; the next serve is
    laid out at once.

Seat frame (mirroring)
    Each seat sees the court, and acts, in its own frame: the world frame for team 0, and the world
    mirrored in ``x`` (``x -> -x``, ``y`` unchanged) for team 1. In its own frame every seat plays on
    the ``x < 0`` side and hits toward ``+x``, so one policy can play either side.

Actions
    Discrete (default), 9 actions, directions in the seat frame (``E`` = ``+x`` = toward the net,
    ``N`` = ``+y`` = up), each a thrust of full strength:
    ``0 noop, 1 E, 2 NE, 3 N, 4 NW, 5 W, 6 SW, 7 S, 8 SE``.
    Continuous: ``[fx, fy]`` in [-1, 1], the thrust in the seat frame as a fraction of full
    strength; a vector longer than 1 is scaled back to length 1 (diagonals are no stronger).

Observation (``float32``, seat frame; positions divided by 4, velocities by 4)
    ====== =================================== =====================================================
    cell   bounds (x cell, y cell)             meaning
    ====== =================================== =====================================================
    0      [0, 1]                              own active flag (always 1 in Tennis)
    1-2    [-1.25, 0], [0, 0.625]              own position ``x, y`` (the own side, within reach)
    3-4    [-3, 3]                             own velocity ``vx, vy``
    5-6    [-1.25, 2.5], [-0.625, 1.5]         ball position relative to the seat (ball - own)
    7-8    [-1.25, 1.25], [0, 1.5]             ball position (absolute)
    9-10   [-3, 3]                             ball velocity
    11     [0, 1]                              1 when the own team played the ball last (or tosses
                                               it to serve), 0 when the other team did
    12     [0, 1]                              1 once the ball has bounced in on the receiving
                                               side since it was played (it must be returned
                                               before it lands again)
    13     [0, 1]                              1 while the ball is a serve's toss not yet struck
    14     [0, 1]                              steps the ball has spent on its side of the net in a
                                               row, as a share of 40 (at 1 that side loses the point)
    15-16  [0, 1]                              the own team's points, then the other team's, as
                                               shares of ``points``
    17+    teammates [-1.25, 1.25], opponents  every other seat, teammates first then opponents,
           [0, 2.5] (x); [-0.625, 0.625] (y);  each in seat order: position relative to the seat
           [-3, 3] (velocity)                  (2 cells) then its velocity (2 cells)
    ====== =================================== =====================================================

    ``obs_dim = 17 + 4 * (n_agents - 1)``: 21 for 2T1P, 29 for 2T2P.

    Bounds: the fences, the floor and the ceiling keep the ball within ``x`` in [-5, 5] and ``y``
    in [0, 6]; the barriers keep every racket within ``x`` in [-5, 0] on its side and ``y`` in [0,
    2.5], which bounds positions and their differences. Velocities are bounded by
    ``VELOCITY_BOUND`` = 3 (12 units/s, four times a racket's top speed and more than the hardest
    shot; only a pile-up pushes a body faster). A cell beyond its bounds is clipped to them. These
    bounds are the env's observation space.

Global state (``float32``, world frame, same scales)
    every seat's ``x, y, vx, vy`` in seat order, then the ball's ``x, y, vx, vy``, then the points
    of team 0 and of team 1 as shares of ``points``, then which team played the ball last (two
    cells, one of them 1), the bounced-in flag, the toss flag and the side clock:
    ``state_dim = 4 * n_agents + 11``. A seat's ``x`` lies in its team's side ([-1.25, 0] for team
    0, [0, 1.25] for team 1), the other cells as for the observation's absolute cells.

Measures
    ``active`` (always true), ``resource_gain`` (the points the seat won this step: a point won by
    its team is shared equally among its members), ``target_distance`` (distance from the racket's
    centre to the ball's: the ball is every seat's target; at a new serve it jumps to the tossed
    ball), ``velocity_to_target`` (the racket's velocity along the direction to the ball),
    ``energy`` (squared thrust length, 0..1: 1 for every discrete move, 0 for noop), ``force``
    (magnitude of the contact force on the racket this step: the impulse pymunk's solver applied to
    it, from the ball and the barriers, divided by ``dt``; 0 on a step a new serve is laid out),
    ``speed`` and ``outcome`` (+1 / -1 for the winning / losing team, 0 for a draw; 0 until the
    match ends). Events: ``{"kind": "hit", "seat": i}`` when a racket's contact with the ball
    begins, ``{"kind": "bounce", "side": t}`` when the ball bounces in on team ``t``'s side, and
    ``{"kind": "point", "team": t, "reason": r}`` with ``r`` one of ``fault``, ``net``, ``out``,
    ``not_returned``, ``held``.

Episode end
    The first team to win ``points`` points (default 7, as in a tie-break) wins the match. A match
    cut at ``max_cycles`` (default 600 steps, 60 s of play) goes to the team with more points, a
    draw when both have as many. ``team_result``: 1 win, 0.5 draw, 0 loss.

Default social tree
    Root CP ``resource_share`` (scale 100: the points are the contested resource; each point pays
    its winner's team +0.5 and the other -0.5); each agent leaf is IS ``target`` (scale 1: progress
    toward the ball). With two players a team, the root's children are one CL ``team_target`` node
    (scale 10: the team's mean progress toward the ball) per team over its two leaves; with one, the
    leaves themselves.

Heuristic
    From the observation alone: the teammate best placed to play the ball predicts its flight,
    picks a stroke that clears the net and lands deep in the other court, and runs its racket
    through the spot of contact at the stroke's speed; the others keep their spots. It assumes the
    default court; :mod:`arena_league.envs.games.tennis.heuristic` describes it in full.

Game kwargs
    ``points`` (an integer in [1, 21], default 7: points to win the match), ``start_jitter`` (a
    number in [0, 0.3], default 0.2: largest random offset of each serve position).

Playing it (``arena-league play``)
    A coarse text view of the side picture (team digits, ``+`` the net, ``o`` the ball; the view's
    edge is the hall's: the floor is its bottom line). A move is an action's number or name, a
    compass direction *on the court as drawn* (``E`` = right, ``N`` = up, whichever side you play:
    team 1's moves are mirrored into its seat frame for you); Enter repeats the last move. In a
    browser, the arrow keys or W A S D (two at once: diagonally). Discrete actions only.

Rendering
    A side picture of the hall (400 pixels wide): the air in light grey framed by the floor, the
    fences and the ceiling in dark grey, the baselines as white marks in the floor, the net, a faint
    line at the rackets' reach, the rackets in their teams' colours and the ball in white.
    ``render_mode="rgb_array"`` returns it; ``"human"`` shows it in a window.

Copies
    The rules pickle and copy (``pickle``, ``copy.deepcopy``) by playing the match again from its
    seed and the actions (and ``place`` calls) since, as pymunk's contact caches cannot be copied;
    a copy goes on bit for bit as the original does.

Replay scene
    The court in 3D, the side view's plane standing along ``x`` with its height as ``z``: the floor
    (``x``, ``y``) with its baselines, the net, every racket and the ball (spheres; teammates in
    lanes ``y = +-0.4``) and the score (text): entities ``court``, ``agent/<seat>``, ``ball``,
    ``score``.
"""


from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from arena_league.envs.controls import MirroredCompassControls
from arena_league.envs.games.tennis.court import (
    _FREE_FALL,
    _FREE_KEEP,
    _FREE_TOLERANCE,
    BALL_RADIUS,
    BARRIER_RADIUS,
    CONTACT,
    GRAVITY,
    HALF_LENGTH,
    HOLD_LIMIT,
    NET_HEIGHT,
    POINT_REASONS,
    POSITION_SCALE,
    RACKET_RADIUS,
    RACKET_TOP_SPEED,
    REACH_HEIGHT,
    SUBSTEP,
    SUBSTEPS,
    THRUST,
    TOSS_SPEED,
    TOSS_XY,
    VELOCITY_BOUND,
    VELOCITY_UNIT,
    TennisCourt,
    check_placement,
    court_picture,
    court_scene,
    draw_serve,
)
from arena_league.envs.options import Option
from arena_league.envs.social import team_tree

# the court's names the tests and tools read from the package
__all__ = ["BALL_RADIUS", "BARRIER_RADIUS", "CONTACT", "GRAVITY", "HALF_LENGTH", "HOLD_LIMIT", "NET_HEIGHT",
           "OPTIONS", "POINT_REASONS", "POSITION_SCALE", "RACKET_RADIUS", "RACKET_TOP_SPEED", "REACH_HEIGHT",
           "RULES", "THRUST", "TOSS_SPEED", "TOSS_XY", "VELOCITY_BOUND", "VELOCITY_UNIT", "TennisControls",
           "TennisRules"]

DEFAULT_POINTS = 7
OPTIONS = (Option("points", int, DEFAULT_POINTS, "points to win the match", 1, 21),
           Option("start_jitter", float, 0.2, "largest random offset of each serve position", 0.0, 0.3))


class TennisRules(TennisCourt):
    """Tennis in a side-view pymunk hall; see the package docstring for the manual."""

    name: ClassVar[str] = "Tennis"
    version: ClassVar[int] = 1
    layouts: ClassVar[tuple[tuple[int, int], ...]] = ((2, 1), (2, 2))
    action_types: ClassVar[tuple[str, ...]] = ("discrete", "continuous")
    measures_provided: ClassVar[frozenset[str]] = frozenset(
        {"active", "resource_gain", "target_distance", "velocity_to_target", "energy", "force", "speed", "outcome"}
    )
    default_max_cycles: ClassVar[int] = 600
    summary: ClassVar[str] = ("Rackets hit a ball over a net, seen from the side (pymunk; a ball landing twice, "
                              "out or in the net is the other side's point; first to 7 points wins)")
    options = OPTIONS

    def __init__(self, n_teams: int, players_per_team: int, action_type: str = "discrete", **kwargs) -> None:
        super().__init__(n_teams, players_per_team, action_type, **kwargs)
        self._first_seats = np.arange(n_teams) * players_per_team
        # the rally, kept in plain Python on the hot path (the work vector mirrors it for observations)
        self._player = 0  # the team that played the ball last (the server, for its toss)
        self._bounced = False
        self._tossed = False
        self._side = 0  # the side of the net the ball is on
        self._clock = 0  # steps the ball has ended on that side in a row
        self._server = 0
        self._landed = False  # whether the ball touched the floor or a fence after the last physics step
        self._touching = 0  # bit mask of the seats whose racket touched the ball after the last physics step
        self.score = np.zeros(2, dtype=np.int64)

    # --- the match -----------------------------------------------------------------------------
    def reset(self, seed: int) -> None:
        self._record_reset(seed)
        self.rng = np.random.default_rng(seed)
        self._server = int(self.rng.integers(2))
        racket_xy, ball_xy, ball_velocity = draw_serve(self.rng, self.start_jitter, self._spots, self._server)
        self.world.build({"racket": racket_xy, "ball": ball_xy}, {"ball": (ball_velocity,)})
        self.score[:] = 0
        self._work[self._score_at: self._score_at + 2] = 0.0
        self._start_rally()
        self.measures.active[:] = True
        self.measures.outcome[:] = 0.0
        self.game_over = False
        self._events = []

    def _serve(self) -> None:
        """Lay out the next point's serve in the running space."""
        racket_xy, ball_xy, ball_velocity = draw_serve(self.rng, self.start_jitter, self._spots, self._server)
        self._move_bodies(racket_xy, None, ball_xy, ball_velocity)
        self._start_rally(keep_energy=True)

    def _start_rally(self, keep_energy: bool = False) -> None:
        """The rally of a serve by ``self._server``: its toss, on its side, played by it."""
        self._set_rally(player=self._server, bounced=False, tossed=True)
        self._side = self._server
        self._clock = 0
        self._work[self._clock_at] = 0.0
        self._measure_still_state(keep_energy)

    def _set_rally(self, player: int, bounced: bool, tossed: bool) -> None:
        self._player, self._bounced, self._tossed = player, bounced, tossed
        work = self._work
        work[self._played_at] = 1.0 - player
        work[self._played_at + 1] = float(player)
        work[self._bounced_at] = float(bounced)
        work[self._toss_at] = float(tossed)

    def step(self, actions: np.ndarray) -> None:
        self._record("step", actions.copy())
        self._seat_thrust.set(actions, self.measures.energy)
        if self._gained:
            self.measures.resource_gain[:] = 0.0
            self._gained = False
        if self._events:
            self._events = []

        # thrust against a linear drag, gravity on the ball; pymunk clears the forces after every
        # physics step, so they are written before each
        np.dot(self._force_matrix, self._force_source, out=self._force_array)
        link = self._link
        work = self._work
        ball = self._ball_cells
        x, _, vx, vy = work[ball].tolist()
        for _ in range(SUBSTEPS):
            link.write_bodies()
            link.step(SUBSTEP)
            link.read_bodies()
            x, _, wx, wy = work[ball].tolist()
            # a physics step that pushed the ball (a contact) is judged; in free flight its velocity
            # is exactly the damped one plus gravity's (up to rounding), and it touches nothing
            if abs(wx - vx * _FREE_KEEP) > _FREE_TOLERANCE or abs(wy - vy * _FREE_KEEP - _FREE_FALL) > _FREE_TOLERANCE:
                winner = self._judge_contacts()
                if winner >= 0:
                    self._win_point(winner)
                    return
            elif self._landed or self._touching:
                self._landed, self._touching = False, 0
            vx, vy = wx, wy
        # the side clock: a side that keeps the ball HOLD_LIMIT steps in a row loses the point
        side = self._side if x == 0.0 else int(x > 0.0)
        if side == self._side:
            self._clock += 1
            if self._clock >= HOLD_LIMIT:
                self._win_point(self._point(1 - side, "held"))
                return
        else:
            self._side = side
            self._clock = 1
        work[self._clock_at] = self._clock / HOLD_LIMIT
        self._update_measures()

    def _judge_contacts(self) -> int:
        """The rally after one physics step: a landing, then the rackets' touches. Returns the team
        that wins the point, or -1 while the ball is in play."""
        landed = self._on_ground()
        new_landing = landed and not self._landed
        self._landed = landed
        if new_landing:
            winner = self._judge_landing()
            if winner >= 0:
                return winner
        touching = self._touch_mask()
        if touching:
            new = touching & ~self._touching
            if new:
                self._events += [{"kind": "hit", "seat": seat} for seat in range(self.n_agents) if new >> seat & 1]
            teams = {int(self.team_of[seat]) for seat in range(self.n_agents) if touching >> seat & 1}
            if len(teams) == 2:
                player = self._ball_side()
            else:
                (player,) = teams
            self._set_rally(player=player, bounced=False, tossed=False)
        self._touching = touching
        return -1

    def _ball_side(self) -> int:
        """The side of the net the ball is on (exactly on it, the side it came from)."""
        x = self._work[self._ball_x_at]
        return self._side if x == 0.0 else int(x > 0.0)

    def _judge_landing(self) -> int:
        """The rally when the ball lands: the point's winner, or -1 when it bounced in."""
        player = self._player
        if self._tossed:
            return self._point(1 - player, "fault")
        if self._bounced:
            return self._point(player, "not_returned")
        side = self._ball_side()
        if side == player:
            return self._point(1 - player, "net")
        if abs(self._work[self._ball_x_at]) > HALF_LENGTH:  # beyond the baseline, or on the back fence
            return self._point(1 - player, "out")
        self._set_rally(player=player, bounced=True, tossed=False)
        self._events.append({"kind": "bounce", "side": side})
        return -1

    def _point(self, team: int, reason: str) -> int:
        self._events.append({"kind": "point", "team": team, "reason": reason})
        return team

    def _win_point(self, team: int) -> None:
        """Score the point for ``team``: the match ends at ``points``, else the next serve."""
        self.score[team] += 1
        self._work[self._score_at + team] = float(self.score[team])
        gain = self.measures.resource_gain
        gain[self._first_seats[team]: self._first_seats[team] + self.players_per_team] = 1.0 / self.players_per_team
        self._gained = True
        if self.score[team] >= self.points:
            self.game_over = True
            self._set_outcome()
            self._update_measures()
            return
        self._server = 1 - self._server
        self._serve()

    def _set_outcome(self) -> None:
        result = self.team_result()
        self.measures.outcome[:] = (2.0 * result - 1.0)[self.team_of]

    def observe(self) -> np.ndarray:
        # the product was taken with the measures; two ufuncs clip faster than np.clip
        clipped = np.minimum(self._obs_rows, self._obs_high, out=self._obs_work)
        return np.maximum(clipped, self._obs_low, out=clipped).astype(np.float32)

    def state(self) -> np.ndarray:
        state = self._state_matrix @ self._work
        return state.clip(self._state_low, self._state_high, out=state).astype(np.float32)

    def finish(self) -> None:
        self._record("finish")
        # a match cut at max_cycles goes to the team with more points, a draw on equal points
        self._set_outcome()

    def team_result(self) -> np.ndarray:
        # more points wins: 1 win, 0.5 draw, 0 loss
        return np.sign(self.score - self.score[::-1]) * 0.5 + 0.5

    # --- tools ---------------------------------------------------------------------------------
    @property
    def rally(self) -> dict[str, Any]:
        """The rally now: which team ``played`` the ball last, whether it ``bounced`` in since,
        whether it is a ``toss`` not yet struck, the ``side`` it is on and the side ``clock``
        (steps in a row), and the ``server`` of the point."""
        return {"played": self._player, "bounced": self._bounced, "toss": self._tossed, "side": self._side,
                "clock": self._clock, "server": self._server}

    def place(self, racket_xy: np.ndarray, ball_xy: np.ndarray, racket_velocity: np.ndarray | None = None,
              ball_velocity: np.ndarray | None = None, played: int = 0, bounced: bool = False,
              score: tuple[int, int] | None = None) -> None:
        """Put the bodies at given world positions and velocities with the ball in play, struck
        last by team ``played`` (having ``bounced`` in since, or not), for tests and scripted
        scenarios; the side clock starts afresh and the match continues from there, each team
        keeping its points (or taking ``score``). Each racket must stand within its side and reach,
        and the ball in the hall above the floor."""
        if self.world.space is None:
            raise RuntimeError("call reset(seed) before place()")
        racket_xy = np.asarray(racket_xy, dtype=np.float64).reshape(self.n_agents, 2)
        racket_velocity = (np.zeros((self.n_agents, 2)) if racket_velocity is None
                           else np.asarray(racket_velocity, dtype=np.float64).reshape(self.n_agents, 2))
        ball_xy = np.array(ball_xy, dtype=np.float64).reshape(2)
        ball_velocity = np.zeros(2) if ball_velocity is None else np.array(ball_velocity, dtype=np.float64).reshape(2)
        score = check_placement(racket_xy, ball_xy, played, score, self.team_of, self._team_sign, self.points)
        self._record("place", racket_xy.copy(), ball_xy.copy(), racket_velocity.copy(), ball_velocity.copy(),
                     played, bounced, score)
        self._move_bodies(racket_xy, racket_velocity, ball_xy, ball_velocity)
        if score is not None:
            self.score[:] = score
            self._work[self._score_at: self._score_at + 2] = self.score
        self._set_rally(player=int(played), bounced=bool(bounced), tossed=False)
        self._side = self._ball_side()
        self._clock = 0
        self._work[self._clock_at] = 0.0
        self._events = []
        self._measure_still_state()

    def render_topdown(self) -> np.ndarray:
        return court_picture(self._racket_pos, self._ball_state, self.team_of)

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        return court_scene(timestamp_ns, self._racket_pos, self._ball_state, self.team_of, self.players_per_team,
                           self.score)

    def human_controls(self, seat: int) -> TennisControls:
        return TennisControls(self, seat)

    # --- social tree and scripted play ---------------------------------------------------------
    @classmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        # the points' share at the root, the team's mean progress toward the ball, each seat's own
        return team_tree(n_teams, players_per_team, "resource_share")

    @staticmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        from arena_league.envs.games.tennis.heuristic import heuristic  # the scripted play, loaded when asked

        return heuristic(obs, action_type)

class TennisControls(MirroredCompassControls):
    """Compass moves of one's racket on the court as drawn (E = right, N = up), mirrored for the
    team that sees the court flipped."""

    move = "move your racket on the court as drawn"
    key_hint = ("Arrow keys or W A S D swing your racket on the court as drawn (two at once: diagonally); let go "
                "to stop pushing.")


RULES = TennisRules
