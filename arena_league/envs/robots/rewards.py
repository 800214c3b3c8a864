"""Dense motor-skill rewards of the robot games, and their annealing into the sparse outcome.

Bansal et al., "Emergent Complexity via Multi-Agent Competition" (ICLR 2018), section 3.1: learning
articulated robots' games from the win/loss alone fails, so each agent first gets a dense
*exploration* reward ``s_t`` for basic motor skills (moving toward its target, staying up, little
control effort, few hard contacts), blended with the competition reward ``R`` as
``r_t = alpha * s_t + R`` with ``alpha`` annealed from 1 to 0 over training (they anneal to zero in
the first few hundred iterations). In Arena's social tree (Song et al., AAAI 2020) the dense part is
an IS node per agent and the outcome sits at the CP root, so annealing scales the IS motor reward
only; the CL and CP rewards of a tree are never scaled.

IS reward function registered here (the built-in ``fall``, ``energy``, ``big_force``, ``target``,
``velocity_to_target`` and ``facing_target`` work with robot games too, unannealed):

``robot_motion`` (needs ``velocity_to_target``, ``fallen``, ``energy``, ``force``)
    ``alpha * (velocity * velocity_to_target - fall * fallen - control * energy - contact * force)``
    per step, where ``velocity_to_target`` is in m/s toward the seat's target (each game's manual
    says what that is), ``fallen`` is 1 while the torso is upside down, ``energy`` is the mean
    squared action (0..1) and ``force`` is the contact force other robots and props exert on the
    seat, in units of its weight. Parameters (weights, default): ``velocity`` 1.0, ``fall`` 1.0,
    ``control`` 0.5, ``contact`` 0.01.

Annealing: ``alpha`` is :attr:`RobotMeasures.anneal` (default 1). Set it per episode with the rules'
``set_anneal(alpha)`` (``env.rules.set_anneal(alpha)``: a float in [0, 1], kept across resets) or
at construction with the game kwarg ``anneal``; e.g. a trainer sets ``alpha = max(0, 1 - it / 500)``
before each rollout. Reward functions other than ``robot_motion`` ignore it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from arena_league.envs.core import Measures
from arena_league.envs.social.rewards import REWARD_FUNCTIONS, NodeView, RewardContext, register_reward

__all__ = ["RobotMeasures", "check_anneal", "robot_motion"]


@dataclass
class RobotMeasures(Measures):
    """Measures of a robot game plus ``anneal``, the weight (1 to 0 over training) of the dense
    IS motor reward ``robot_motion`` this episode, and ``block``: the float measures as rows of
    one ``[rows, n_agents]`` array (``block_rows`` names the row of each; ``fallen`` as 0/1) that
    the rules keep current, so that ``robot_motion`` is one dot product."""

    anneal: float = 1.0
    block: np.ndarray | None = None
    block_rows: dict[str, int] | None = None


def check_anneal(alpha: Any) -> float:
    """``alpha`` as a float in [0, 1], or a ``ValueError`` that says so."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.floating, np.integer)) \
            or not 0.0 <= float(alpha) <= 1.0:
        raise ValueError(f"anneal (the weight of the dense motor reward) must be a number in [0, 1], not {alpha!r}")
    return float(alpha)


_TERMS = (("velocity", "velocity_to_target", 1.0), ("fall", "fallen", -1.0), ("control", "energy", -1.0),
          ("contact", "force", -1.0))


def robot_motion(ctx: RewardContext, node: NodeView, params: dict) -> np.ndarray:
    """Dense robot motor reward: speed toward the target, minus falling, control and contact costs (annealed)."""
    m = ctx.measures
    alpha = getattr(m, "anneal", 1.0)
    if alpha == 0.0:
        return np.zeros(len(node.agents))
    a = node.agents
    block = getattr(m, "block", None)
    if block is not None:
        # one dot product of the weights (alpha folded in) with the rules' block of measures
        memory = node.memory
        if memory.get("alpha") != alpha:
            weights = np.zeros(len(block))
            for param, measure, sign in _TERMS:
                weights[m.block_rows[measure]] += sign * float(params[param])
            memory["weights"] = alpha * weights
            memory["alpha"] = alpha
            memory["all_seats"] = np.array_equal(a, np.arange(block.shape[1]))
        if memory["all_seats"]:
            return np.dot(memory["weights"], block)
        return np.dot(memory["weights"], block[:, a])
    dense = (float(params["velocity"]) * m.velocity_to_target[a]
             - float(params["fall"]) * m.fallen[a]
             - float(params["control"]) * m.energy[a]
             - float(params["contact"]) * m.force[a])
    return alpha * dense


if "robot_motion" not in REWARD_FUNCTIONS["IS"]:  # importable twice (reloads) without a clash
    register_reward("robot_motion", "IS", needs=("velocity_to_target", "fallen", "energy", "force"),
                    velocity=1.0, fall=1.0, control=0.5, contact=0.01)(robot_motion)
