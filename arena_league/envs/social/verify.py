"""Verification of a social tree by sampling, after the procedure of Song et al., "Arena" (AAAI 2020).

A node's scheme is defined by the signs of ``dr_i/dx_j``: how the node's reward to one child
moves when another child (or the same one) plays better (see ``envs.social.rewards``). We estimate
those signs from *paired episodes*: two episodes with the same env seed and the same random
streams for every seat, that differ only in the policy of one seat ``j``. Policies come from a
one-parameter family per seat: with probability ``epsilon`` a uniformly random legal action,
otherwise the game's scripted heuristic; each pair gives every seat a random ``epsilon`` and gives
seat ``j`` a low and a high one.

For every node, with ``D_c`` the change of the node's episode reward to child ``c`` between the
two episodes and ``c(j)`` the child holding ``j``:

* rewards are compared as discounted returns (``GAMMA``), as a learner sees them;
* the node is *learnable* when ``D_c(j)`` is non-zero in a fair share of pairs (else NL);
* for every other child ``c``, the slope ``beta = sum D_c(j) D_c / sum D_c(j)^2`` (a finite
  difference estimate of ``dr_c/dx_c(j)`` measured in units of the own effect) and the correlation
  give the sign of the pair ``(c(j), c)``: positive, negative, or none;
* none everywhere: IS; positive everywhere: CL; negative everywhere: CP; both signs: CC. A node with
  one child cannot tell IS from CL, and accepts either.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from arena_league.envs.env import ArenaParallelEnv

#: |slope| and |correlation| below these count as "no effect" of one child on another.
SLOPE_THRESHOLD = 0.1
CORRELATION_THRESHOLD = 0.15
#: Discount of the returns compared: learners maximise discounted returns, under which reaching a
#: target sooner is better even when the undiscounted shaping sums to the same total.
GAMMA = 0.99
#: A node is learnable when its own effect is non-zero in at least this share of its pairs.
LEARNABLE_SHARE = 0.1


@dataclass
class NodeVerdict:
    """The verified scheme of one node."""

    path: str
    declared: str
    verified: str
    ok: bool
    reward: str
    agents: list[int]
    pairs: int  # sampled pairs whose perturbed seat lies below this node
    learnable_share: float  # share of those pairs where the own reward changed
    child_signs: dict[str, dict[str, float]] = field(default_factory=dict)  # "a~b" -> slope, corr, n


@dataclass
class VerificationReport:
    """Verification of every node of one game's social tree."""

    game_id: str
    samples: int
    seed: int
    nodes: list[NodeVerdict]

    @property
    def ok(self) -> bool:
        return all(n.ok for n in self.nodes)

    def to_dict(self) -> dict[str, Any]:
        return {"game_id": self.game_id, "samples": self.samples, "seed": self.seed, "ok": self.ok,
                "nodes": [asdict(n) for n in self.nodes]}


def play_episode(env: ArenaParallelEnv, env_seed: int, skills: np.ndarray, seat_seeds: list[list[int]],
                 gamma: float = GAMMA) -> np.ndarray:
    """One episode of the epsilon-heuristic policy family; returns ``[n_nodes, n_agents]`` discounted
    episode returns of each node's unscaled reward. Each seat draws from its own stream, the same
    number of draws every step, so two episodes that differ in one seat's epsilon stay paired."""
    rules = env.rules
    n = rules.n_agents
    returns = np.zeros((len(env.tree.nodes), n))
    per_node = np.zeros_like(returns)
    env._per_node = per_node
    weight = 1.0
    try:
        obs = env.reset_arrays(env_seed)
        rngs = [np.random.default_rng(s) for s in seat_seeds]
        discrete = rules.action_type == "discrete"
        width = max((env.tree.board_width(i) for i in range(n)), default=0)
        messages = np.zeros((n, width), dtype=np.float32) if width else None
        while True:
            skilled = rules.heuristic(obs[:, : rules.obs_dim], rules.action_type)
            actions = np.array(skilled, copy=True) if discrete else np.array(skilled, dtype=np.float32, copy=True)
            for i, rng in enumerate(rngs):
                explore = rng.random() < skills[i]
                random_action = rules.random_action(i, rng)
                if explore:
                    actions[i] = random_action
            per_node[:] = 0.0
            obs, _, terminated, truncated = env.step_arrays(actions, messages)
            returns += weight * per_node
            weight *= gamma
            if terminated or truncated:
                return returns
    finally:
        env._per_node = None


def verify_env(env: ArenaParallelEnv, samples: int = 64, seed: int = 0,
               progress: Callable[[int, int], None] | None = None) -> VerificationReport:
    """Verify every node of ``env``'s social tree from ``samples`` paired episodes;
    ``progress(done, total)`` is called after each pair."""
    if samples < 4:
        raise ValueError(f"verification needs at least 4 paired samples to estimate signs, not {samples}")
    n = env.rules.n_agents
    tree = env.tree
    deltas = np.zeros((samples, len(tree.nodes), n))
    perturbed = np.zeros(samples, dtype=np.int64)
    for k in range(samples):
        rng = np.random.default_rng([seed, k])
        j = k % n
        skills = rng.uniform(0.0, 1.0, n)
        low = rng.uniform(0.0, 0.35)
        env_seed = int(rng.integers(2**31))
        seat_seeds = [[seed, k, i] for i in range(n)]
        totals = []
        for eps_j in (low, 1.0 - low):
            skills[j] = eps_j
            totals.append(play_episode(env, env_seed, skills, seat_seeds))
        # positive delta = the change when seat j plays better (lower epsilon)
        deltas[k] = totals[0] - totals[1]
        perturbed[k] = j
        if progress is not None:
            progress(k + 1, samples)
    verdicts = [_classify(node, k, deltas, perturbed) for k, node in enumerate(tree.nodes)]
    return VerificationReport(env.game_id, samples, seed, verdicts)


def verify(game_id: str, tree: Any = None, samples: int = 64, seed: int = 0, max_cycles: int | None = None,
           action_type: str | None = None, progress: Callable[[int, int], None] | None = None,
           **game_kwargs: Any) -> VerificationReport:
    """Verify the social tree of ``game_id`` (its default, or ``tree``) by paired sampling."""
    from arena_league.envs import make

    env = make(game_id, tree=tree, action_type=action_type, max_cycles=max_cycles, **game_kwargs)
    return verify_env(env, samples=samples, seed=seed, progress=progress)


def _classify(node, node_index: int, deltas: np.ndarray, perturbed: np.ndarray) -> NodeVerdict:
    agents = node.agents
    groups = node.view.group
    n_groups = node.view.n_groups
    below = np.isin(perturbed, agents)
    rows = np.flatnonzero(below)
    position = {int(a): p for p, a in enumerate(agents)}
    # per pair: the change of the node's reward to each child (mean over the child's agents)
    counts = np.bincount(groups, minlength=n_groups)
    child_delta = np.zeros((len(rows), n_groups))
    own_child = np.zeros(len(rows), dtype=np.int64)
    for r, k in enumerate(rows):
        d = deltas[k, node_index, agents]
        child_delta[r] = np.bincount(groups, weights=d, minlength=n_groups) / counts
        own_child[r] = groups[position[int(perturbed[k])]]
    own = child_delta[np.arange(len(rows)), own_child] if len(rows) else np.zeros(0)
    scale = max(np.abs(deltas[:, node_index]).max(initial=0.0), 1e-12)
    changed = np.abs(own) > 1e-9 * max(scale, 1.0)
    learnable_share = float(changed.mean()) if len(rows) else 0.0
    learnable = learnable_share >= LEARNABLE_SHARE
    signs: dict[str, dict[str, float]] = {}
    counted = {1: 0, -1: 0, 0: 0}
    if n_groups > 1 and learnable:
        for a in range(n_groups):
            for b in range(a + 1, n_groups):
                x_parts, y_parts = [], []
                for src, dst in ((a, b), (b, a)):
                    sel = own_child == src
                    x_parts.append(own[sel])
                    y_parts.append(child_delta[sel, dst])
                x = np.concatenate(x_parts)
                y = np.concatenate(y_parts)
                sxx, syy, sxy = float(x @ x), float(y @ y), float(x @ y)
                slope = sxy / sxx if sxx > 0 else 0.0
                corr = sxy / np.sqrt(sxx * syy) if sxx > 0 and syy > 0 else 0.0
                sign = int(np.sign(slope)) if abs(slope) >= SLOPE_THRESHOLD and abs(corr) >= CORRELATION_THRESHOLD else 0
                counted[sign] += 1
                signs[f"{a}~{b}"] = {"slope": round(slope, 4), "correlation": round(float(corr), 4), "pairs": len(x),
                                     "sign": sign}
    if not learnable:
        verified = "NL"
    elif n_groups == 1:
        verified = "IS"
    elif counted[1] and counted[-1]:
        verified = "CC"
    elif counted[1] > counted[0]:
        verified = "CL"
    elif counted[-1] > counted[0]:
        verified = "CP"
    else:
        verified = "IS"
    declared = node.scheme
    ok = verified == declared or (n_groups == 1 and verified == "IS" and declared == "CL")
    return NodeVerdict(node.path, declared, verified, ok, node.reward.name, [int(a) for a in agents], len(rows),
                       round(learnable_share, 4), signs)
