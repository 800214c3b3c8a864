"""The library of social-tree reward functions, each declared with its basic multi-agent scheme.

After Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence" (AAAI 2020): every node of the social tree carries one of five basic multi-agent
reward schemes and a ready-to-use reward function of that scheme. With ``x_j`` the performance of
agent (or child group) ``j`` and ``r_i`` the node's reward to ``i``, the schemes are

* NL, non-learnable: ``dr_i/dx_i = 0`` (nothing an agent does changes its reward);
* IS, isolated: ``dr_i/dx_i > 0`` and ``dr_i/dx_j = 0`` for ``j != i``;
* CP, competitive: ``dr_i/dx_i > 0`` and ``dr_i/dx_j < 0`` between the node's children;
* CL, collaborative: ``dr_i/dx_i > 0`` and ``dr_i/dx_j > 0``;
* CC, mixed (competitive and collaborative): ``dr_i/dx_j`` positive for some pairs (teammates)
  and negative for others (opponents).

A reward function maps the game's measures (``envs.core.Measures``) to one value per agent below
its node. Game rules emit measures only; every social reward is computed here.

Custom functions are registered with :func:`register_reward`; verification
(``envs.social.verify``) checks that a function behaves as the scheme it is declared with.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from arena_league.envs.core import Measures

SCHEMES: dict[str, str] = {
    "NL": "non-learnable: the reward does not depend on what the agents do",
    "IS": "isolated: each agent's reward depends on its own behaviour only",
    "CP": "competitive: a child's gain is the other children's loss",
    "CL": "collaborative: every agent below the node shares one reward",
    "CC": "mixed: teammates below the node gain together, opponents lose",
}


@dataclass
class NodeView:
    """What a reward function sees of its node: the agents below it and how they group.

    ``agents`` are seat indices below the node (in spec order); ``group`` gives, for each of them,
    the index of the node's child that holds it; ``n_groups`` is the number of children.
    ``memory`` is per-episode scratch space for stateful functions (e.g. ranking), cleared at reset.
    """

    agents: np.ndarray
    group: np.ndarray
    n_groups: int
    memory: dict[str, Any] = field(default_factory=dict)
    #: ``agents`` as an index (:func:`seat_index`): a slice where they are consecutive seats.
    index: Any = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.index = seat_index(self.agents)


def seat_index(agents: np.ndarray) -> Any:
    """``agents`` as a slice when they are consecutive seats in order (indexing with one is
    cheaper than with an array, and picks the same cells), else as they are."""
    if len(agents) and np.array_equal(agents, np.arange(agents[0], agents[0] + len(agents))):
        return slice(int(agents[0]), int(agents[0]) + len(agents))
    return agents


@dataclass
class RewardContext:
    """The step a reward is computed for."""

    measures: Measures
    previous: dict[str, np.ndarray]  # the measures of the previous step that functions need
    team_of: np.ndarray
    step: int
    ending: bool  # the episode ends with this step (game over or max_cycles)


RewardFn = Callable[[RewardContext, NodeView, dict[str, Any]], np.ndarray]


@dataclass(frozen=True)
class RewardFunction:
    """A reward function of the library: its scheme, the measures it reads, its parameters."""

    name: str
    scheme: str
    fn: RewardFn
    needs: tuple[str, ...]
    needs_previous: tuple[str, ...]
    defaults: dict[str, Any]
    doc: str
    grouped: RewardFn | None = None
    """The same reward for several sibling nodes in one call (see :func:`register_grouped`)."""

    def check_params(self, params: dict[str, Any]) -> dict[str, Any]:
        unknown = set(params) - set(self.defaults)
        if unknown:
            valid = ", ".join(sorted(self.defaults)) or "none"
            raise ValueError(
                f"reward function {self.scheme}/{self.name} has no parameter(s) {sorted(unknown)}; valid: {valid}"
            )
        merged = {**self.defaults, **params}
        validator = _PARAM_CHECKS.get(self.name)
        if validator:
            validator(merged)
        return merged


#: scheme -> name -> function
REWARD_FUNCTIONS: dict[str, dict[str, RewardFunction]] = {s: {} for s in SCHEMES}
_PARAM_CHECKS: dict[str, Callable[[dict[str, Any]], None]] = {}


def register_reward(name: str, scheme: str, needs: tuple[str, ...] = (), needs_previous: tuple[str, ...] = (),
                    **defaults: Any) -> Callable[[RewardFn], RewardFn]:
    """Declare a reward function of ``scheme`` under ``name`` (decorator).

    The function gets ``(ctx: RewardContext, node: NodeView, params: dict)`` and returns a float
    array with one reward per agent in ``node.agents``. ``needs`` names the measures it reads,
    ``needs_previous`` those it also reads from the previous step (``ctx.previous``).
    """
    if scheme not in SCHEMES:
        raise ValueError(f"unknown scheme {scheme!r}; valid schemes: {', '.join(SCHEMES)}")

    def decorate(fn: RewardFn) -> RewardFn:
        if name in REWARD_FUNCTIONS[scheme]:
            raise ValueError(f"a reward function {scheme}/{name} is already registered; pick another name")
        doc = (fn.__doc__ or "").strip().splitlines()[0] if fn.__doc__ else ""
        REWARD_FUNCTIONS[scheme][name] = RewardFunction(
            name, scheme, fn, tuple(needs), tuple(needs_previous), dict(defaults), doc
        )
        return fn

    return decorate


def register_grouped(name: str, scheme: str) -> Callable[[RewardFn], RewardFn]:
    """Give the registered reward ``scheme/name`` a grouped form (decorator): called with a view
    whose ``agents`` are those of several nodes of that reward (same parameters and scale, no agent
    in two of them) and whose ``group`` says which node each agent is under, it returns every
    agent's reward, the same numbers each node's own call gives. The tree then computes such
    siblings (e.g. the CL node of every team) in one call on the hot path."""

    def decorate(fn: RewardFn) -> RewardFn:
        function = lookup_reward(scheme, name)
        REWARD_FUNCTIONS[scheme][name] = dataclasses.replace(function, grouped=fn)
        return fn

    return decorate


def unregister_reward(name: str, scheme: str) -> None:
    """Remove a custom reward function (tests and notebooks that register throwaway ones)."""
    REWARD_FUNCTIONS[scheme].pop(name, None)


def lookup_reward(scheme: str, name: str) -> RewardFunction:
    if scheme not in SCHEMES:
        raise ValueError(f"unknown scheme {scheme!r}; valid schemes: {', '.join(SCHEMES)}")
    table = REWARD_FUNCTIONS[scheme]
    if name not in table:
        elsewhere = [s for s, t in REWARD_FUNCTIONS.items() if name in t]
        hint = f" ({name!r} is a {'/'.join(elsewhere)} function)" if elsewhere else ""
        raise ValueError(
            f"reward function {name!r} is not in scheme {scheme}{hint}; {scheme} functions: {', '.join(sorted(table))}"
        )
    return table[name]


# --- helpers -------------------------------------------------------------------------------------

def _zeros_for(node: NodeView) -> np.ndarray:
    """A cached read-only zero reward for the node's agents (callers only read rewards)."""
    zeros = node.memory.get("_zeros")
    if zeros is None:
        zeros = node.memory["_zeros"] = np.zeros(len(node.agents))
        zeros.flags.writeable = False
    return zeros


def is_cached_zeros(value: np.ndarray, node: NodeView) -> bool:
    """Whether a reward function returned the node's cached zeros (:func:`_zeros_for`): a step
    on which it pays nothing."""
    return value is node.memory.get("_zeros")


def _shared(node: NodeView, value: float) -> np.ndarray:
    """``value`` for every agent of the node, as a new array (ones times the value: the same
    numbers as ``np.full``, for less work on the hot path)."""
    ones = node.memory.get("_ones")
    if ones is None:
        ones = node.memory["_ones"] = np.ones(len(node.agents))
    return ones * value


def _per_group(values: np.ndarray, node: NodeView) -> np.ndarray:
    """Sum per child group of per-agent values of the node's agents."""
    return np.bincount(node.group, weights=values, minlength=node.n_groups)


def _zero_sum(group_values: np.ndarray) -> np.ndarray:
    return group_values - group_values.mean()


def _by_team(values: np.ndarray, teams: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean of per-agent values within each game team present; returns (team index per agent,
    team means indexed by that)."""
    present, inverse = np.unique(teams, return_inverse=True)
    sums = np.bincount(inverse, weights=values, minlength=len(present))
    counts = np.bincount(inverse, minlength=len(present))
    return inverse, sums / counts


# --- NL ------------------------------------------------------------------------------------------

@register_reward("none", "NL")
def _none(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """No reward (a node that only groups its children)."""
    return _zeros_for(node)


@register_reward("constant", "NL", value=1.0)
def _constant(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """A constant paid once, on the first step of every episode, whatever anyone does.

    (Paid every step it would not be non-learnable: agents could then earn more of it by making
    the episode last longer.)"""
    return np.full(len(node.agents), float(params["value"]) if ctx.step == 1 else 0.0)


# --- IS ------------------------------------------------------------------------------------------

@register_reward("target", "IS", needs=("target_distance",), needs_previous=("target_distance",))
def _target(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Progress toward one's target: the decrease of the distance to it this step."""
    a = node.index
    return ctx.previous["target_distance"][a] - ctx.measures.target_distance[a]


@register_reward("velocity_to_target", "IS", needs=("velocity_to_target",))
def _velocity_to_target(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Velocity component toward one's target."""
    return ctx.measures.velocity_to_target[node.agents].astype(np.float64, copy=False)


@register_reward("facing_target", "IS", needs=("facing_target",))
def _facing_target(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Cosine of the angle between one's heading and one's target."""
    return ctx.measures.facing_target[node.agents].astype(np.float64)


@register_reward("energy", "IS", needs=("energy",))
def _energy(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Energy cost: minus the control effort spent this step."""
    return -ctx.measures.energy[node.agents]


@register_reward("big_force", "IS", needs=("force",), threshold=1.0, penalty=1.0)
def _big_force(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Big-force penalty: minus ``penalty`` on each step the contact force exceeds ``threshold``."""
    return -float(params["penalty"]) * (ctx.measures.force[node.agents] > params["threshold"])


@register_reward("steady_velocity", "IS", needs=("speed",), needs_previous=("speed",))
def _steady_velocity(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Steady velocity: minus the change of one's speed this step."""
    a = node.agents
    return -np.abs(ctx.measures.speed[a] - ctx.previous["speed"][a])


@register_reward("time_penalty", "IS", needs=("active",), needs_previous=("active",), value=1.0)
def _time_penalty(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Time penalty: minus ``value`` for every step one is still in play."""
    return -float(params["value"]) * ctx.previous["active"][node.agents]


@register_reward("fall", "IS", needs=("fallen",))
def _fall(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Fall / head-down penalty: minus one on each step one is fallen."""
    return -ctx.measures.fallen[node.agents].astype(np.float64)


# --- CP ------------------------------------------------------------------------------------------

def _check_ranking(params: dict[str, Any]) -> None:
    if params["order"] not in ("depart", "survive"):
        raise ValueError(
            f"ranking order {params['order']!r} is not valid; use 'depart' (first to arrive ranks first) "
            "or 'survive' (last to be eliminated ranks first)"
        )
    if float(params["tie_penalty"]) < 0:
        raise ValueError("ranking tie_penalty must be >= 0 (it is subtracted from tied children)")


_PARAM_CHECKS["ranking"] = _check_ranking


@register_reward("ranking", "CP", needs=("active",), order="depart", tie_penalty=0.0)
def _ranking(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Ranking of the children by order of arrival ("depart") or elimination ("survive").

    A child group resolves when all its agents have arrived (depart) or none is alive (survive);
    groups resolving on the same step tie. Place p (0 = first) of G pays 1 - 2p/(G-1), ties the mean
    of their places, minus ``tie_penalty`` for each tied child; when one group is left it is placed
    at once, and groups unresolved at the end share the remaining places.
    """
    m = ctx.measures
    survive = params["order"] == "survive"
    flag = m.alive if survive else m.arrived
    if flag is None:
        needed = "alive" if survive else "arrived"
        raise ValueError(f"ranking with order {params['order']!r} needs the measure {needed!r}, which this game lacks")
    mem = node.memory
    n_groups = node.n_groups
    # (a few groups: Python lists beat numpy calls, and the places are the same Python floats)
    resolved: list[bool] | None = mem.get("resolved")
    if resolved is None:
        resolved = mem["resolved"] = [False] * n_groups
        mem["best_free"] = 0  # next place from the top (depart)
        mem["worst_free"] = n_groups - 1  # next place from the bottom (survive)
        mem["flag_count"] = -1
        mem["seats"] = list(zip(node.agents.tolist(), node.group.tolist()))
    values = flag.tolist()
    # arrival and elimination flags only ever flip one way: an unchanged count means no change
    count = len(values) - values.count(0)
    if mem.get("all_resolved") or (not ctx.ending and count == mem["flag_count"]):
        return _zeros_for(node)  # nothing can resolve on this step
    mem["flag_count"] = count
    # a group is open while one of its agents is alive (survive) or has not arrived (depart)
    open_g = [False] * n_groups
    for seat, group in mem["seats"]:
        if bool(values[seat]) is survive:
            open_g[group] = True
    newly = [not (is_open or done) for is_open, done in zip(open_g, resolved)]
    rewards_g = [0.0] * n_groups
    span = max(n_groups - 1, 1)
    tie_penalty = float(params["tie_penalty"])

    def place(groups: list[bool], from_top: bool) -> None:
        k = groups.count(True)
        if k == 0:
            return
        if from_top:
            first = mem["best_free"]
            mem["best_free"] += k
        else:
            first = mem["worst_free"] - k + 1
            mem["worst_free"] -= k
        mean_place = first + (k - 1) / 2.0
        value = 1.0 - 2.0 * mean_place / span - (tie_penalty if k > 1 else 0.0)
        for g, chosen in enumerate(groups):
            if chosen:
                rewards_g[g] = value
                resolved[g] = True

    place(newly, from_top=not survive)
    remaining = [not done for done in resolved]
    left = remaining.count(True)
    if left == 1 or (ctx.ending and left):
        # the last group's place is determined; at the end the unresolved share what is left
        place(remaining, from_top=survive)
    mem["all_resolved"] = False not in resolved
    return np.array([rewards_g[group] for _, group in mem["seats"]])


@register_reward("resource_share", "CP", needs=("resource_gain",))
def _resource_share(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Share of a limited resource: a child's take this step minus the children's mean take."""
    if not np.count_nonzero(ctx.measures.resource_gain):
        return _zeros_for(node)  # most steps nobody takes anything: every share is 0
    gains = _per_group(ctx.measures.resource_gain[node.agents], node)
    return _zero_sum(gains)[node.group]


@register_reward("win_loss", "CP", needs=("outcome",))
def _win_loss(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Zero-sum win/loss: at the end, a child's mean outcome minus the children's mean outcome."""
    if not ctx.ending:
        return _zeros_for(node)
    counts = np.bincount(node.group, minlength=node.n_groups)
    outcome_g = _per_group(ctx.measures.outcome[node.agents], node) / counts
    return _zero_sum(outcome_g)[node.group]


# --- CL ------------------------------------------------------------------------------------------

@register_reward("team_progress", "CL", needs=("object_progress",))
def _team_progress(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Team progress of a shared object: the distance it moved toward the goal, shared by all."""
    values = ctx.measures.object_progress[node.agents]
    return _shared(node, np.add.reduce(values, axis=None) / len(values))  # what ndarray.sum calls


@register_reward("team_target", "CL", needs=("target_distance",), needs_previous=("target_distance",))
def _team_target(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """The group's mean progress toward the targets of its members, shared by all."""
    a = node.agents
    progress = ctx.previous["target_distance"][a] - ctx.measures.target_distance[a]
    return _shared(node, progress.sum() / len(a))


@register_grouped("team_target", "CL")
def _team_target_grouped(ctx: RewardContext, nodes: NodeView, params: dict) -> np.ndarray:
    """``team_target`` of several nodes (``nodes.group``: each agent's node) at once."""
    a = nodes.agents
    progress = ctx.previous["target_distance"][a] - ctx.measures.target_distance[a]
    sizes = nodes.memory.get("_sizes")
    if sizes is None:
        sizes = nodes.memory["_sizes"] = np.bincount(nodes.group, minlength=nodes.n_groups).astype(float)
    return (_per_group(progress, nodes) / sizes)[nodes.group]


@register_reward("team_living_longer", "CL", needs=("active",), needs_previous=("active",))
def _team_living_longer(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Team living time, longer is better: +1 per step while anyone below is still in play."""
    return np.full(len(node.agents), float(ctx.previous["active"][node.agents].any()))


@register_reward("team_living_shorter", "CL", needs=("active",), needs_previous=("active",))
def _team_living_shorter(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Team living time, shorter is better: -1 per step while anyone below is still in play."""
    return np.full(len(node.agents), -float(ctx.previous["active"][node.agents].any()))


def _groups_living(ctx: RewardContext, nodes: NodeView, sign: float) -> np.ndarray:
    """``sign`` times 1.0 for each agent whose node has an agent in play before the step, else
    ``sign`` times 0.0 (a new array, or a cached read-only one while every node lives)."""
    mem = nodes.memory
    seats = mem.get("_seats")
    if seats is None:  # (cached: grouped views live as long as the tree)
        seats = mem["_seats"] = list(zip(nodes.agents.tolist(), nodes.group.tolist()))
        mem["_all_living"] = np.full(len(seats), sign * 1.0)
        mem["_all_living"].flags.writeable = False
    active = ctx.previous["active"].tolist()
    if False not in active:  # every seat in play: every node lives
        return mem["_all_living"]
    living = [sign * 0.0] * nodes.n_groups
    for seat, group in seats:
        if active[seat]:
            living[group] = sign * 1.0
    if sign * 0.0 not in living:  # (0.0 == -0.0: any node out)
        return mem["_all_living"]
    return np.array([living[group] for _, group in seats])


@register_grouped("team_living_longer", "CL")
def _team_living_longer_grouped(ctx: RewardContext, nodes: NodeView, params: dict) -> np.ndarray:
    """``team_living_longer`` of several nodes (``nodes.group``: each agent's node) at once."""
    return _groups_living(ctx, nodes, 1.0)


@register_grouped("team_living_shorter", "CL")
def _team_living_shorter_grouped(ctx: RewardContext, nodes: NodeView, params: dict) -> np.ndarray:
    """``team_living_shorter`` of several nodes at once (-0.0 where a node's agents are all out, as
    node by node)."""
    return _groups_living(ctx, nodes, -1.0)


# --- CC ------------------------------------------------------------------------------------------

@register_reward("team_win_loss", "CC", needs=("outcome",))
def _team_win_loss(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Mixed win/loss over the agents below, grouped by game team: one's team's mean outcome
    minus the mean over the teams present (teammates gain together, opponents lose)."""
    if not ctx.ending:
        return _zeros_for(node)
    inverse, means = _by_team(ctx.measures.outcome[node.agents], ctx.team_of[node.agents])
    return (means - means.mean())[inverse]


@register_reward("team_progress_race", "CC", needs=("object_progress",))
def _team_progress_race(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Mixed object race over the agents below, grouped by game team: one's team object's
    progress minus the mean progress of the teams present."""
    inverse, means = _by_team(ctx.measures.object_progress[node.agents], ctx.team_of[node.agents])
    return (means - means.mean())[inverse]
