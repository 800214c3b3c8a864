"""The envs a rollout steps: K copies of one game seen as arrays over ``[K, n_agents]``.

A training run steps its K envs in lockstep; the collector
(:class:`~arena_league.training.rollout.RolloutCollector`) reads and writes them only through
:class:`EnvBatch`, so the same collector drives K separate envs (:class:`EnvList`, any game) and a
game's whole-array engine (many boards or MuJoCo matches per call, where the game has one). Every
implementation gives, from the same seeds and actions, exactly the observations, rewards and
endings of K separate :class:`~arena_league.envs.env.ArenaParallelEnv` stepped through
``reset_arrays`` / ``step_arrays``.

Protocol of one step: read :meth:`EnvBatch.observations`, :meth:`EnvBatch.acting` (and
:meth:`EnvBatch.action_masks`, :meth:`EnvBatch.states` when needed), then :meth:`EnvBatch.step`
with every seat's action; for each env whose episode ended, read :meth:`EnvBatch.team_result`
and start its next episode with :meth:`EnvBatch.reset` before the next read.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = ["EnvBatch", "EnvList", "env_batch"]


class EnvBatch(ABC):
    """K envs of one game and social tree, as arrays.

    Attributes (set by implementations): ``n_envs`` (K), ``n_agents``, ``obs_dim`` (the rules'
    base observation width: what actors read), ``state_dim``, ``discrete``, ``n_actions``,
    ``act_dim``, ``turn_based``, ``team_of`` (``int64[n_agents]``), ``masked`` (the game masks
    illegal actions), ``game_id``.
    """

    n_envs: int
    n_agents: int
    obs_dim: int
    state_dim: int
    discrete: bool
    n_actions: int
    act_dim: int
    turn_based: bool
    team_of: np.ndarray
    masked: bool
    game_id: str

    def _describe(self, rules: Any, game_id: str) -> None:
        """Set the attributes from one env's rules."""
        self.game_id = game_id
        self.n_agents = int(rules.n_agents)
        self.obs_dim = int(rules.obs_dim)
        self.state_dim = int(rules.state_dim)
        self.discrete = rules.action_type == "discrete"
        self.n_actions = int(getattr(rules, "n_actions", 0))
        self.act_dim = int(getattr(rules, "act_dim", 0))
        self.turn_based = bool(rules.turn_based)
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.masked = self.discrete and bool(getattr(rules, "masks_actions", False))

    @abstractmethod
    def reset(self, k: int, seed: int) -> None:
        """Start a new episode of env ``k`` from ``seed`` (as ``env.reset_arrays(seed)``)."""

    @abstractmethod
    def observations(self) -> np.ndarray:
        """``float32[K, n_agents, obs_dim]``: every seat's base observation now."""

    @abstractmethod
    def acting(self) -> np.ndarray:
        """``bool[K, n_agents]``: the seats whose action counts this step (active seats; the seat to
        move in a turn-based game)."""

    @abstractmethod
    def action_masks(self) -> np.ndarray | None:
        """``bool[K, n_agents, n_actions]`` legal actions, or None for games without illegal ones."""

    @abstractmethod
    def states(self) -> np.ndarray:
        """``float32[K, state_dim]``: every env's global state (``env.state()``)."""

    @abstractmethod
    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Step every env with ``int64[K, n_agents]`` (discrete; non-acting seats' entries are
        ignored) or ``float32[K, n_agents, act_dim]`` actions. Returns (``float32[K, n_agents]``
        rewards, ``bool[K]`` the episode ended with this step, terminated or cut at
        ``max_cycles``)."""

    @abstractmethod
    def team_result(self, k: int) -> np.ndarray:
        """``float64[n_teams]``: the result of env ``k``'s episode that just ended."""

    def close(self) -> None:
        """Release what the envs hold (an engine's threads); separate envs hold nothing to release."""
        return None


class EnvList(EnvBatch):
    """K separate envs stepped one after the other through the array API: any game."""

    def __init__(self, envs: Sequence[Any]) -> None:
        if not envs:
            raise ValueError("an EnvList needs at least one env")
        self.envs = list(envs)
        self.n_envs = len(self.envs)
        rules = self.envs[0].rules
        self._describe(rules, self.envs[0].game_id)
        self._obs = np.zeros((self.n_envs, self.n_agents, self.obs_dim), dtype=np.float32)
        self._rewards = np.zeros((self.n_envs, self.n_agents), dtype=np.float32)
        self._ended = np.zeros(self.n_envs, dtype=bool)
        self._acting = np.ones((self.n_envs, self.n_agents), dtype=bool)
        self._masks = np.ones((self.n_envs, self.n_agents, self.n_actions), dtype=bool) if self.masked else None

    def reset(self, k: int, seed: int) -> None:
        obs = self.envs[k].reset_arrays(seed)
        self._obs[k] = obs[:, : self.obs_dim]

    def observations(self) -> np.ndarray:
        return self._obs

    def acting(self) -> np.ndarray:
        acting = self._acting
        if self.turn_based:
            acting[:] = False
            for k, env in enumerate(self.envs):
                acting[k, int(env.rules.current_player())] = True
        else:
            for k, env in enumerate(self.envs):
                # the rules may replace their measures object on reset: read it off the rules each time
                acting[k] = env.rules.measures.active
        return acting

    def action_masks(self) -> np.ndarray | None:
        if self._masks is None:
            return None
        for k, env in enumerate(self.envs):
            self._masks[k] = env.rules.action_mask()
        return self._masks

    def states(self) -> np.ndarray:
        return np.stack([env.state() for env in self.envs]).astype(np.float32, copy=False)

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        obs_dim = self.obs_dim
        for k, env in enumerate(self.envs):
            next_obs, reward, terminated, truncated = env.step_arrays(actions[k])
            self._rewards[k] = reward
            self._obs[k] = next_obs[:, :obs_dim]
            self._ended[k] = terminated or truncated
        return self._rewards, self._ended

    def team_result(self, k: int) -> np.ndarray:
        return np.asarray(self.envs[k].team_result(), dtype=np.float64).copy()


def env_batch(env_fn: Callable[[], Any], num_envs: int, probe: Any = None) -> EnvBatch:
    """The :class:`EnvBatch` of ``num_envs`` envs made by ``env_fn``: the game's whole-array engine
    (:class:`~arena_league.training.engine_batch.EngineBatch`, built from one env's rules) where
    the game has one and the observations are the rules' own (no broadcast boards, no global
    state in them); else K separate envs. ``probe``: an env the caller already made with ``env_fn``
    (it becomes the first env, or the engine's template), so none is made twice."""
    from arena_league.training.engine_batch import EngineBatch, engine_fits

    if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
        raise ValueError(f"num_envs must be a positive integer, not {num_envs!r}")
    probe = env_fn() if probe is None else probe
    if engine_fits(probe):
        return EngineBatch(probe, num_envs)
    return EnvList([probe, *(env_fn() for _ in range(num_envs - 1))])
