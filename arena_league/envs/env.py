"""The PettingZoo ``ParallelEnv`` of every game: rules + social tree + boards + global state.

The env validates actions, counts steps, truncates at ``max_cycles``, turns the rules' measures
into rewards through the social tree, routes broadcast-board messages, and builds the PettingZoo
dicts. Besides the dict API it offers an array API (:meth:`ArenaParallelEnv.reset_arrays`,
:meth:`ArenaParallelEnv.step_arrays`) used by the batched match engine.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from arena_league.envs.core import GameRules
from arena_league.envs.social.rewards import RewardContext
from arena_league.envs.social.tree import SocialTree

_MAX_SEED = 2**63 - 1


class ArenaParallelEnv(ParallelEnv):
    """One game id with one social tree, as a PettingZoo ParallelEnv.

    All agents stay until the episode ends (the rules mark arrived or eliminated seats inactive),
    then all are terminated (the rules ended the match) or truncated (``max_cycles``) together.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "is_parallelizable": True, "render_fps": 20}

    def __init__(self, game_id: str, rules: GameRules, tree: SocialTree, max_cycles: int,
                 render_mode: str | None = None, state_in_obs: bool = False) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r} is not offered; valid: None, 'rgb_array' "
                             "(a top-down picture, drawn without a display)")
        if not isinstance(max_cycles, int) or isinstance(max_cycles, bool) or max_cycles < 1:
            raise ValueError(f"max_cycles must be a positive integer, not {max_cycles!r}")
        self.game_id = game_id
        self.rules = rules
        self.tree = tree
        self.max_cycles = max_cycles
        self.render_mode = render_mode
        self.state_in_obs = bool(state_in_obs)
        self.metadata = {**self.metadata, "name": game_id}
        n = rules.n_agents
        self.possible_agents = [f"player_{i}" for i in range(n)]
        self.agents: list[str] = []
        self.teams: dict[int, list[str]] = {
            t: [a for i, a in enumerate(self.possible_agents) if rules.team_of[i] == t] for t in range(rules.n_teams)
        }
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        self._discrete = rules.action_type == "discrete"
        self._board_width = [tree.board_width(i) for i in range(n)]
        self._has_boards = any(self._board_width)
        self._board_content = [np.zeros(b.board, dtype=np.float32) for b in tree.boards]
        self._obs_dim = [rules.obs_dim + self._board_width[i] + (rules.state_dim if state_in_obs else 0)
                         for i in range(n)]
        self._build_spaces()
        self._step = 0
        self._seed_rng = np.random.default_rng(0)
        self._ctx: RewardContext | None = None
        self._per_node: np.ndarray | None = None
        self.last_obs: np.ndarray | None = None

    # --- spaces ------------------------------------------------------------------------------------
    def _build_spaces(self) -> None:
        r = self.rules
        base_action = (spaces.Discrete(r.n_actions) if self._discrete
                       else spaces.Box(-1.0, 1.0, (r.act_dim,), dtype=np.float32))
        self._action_spaces: dict[str, spaces.Space] = {}
        self._observation_spaces: dict[str, spaces.Space] = {}
        for i, agent in enumerate(self.possible_agents):
            self._observation_spaces[agent] = spaces.Box(-np.inf, np.inf, (self._obs_dim[i],), dtype=np.float32)
            if self._board_width[i]:
                message = spaces.Box(-1.0, 1.0, (self._board_width[i],), dtype=np.float32)
                self._action_spaces[agent] = spaces.Dict({"action": base_action, "message": message})
            else:
                self._action_spaces[agent] = base_action
        self.state_space = spaces.Box(-np.inf, np.inf, (r.state_dim,), dtype=np.float32)

    def observation_space(self, agent: str) -> spaces.Space:
        return self._observation_spaces[self._agent_check(agent)]

    def action_space(self, agent: str) -> spaces.Space:
        return self._action_spaces[self._agent_check(agent)]

    def _agent_check(self, agent: str) -> str:
        if agent not in self._index:
            raise KeyError(f"unknown agent {agent!r}; agents of {self.game_id}: {', '.join(self.possible_agents)}")
        return agent

    # --- array API ---------------------------------------------------------------------------------
    def reset_arrays(self, seed: int | None = None) -> np.ndarray:
        """Reset; return ``float32[n_agents, obs_dim]`` observations (boards and state included)."""
        if seed is not None:
            if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
                raise ValueError(f"seed must be a non-negative integer, not {seed!r}")
            self._seed_rng = np.random.default_rng(int(seed))
            match_seed = int(seed)
        else:
            match_seed = int(self._seed_rng.integers(_MAX_SEED))
        self.rules.reset(match_seed)
        self.tree.reset()
        for content in self._board_content:
            content[:] = 0.0
        self._step = 0
        self._ctx = RewardContext(self.rules.measures, self.rules.measures.copy_of(self.tree.previous_needed),
                                  self.tree.team_of, 0, False)
        self.agents = list(self.possible_agents)
        self.last_obs = self._observations()
        return self.last_obs

    def step_arrays(self, actions: np.ndarray, messages: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, bool, bool]:
        """One step from validated-shape arrays: discrete ``int[n]`` or continuous ``float[n, act_dim]``
        actions, and (with boards) ``float[n, max_board_width]`` messages.
        Returns (observations, rewards, terminated, truncated)."""
        if not self.agents:
            raise RuntimeError(f"{self.game_id}: the episode is over; call reset() before step()")
        actions = self._check_action_array(actions)
        rules = self.rules
        measures = rules.measures
        ctx = self._ctx
        prev = ctx.previous
        for name in self.tree.previous_needed:
            np.copyto(prev[name], getattr(measures, name))
        rules.step(actions)
        self._step += 1
        terminated = bool(rules.game_over)
        truncated = not terminated and self._step >= self.max_cycles
        if truncated:
            rules.finish()
        ctx.step = self._step
        ctx.ending = terminated or truncated
        rewards = self.tree.rewards(ctx, self._per_node)
        if self._has_boards and messages is not None:
            self._write_boards(messages)
        obs = self._observations()
        self.last_obs = obs
        if terminated or truncated:
            self.agents = []
        return obs, rewards, terminated, truncated

    def _check_action_array(self, actions: Any) -> np.ndarray:
        n = self.rules.n_agents
        if self._discrete:
            arr = np.asarray(actions)
            if arr.shape != (n,) or arr.dtype.kind not in "iu":
                if arr.shape == (n,) and arr.dtype.kind == "f" and np.all(arr == np.round(arr)):
                    arr = arr.astype(np.int64)
                else:
                    raise ValueError(f"{self.game_id}: discrete actions are one integer per seat, shape ({n},); "
                                     f"got shape {arr.shape} dtype {arr.dtype}")
            if arr.min() < 0 or arr.max() >= self.rules.n_actions:
                seat = int(np.flatnonzero((arr < 0) | (arr >= self.rules.n_actions))[0])
                raise ValueError(f"{self.game_id}: action {int(arr[seat])} of player_{seat} is out of range; "
                                 f"valid actions: {self._action_help()}")
            return arr.astype(np.int64, copy=False)
        arr = np.asarray(actions, dtype=np.float32)
        if arr.shape != (n, self.rules.act_dim):
            raise ValueError(f"{self.game_id}: continuous actions have shape ({n}, {self.rules.act_dim}) "
                             f"(one vector of {self.rules.act_dim} floats in [-1, 1] per seat); got {arr.shape}")
        if not (arr.min() >= -1.0 and arr.max() <= 1.0):  # NaN fails both comparisons
            seat = int(np.flatnonzero(~(np.isfinite(arr) & (np.abs(arr) <= 1.0)).all(axis=1))[0])
            raise ValueError(f"{self.game_id}: action {arr[seat].tolist()} of player_{seat} is out of range; "
                             f"every component must be finite and within [-1, 1]")
        return arr

    def _action_help(self) -> str:
        meanings = self.rules.action_meanings
        n = self.rules.n_actions
        if meanings and len(meanings) == n and n <= 16:
            return ", ".join(f"{i} ({m})" for i, m in enumerate(meanings))
        return f"integers 0..{n - 1}" + (f" ({meanings[0]})" if len(meanings) == 1 else "")

    def _write_boards(self, messages: np.ndarray) -> None:
        """Each board becomes the mean of the messages its active descendants wrote this step."""
        active = self.rules.measures.active
        sums = [np.zeros_like(c) for c in self._board_content]
        counts = [0] * len(self._board_content)
        for seat, parts in self.tree.board_slices.items():
            if not active[seat]:
                continue
            for b, sl in parts:
                sums[b] += messages[seat, sl]
                counts[b] += 1
        for b, content in enumerate(self._board_content):
            if counts[b]:
                content[:] = sums[b] / counts[b]

    def _observations(self) -> np.ndarray:
        """Row ``i``: base observation | seat i's boards, root first | global state (if asked),
        zero-padded at the end to the widest seat (the dict API hands each seat its own width)."""
        obs = self.rules.observe()
        if not self._has_boards and not self.state_in_obs:
            return obs
        rules = self.rules
        out = np.zeros((rules.n_agents, max(self._obs_dim)), dtype=np.float32)
        out[:, : rules.obs_dim] = obs
        state = rules.state() if self.state_in_obs else None
        for seat in range(rules.n_agents):
            offset = rules.obs_dim
            for b, sl in self.tree.board_slices.get(seat, ()):
                out[seat, offset + sl.start: offset + sl.stop] = self._board_content[b]
            if state is not None:
                start = offset + self._board_width[seat]
                out[seat, start: start + rules.state_dim] = state
        return out

    # --- PettingZoo API ----------------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        obs = self.reset_arrays(seed)
        return self._obs_dict(obs), self._infos()

    def step(self, actions: dict[str, Any]):
        if not self.agents:
            raise RuntimeError(f"{self.game_id}: the episode is over; call reset() before step()")
        names = self.possible_agents
        try:
            if len(actions) != len(names):
                raise KeyError
            flat = [actions[a] for a in names]
        except (KeyError, TypeError):
            self._explain_action_dict(actions)
        messages = None
        if self._has_boards:
            flat, messages = self._split_board_actions(actions)
        if self._discrete:
            array = _integer_array(flat)
            if array is None:
                for i, a in enumerate(flat):
                    if not isinstance(a, (int, np.integer)) or isinstance(a, bool):
                        # ValueError, as for every other bad action: the front ends report it as bad input
                        raise ValueError(  # noqa: TRY004
                            f"{self.game_id}: action {a!r} of player_{i} is not an integer; "
                            f"valid actions: {self._action_help()}")
        else:
            try:
                array = np.asarray(flat, dtype=np.float32)
            except (ValueError, TypeError):
                array = None
            if array is None or array.shape != (len(names), self.rules.act_dim):
                bad = next((i for i, a in enumerate(flat) if np.shape(a) != (self.rules.act_dim,)), 0)
                raise ValueError(f"{self.game_id}: action of player_{bad} has shape {np.shape(flat[bad])}; "
                                 f"continuous actions are {self.rules.act_dim} floats in [-1, 1]")
        obs, rewards, terminated, truncated = self.step_arrays(array, messages)
        return (self._obs_dict(obs), dict(zip(names, rewards.tolist())), dict.fromkeys(names, terminated),
                dict.fromkeys(names, truncated), self._infos())

    def _explain_action_dict(self, actions: Any) -> None:
        if not isinstance(actions, dict):
            raise TypeError(f"{self.game_id}: step() takes a dict agent name -> action, not {type(actions).__name__}")
        missing = [a for a in self.agents if a not in actions]
        extra = [a for a in actions if a not in self._index]
        problem = (f"missing actions for {', '.join(missing)}" if missing
                   else f"unknown agent(s) {', '.join(map(str, extra))}")
        raise ValueError(f"{self.game_id}: {problem}; give one action for each of {', '.join(self.agents)}")

    def _split_board_actions(self, actions: dict[str, Any]) -> tuple[list, np.ndarray]:
        width = max(self._board_width)
        messages = np.zeros((self.rules.n_agents, width), dtype=np.float32)
        flat = []
        for i, agent in enumerate(self.possible_agents):
            act = actions[agent]
            w = self._board_width[i]
            if not w:
                flat.append(act)
                continue
            if not isinstance(act, dict) or set(act) != {"action", "message"}:
                raise ValueError(f"{self.game_id}: {agent} sits under a broadcast board, so its action is a dict "
                                 f"{{'action': ..., 'message': {w} floats in [-1, 1]}}")
            msg = np.asarray(act["message"], dtype=np.float32)
            if msg.shape != (w,) or not np.all(np.isfinite(msg)) or np.any(np.abs(msg) > 1):
                raise ValueError(f"{self.game_id}: {agent}'s board message must be {w} finite floats in [-1, 1], "
                                 f"got {msg.tolist() if msg.size < 10 else msg.shape}")
            messages[i, :w] = msg
            flat.append(act["action"])
        return flat, messages

    def _obs_dict(self, obs: np.ndarray) -> dict[str, np.ndarray]:
        if self._has_boards:
            return {a: obs[i, : self._obs_dim[i]] for i, a in enumerate(self.possible_agents)}
        return {a: obs[i] for i, a in enumerate(self.possible_agents)}

    def _info(self, seat: int) -> dict[str, Any]:
        mask = self.rules.action_mask()
        return {} if mask is None else {"action_mask": mask[seat].astype(np.int8)}

    def _infos(self) -> dict[str, dict[str, Any]]:
        mask = self.rules.action_mask()
        if mask is None:
            return {a: {} for a in self.possible_agents}
        mask = mask.astype(np.int8)
        return {a: {"action_mask": mask[i]} for i, a in enumerate(self.possible_agents)}

    def state(self) -> np.ndarray:
        return self.rules.state()

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            return None
        return self.rules.render_topdown()

    def close(self) -> None:
        pass

    # --- league helpers ----------------------------------------------------------------------------
    def team_result(self) -> np.ndarray:
        """Each team's final score (higher is better), once the episode has ended."""
        return self.rules.team_result()

    @property
    def step_count(self) -> int:
        return self._step


def _integer_array(values: list) -> np.ndarray | None:
    """``int64`` array of one integer per seat, or None when any value is not an integer."""
    try:
        array = np.array(values)
    except (ValueError, TypeError):
        return None
    if array.ndim != 1 or array.dtype.kind not in "iu":
        return None
    return array
