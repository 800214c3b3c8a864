"""Game rules and the measures they emit.

A game module (one per game under ``envs/games/``) implements :class:`GameRules`: the state of
one match, its physics or board logic, the flattened vector observation of every seat, and the
*measures and events* of each step (distances, arrivals, eliminations, the progress of a shared
object, the final outcome). Rules never compute social rewards: the social tree
(``envs/social``) turns measures into rewards, so the same rules become a different social problem
when the tree changes (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for
Multi-Agent Intelligence", AAAI 2020, section "Social tree").

Conventions every game follows:

* seats are numbered ``0..n_agents-1`` in team order (team 0's players first); the PettingZoo
  agent names are ``player_<seat>``;
* all agents stay in the episode until it ends (an agent that arrived or died is *inactive*: its
  actions are ignored and its observation says so), so team rewards reach every member;
* every random draw comes from ``self.rng``, created in :meth:`GameRules.reset` from the seed;
* discrete actions arrive as ``int64[n_agents]``; continuous ones as ``float32[n_agents, act_dim]``
  already checked to lie in [-1, 1];
* every observation cell and every state cell has bounds, given by
  :meth:`GameRules.observation_bounds` and :meth:`GameRules.state_bounds` from the limits the game's
  manual documents (finite in every game of the catalog); ``observe()`` and ``state()`` keep every
  cell inside them;
* rules pickle and copy (``pickle``, ``copy.deepcopy``) into rules that go on exactly as the
  original would, at any point of a match.

Besides the match itself, a game declares, on its rules, everything the layers above need of it,
so that adding a game touches no other package:

* ``human_controls(seat)``: how a person plays a seat at a terminal (:mod:`arena_league.envs.controls`);
* ``scene_entities(timestamp_ns)``: the match as a 3D replay scene (:mod:`arena_league.envs.scene`);
* ``batched_matches``: its whole-array engine of many matches, if it has one (the contract is in
  ``arena_league.matchmaking.batched``);
* ``match_format`` and ``pair_points()``: whether its matches are played one at a time or in pairs
  (two matches from one seed with the teams' seats swapped), and what each team scored toward its
  pair in a match.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

import numpy as np

from arena_league.envs.controls import ActionControls, Controls
from arena_league.envs.options import Option, check_options

#: Every measure a game may emit, with its meaning. Arrays have one entry per seat.
MEASURE_DOCS: dict[str, str] = {
    "active": "bool: the seat is still playing (not arrived, not eliminated); always emitted",
    "alive": "bool: the seat has not been eliminated (games with elimination)",
    "arrived": "bool: the seat has reached its target (games with arrival)",
    "target_distance": "float: distance from the seat to its target",
    "velocity_to_target": "float: component of the seat's velocity along the direction to its target",
    "facing_target": "float: cosine of the angle between the seat's heading and its target",
    "energy": "float: control effort spent this step (mean squared action, 0..1)",
    "force": "float: magnitude of the contact force on the seat this step",
    "speed": "float: the seat's speed",
    "fallen": "bool: the seat has fallen or has its head down (robot games)",
    "object_progress": "float: distance the seat's team object moved toward its goal this step",
    "resource_gain": "float: amount of the limited resource the seat took this step",
    "outcome": "float: final result of the seat, +1 win, -1 loss, 0 draw; 0 until the game ends",
}

#: The values of :attr:`GameRules.match_format`.
MATCH_FORMATS: tuple[str, ...] = ("single", "paired")

_BOOL_MEASURES = frozenset({"active", "alive", "arrived", "fallen"})


@dataclass
class Measures:
    """The measures of one step, one array entry per seat; ``None`` where the game emits none.

    Rules update the arrays in place (or assign new ones) every step. ``outcome`` is filled when
    the game ends (including a truncation at ``max_cycles``, when rules must decide the result).
    """

    n_agents: int
    active: np.ndarray = field(default=None)  # type: ignore[assignment]
    alive: np.ndarray | None = None
    arrived: np.ndarray | None = None
    target_distance: np.ndarray | None = None
    velocity_to_target: np.ndarray | None = None
    facing_target: np.ndarray | None = None
    energy: np.ndarray | None = None
    force: np.ndarray | None = None
    speed: np.ndarray | None = None
    fallen: np.ndarray | None = None
    object_progress: np.ndarray | None = None
    resource_gain: np.ndarray | None = None
    outcome: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.active is None:
            self.active = np.ones(self.n_agents, dtype=bool)

    @classmethod
    def allocate(cls, n_agents: int, names: frozenset[str] | set[str] | tuple[str, ...],
                 n_slots: int | None = None) -> Measures:
        """Zeroed arrays for the named measures (bools for flags, float64 otherwise); with
        ``n_slots``, the measures of that many matches at once: arrays ``[n_slots, n_agents]``
        (a whole-array engine's, see :meth:`row`)."""
        unknown = set(names) - set(MEASURE_DOCS)
        if unknown:
            raise ValueError(f"unknown measures {sorted(unknown)}; valid: {sorted(MEASURE_DOCS)}")
        shape = n_agents if n_slots is None else (n_slots, n_agents)
        m = cls(n_agents, active=np.ones(shape, dtype=bool))
        for name in names:
            if name == "active":
                continue
            dtype = bool if name in _BOOL_MEASURES else np.float64
            setattr(m, name, np.zeros(shape, dtype=dtype))
        if "alive" in names:
            m.alive[:] = True
        return m

    def row(self, slot: int) -> Measures:
        """The measures of match ``slot`` of measures held for many matches (every array's first
        axis is the match): the same class with each array replaced by its row ``slot`` (a view,
        so it follows the many-match arrays when they are updated in place)."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return type(self)(**{name: value[slot] if isinstance(value, np.ndarray) else value
                             for name, value in values.items()})

    def copy_of(self, names: tuple[str, ...]) -> dict[str, np.ndarray]:
        """A snapshot of the named measures (for rewards that need the previous step)."""
        return {n: getattr(self, n).copy() for n in names}


class GameRules(ABC):
    """The rules of one match of a game, with no knowledge of rewards.

    Subclasses set the class attributes, build their spaces' sizes in ``__init__`` and implement
    the abstract methods. The module docstring of each game is its manual.
    """

    #: The game's name as in its id, e.g. ``"Crossroads"``.
    name: ClassVar[str]
    #: Id version: ``<name>-<x>T<y>P-v<version>``.
    version: ClassVar[int] = 1
    #: The (teams, players per team) layouts that make sense for this game.
    layouts: ClassVar[tuple[tuple[int, int], ...]]
    #: Action variants offered, first is the default.
    action_types: ClassVar[tuple[str, ...]] = ("discrete",)
    #: True for games where one seat moves at a time (these also get a native AEC env).
    turn_based: ClassVar[bool] = False
    #: Names of the measures this game emits (keys of MEASURE_DOCS, ``active`` included).
    measures_provided: ClassVar[frozenset[str]]
    #: Episode length cap used when ``make(..., max_cycles=None)``.
    default_max_cycles: ClassVar[int]
    #: One-line description for ``arena-league games``.
    summary: ClassVar[str] = ""
    #: The game's whole-array engine, or None: a class called as ``batched_matches(rules, n_slots,
    #: max_cycles)`` whose instances step ``n_slots`` matches of these rules' layout and options
    #: together, with exactly the moves and results of one match at a time (the engine-adapter
    #: contract of ``arena_league.matchmaking.batched``).
    batched_matches: ClassVar[Callable[..., Any] | None] = None
    #: How the league plays the game's matches: ``"single"``, each match on its own (its
    #: :meth:`team_result` is what is rated), or ``"paired"``, in pairs of two matches (halves) from one
    #: seed with the two teams' seats swapped, for games whose two roles differ (a runner and a
    #: blocker): the pair is decided by :meth:`pair_points`, summed over the two halves for each agent
    #: (an agent's team in each half), higher wins, equal totals draw. Paired games have two teams;
    #: the catalog refuses any other value (:meth:`check_match_format`).
    match_format: ClassVar[str] = "single"
    #: The game's keyword options (``make(game_id, **options)``), declared once: the error messages,
    #: the manual and the catalogs read them. A game that declares them checks its keyword arguments
    #: with :meth:`checked_options` in ``__init__``; one that declares none checks its own.
    options: ClassVar[tuple[Option, ...]] = ()

    # Set by every subclass __init__:
    n_teams: int
    players_per_team: int
    n_agents: int
    action_type: str
    team_of: np.ndarray  # int64[n_agents], team index of each seat
    obs_dim: int
    state_dim: int
    n_actions: int  # discrete variant: number of actions
    act_dim: int  # continuous variant: action vector size
    action_meanings: tuple[str, ...] = ()  # discrete variant: what each action index does
    measures: Measures
    rng: np.random.Generator
    #: True once the rules say the match is over (everyone arrived, a goal, five in a row...).
    game_over: bool = False
    #: The step at which the match is cut: the env playing these rules sets it to its own
    #: ``max_cycles``; None for rules played without an env (then ``default_max_cycles``). Only
    #: :meth:`pair_points` of games that score time reads it.
    max_cycles: int | None = None

    def __init__(self, n_teams: int, players_per_team: int, action_type: str) -> None:
        self.n_teams = n_teams
        self.players_per_team = players_per_team
        self.n_agents = n_teams * players_per_team
        self.action_type = action_type
        self.team_of = np.repeat(np.arange(n_teams, dtype=np.int64), players_per_team)
        self.measures = Measures.allocate(self.n_agents, self.measures_provided)
        self.rng = np.random.default_rng(0)

    @classmethod
    def check_layout(cls, n_teams: int, players_per_team: int, action_type: str) -> None:
        """Refuse a layout or an action type the game does not offer (a ValueError listing those it does)."""
        if (n_teams, players_per_team) not in cls.layouts:
            valid = ", ".join(f"{t}T{p}P" for t, p in cls.layouts)
            raise ValueError(f"{cls.name} has no {n_teams}T{players_per_team}P layout; valid layouts: {valid}")
        if action_type not in cls.action_types:
            raise ValueError(f"{cls.name} action_type {action_type!r} is not offered; valid: "
                             f"{', '.join(cls.action_types)}")

    @classmethod
    def checked_options(cls, given: Mapping[str, Any]) -> dict[str, Any]:
        """Every declared option's value from ``given`` or its default (``None`` for a default the
        game computes from its layout); an unknown name or a bad value raises one ValueError naming
        the game, the option, what it accepts and its default (:func:`~arena_league.envs.options.check_options`)."""
        return check_options(cls.name, given, cls.options)

    @classmethod
    def check_match_format(cls) -> None:
        """Refuse a ``match_format`` that is not one of :data:`MATCH_FORMATS`, and ``"paired"`` for a
        game with a layout of other than two teams (a pair swaps the two teams' seats)."""
        if cls.match_format not in MATCH_FORMATS:
            raise ValueError(f"{cls.name} declares match_format {cls.match_format!r}; valid: "
                             f"{', '.join(map(repr, MATCH_FORMATS))}")
        if cls.match_format == "paired":
            others = [f"{t}T{p}P" for t, p in cls.layouts if t != 2]
            if others:
                raise ValueError(f"{cls.name} declares match_format 'paired' but offers {', '.join(others)}: a pair "
                                 "swaps the seats of two teams; declare 'single' or offer two-team layouts only")

    # --- the match -------------------------------------------------------------------------
    @abstractmethod
    def reset(self, seed: int) -> None:
        """Start a new match. Create ``self.rng = np.random.default_rng(seed)`` and draw from it
        only; reset ``measures`` (``outcome`` to 0, ``active`` to True) and ``game_over``."""

    @abstractmethod
    def step(self, actions: np.ndarray) -> None:
        """Advance one step with validated actions of every seat (inactive seats' are ignored);
        update ``measures`` (and ``game_over``; ``outcome`` when the game ends)."""

    @abstractmethod
    def observe(self) -> np.ndarray:
        """A new ``float32[n_agents, obs_dim]`` array: each seat's flattened observation."""

    @abstractmethod
    def state(self) -> np.ndarray:
        """A new ``float32[state_dim]`` array: the global state."""

    @abstractmethod
    def render_topdown(self) -> np.ndarray:
        """A ``uint8[H, W, 3]`` picture of the whole arena from above, drawn without a display."""

    @abstractmethod
    def finish(self) -> None:
        """Called once when the episode is cut at ``max_cycles`` before the rules ended it:
        set ``measures.outcome`` to the result the rules give a timed-out match."""

    @abstractmethod
    def team_result(self) -> np.ndarray:
        """``float64[n_teams]`` final score of each team, higher is better (win 1 / draw 0.5 /
        loss 0 in two-team games; the finishing order, as n_teams-1-position, with more teams).
        Valid once the episode ended."""

    def pair_points(self) -> np.ndarray:
        """``float64[n_teams]``: what each team scored toward its pair in this match (a half of a
        pair, see :attr:`match_format`); valid once the episode ended. Default: :meth:`team_result`,
        so a pair of an ordinary two-team game is decided by its points over both seatings, as a
        colour-swapped pair of games in chess."""
        return self.team_result()

    @classmethod
    @abstractmethod
    def default_tree(cls, n_teams: int, players_per_team: int) -> dict:
        """The default social tree spec of this layout, mirroring the paper."""

    @classmethod
    def example_trees(cls, n_teams: int, players_per_team: int) -> dict[str, dict]:
        """Other social trees of this layout worth starting from (a paper's case study), by name.
        Default: none."""
        return {}

    @staticmethod
    @abstractmethod
    def heuristic(obs: np.ndarray, action_type: str) -> np.ndarray:
        """A simple scripted policy, deterministic, from the flattened observations
        ``float32[N, obs_dim]`` of N seats (any game, any seat) to their actions
        (``int64[N]`` or ``float32[N, act_dim]``). Used as the built-in heuristic agent and by
        social-tree verification as the 'skilled' end of its policy space."""

    #: A game may offer a search agent over its own rules (GoBang over its whole board, Snake over
    #: each seat's window, FightForFood over a model of its pen), ``search(obs, uniforms, *,
    #: action_type, width, rollouts, horizon, epsilon)``: from ``float32[N, obs_dim]`` and
    #: ``float64[N]`` (one uniform per seat) to actions of ``action_type``, deterministic given them; a
    #: budget the game cannot search raises ValueError (also for N = 0, which checks it).
    #: ``arena_league.policies.scripted`` names and bounds the budget; None where the game has none.
    search: ClassVar[Callable[..., np.ndarray] | None] = None
    #: What ``search-wW-rR-hH-eE`` means in this game, in words (population provenance quotes it).
    search_budget_meaning: ClassVar[str] = ""
    #: The versions of the search agent: the first is named without a version; a later one, improved
    #: after populations were built with the first, adds ``-vV`` to the name and is passed to
    #: ``search`` as ``version=V`` (the first never is, so a game with one version takes no argument).
    search_versions: ClassVar[tuple[int, ...]] = (1,)
    #: Why this game's search plays no random rollouts, where it plays none: ``arena_league.policies.scripted``
    #: then refuses any ``R`` but 1 with this reason (None: the game takes rollouts).
    search_without_rollouts: ClassVar[str | None] = None
    #: A game may offer its heuristic with other constants, ``heuristic(obs, action_type, **options)``:
    #: each option's (low, high) bounds, by name. ``arena_league.policies.scripted`` names such a
    #: tuned heuristic with its options, ``heuristic-lane0.6-side0.3``; none where the game has none.
    heuristic_options: ClassVar[dict[str, tuple[float, float]]] = {}
    #: What the options mean, in words (population provenance quotes it).
    heuristic_options_meaning: ClassVar[str] = ""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.masks_actions = cls.action_mask is not GameRules.action_mask

    # --- bounds --------------------------------------------------------------------------------
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)``, each ``float32[obs_dim]``: the lowest and highest value of every
        observation cell, as the game's manual documents them (the env's observation space).
        :meth:`observe` keeps every cell inside, clipping what the physics can carry past a limit.
        Default: unbounded (every game of the catalog gives finite bounds)."""
        return _unbounded(self.obs_dim)

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)``, each ``float32[state_dim]``: the bounds of every global state cell (the
        env's state space), kept by :meth:`state`. Default: unbounded."""
        return _unbounded(self.state_dim)

    # --- optional ------------------------------------------------------------------------------
    #: Whether the game has illegal actions: true for rules that override :meth:`action_mask`
    #: (set for every subclass). Their env observations are PettingZoo's dicts with the mask.
    masks_actions: ClassVar[bool] = False

    def action_mask(self) -> np.ndarray | None:
        """``bool[n_agents, n_actions]`` of legal actions, for games that have illegal moves
        (overriding it makes :attr:`masks_actions` true)."""
        return None

    def current_player(self) -> int | None:
        """Turn-based games: the seat to move."""
        return None

    def random_action(self, seat: int, rng: np.random.Generator) -> np.ndarray | int:
        """A uniformly random *legal* action for ``seat`` drawn from ``rng``."""
        if self.action_type == "discrete":
            mask = self.action_mask()
            if mask is not None:
                legal = np.flatnonzero(mask[seat])
                if len(legal):
                    return int(legal[rng.integers(len(legal))])
            return int(rng.integers(self.n_actions))
        return rng.uniform(-1.0, 1.0, self.act_dim).astype(np.float32)

    def events(self) -> list[dict]:
        """Events of the last step for replays and logs, e.g. ``{"kind": "arrive", "seat": 2}``."""
        return []

    # --- what the layers above ask of a game -------------------------------------------------------
    def human_controls(self, seat: int) -> Controls:
        """How a person plays ``seat`` at a terminal. Default: :class:`~arena_league.envs.controls.ActionControls`
        (the actions by number or name under a text view of the top-down picture; discrete actions
        only). Games with a board, a seat frame or continuous actions give their own."""
        return ActionControls(self, seat)

    def scene_entities(self, timestamp_ns: int) -> list[dict[str, Any]]:
        """The match now as ``foxglove.SceneEntity`` dicts stamped ``timestamp_ns``, built with
        :mod:`arena_league.envs.scene`, entity ids stable across steps: what a replay shows."""
        raise ValueError(f"{self.name} has no replay scene: give {type(self).__name__} a "
                         "scene_entities(timestamp_ns) method returning foxglove.SceneEntity dicts built "
                         "with arena_league.envs.scene")


def cell_bounds(*runs: tuple[float, float, int]) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)`` ``float32`` arrays from runs of ``(low, high, cells)``, in cell order."""
    low = np.concatenate([np.full(cells, lo, dtype=np.float64) for lo, _, cells in runs])
    high = np.concatenate([np.full(cells, hi, dtype=np.float64) for _, hi, cells in runs])
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high)) and np.all(low <= high)):
        raise ValueError("cell bounds must be finite with low <= high in every run (low, high, cells)")
    return low.astype(np.float32), high.astype(np.float32)


def _unbounded(cells: int) -> tuple[np.ndarray, np.ndarray]:
    return np.full(cells, -np.inf, dtype=np.float32), np.full(cells, np.inf, dtype=np.float32)


class ReplayedMatch:
    """Pickling and copying by playing the match again, for rules whose state no API can copy.

    Chipmunk (pymunk) keeps the contacts of the last steps, whose accumulated impulses start the
    next step's solver, and a collision tree shaped by the bodies' history; neither can be read or
    written, so a space rebuilt from the bodies' positions and velocities goes on differently.
    Rules that mix this class in (before :class:`GameRules`) set ``_arguments`` (their constructor's
    positional and keyword arguments) in ``__init__`` and note every call that changes the match:
    :meth:`_record_reset` in ``reset`` and :meth:`_record` in ``step``, ``finish`` and any tool that
    moves bodies. They pickle as those arguments and calls; unpickling builds new rules and makes
    the same calls, so a copy goes on exactly as the original does (a copy costs one replay of the
    match so far).
    """

    _arguments: tuple[tuple[Any, ...], dict[str, Any]]
    _calls: list[tuple[str, tuple[Any, ...]]]

    def _record_reset(self, seed: int) -> None:
        self._calls = [("reset", (seed,))]

    def _record(self, method: str, *args: Any) -> None:
        """Note a call of ``method`` with ``args`` (which the caller no longer changes)."""
        self._calls.append((method, args))

    def __getstate__(self) -> dict[str, Any]:
        return {"arguments": self._arguments, "calls": list(self._calls)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        args, kwargs = state["arguments"]
        self.__init__(*args, **kwargs)  # type: ignore[misc]
        for method, call_args in state["calls"]:
            getattr(self, method)(*call_args)
