"""Rollouts: K copies of one game stepped in lockstep, every seat's action from one batched forward.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) trains its baselines on many parallel games; here, as in the league's
match engine, the rows of all seats of all K envs are grouped by who controls them: the learners
that stack (:mod:`arena_league.training.stack`) make one stacked actor forward (and one critic
forward) per step over every seat they hold, and each fixed opponent policy (a scripted agent, a
snapshot, or a whole pool of snapshots with owner indices) one ``act`` call. The envs are read
and stepped as arrays (:class:`~arena_league.training.vector.EnvBatch`: the game's whole-array
engine where it has one).

Slots: seat ``i`` of env ``k`` is slot ``s = k * n_agents + i``; every array of a
:class:`Rollout` is ``[T, S, ...]`` over T steps and S = K * n_agents slots. Who controls a slot is
chosen when its env starts an episode, by the *seating* callback ``seating(env_index, episode)``
that returns one controller code per seat: ``c >= 0`` is learner ``c`` (of the list passed to
:meth:`RolloutCollector.collect`), ``c < 0`` is fixed opponent ``-1 - c`` of
:attr:`RolloutCollector.opponents` (an :class:`Opponent`: a policy, and for a stacked pool of
snapshots the member it plays). The callback may instead return ``(codes, owners)``; the owners
are kept with the rollout and its episodes for bookkeeping. Controllers change only at episode
boundaries, so every learner's slot trajectory is cut by ``dones`` exactly where it starts and
ends, and one GAE pass over all slots serves every learner (:func:`learner_batch`).

Episodes run across rollouts (the collector keeps its envs); an env whose episode ends is reset at
once with a seed drawn from the collector's generator. The actors read the game's base
observation (its first ``rules.obs_dim`` cells, what an exported agent reads); the critic reads
what :meth:`~arena_league.training.ppo.Learner.critic_features` builds from the observation, the
env's global state ``env.state()`` (recorded when a learner sets ``needs_state``) and the seat.

Determinism: every draw (env seeds, action noise, the opponents' uniforms) comes from the
collector's generator, one fixed-size draw per step whoever acts, so a run is a function of its
seed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from arena_league.policies.policy import Policy
from arena_league.training.ppo import Batch, Learner, gae
from arena_league.training.stack import LearnerStack, RowLayout, stackable, stacks_of
from arena_league.training.vector import env_batch

__all__ = ["Episode", "Opponent", "Rollout", "RolloutCollector", "check_trainable", "learner_batch"]

#: A seating callback: ``(env_index, episode_number) -> codes`` or ``(codes, owners)``.
SeatingFn = Callable[[int, int], Any]


def check_trainable(env: Any) -> None:
    """Raise when ``env`` cannot be trained on by these learners (with the fix)."""
    if getattr(env.tree, "boards", None):
        raise ValueError(f"{env.game_id}: this social tree has broadcast boards, whose message actions the PPO "
                         "learners do not produce; train with a tree without 'board' nodes")


@dataclass(frozen=True)
class Opponent:
    """A fixed policy in some seats: ``policy`` (any league Policy), and for a stacked pool the
    member it plays (``owner``)."""

    policy: Policy
    owner: int | None = None
    name: str = "opponent"


@dataclass
class Episode:
    """A finished episode of one env."""

    env_index: int
    controllers: np.ndarray
    """Controller code of each seat (see the module docstring)."""
    owners: np.ndarray
    returns: np.ndarray
    """Undiscounted return of each seat."""
    team_scores: np.ndarray
    """``env.team_result()``: each team's score, higher is better (two teams: 1 win, 0.5 draw, 0 loss)."""
    team_of: np.ndarray
    length: int

    @property
    def mean_return(self) -> float:
        """Mean return of the learners' seats (all seats when no learner played)."""
        mine = self.controllers >= 0
        return float(self.returns[mine].mean() if mine.any() else self.returns.mean())

    def score_of_team(self, team: int) -> float:
        """A team's result scaled to [0, 1]: 1 for beating every other team, 0.5 a draw, 0 last."""
        n_teams = len(self.team_scores)
        return float(self.team_scores[team]) / max(n_teams - 1, 1)

    def score_of_controller(self, code: int) -> float | None:
        """The result of the team controller ``code`` played (its first seat's team), in [0, 1]."""
        seats = np.flatnonzero(self.controllers == code)
        return None if seats.size == 0 else self.score_of_team(int(self.team_of[seats[0]]))


@dataclass
class Rollout:
    """T lockstep steps of K envs, every array over slots ``s = k * n_agents + seat``."""

    obs: np.ndarray
    """``float32[T, S, obs_dim]`` base observations (what the actors read)."""
    actions: np.ndarray
    """Learner rows: the sampled action the loss re-evaluates (discrete index, or the Gaussian
    sample before clipping / squashing); other rows: the action played."""
    env_actions: np.ndarray
    """The action every seat played (``int64[T, S]`` or ``float32[T, S, act_dim]``)."""
    logprobs: np.ndarray
    values: np.ndarray
    """Denormalised value of the controlling learner's critic (0 for opponents' rows)."""
    value_preds: np.ndarray
    """The critic's raw outputs (normalised when ``norm_value``)."""
    rewards: np.ndarray
    dones: np.ndarray
    """The episode ended with this step."""
    acting: np.ndarray
    """The seat's action counted (active; its turn in a turn-based game)."""
    controllers: np.ndarray
    owners: np.ndarray
    masks: np.ndarray | None
    """``bool[T, S, n_actions]`` legal actions, for games that mask actions."""
    states: np.ndarray | None
    """``float32[T, K, state_dim]`` global states ``env.state()``, when recorded."""
    policy_states: dict[int, np.ndarray]
    """Learner code -> ``float32[T, S, gru_size]`` the recurrent state each step started from."""
    critic_inputs: dict[int, np.ndarray]
    """Learner code -> ``float32[T, S, critic_dim]`` when its critic reads more than the observation."""
    next_values: np.ndarray
    """``float32[S]`` value of the observation after the last step, under the slot's then controller."""
    n_agents: int
    episodes: list[Episode] = field(default_factory=list)
    gae_cache: dict[tuple[float, float], tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)
    """GAE over every slot per (gamma, lambda), computed once for all the learners that share them."""

    @property
    def num_steps(self) -> int:
        return int(self.rewards.shape[0])

    @property
    def num_envs(self) -> int:
        return int(self.rewards.shape[1]) // self.n_agents

    @property
    def env_steps(self) -> int:
        """Env steps taken: ``num_steps * num_envs``."""
        return self.num_steps * self.num_envs

    @property
    def seats(self) -> np.ndarray:
        """Seat index of every slot, ``int64[S]``."""
        return np.tile(np.arange(self.n_agents), self.num_envs)


class RolloutCollector:
    """Steps ``num_envs`` envs in lockstep and records every seat's trajectory.

    Args:
        env_fn: makes one env (``arena_league.envs.make(game_id, ...)`` or any env with the array API).
        num_envs: K, the envs stepped together (as an :class:`~arena_league.training.vector.EnvBatch`:
            the game's whole-array engine where it has one, else K separate envs).
        seed: seeds the collector's generator (env resets, action noise, opponents' uniforms).
        seating: ``(env_index, episode) -> codes`` or ``(codes, owners)``, called whenever an env
            starts an episode (see the module docstring).
        opponents: the fixed policies that negative codes name (may be replaced between rollouts).
        on_episode: called with every finished :class:`Episode` (win-rate tracking, Elo).
    """

    def __init__(self, env_fn: Callable[[], Any], num_envs: int, seed: int, seating: SeatingFn,
                 opponents: Sequence[Opponent] = (), on_episode: Callable[[Episode], None] | None = None) -> None:
        probe = env_fn()
        check_trainable(probe)
        self.envs = env_batch(env_fn, num_envs, probe)
        batch = self.envs
        self.n_agents = batch.n_agents
        self.obs_dim = batch.obs_dim
        self.discrete = batch.discrete
        self.n_actions = batch.n_actions
        self.act_dim = batch.act_dim
        self.turn_based = batch.turn_based
        self.state_dim = batch.state_dim
        self.team_of = batch.team_of
        self.masked = batch.masked
        self.seating = seating
        self.opponents: list[Opponent] = list(opponents)
        self.on_episode = on_episode
        self.rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))
        K, n = num_envs, self.n_agents
        self.num_envs = K
        self.n_slots = K * n
        self.seats = np.tile(np.arange(n), K)
        self.controllers = np.zeros(self.n_slots, dtype=np.int64)
        self.owners = np.zeros(self.n_slots, dtype=np.int64)
        self.episode_count = np.zeros(K, dtype=np.int64)
        self.episode_return = np.zeros(self.n_slots, dtype=np.float64)
        self.episode_length = np.zeros(K, dtype=np.int64)
        self._learner_state: dict[int, np.ndarray] = {}
        self._opponent_state: list[np.ndarray | None] = [None] * self.n_slots
        self._plan: list[tuple[Any, list[int], np.ndarray, np.ndarray, RowLayout]] | None = None
        for k in range(K):
            self._start(k)

    # --- episodes -----------------------------------------------------------------------------------
    def _start(self, k: int) -> None:
        """Reset env k with a fresh seed and seat its controllers for the next episode."""
        n = self.n_agents
        self.envs.reset(k, int(self.rng.integers(2**62)))
        seats = self.seating(k, int(self.episode_count[k]))
        codes, owners = (seats if isinstance(seats, tuple) else (seats, np.zeros(n, dtype=np.int64)))
        codes = np.asarray(codes, dtype=np.int64)
        if codes.shape != (n,):
            raise ValueError(f"the seating callback returned {codes.shape} controller codes; give one per seat ({n})")
        block = slice(k * n, (k + 1) * n)
        if not np.array_equal(self.controllers[block], codes):
            self._plan = None
        self.controllers[block] = codes
        self.owners[block] = np.asarray(owners, dtype=np.int64)
        self.episode_return[block] = 0.0
        self.episode_length[k] = 0
        for states in self._learner_state.values():
            states[block] = 0.0
        for slot in range(k * n, (k + 1) * n):
            code = int(self.controllers[slot])
            if code < 0:
                policy = self._opponent(code).policy
                initial = policy.initial_state(1) if policy.recurrent else None
                self._opponent_state[slot] = None if initial is None else np.asarray(initial)[0]

    def _opponent(self, code: int) -> Opponent:
        index = -1 - code
        if not 0 <= index < len(self.opponents):
            raise ValueError(f"controller code {code} names opponent {index}, but the collector holds "
                             f"{len(self.opponents)}; set collector.opponents before seating them")
        return self.opponents[index]

    def _acting_plan(self, stacks: list[tuple[Any, list[int]]]
                     ) -> list[tuple[Any, list[int], np.ndarray, np.ndarray, RowLayout]]:
        """Per stack of learners: (the stack, its codes, the slots its learners hold now, and each
        slot's position in the stack); recomputed only when a new episode seats other controllers."""
        if self._plan is None:
            plan = []
            for stack, codes in stacks:
                position = np.full(int(max(codes)) + 1, -1, dtype=np.int64)
                position[codes] = np.arange(len(codes))
                held = (self.controllers >= 0) & (self.controllers <= max(codes))
                rows = np.flatnonzero(held)
                rows = rows[position[self.controllers[rows]] >= 0]
                if rows.size:
                    members = position[self.controllers[rows]]
                    plan.append((stack, codes, rows, members, RowLayout(members, len(codes))))
            self._plan = plan
        return self._plan

    # --- the rollout ----------------------------------------------------------------------------------
    def collect(self, learners: Sequence[Learner], num_steps: int, *, stacked: bool = True) -> Rollout:
        """``num_steps`` lockstep steps of every env; learner ``c`` acts for the slots coded ``c``.

        The learners that stack (:func:`~arena_league.training.stack.stacks_of`) act together: one
        stacked actor forward and one stacked critic forward per step for all the slots they hold;
        ``stacked=False`` makes each learner a stack of its own (the same rollout, more calls)."""
        T, S, n, K = num_steps, self.n_slots, self.n_agents, self.num_envs
        batch = self.envs
        needs_state = any(getattr(lr, "needs_state", False) for lr in learners)
        seats = self.seats
        env_of = np.repeat(np.arange(K), n)
        obs_buf = np.zeros((T, S, self.obs_dim), dtype=np.float32)
        if self.discrete:
            actions = np.zeros((T, S), dtype=np.int64)
            env_actions = np.zeros((T, S), dtype=np.int64)
        else:
            actions = np.zeros((T, S, self.act_dim), dtype=np.float32)
            env_actions = np.zeros((T, S, self.act_dim), dtype=np.float32)
        logprobs = np.zeros((T, S), dtype=np.float32)
        values = np.zeros((T, S), dtype=np.float32)
        value_preds = np.zeros((T, S), dtype=np.float32)
        rewards = np.zeros((T, S), dtype=np.float32)
        dones = np.zeros((T, S), dtype=bool)
        acting_buf = np.zeros((T, S), dtype=bool)
        controllers = np.zeros((T, S), dtype=np.int64)
        owners = np.zeros((T, S), dtype=np.int64)
        masks = np.zeros((T, S, self.n_actions), dtype=bool) if self.masked else None
        states = np.zeros((T, K, self.state_dim), dtype=np.float32) if needs_state else None
        policy_states: dict[int, np.ndarray] = {}
        critic_inputs: dict[int, np.ndarray] = {}
        for code, learner in enumerate(learners):
            if learner.architecture.recurrent:
                self._learner_state.setdefault(code, np.zeros((S, learner.architecture.gru_size), dtype=np.float32))
                policy_states[code] = np.zeros((T, S, learner.architecture.gru_size), dtype=np.float32)
        groups = stacks_of(range(len(learners)), learners) if stacked else [[c] for c in range(len(learners))]
        stacks = [(LearnerStack([learners[c] for c in codes]) if stackable([learners[c] for c in codes]) else None,
                  codes) for codes in groups]
        self._plan = None
        episodes: list[Episode] = []
        opponent_tables = self._opponent_tables()
        k_uniform = max(1, self.act_dim) if not self.discrete else 1
        any_opponents = bool(self.opponents)
        for t in range(T):
            # observe: observations, legal actions, who acts, global states
            obs = batch.observations().reshape(S, self.obs_dim)
            obs_buf[t] = obs
            acting = acting_buf[t]
            acting[:] = batch.acting().reshape(S)
            controllers[t] = self.controllers
            owners[t] = self.owners
            mask = None
            if masks is not None:
                mask = masks[t]
                mask[:] = batch.action_masks().reshape(S, self.n_actions)
            state_rows = None
            if states is not None:
                states[t] = batch.states()
                state_rows = states[t][env_of]
            # one fixed-size draw per step, whoever acts: learners' noise and opponents' uniforms
            noise = self.rng.random(S) if self.discrete else self.rng.standard_normal((S, self.act_dim))
            uniforms = self.rng.random((S, k_uniform))
            # act: one stacked forward per stack of learners over every slot they hold
            for stack, codes, rows, members, layout in self._acting_plan(stacks):
                if stack is None:
                    self._learner_act(t, codes[0], learners[codes[0]], rows, obs, noise, mask, state_rows, seats,
                                      acting, actions, env_actions, logprobs, values, value_preds, policy_states,
                                      critic_inputs)
                    continue
                critic_input = self._critic_input(t, T, stack, codes, rows, members, obs, state_rows, critic_inputs)
                out = stack.act(members, obs[rows], noise[rows], None if mask is None else mask[rows], critic_input,
                                layout)
                actions[t, rows] = out.actions
                env_actions[t, rows] = out.env_actions
                logprobs[t, rows] = out.logprobs
                values[t, rows] = out.values
                value_preds[t, rows] = out.value_preds
            # act: one call per distinct fixed opponent policy over its acting rows
            if any_opponents:
                self._opponents_act(opponent_tables, obs, uniforms, mask, acting, env_actions[t])
                opponent_rows = self.controllers < 0
                actions[t][opponent_rows] = env_actions[t][opponent_rows]
            # step every env; an ended episode is recorded and its env reset at once
            step_actions = env_actions[t]
            if self.discrete:
                step_actions = np.where(acting, step_actions, 0)
            reward, ended = batch.step(step_actions.reshape(K, n, *step_actions.shape[1:]))
            rewards[t] = reward.reshape(S)
            self.episode_return += rewards[t]
            self.episode_length += 1
            if ended.any():
                for k in np.flatnonzero(ended).tolist():
                    block = slice(k * n, (k + 1) * n)
                    dones[t, block] = True
                    episode = Episode(k, self.controllers[block].copy(), self.owners[block].copy(),
                                      self.episode_return[block].copy(), batch.team_result(k), self.team_of,
                                      int(self.episode_length[k]))
                    episodes.append(episode)
                    if self.on_episode is not None:
                        self.on_episode(episode)
                    self.episode_count[k] += 1
                    self._start(k)
        # bootstrap: the value of the observation after the last step, under the slot's controller
        next_values = np.zeros(S, dtype=np.float32)
        next_obs = batch.observations().reshape(S, self.obs_dim)
        next_state_rows = batch.states()[env_of] if needs_state else None
        for stack, codes, rows, members, _ in self._acting_plan(stacks):
            if stack is None:
                learner = learners[codes[0]]
                features = learner.critic_features(next_obs[rows], None if next_state_rows is None else
                                                   next_state_rows[rows], seats[rows], n)
                next_values[rows] = learner.values(features)
            else:
                features = stack.learners[0].critic_features(next_obs[rows], None if next_state_rows is None else
                                                             next_state_rows[rows], seats[rows], n)
                next_values[rows] = stack.values(members, features)
        return Rollout(obs_buf, actions, env_actions, logprobs, values, value_preds, rewards, dones, acting_buf,
                       controllers, owners, masks, states, policy_states, critic_inputs, next_values, n, episodes)

    def _critic_input(self, t: int, T: int, stack: LearnerStack, codes: list[int], rows: np.ndarray,
                      members: np.ndarray, obs: np.ndarray, state_rows: np.ndarray | None,
                      critic_inputs: dict[int, np.ndarray]) -> np.ndarray:
        """The stack's critic input rows (its learners share one kind of critic), kept per learner
        in the rollout when the critic reads more than the observation."""
        first = stack.learners[0]
        critic_input = first.critic_features(obs[rows], None if state_rows is None else state_rows[rows],
                                             self.seats[rows], self.n_agents)
        if _own_critic_features(first):
            for i, code in enumerate(codes):
                store = critic_inputs.get(code)
                if store is None:
                    store = critic_inputs[code] = np.zeros((T, self.n_slots, critic_input.shape[1]), dtype=np.float32)
                mine = members == i
                store[t, rows[mine]] = critic_input[mine]
        return critic_input

    def _learner_act(self, t: int, code: int, learner: Learner, rows: np.ndarray, obs: np.ndarray,
                     noise: np.ndarray, mask: np.ndarray | None, state_rows: np.ndarray | None, seats: np.ndarray,
                     acting: np.ndarray, actions: np.ndarray, env_actions: np.ndarray, logprobs: np.ndarray,
                     values: np.ndarray, value_preds: np.ndarray, policy_states: dict[int, np.ndarray],
                     critic_inputs: dict[int, np.ndarray]) -> None:
        """A learner that does not stack (a recurrent or convolutional actor) acts on its own."""
        h = None
        if code in policy_states:
            h = self._learner_state[code][rows]
            policy_states[code][t, rows] = h
        critic_input = learner.critic_features(obs[rows], None if state_rows is None else state_rows[rows],
                                               seats[rows], self.n_agents)
        if _own_critic_features(learner):
            store = critic_inputs.get(code)
            if store is None:
                store = critic_inputs[code] = np.zeros((actions.shape[0], self.n_slots, critic_input.shape[1]),
                                                       dtype=np.float32)
            store[t, rows] = critic_input
        out = learner.act(obs[rows], noise[rows], None if mask is None else mask[rows], h, critic_input)
        actions[t, rows] = out.actions
        env_actions[t, rows] = out.env_actions
        logprobs[t, rows] = out.logprobs
        values[t, rows] = out.values
        value_preds[t, rows] = out.value_preds
        if out.policy_state is not None:
            moved = acting[rows]  # a recurrent state advances only when the seat acts, as in matches
            self._learner_state[code][rows[moved]] = out.policy_state[moved]

    def _opponent_tables(self) -> tuple[list[Policy], np.ndarray, np.ndarray]:
        """The distinct opponent policies, and per opponent index its policy's position and owner."""
        policies: list[Policy] = []
        position: dict[int, int] = {}
        policy_index = np.zeros(len(self.opponents), dtype=np.int64)
        owner = np.full(len(self.opponents), -1, dtype=np.int64)
        for j, opponent in enumerate(self.opponents):
            if id(opponent.policy) not in position:
                position[id(opponent.policy)] = len(policies)
                policies.append(opponent.policy)
            policy_index[j] = position[id(opponent.policy)]
            owner[j] = -1 if opponent.owner is None else opponent.owner
        return policies, policy_index, owner

    def _opponents_act(self, tables: tuple[list[Policy], np.ndarray, np.ndarray], obs: np.ndarray,
                       uniforms: np.ndarray, mask: np.ndarray | None, acting: np.ndarray,
                       env_actions: np.ndarray) -> None:
        """One ``act`` call per distinct opponent policy over its acting rows (a stacked pool gets
        each row's owner); recurrent opponents' states advance only when they act."""
        policies, policy_index, owner = tables
        rows_all = np.flatnonzero((self.controllers < 0) & acting)
        if rows_all.size == 0:
            return
        opponent = -1 - self.controllers[rows_all]
        if opponent.max() >= len(self.opponents):
            self._opponent(int(self.controllers[rows_all[np.argmax(opponent)]]))  # raises, naming the fix
        for p in np.unique(policy_index[opponent]).tolist():
            chosen = policy_index[opponent] == p
            rows = rows_all[chosen]
            policy = policies[p]
            owners = owner[opponent[chosen]]
            kwargs = {"owners": owners} if (owners >= 0).all() else {}
            state = np.stack([self._opponent_state[r] for r in rows]) if policy.recurrent else None
            out, next_state = policy.act(obs[rows, : policy.spec.obs_dim], uniforms[rows],
                                         None if mask is None else mask[rows], state, **kwargs)
            env_actions[rows] = out
            if policy.recurrent and next_state is not None:
                for i, r in enumerate(rows.tolist()):
                    self._opponent_state[r] = np.asarray(next_state)[i]


def learner_batch(rollout: Rollout, code: int, learner: Learner, advantages: np.ndarray | None = None) -> Batch:
    """The :class:`Batch` of learner ``code``'s slots: GAE with the learner's gamma and lambda over
    every slot (controllers change only where episodes end), then the steps it controlled.

    ``advantages``: ``float32[T, S]`` from another estimator (returns are then advantages + values).
    """
    config = learner.config
    if advantages is None:
        key = (config.gamma, config.gae_lambda)
        if key not in rollout.gae_cache:
            rollout.gae_cache[key] = gae(rollout.rewards, rollout.values, rollout.dones, rollout.next_values,
                                         config.gamma, config.gae_lambda)
        advantages, returns = rollout.gae_cache[key]
    else:
        returns = (advantages + rollout.values).astype(np.float32)
    t_idx, s_idx = np.nonzero(rollout.controllers == code)
    if t_idx.size == 0:
        raise ValueError(f"learner {code} ({learner.name}) held no seat in this rollout; check the seating callback")

    def take(array: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(np.ascontiguousarray(array[t_idx, s_idx]))

    critic_input = None
    if code in rollout.critic_inputs:
        critic_input = take(rollout.critic_inputs[code])
    return Batch(
        obs=take(rollout.obs), actions=take(rollout.actions), logprobs=take(rollout.logprobs),
        advantages=take(advantages), returns=take(returns), values=take(rollout.value_preds),
        critic_input=critic_input, masks=None if rollout.masks is None else _legal(take(rollout.masks)),
        policy_states=take(rollout.policy_states[code]) if code in rollout.policy_states else None,
        policy_mask=take(rollout.acting))


def _own_critic_features(learner: Learner) -> bool:
    """True when the learner's critic reads something other than the observation."""
    return type(learner).critic_features is not Learner.critic_features


def _legal(masks: torch.Tensor) -> torch.Tensor:
    """Rows with no legal action (a finished board) become all legal, as the samplers treat them."""
    empty = ~masks.any(dim=1)
    if bool(empty.any()):
        masks = masks.clone()
        masks[empty] = True
    return masks
