"""The batched policy interface every agent implements: built-in scripted agents, torch families,
ONNX submissions.

One :class:`Policy` acts for many seats at once (the match engine groups all seats a policy holds
across every match in play into one call). Randomness never comes from the policy: the engine
hands it per-seat uniform draws taken from each match's own generator, so outcomes are the same
whatever the batch size or the backend.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ActionSpec:
    """What a game's seats must output."""

    action_type: str  # "discrete" | "continuous"
    obs_dim: int
    n_actions: int = 0  # discrete
    act_dim: int = 0  # continuous

    @property
    def uniforms_per_seat(self) -> int:
        """Uniform draws the engine gives each seat per step (``act_dim`` for continuous, else 1)."""
        return max(1, self.act_dim) if self.action_type == "continuous" else 1


class Policy(ABC):
    """An agent's policy, batched over seats.

    ``act`` maps observations ``float32[N, obs_dim]`` to actions (``int64[N]`` discrete, or
    ``float32[N, act_dim]`` in [-1, 1] continuous). ``uniforms`` is ``float64[N, k]`` of U(0, 1)
    draws (``k = spec.uniforms_per_seat``) for any sampling the policy does; ``mask`` is
    ``bool[N, n_actions]`` of legal actions for games that have illegal moves, or None.
    Recurrent policies carry ``state`` (``float32[N, ...]``) from one step to the next.
    """

    spec: ActionSpec
    #: A short name for logs: "random", "heuristic", "onnx:<sha>", "mlp".
    name: str = "policy"
    recurrent: bool = False

    def initial_state(self, n: int) -> np.ndarray | None:
        return None

    @abstractmethod
    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """Actions for N seats, and the next recurrent state (None for feed-forward policies)."""


def sample_from_logits(logits: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """Categorical sample per row by inverse CDF of ``softmax(logits)`` with one uniform per row;
    illegal actions (``mask`` False) get probability zero. ``int64[N]``."""
    z = logits.astype(np.float64, copy=True)
    if mask is not None:
        z[~mask] = -np.inf
    z -= z.max(axis=1, keepdims=True)
    p = np.exp(z)
    cdf = np.cumsum(p, axis=1)
    cdf /= cdf[:, -1:]
    u = uniforms[:, :1]
    choice = (cdf < u).sum(axis=1)
    return np.minimum(choice, logits.shape[1] - 1).astype(np.int64)


def legal_mask(mask: np.ndarray | None, shape: tuple[int, int]) -> np.ndarray | None:
    """``mask`` checked against ``[N, n_actions]``; rows with no legal action (a finished board)
    become all legal, since the env ignores those seats' actions."""
    if mask is None:
        return None
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != shape:
        raise ValueError(f"action mask has shape {mask.shape}, expected {shape} (one row per seat, one column "
                         "per action)")
    empty = ~mask.any(axis=1)
    if empty.any():
        mask = mask.copy()
        mask[empty] = True
    return mask


def invalid_actions(spec: ActionSpec, actions: np.ndarray, rows: int) -> tuple[str | None, np.ndarray]:
    """What is wrong with a policy's ``actions`` for ``rows`` rows: a message when their shape or dtype
    is wrong (every row is then at fault), else None and the rows whose action is out of range
    (discrete: not an integer in ``0..n_actions-1``; continuous: not finite or outside [-1, 1])."""
    if spec.action_type == "discrete":
        if actions.shape != (rows,) or actions.dtype.kind not in "iu":
            return (f"returned actions of shape {actions.shape} dtype {actions.dtype}; discrete policies return "
                    "int64[N], one action per row"), np.arange(rows)
        return None, np.flatnonzero((actions < 0) | (actions >= spec.n_actions))
    if actions.shape != (rows, spec.act_dim):
        return (f"returned actions of shape {actions.shape}; continuous policies return "
                f"float32[N, {spec.act_dim}]"), np.arange(rows)
    return None, np.flatnonzero(~(np.isfinite(actions) & (np.abs(actions) <= 1.0)).all(axis=1))


def valid_actions_text(spec: ActionSpec) -> str:
    """What a valid action of ``spec`` is, for messages."""
    if spec.action_type == "discrete":
        return f"integers 0..{spec.n_actions - 1}"
    return f"{spec.act_dim} finite floats in [-1, 1]"


def raw_outputs(policy: Policy, obs: np.ndarray, state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """A policy's raw outputs for ``obs`` as float64 (``logits`` or ``action`` of a learned policy,
    through its ``forward``; a scripted one's actions, taken at the middle uniform) and its next state."""
    forward = getattr(policy, "forward", None)
    if forward is not None:
        out, next_state = forward(obs, state)
        return np.asarray(out, dtype=np.float64), next_state
    uniforms = np.full((obs.shape[0], policy.spec.uniforms_per_seat), 0.5)
    actions, next_state = policy.act(obs, uniforms, None, state)
    return np.asarray(actions, dtype=np.float64).reshape(obs.shape[0], -1), next_state
