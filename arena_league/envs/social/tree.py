"""The social tree: agents are leaves, every node carries a reward scheme, a function and a scale.

After Song et al., "Arena" (AAAI 2020). An agent's reward is the sum, over the nodes on its path
from the root, of ``scale * node reward``; a node's reward reaches every agent below it. A node
may carry ``"board": n``, a broadcast board of n floats that its descendants write (an extra part
of their action) and read (an extra part of their observation).

Spec (a dict, or the same as YAML/JSON)::

    {"scheme": "CP", "reward": "ranking", "scale": 100, "params": {"order": "depart"},
     "children": [
        {"scheme": "CL", "reward": "team_target", "scale": 10, "board": 4, "children": [
            {"agent": "player_0", "scheme": "IS", "reward": "target", "scale": 1},
            "player_1"]},
        {"scheme": "CL", "reward": "team_target", "children": ["player_2", "player_3"]}]}
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.envs.bounded import MAX_TEXT_BYTES, BoundedInputError, load_json, load_yaml
from arena_league.envs.social.rewards import (
    SCHEMES,
    NodeView,
    RewardContext,
    RewardFunction,
    is_cached_zeros,
    lookup_reward,
    seat_index,
)

_NODE_KEYS = {"scheme", "reward", "scale", "params", "children", "board", "name"}
_LEAF_KEYS = {"agent", "scheme", "reward", "scale", "params", "name"}
_DEFAULT_REWARD = {"NL": "none"}


class TreeSpecError(ValueError):
    """A social tree spec that cannot be built; the message names the node and the fix."""


@dataclass
class SocialNode:
    """One compiled node. ``agents`` are seat indices below it; ``view.group`` maps each to a child."""

    path: str  # e.g. "root", "root/0", "root/1/player_3"
    scheme: str
    reward: RewardFunction
    params: dict[str, Any]
    scale: float
    agents: np.ndarray
    children: list[SocialNode]
    view: NodeView
    board: int = 0
    agent_leaf: str | None = None  # the agent name when this node is an agent leaf with a reward
    label: str | None = None

    def describe(self) -> dict[str, Any]:
        return {
            "path": self.path,
            "scheme": self.scheme,
            "reward": self.reward.name,
            "scale": self.scale,
            "agents": [int(a) for a in self.agents],
            "board": self.board,
        }


@dataclass
class SocialTree:
    """A validated, compiled social tree over the seats of one game layout."""

    spec: dict[str, Any]
    agent_names: list[str]
    nodes: list[SocialNode]  # pre-order, root first
    team_of: np.ndarray
    previous_needed: tuple[str, ...] = ()
    boards: list[SocialNode] = field(default_factory=list)  # nodes with a board, pre-order
    board_slices: dict[int, list[tuple[int, slice]]] = field(default_factory=dict)  # seat -> [(board idx, msg slice)]
    #: The per-step evaluation plan: nodes that can pay anything, with IS nodes of the same function,
    #: parameters and scale fused into one (IS functions are per agent, so fusing changes nothing).
    plan: list[tuple[Any, NodeView, dict[str, Any], float]] = field(default_factory=list)

    # --- construction ----------------------------------------------------------------------------
    @classmethod
    def build(cls, spec: Any, agent_names: Sequence[str], team_of: np.ndarray,
              measures_provided: frozenset[str], game: str = "this game") -> SocialTree:
        """Validate ``spec`` (dict, or a path to a YAML/JSON file) against the seats and measures."""
        spec = load_tree_spec(spec)
        if not isinstance(spec, Mapping):
            raise TreeSpecError(f"a social tree spec is a dict (the root node), not {type(spec).__name__}")
        names = list(agent_names)
        index = {n: i for i, n in enumerate(names)}
        seen: dict[str, str] = {}
        nodes: list[SocialNode] = []
        on_stack: set[int] = set()

        def fail(path: str, problem: str) -> None:
            raise TreeSpecError(f"social tree node {path}: {problem}")

        def reward_of(path: str, raw: Mapping) -> tuple[str, RewardFunction, dict, float]:
            scheme = raw.get("scheme")
            if scheme is None:
                fail(path, f"missing 'scheme'; give one of {', '.join(SCHEMES)}")
            if scheme not in SCHEMES:
                fail(path, f"unknown scheme {scheme!r}; valid schemes: {', '.join(SCHEMES)} ({_scheme_help()})")
            name = raw.get("reward", _DEFAULT_REWARD.get(scheme))
            if name is None:
                fail(path, f"missing 'reward'; {scheme} functions: {', '.join(sorted(_functions(scheme)))}")
            try:
                fn = lookup_reward(scheme, name)
                params = fn.check_params(dict(raw.get("params") or {}))
            except ValueError as exc:
                fail(path, str(exc))
            missing = [m for m in fn.needs + fn.needs_previous if m not in measures_provided]
            if missing:
                fail(path, f"reward {scheme}/{name} needs the measure(s) {missing}, which {game} does not emit; "
                     f"{game} emits: {', '.join(sorted(measures_provided))}")
            scale = raw.get("scale", 1.0)
            if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not np.isfinite(scale):
                fail(path, f"'scale' must be a finite number, not {scale!r}")
            return scheme, fn, params, float(scale)

        def visit(raw: Any, path: str) -> tuple[list[int], SocialNode | None]:
            """Returns the seats below ``raw`` and its compiled node (None for a bare agent)."""
            if isinstance(raw, str):
                if raw not in index:
                    fail(path, f"unknown agent {raw!r}; agents of {game}: {', '.join(names)}")
                if raw in seen:
                    fail(path, f"agent {raw!r} is listed twice (also at {seen[raw]}); each agent is one leaf")
                seen[raw] = path
                return [index[raw]], None
            if not isinstance(raw, Mapping):
                fail(path, f"a node is a dict or an agent name, not {type(raw).__name__} {raw!r}")
            if id(raw) in on_stack:
                fail(path, "the tree has a cycle (a node is its own descendant); a social tree must be a tree")
            if "agent" in raw:
                unknown = set(raw) - _LEAF_KEYS
                if unknown:
                    fail(path, f"unknown key(s) {sorted(unknown)} on an agent leaf; valid: {sorted(_LEAF_KEYS)}")
                agent = raw["agent"]
                seats, _ = visit(agent, path)
                if "scheme" not in raw and "reward" not in raw:
                    return seats, None
                scheme, fn, params, scale = reward_of(path, raw)
                if scheme not in ("IS", "NL"):
                    fail(path, f"an agent leaf can carry only an IS or NL reward (one agent cannot compete or "
                         f"collaborate with itself); put the {scheme} reward on a node above it")
                arr = np.array(seats, dtype=np.int64)
                node = SocialNode(path, scheme, fn, params, scale, arr, [],
                                  NodeView(arr, np.zeros(1, dtype=np.int64), 1), agent_leaf=agent,
                                  label=raw.get("name"))
                return seats, node
            unknown = set(raw) - _NODE_KEYS
            if unknown:
                fail(path, f"unknown key(s) {sorted(unknown)}; valid keys: {sorted(_NODE_KEYS)} "
                     "(or 'agent' for a leaf)")
            children = raw.get("children")
            if not isinstance(children, Sequence) or isinstance(children, (str, bytes)) or not children:
                fail(path, "a node needs a non-empty 'children' list (agent names or nodes)")
            scheme, fn, params, scale = reward_of(path, raw)
            if scheme in ("CP", "CC") and len(children) < 2:
                fail(path, f"a {scheme} node needs at least two children to compete between")
            board = raw.get("board", 0)
            if isinstance(board, bool) or not isinstance(board, int) or board < 0:
                fail(path, f"'board' must be a non-negative integer number of floats, not {board!r}")
            on_stack.add(id(raw))
            node = SocialNode(path, scheme, fn, params, scale, np.zeros(0, np.int64), [], None,  # type: ignore[arg-type]
                              board=board, label=raw.get("name"))
            nodes.append(node)
            seats: list[int] = []
            groups: list[int] = []
            for k, child in enumerate(children):
                if isinstance(child, str):
                    child_path = f"{path}/{child}"
                elif isinstance(child, Mapping) and isinstance(child.get("agent"), str):
                    child_path = f"{path}/{child['agent']}"
                else:
                    child_path = f"{path}/{k}"
                child_seats, child_node = visit(child, child_path)
                seats += child_seats
                groups += [k] * len(child_seats)
                if child_node is not None:
                    node.children.append(child_node)
                    if child_node.agent_leaf is not None:
                        nodes.append(child_node)
            on_stack.discard(id(raw))
            node.agents = np.array(seats, dtype=np.int64)
            node.view = NodeView(node.agents, np.array(groups, dtype=np.int64), len(children))
            return seats, node

        _, root = visit(spec, "root")
        if root is None or root.agent_leaf is not None:
            raise TreeSpecError("the root of a social tree must be a node with 'scheme' and 'children', not an agent")
        missing = [n for n in names if n not in seen]
        if missing:
            raise TreeSpecError(f"social tree leaves out agent(s) {', '.join(missing)}; every agent of {game} "
                                f"({', '.join(names)}) must be a leaf exactly once")
        previous = sorted({m for n in nodes for m in n.reward.needs_previous})
        tree = cls(dict(spec), names, nodes, np.asarray(team_of, dtype=np.int64), tuple(previous))
        tree.plan = _evaluation_plan(nodes, len(names))
        tree.boards = [n for n in nodes if n.board > 0]
        for b, node in enumerate(tree.boards):
            for seat in node.agents:
                tree.board_slices.setdefault(int(seat), []).append((b, slice(0, node.board)))
        # message slices in the order the seat's boards appear root-to-leaf (pre-order keeps that)
        for parts in tree.board_slices.values():
            offset = 0
            for i, (b, _) in enumerate(parts):
                width = tree.boards[b].board
                parts[i] = (b, slice(offset, offset + width))
                offset += width
        return tree

    # --- use ---------------------------------------------------------------------------------------
    @property
    def n_agents(self) -> int:
        return len(self.agent_names)

    def board_width(self, seat: int) -> int:
        """Floats of board message (action) and of board content (observation) for ``seat``."""
        return sum(s.stop - s.start for _, s in self.board_slices.get(seat, ()))

    def reset(self) -> None:
        for node in self.nodes:
            node.view.memory.clear()

    def rewards(self, ctx: RewardContext, per_node: np.ndarray | None = None) -> np.ndarray:
        """Every seat's reward for the step; ``per_node`` (``[n_nodes, n_agents]``), when given,
        receives each node's unscaled reward (for verification)."""
        total = np.zeros(self.n_agents)
        if per_node is None:
            for fn, view, params, scale, where, first in self.plan:
                value = fn(ctx, view, params)
                # cached zeros add +0.0: nothing to do while no call before has touched those rewards
                if first and is_cached_zeros(value, view):
                    continue
                if where is None:  # every seat: an in-place add, without the slice
                    total += value if scale == 1.0 else scale * value  # (1.0 * x is x, bit for bit)
                else:
                    total[where] += value if scale == 1.0 else scale * value
            return total
        for k, node in enumerate(self.nodes):
            value = node.reward.fn(ctx, node.view, node.params)
            per_node[k, node.agents] += value
            if node.scale != 0.0:
                total[node.agents] += node.scale * value
        return total

    def describe(self) -> list[dict[str, Any]]:
        return [n.describe() for n in self.nodes]


def _evaluation_plan(nodes: list[SocialNode], n_agents: int
                     ) -> list[tuple[Any, NodeView, dict[str, Any], float, Any, bool]]:
    """The calls of a step: IS leaves of one reward computed in one call (every agent once), as are
    sibling nodes of a reward with a grouped form (each team's CL node), which takes the place of
    the first of them (each agent's reward is summed in the same order as node by node). Each call
    comes with where its rewards go: None for every seat in order (added in place), a slice when its
    agents are consecutive seats (cheaper than indexing by an array, and the same sums)."""
    plan: list[tuple[Any, NodeView, dict[str, Any], float] | None] = []
    fused: dict[tuple, list[SocialNode]] = {}
    siblings: dict[tuple, list[tuple[int, SocialNode]]] = {}
    for node in nodes:
        if node.scale == 0.0 or (node.scheme == "NL" and node.reward.name == "none"):
            continue  # pays nothing, ever
        key = (node.scheme, node.reward.name, json.dumps(node.params, sort_keys=True, default=str), node.scale)
        if node.scheme == "IS":
            fused.setdefault(key, []).append(node)
            continue
        if node.reward.grouped is not None:
            siblings.setdefault(key, []).append((len(plan), node))
        plan.append((node.reward.fn, node.view, node.params, node.scale))
    for placed in siblings.values():
        group = [node for _, node in placed]
        agents = np.concatenate([n.agents for n in group])
        if len(group) > 1 and len(np.unique(agents)) == len(agents):  # disjoint: one call
            view = NodeView(agents, np.repeat(np.arange(len(group)), [len(n.agents) for n in group]), len(group))
            plan[placed[0][0]] = (group[0].reward.grouped, view, group[0].params, group[0].scale)
            for place, _ in placed[1:]:
                plan[place] = None
    calls = [entry for entry in plan if entry is not None]
    for group in fused.values():
        agents = np.concatenate([n.agents for n in group])
        if len(group) > 1 and len(np.unique(agents)) == len(agents):
            view = NodeView(agents, np.arange(len(agents)), len(agents))
            calls.append((group[0].reward.fn, view, group[0].params, group[0].scale))
        else:
            calls += [(n.reward.fn, n.view, n.params, n.scale) for n in group]
    reached: set[int] = set()
    placed_calls = []
    for call in calls:
        agents = call[1].agents.tolist()
        where = seat_index(call[1].agents)
        if isinstance(where, slice) and where == slice(0, n_agents):
            where = None
        placed_calls.append((*call, where, reached.isdisjoint(agents)))
        reached.update(agents)
    return placed_calls


def team_groups(n_teams: int, players_per_team: int, member: Callable[[int], Any] = "player_{}".format) -> list[Any]:
    """A root's children, one per team: ``member(seat)`` of each agent when a team has one player,
    else an NL node over each team's members (the teams of a CP root whose members share no reward)."""
    if players_per_team == 1:
        return [member(t) for t in range(n_teams)]
    return [{"scheme": "NL", "reward": "none",
             "children": [member(t * players_per_team + p) for p in range(players_per_team)]}
            for t in range(n_teams)]


def team_tree(n_teams: int, players_per_team: int, root: str, *, team: str = "team_target", leaf: str = "target",
              root_scale: float = 100, team_scale: float = 10, leaf_scale: float = 1) -> dict[str, Any]:
    """The tree spec of the Arena paper's convention: CP ``root`` over a CL ``team`` node per team
    (when a team has two or more players) over an IS ``leaf`` per agent; with one player a team,
    the leaves sit under the root."""
    def leaf_of(seat: int) -> dict[str, Any]:
        return {"agent": f"player_{seat}", "scheme": "IS", "reward": leaf, "scale": leaf_scale}

    if players_per_team == 1:
        children: list[dict[str, Any]] = [leaf_of(t) for t in range(n_teams)]
    else:
        children = [{"scheme": "CL", "reward": team, "scale": team_scale,
                     "children": [leaf_of(t * players_per_team + p) for p in range(players_per_team)]}
                    for t in range(n_teams)]
    return {"scheme": "CP", "reward": root, "scale": root_scale, "children": children}


def _functions(scheme: str) -> list[str]:
    from arena_league.envs.social.rewards import REWARD_FUNCTIONS

    return list(REWARD_FUNCTIONS[scheme])


def _scheme_help() -> str:
    return "; ".join(f"{k}: {v}" for k, v in SCHEMES.items())


def load_tree_spec(spec: Any) -> Any:
    """A spec given as a dict stays; a path (str or Path) to a .yaml/.yml/.json file is read, and a
    string starting with ``{`` is JSON; either within :mod:`arena_league.envs.bounded`'s bounds
    (size, nesting, no YAML aliases)."""
    if isinstance(spec, (str, Path)) and not (isinstance(spec, str) and spec.strip().startswith("{")):
        path = Path(spec)
        if not path.is_file():
            raise TreeSpecError(f"social tree file {path} does not exist" if not path.exists() else
                                f"social tree file {path} is not a file; give a .yaml or .json file")
        what = f"social tree file {path}"
        size = path.stat().st_size
        if size > MAX_TEXT_BYTES:  # refused before it is read
            raise TreeSpecError(f"{what} is {size} bytes, over the limit of {MAX_TEXT_BYTES}; a social tree is a few "
                                "kilobytes")
        try:
            text = path.read_text(encoding="utf-8")
            return load_json(text, what) if path.suffix == ".json" else load_yaml(text, what)
        except UnicodeDecodeError as exc:
            raise TreeSpecError(f"{what} is not UTF-8 text ({exc.reason}); save it as UTF-8") from None
        except BoundedInputError as exc:
            raise TreeSpecError(str(exc)) from None
    if isinstance(spec, str):
        try:
            return load_json(spec, "social tree given as a string")
        except BoundedInputError as exc:
            raise TreeSpecError(str(exc)) from None
    return spec
