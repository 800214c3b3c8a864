"""The native PettingZoo ``AECEnv`` of turn-based games: one seat acts per step.

The seat to move is ``rules.current_player()``; the others' actions are never asked for. Rewards,
boards, termination, observations (PettingZoo's ``{"observation", "action_mask"}`` dicts in games
with illegal actions), rendering and copies follow the parallel env it wraps.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from pettingzoo import AECEnv

from arena_league.envs.env import ArenaParallelEnv


class ArenaAECEnv(AECEnv):
    """Turn-based play over an :class:`ArenaParallelEnv` (which holds the rules and the tree)."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "is_parallelizable": True,
                                          "render_fps": 4}

    def __init__(self, parallel: ArenaParallelEnv) -> None:
        super().__init__()
        if not parallel.rules.turn_based:
            raise ValueError(f"{parallel.game_id} is not turn-based; use make() for its ParallelEnv")
        self._par = parallel
        self.metadata = {**self.metadata, "name": parallel.game_id}
        self.render_mode = parallel.render_mode
        self.possible_agents = list(parallel.possible_agents)
        self.teams = parallel.teams
        self.agents: list[str] = []
        self._obs: np.ndarray | None = None

    def observation_space(self, agent: str):
        return self._par.observation_space(agent)

    def action_space(self, agent: str):
        return self._par.action_space(agent)

    def reset(self, seed: int | None = None, options: dict | None = None) -> None:
        self._obs = self._par.reset_arrays(seed)
        self.agents = list(self.possible_agents)
        self.rewards = dict.fromkeys(self.agents, 0.0)
        self._cumulative_rewards = dict.fromkeys(self.agents, 0.0)
        self.terminations = dict.fromkeys(self.agents, False)
        self.truncations = dict.fromkeys(self.agents, False)
        self.infos = {a: {} for a in self.agents}
        self.agent_selection = self.possible_agents[self._par.rules.current_player()]
        if self.render_mode == "human":
            self.render()

    def observe(self, agent: str) -> Any:
        return self._par._seat_observation(self.possible_agents.index(agent), self._obs)

    def state(self) -> np.ndarray:
        return self._par.state()

    def step(self, action: Any) -> None:
        agent = self.agent_selection
        if self.terminations[agent] or self.truncations[agent]:
            self._was_dead_step(action)
            return
        seat = self.possible_agents.index(agent)
        rules = self._par.rules
        if rules.action_type == "discrete":
            actions = np.zeros(rules.n_agents, dtype=np.int64)
            try:
                actions[seat] = action
            except (TypeError, ValueError):
                raise ValueError(f"{self._par.game_id}: action {action!r} of {agent} is not an integer") from None
        else:
            actions = np.zeros((rules.n_agents, rules.act_dim), dtype=np.float32)
            actions[seat] = action
        self._cumulative_rewards[agent] = 0.0
        obs, rewards, terminated, truncated = self._par.step_arrays(actions)
        self._obs = obs
        for i, a in enumerate(self.agents):
            self.rewards[a] = float(rewards[i])
            self.terminations[a] = terminated
            self.truncations[a] = truncated
            self.infos[a] = {}
        if not (terminated or truncated):
            self.agent_selection = self.possible_agents[rules.current_player()]
        self._accumulate_rewards()
        if self.render_mode == "human":
            self.render()

    def render(self) -> np.ndarray | None:
        """The top-down picture (``rgb_array``); with ``human``, shows it in the window (paced at this
        env's ``metadata["render_fps"]``) and returns None."""
        return self._par._render(self.metadata["render_fps"])

    def close(self) -> None:
        self._par.close()

    def team_result(self) -> np.ndarray:
        return self._par.team_result()

    def pair_points(self) -> np.ndarray:
        return self._par.pair_points()
