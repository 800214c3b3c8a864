"""K envs of a game with a whole-array engine, stepped as one: :class:`EngineBatch`.

Snake and GoBang step many boards per numpy call and the robot games step many MuJoCo matches on a
pool of threads (their ``batched_matches``, :mod:`arena_league.matchmaking.batched`). Those engines
give what a match needs (observations, seats to move, endings, results); a rollout also needs each
step's rewards, which the env computes from the rules' measures through its social tree.
:class:`EngineBatch` adds them: the engine keeps every match's measures as the rules would
(``engine.measures``: arrays ``[n_slots, n_agents]``), and each slot has its own copy of the env's
social tree (trees keep per-episode memory, e.g. the ranking's places), evaluated on views of its
slot's row exactly as ``ArenaParallelEnv.step_arrays`` evaluates it. The physics or boards stay
batched; only the trees run once per slot (cheap next to a step: ``benchmarks/env_batch.py``
measures both).

What the engine must offer beside the match-engine contract: ``measures`` (a ``Measures`` of
``[n_slots, n_agents]`` arrays kept current by ``start`` and ``step``, ``outcome`` set when a match
ends by the rules or at ``max_cycles``), ``state()`` (``float32[n_slots, state_dim]``), and, in
turn-based games, ``current_player()`` (``int64[n_slots]``); its ``observe()`` rows of a match
that ended are the rules' observation after the end.

An :class:`EngineBatch` pickles mid-episode (a training run's checkpoint holds one) and goes on
from where it stood. From the same seeds and actions, an :class:`EngineBatch` gives bit for bit the arrays of
:class:`~arena_league.training.vector.EnvList` over K envs made by the same ``env_fn`` (tests check
this for every game with an engine, with default and other social trees).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from arena_league.envs.social.rewards import RewardContext
from arena_league.matchmaking.batched import batched_engine, has_batched_engine
from arena_league.training.vector import EnvBatch

__all__ = ["EngineBatch", "engine_fits"]


def engine_fits(env: Any) -> bool:
    """Whether K envs like ``env`` can be stepped on its game's whole-array engine: the game has
    one, and the observations are the rules' own (no broadcast boards, no global state in them),
    which is all an engine builds."""
    rules = env.rules
    plain = not env.state_in_obs and not any(env.tree.board_width(i) for i in range(rules.n_agents))
    return plain and has_batched_engine(rules)


class EngineBatch(EnvBatch):
    """``n_envs`` envs like ``probe_env`` (its game, options, social tree and ``max_cycles``) on its
    game's whole-array engine; see the module docstring. The probe env itself is not stepped: the
    engine is built from its rules, as the match engine builds it."""

    def __init__(self, probe_env: Any, n_envs: int) -> None:
        if isinstance(n_envs, bool) or not isinstance(n_envs, (int, np.integer)) or n_envs < 1:
            raise ValueError(f"an EngineBatch needs a positive number of envs, not {n_envs!r}")
        if not engine_fits(probe_env):
            raise ValueError(f"{probe_env.game_id}: this env cannot be stepped on a whole-array engine (the game "
                             "has none, or its observations hold broadcast boards or the global state); "
                             "use EnvList (env_batch picks it)")
        self.probe = probe_env
        self.n_envs = int(n_envs)
        rules = probe_env.rules
        self._describe(rules, probe_env.game_id)
        self.max_cycles = int(probe_env.max_cycles)
        self.engine = batched_engine(probe_env, self.n_envs)
        measures = self.engine.measures
        tree = probe_env.tree
        self._previous_names = tuple(tree.previous_needed)
        self._previous = {name: np.array(getattr(measures, name)) for name in self._previous_names}
        self._trees = [copy.deepcopy(tree) for _ in range(self.n_envs)]
        for t in self._trees:
            t.reset()
        self._bind_contexts()
        self._steps = np.zeros(self.n_envs, dtype=np.int64)
        self._live = np.zeros(self.n_envs, dtype=bool)
        self._rewards = np.zeros((self.n_envs, self.n_agents), dtype=np.float32)
        self._obs = np.zeros((self.n_envs, self.n_agents, self.obs_dim), dtype=np.float32)
        self._obs_current = True  # zeros until the first reset, as EnvList's
        self._acting = np.zeros((self.n_envs, self.n_agents), dtype=bool)
        self._masks = np.ones((self.n_envs, self.n_agents, self.n_actions), dtype=bool) if self.masked else None
        self._rows = np.arange(self.n_envs)

    def _bind_contexts(self) -> None:
        """Each slot's reward context: views of its row of the engine's measures and of the previous
        step's, so that the trees read them as the engine updates them in place."""
        measures = self.engine.measures
        self._contexts = [RewardContext(measures.row(k), {name: self._previous[name][k] for name in
                                                          self._previous_names}, self.probe.tree.team_of, 0, False)
                          for k in range(self.n_envs)]

    def __getstate__(self) -> dict[str, Any]:
        # pickling would turn the contexts' views into copies that no longer follow the measures
        state = self.__dict__.copy()
        del state["_contexts"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._bind_contexts()

    def reset(self, k: int, seed: int) -> None:
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be a non-negative integer, not {seed!r}")
        self.engine.start(k, int(seed))
        self._trees[k].reset()
        measures = self.engine.measures
        for name in self._previous_names:
            self._previous[name][k] = getattr(measures, name)[k]
        self._steps[k] = 0
        self._live[k] = True
        self._obs_current = False

    def observations(self) -> np.ndarray:
        if not self._obs_current:
            np.copyto(self._obs, self.engine.observe())
            self._obs_current = True
        return self._obs

    def acting(self) -> np.ndarray:
        acting = self._acting
        if self.turn_based:
            acting[:] = False
            acting[self._rows, self.engine.current_player()] = True
        else:
            np.copyto(acting, self.engine.measures.active)
        return acting

    def action_masks(self) -> np.ndarray | None:
        if self._masks is None:
            return None
        np.copyto(self._masks, self.engine.action_mask())
        return self._masks

    def states(self) -> np.ndarray:
        return self.engine.state()

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if not self._live.all():
            k = int(np.flatnonzero(~self._live)[0])
            raise RuntimeError(f"{self.game_id}: env {k}'s episode is over (or never started); call reset(k, seed) "
                               "before step()")
        actions = self._checked(actions)
        measures = self.engine.measures
        for name in self._previous_names:
            np.copyto(self._previous[name], getattr(measures, name))
        ended = np.asarray(self.engine.step(actions), dtype=bool)
        self._steps += 1
        self._evaluate_trees(ended)
        self._live &= ~ended
        self._obs_current = False
        return self._rewards, ended

    def _evaluate_trees(self, ended: np.ndarray) -> None:
        """Every slot's rewards of the step just played, from its own tree (a method of its own so
        that ``benchmarks/env_batch.py`` can time it apart from the engine)."""
        rewards = self._rewards
        for k, (tree, ctx, step, ending) in enumerate(zip(self._trees, self._contexts, self._steps.tolist(),
                                                          ended.tolist(), strict=True)):
            ctx.step = step
            ctx.ending = ending
            rewards[k] = tree.rewards(ctx)

    def _checked(self, actions: Any) -> np.ndarray:
        """The actions as the engine takes them, refused as an env refuses them (every seat's,
        also those the rules ignore)."""
        k, n = self.n_envs, self.n_agents
        if self.discrete:
            arr = np.asarray(actions)
            if arr.shape != (k, n) or arr.dtype.kind not in "iu":
                raise ValueError(f"{self.game_id}: discrete actions are one integer per env and seat, shape ({k}, {n}); "
                                 f"got shape {arr.shape} dtype {arr.dtype}")
            bad = (arr < 0) | (arr >= self.n_actions)
            if bad.any():
                env, seat = (int(i) for i in np.argwhere(bad)[0])
                raise ValueError(f"{self.game_id}: action {int(arr[env, seat])} of player_{seat} in env {env} is "
                                 f"out of range; valid actions: integers 0..{self.n_actions - 1}")
            return arr.astype(np.int64, copy=False)
        arr = np.asarray(actions, dtype=np.float32)
        if arr.shape != (k, n, self.act_dim):
            raise ValueError(f"{self.game_id}: continuous actions have shape ({k}, {n}, {self.act_dim}) (one vector "
                             f"of {self.act_dim} floats in [-1, 1] per env and seat); got {arr.shape}")
        inside = np.abs(arr) <= 1.0  # NaN fails the comparison
        if not inside.all():
            env, seat = (int(i) for i in np.argwhere(~inside.all(axis=2))[0])
            raise ValueError(f"{self.game_id}: action {arr[env, seat].tolist()} of player_{seat} in env {env} is out "
                             "of range; every component must be finite and within [-1, 1]")
        return arr

    def team_result(self, k: int) -> np.ndarray:
        return np.asarray(self.engine.team_result(k), dtype=np.float64).copy()

    def close(self) -> None:
        close = getattr(self.engine, "close", None)
        if close is not None:
            close()
        self.probe.close()
