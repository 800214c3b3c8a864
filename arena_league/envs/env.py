"""The PettingZoo ``ParallelEnv`` of every game: rules + social tree + boards + global state.

The env validates actions, counts steps, truncates at ``max_cycles``, turns the rules' measures
into rewards through the social tree, routes broadcast-board messages, and builds the PettingZoo
dicts. Besides the dict API it offers an array API (:meth:`ArenaParallelEnv.reset_arrays`,
:meth:`ArenaParallelEnv.step_arrays`) used by the batched match engine.

Observations
    A seat's observation is one ``float32`` vector (:meth:`ArenaParallelEnv.vector_observation_space`):
    the game's cells (its manual), then the seat's broadcast boards, then the global state when
    ``state_in_obs``; each cell within finite bounds (the game's limits; boards in [-1, 1]). In
    games with illegal actions (the rules' ``masks_actions``, e.g. GoBang) the dict API follows
    PettingZoo's classic convention instead: each observation is
    ``{"observation": <that vector>, "action_mask": int8[n_actions]}`` (1 for a legal action) under a
    ``Dict`` observation space, so that PettingZoo's tests, samplers and RLlib's masking play legal
    moves. The array API always returns the vectors.

Rendering
    ``render_mode="rgb_array"``: ``render()`` returns the game's top-down picture; ``"human"``: the
    same picture in a pygame window (``envs.rendering``), drawn on every ``reset`` and ``step`` of the
    dict API and on ``render()``, at ``metadata["render_fps"]`` frames per second.

Copies
    Envs pickle and copy (``pickle``, ``copy.deepcopy``, cloudpickle, as SuperSuit's vector envs
    make them) at any point: a copy is an env that goes on exactly as the original would, and a
    copy of a fresh env plays as a fresh one (same seeds, same trajectories). A human window stays
    with its env; a copy opens its own when it draws.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from arena_league.envs.core import GameRules
from arena_league.envs.rendering import HumanWindow, check_human_rendering
from arena_league.envs.social.rewards import RewardContext
from arena_league.envs.social.tree import SocialTree

_MAX_SEED = 2**63 - 1


class ArenaParallelEnv(ParallelEnv):
    """One game id with one social tree, as a PettingZoo ParallelEnv.

    All agents stay until the episode ends (the rules mark arrived or eliminated seats inactive),
    then all are terminated (the rules ended the match) or truncated (``max_cycles``) together.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "is_parallelizable": True,
                                          "render_fps": 20}

    def __init__(self, game_id: str, rules: GameRules, tree: SocialTree, max_cycles: int,
                 render_mode: str | None = None, state_in_obs: bool = False) -> None:
        if render_mode not in (None, "human", "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r} is not offered; valid: None, 'rgb_array' "
                             "(a top-down picture, drawn without a display) or 'human' (that picture in a window)")
        if not isinstance(max_cycles, int) or isinstance(max_cycles, bool) or max_cycles < 1:
            raise ValueError(f"max_cycles must be a positive integer, not {max_cycles!r}")
        if render_mode == "human":
            check_human_rendering()
        self.game_id = game_id
        self.rules = rules
        self.tree = tree
        self.max_cycles = max_cycles
        rules.max_cycles = max_cycles  # the step the env cuts at, which a paired game's points may count
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
        self._masked = self._discrete and rules.masks_actions
        self._board_width = [tree.board_width(i) for i in range(n)]
        self._has_boards = any(self._board_width)
        self._board_content = [np.zeros(b.board, dtype=np.float32) for b in tree.boards]
        self._obs_dim = [rules.obs_dim + self._board_width[i] + (rules.state_dim if state_in_obs else 0)
                         for i in range(n)]
        self._build_spaces()
        self._step = 0
        # the generator of unseeded resets' match seeds, made from _seed_base when first needed
        self._seed_base = 0
        self._seed_rng: np.random.Generator | None = None
        self._ctx: RewardContext | None = None
        self._per_node: np.ndarray | None = None
        self.last_obs: np.ndarray | None = None
        self._window = HumanWindow(game_id) if render_mode == "human" else None

    # --- spaces ------------------------------------------------------------------------------------
    def _build_spaces(self) -> None:
        r = self.rules
        base_action = (spaces.Discrete(r.n_actions) if self._discrete
                       else spaces.Box(-1.0, 1.0, (r.act_dim,), dtype=np.float32))
        obs_low, obs_high = _checked_bounds(r.observation_bounds(), r.obs_dim, "observation", r)
        state_low, state_high = _checked_bounds(r.state_bounds(), r.state_dim, "state", r)
        self._action_spaces: dict[str, spaces.Space] = {}
        self._vector_spaces: dict[str, spaces.Box] = {}
        self._observation_spaces: dict[str, spaces.Space] = {}
        for i, agent in enumerate(self.possible_agents):
            board = np.ones(self._board_width[i], dtype=np.float32)  # board content: mean of messages in [-1, 1]
            parts = [(obs_low, obs_high), (-board, board)]
            if self.state_in_obs:
                parts.append((state_low, state_high))
            vector = spaces.Box(np.concatenate([low for low, _ in parts]), np.concatenate([high for _, high in parts]),
                                dtype=np.float32)
            self._vector_spaces[agent] = vector
            self._observation_spaces[agent] = (spaces.Dict({
                "observation": vector,
                "action_mask": spaces.Box(0, 1, (r.n_actions,), dtype=np.int8)}) if self._masked else vector)
            if self._board_width[i]:
                message = spaces.Box(-1.0, 1.0, (self._board_width[i],), dtype=np.float32)
                self._action_spaces[agent] = spaces.Dict({"action": base_action, "message": message})
            else:
                self._action_spaces[agent] = base_action
        self.state_space = spaces.Box(state_low, state_high, dtype=np.float32)

    def observation_space(self, agent: str) -> spaces.Space:
        """The seat's observation space: the ``Box`` of its vector, or, in games with illegal
        actions, the ``Dict`` of ``observation`` (that ``Box``) and ``action_mask``."""
        return self._observation_spaces[self._agent_check(agent)]

    def vector_observation_space(self, agent: str) -> spaces.Box:
        """The ``Box`` of the seat's observation vector: what the array API returns for it (its
        row, up to its width), and the ``observation`` entry of the dict in masked games."""
        return self._vector_spaces[self._agent_check(agent)]

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
            self._seed_base, self._seed_rng = int(seed), None  # made only if an unseeded reset follows
            match_seed = int(seed)
        else:
            if self._seed_rng is None:
                self._seed_rng = np.random.default_rng(self._seed_base)
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
        return self._step_checked(self._check_action_array(actions), messages)

    def _step_checked(self, actions: np.ndarray, messages: np.ndarray | None
                      ) -> tuple[np.ndarray, np.ndarray, bool, bool]:
        """:meth:`step_arrays` for actions already checked (:meth:`_check_values`)."""
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
            return self._check_values(arr)
        arr = np.asarray(actions, dtype=np.float32)
        if arr.shape != (n, self.rules.act_dim):
            raise ValueError(f"{self.game_id}: continuous actions have shape ({n}, {self.rules.act_dim}) "
                             f"(one vector of {self.rules.act_dim} floats in [-1, 1] per seat); got {arr.shape}")
        return self._check_values(arr)

    def _check_values(self, arr: np.ndarray) -> np.ndarray:
        """The actions of an array of the right shape and kind (integers of shape ``(n,)``, or
        float32 of shape ``(n, act_dim)``), checked to be in range: as the step takes them."""
        if self._discrete:
            values = arr.tolist()  # a few seats: Python's min and max beat two numpy reductions
            if min(values) < 0 or max(values) >= self.rules.n_actions:
                seat = int(np.flatnonzero((arr < 0) | (arr >= self.rules.n_actions))[0])
                raise ValueError(f"{self.game_id}: action {int(arr[seat])} of player_{seat} is out of range; "
                                 f"valid actions: {self._action_help()}")
            return arr.astype(np.int64, copy=False)
        values = arr.ravel().tolist()
        # (NaN fails a bound where min or max picks it, else makes the sum NaN, unequal to itself)
        if not (min(values) >= -1.0 and max(values) <= 1.0 and sum(values) == sum(values)):
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
        if self._window is not None:
            self.render()
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
        obs, rewards, terminated, truncated = self._step_checked(self._check_values(array), messages)
        if self._window is not None:
            self.render()
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

    def _obs_dict(self, obs: np.ndarray) -> dict[str, Any]:
        if self._masked:
            mask = self.rules.action_mask().astype(np.int8)
            return {a: {"observation": obs[i, : self._obs_dim[i]], "action_mask": mask[i]}
                    for i, a in enumerate(self.possible_agents)}
        if self._has_boards:
            return {a: obs[i, : self._obs_dim[i]] for i, a in enumerate(self.possible_agents)}
        return dict(zip(self.possible_agents, obs))

    def _seat_observation(self, seat: int, obs: np.ndarray) -> Any:
        """What the dict API gives ``seat`` (a copy) for the observations ``obs``."""
        vector = obs[seat, : self._obs_dim[seat]].copy()
        if not self._masked:
            return vector
        return {"observation": vector, "action_mask": self.rules.action_mask()[seat].astype(np.int8)}

    def _infos(self) -> dict[str, dict[str, Any]]:
        return {a: {} for a in self.possible_agents}

    def state(self) -> np.ndarray:
        return self.rules.state()

    def render(self) -> np.ndarray | None:
        """The top-down picture (``rgb_array``); with ``human``, shows it in the window and returns None."""
        return self._render(self.metadata["render_fps"])

    def _render(self, fps: float) -> np.ndarray | None:
        if self.render_mode is None:
            return None
        picture = self.rules.render_topdown()
        if self._window is None:
            return picture
        self._window.show(picture, fps)
        return None

    def close(self) -> None:
        if self._window is not None:
            self._window.close()

    # --- copies ------------------------------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        # the reward context points at the rules' measures, which the rules' own copy may rebuild
        ctx = state.pop("_ctx")
        state["_ctx"] = None if ctx is None else (ctx.previous, ctx.step, ctx.ending)
        if self._window is not None:
            state["_window"] = HumanWindow(self.game_id)  # a window stays with its env
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        ctx = state.pop("_ctx")
        self.__dict__.update(state)
        self.rules.max_cycles = self.max_cycles
        self._ctx = None if ctx is None else RewardContext(self.rules.measures, ctx[0], self.tree.team_of, *ctx[1:])

    # --- league helpers ----------------------------------------------------------------------------
    def team_result(self) -> np.ndarray:
        """Each team's final score (higher is better), once the episode has ended."""
        return self.rules.team_result()

    def pair_points(self) -> np.ndarray:
        """What each team scored toward its pair in this match (``GameRules.pair_points``: the
        game's own measure in paired games, the team result otherwise), once the episode has ended."""
        return self.rules.pair_points()

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


def _checked_bounds(bounds: tuple[np.ndarray, np.ndarray], cells: int, what: str,
                    rules: GameRules) -> tuple[np.ndarray, np.ndarray]:
    low, high = (np.asarray(bound, dtype=np.float32) for bound in bounds)
    if low.shape != (cells,) or high.shape != (cells,) or not np.all(low <= high):
        raise ValueError(f"{type(rules).__name__}.{what}_bounds() must give float32 low and high arrays of "
                         f"{cells} cells with low <= high, not shapes {low.shape} and {high.shape}")
    return low, high
