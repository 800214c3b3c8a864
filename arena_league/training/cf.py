"""CF: the counterfactual baseline of COMA, for discrete actions.

One of the five baselines of Arena (Song et al., "Arena: A General Evaluation Platform and Building
Toolkit for Multi-Agent Intelligence", AAAI 2020), after Foerster, Farquhar, Afouras, Nardelli &
Whiteson, "Counterfactual Multi-Agent Policy Gradients" (AAAI 2018), COMA:

* **Decentralised actors**, one actor shared by the seats of the trained team (a
  :class:`~arena_league.policies.families.FamilyNet` reading the seat's own observation, so
  every snapshot is an ordinary agent).
* **A centralised Q critic** ``Q(s, u^-a, a, .)``: from the global state ``s = env.state()``, the
  seat's one-hot id ``a`` and the actions ``u^-a`` of every *other* seat (one-hot blocks in seat
  order; the seat's own block, and the block of a seat whose action did not count, are zero), it
  outputs the Q value of each of the seat's ``n_actions`` actions in one forward.
* **The counterfactual advantage** (COMA, eq. 4): ``A^a(s, u) = Q(s, u) - sum_u' pi^a(u' | tau^a)
  Q(s, (u^-a, u'))``: the taken action's value minus the policy-weighted value of the seat's
  alternatives, with the other seats' actions held fixed. All of it comes from the one forward
  above, since the critic's input does not contain the seat's own action.
* **The critic** learns from TD(lambda) targets (COMA: lambda = 0.8) computed with a target
  network that is copied from the critic every ``target_update_interval`` critic gradient steps:
  ``G_t = r_t + gamma * [(1 - lambda) Q'(s_{t+1}, u_{t+1}) + lambda G_{t+1}]``, cut where an
  episode ends (a game's cut at ``max_cycles`` is a real end: the rules give that match its
  result, as the core's GAE treats it). The last step of a rollout whose episode goes on has no
  target of its own (its successor is not collected yet); it only bootstraps the steps before it.
  The critic is trained first, then the advantages are computed with it.
* **The actor** is trained with that advantage through the PPO core's clipped update
  (:func:`~arena_league.training.ppo.ppo_update`, value loss off: the learner holds no value
  critic), not with COMA's plain policy gradient. Why: the clipped surrogate lets each rollout be
  used for several epochs of minibatches without the policy moving far from the one that
  collected it (COMA's gradient is on-policy, so it would get one step per rollout), and the core
  already carries the entropy bonus, advantage normalisation and gradient clipping. With
  ``update_epochs=1``, ``num_minibatches=1``, ``norm_adv=False`` and ``ent_coef=0`` the update is
  exactly COMA's: at the collecting policy the ratio is 1, where the clipped surrogate's gradient
  is ``A grad log pi``.

Opponents are seated as in the centralised-critic learner (:class:`~arena_league.training.cc.TeamSeats`):
by default the learner plays a different team each episode against snapshots of itself. The
opponents' actions enter the critic like the teammates' (they are part of ``u^-a``).

Measured (seed 0, one run each, the shared 2-core machine), :class:`CFConfig`'s defaults, iterations
of 8 x 128 steps on Crossroads-2T2P-v1 (``max_cycles=100``): against ``scripted:heuristic`` on the
default tree, the mean return went from -100.1 (first 10 iterations) to -86.9 (last 10 of 150; the
best 10-iteration window -57.0: it learns to win sooner than the centralised critic, then
oscillates), 53 s; on the fully cooperative ``all_CL`` tree with the learner in every seat, from
1.4 to 12.6 in 100 iterations.

Continuous actions are refused: the critic's output and the baseline's sum run over a finite set
of actions (COMA is defined for discrete actions); use the ``"cc"`` scheme for continuous control.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np
import torch
from torch import nn

from arena_league.policies.architecture import Architecture
from arena_league.policies.families import legal_mask
from arena_league.policies.policy import Policy
from arena_league.training.cc import TeamSeats, paper_config, paper_runner
from arena_league.training.ppo import Learner, PPOConfig
from arena_league.training.rollout import RolloutCollector
from arena_league.training.schemes import register_scheme
from arena_league.training.trainer import TrainerBase, annealed_lr, figure, format_record, iteration_record

__all__ = ["CF", "CFConfig", "COMACritic", "counterfactual_advantage", "counterfactual_critic_inputs",
           "policy_probabilities", "td_lambda_targets"]

#: Logit of an illegal action (as the core's): finite, so ``0 * Q`` stays 0 in the baseline.
_ILLEGAL_LOGIT = -1e8


@dataclass(frozen=True)
class CFConfig(PPOConfig):
    """PPO's hyper-parameters and the Q critic's, with COMA's values (Foerster et al. 2018, and
    the authors' pymarl ``coma.yaml``) where it has them."""

    learning_rate: float = 5e-4
    """Actor step size (COMA: 5e-4)."""
    anneal_lr: bool = False
    """Linear step-size decay of actor and critic (COMA: none)."""
    clip_coef: float = 0.2
    """Surrogate clipping epsilon (PPO with several epochs; MAPPO's 0.2)."""
    max_grad_norm: float = 10.0
    """Global gradient-norm clip of actor and critic (pymarl's COMA: 10)."""
    critic_lr: float = 5e-4
    """Q critic's Adam step size (COMA: 5e-4)."""
    td_lambda: float = 0.8
    """Lambda of the critic's TD(lambda) targets (COMA: 0.8)."""
    target_update_interval: int = 200
    """Critic gradient steps between copies of the critic into its target network (pymarl's COMA: 200)."""
    critic_epochs: int = 4
    """Passes of the critic over each rollout (PPO's epochs; COMA: one pass)."""
    critic_minibatches: int = 4
    """Critic minibatches per pass."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (0 <= self.td_lambda <= 1 and self.critic_lr > 0):
            raise ValueError(f"CFConfig: td_lambda must lie in [0, 1] and critic_lr be positive, got "
                             f"{self.td_lambda}, {self.critic_lr}")
        for name in ("target_update_interval", "critic_epochs", "critic_minibatches"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"CFConfig.{name} must be a positive integer, not {value!r}")


# --- the counterfactual maths (pure functions) -------------------------------------------------------

def counterfactual_critic_inputs(states: np.ndarray, actions: np.ndarray, acting: np.ndarray,
                                 n_actions: int) -> np.ndarray:
    """The Q critic's input of every seat: ``[s | one-hot seat id | one-hot actions of the others]``.

    Args:
        states: ``float32[..., state_dim]`` global states.
        actions: ``int[..., n_agents]`` every seat's action at that state.
        acting: ``bool[..., n_agents]`` the seats whose action counted (the others' blocks are zero).
        n_actions: actions per seat.
    Returns ``float32[..., n_agents, state_dim + n_agents + n_agents * n_actions]``: row ``i`` holds
    seat ``i``'s id and every other seat's action; seat ``i``'s own block is zero, so the row is the
    same whatever seat ``i`` did (the others' actions held fixed).
    """
    actions = np.asarray(actions, dtype=np.int64)
    lead, n = actions.shape[:-1], actions.shape[-1]
    joint = np.eye(n_actions, dtype=np.float32)[actions] * np.asarray(acting, dtype=np.float32)[..., None]
    joint = joint.reshape(*lead, 1, n * n_actions)
    not_own = 1.0 - np.kron(np.eye(n, dtype=np.float32), np.ones((1, n_actions), dtype=np.float32))
    others = joint * not_own  # [..., n, n * n_actions]
    ids = np.broadcast_to(np.eye(n, dtype=np.float32), (*lead, n, n))
    state = np.broadcast_to(np.asarray(states, dtype=np.float32)[..., None, :], (*lead, n, states.shape[-1]))
    return np.concatenate([state, ids, others], axis=-1)


def counterfactual_advantage(q_values: torch.Tensor, probs: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
    """COMA's advantage ``Q(s, u)[u^a] - sum_u' pi(u') Q(s, (u^-a, u'))`` (Foerster et al. 2018, eq. 4).

    Args:
        q_values: ``[..., n_actions]`` the critic's Q of each of the seat's actions, others' actions fixed.
        probs: ``[..., n_actions]`` the seat's policy ``pi^a(. | tau^a)``.
        actions: ``int[...]`` the action the seat took.
    """
    taken = q_values.gather(-1, actions.long().unsqueeze(-1)).squeeze(-1)
    return taken - (probs * q_values).sum(-1)


def td_lambda_targets(rewards: np.ndarray, dones: np.ndarray, q_taken: np.ndarray, gamma: float,
                      td_lambda: float) -> tuple[np.ndarray, np.ndarray]:
    """TD(lambda) targets of ``[T, N]`` trajectories for a Q critic (Sutton & Barto, ch. 12).

    ``G_t = r_t + gamma (1 - done_t) [(1 - lambda) q_{t+1} + lambda G_{t+1}]``, where ``q_t`` is the
    (target network's) Q of the action taken at step t and ``dones[t]`` marks that the episode
    ended with step t. The last step bootstraps the truncated return (``G_{T-1} = q_{T-1}``, or
    ``r_{T-1}`` when its episode ended there) and has a target only in that case.

    Returns (targets ``float32[T, N]``, valid ``bool[T, N]``: the steps that have a target).
    """
    T = rewards.shape[0]
    targets = np.zeros(rewards.shape, dtype=np.float64)
    done = np.asarray(dones, dtype=bool)
    last = np.where(done[T - 1], rewards[T - 1], q_taken[T - 1]).astype(np.float64)
    targets[T - 1] = last
    for t in reversed(range(T - 1)):
        following = (1.0 - td_lambda) * q_taken[t + 1] + td_lambda * last
        last = rewards[t] + gamma * (1.0 - done[t]) * following
        targets[t] = last
    valid = np.ones(rewards.shape, dtype=bool)
    valid[T - 1] = done[T - 1]
    return targets.astype(np.float32), valid


def policy_probabilities(learner: Learner, obs: torch.Tensor, masks: np.ndarray | None,
                         policy_states: torch.Tensor | None = None) -> torch.Tensor:
    """``pi^a(. | tau^a)`` of rows of the learner's actor, illegal actions at probability 0."""
    with torch.no_grad():
        logits, _ = learner.actor(obs, policy_states)
        mask = legal_mask(masks, tuple(logits.shape))
        if mask is not None:
            logits = logits.masked_fill(~torch.from_numpy(mask), _ILLEGAL_LOGIT)
        return torch.softmax(logits, dim=-1)


class COMACritic(nn.Module):
    """``Q(s, u^-a, a, .)``: ``[Linear -> act] * len(hidden) -> Linear(n_actions)``, orthogonally
    initialised (gain sqrt 2 in the body, 1 at the output, as the core's critic)."""

    def __init__(self, in_dim: int, n_actions: int, hidden: tuple[int, ...], activation: str,
                 generator: torch.Generator) -> None:
        super().__init__()
        widths = (in_dim, *hidden)
        self.hidden = nn.ModuleList(nn.Linear(a, b) for a, b in pairwise(widths))
        self.head = nn.Linear(widths[-1], n_actions)
        self._act = torch.tanh if activation == "tanh" else torch.relu
        with torch.no_grad():
            for layer, gain in [(h, math.sqrt(2.0)) for h in self.hidden] + [(self.head, 1.0)]:
                nn.init.orthogonal_(layer.weight, gain=gain, generator=generator)
                layer.bias.zero_()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        for layer in self.hidden:
            x = self._act(layer(x))
        return self.head(x)


# --- the scheme ------------------------------------------------------------------------------------

class CF(TrainerBase):
    """COMA: one team's shared actor trained with the counterfactual advantage of a Q critic.

    Args:
        env_fn: makes one env of the game; its actions must be discrete.
        config: hyper-parameters (default :class:`CFConfig`; a plain PPOConfig keeps its values).
        seed: seeds actor, critic, env resets, action noise and opponent draws.
        critic_lr, td_lambda, target_update_interval, critic_epochs, critic_minibatches: the Q
            critic's hyper-parameters (None: the config's; see :class:`CFConfig`).
        opponent, opponent_sampling, pfsp_p, pool_every, pool_size, team: who plays the other
            teams (see :class:`~arena_league.training.cc.TeamSeats`).
        architecture: the actor's family and sizes (default from ``config``).
        total_steps: env steps of the run, for learning-rate annealing.
        log: called with a line per iteration.

    Raises ``ValueError`` for a game made with continuous actions.
    """

    scheme = "cf"
    #: The action types it trains (``training.schemes.scheme_action_types`` reads it).
    action_types = ("discrete",)

    def __init__(self, env_fn: Callable[[], Any], config: PPOConfig | None = None, seed: int = 0, *,
                 critic_lr: float | None = None, td_lambda: float | None = None,
                 target_update_interval: int | None = None, critic_epochs: int | None = None,
                 critic_minibatches: int | None = None, opponent: str | Policy = "self",
                 opponent_sampling: str = "pfsp_hard", pfsp_p: float = 2.0, pool_every: int = 5,
                 pool_size: int = 64, team: int | None = None, architecture: Architecture | None = None,
                 total_steps: int | None = None, log: Callable[[str], None] | None = None) -> None:
        critic_options = {"critic_lr": critic_lr, "td_lambda": td_lambda, "target_update_interval":
                          target_update_interval, "critic_epochs": critic_epochs,
                          "critic_minibatches": critic_minibatches}
        config = paper_config(CFConfig, config)
        config = CFConfig(**{**config.__dict__, **{k: v for k, v in critic_options.items() if v is not None}})
        probe = self._begin(env_fn, config, seed, architecture, total_steps, log)
        rules = probe.rules
        if rules.action_type not in self.action_types:
            raise ValueError(f"CF (COMA's counterfactual baseline) needs discrete actions: its critic outputs Q for "
                             f"each of a seat's actions and the baseline sums over them, but this {probe.game_id} "
                             f"env has {rules.action_type} actions. Make it with action_type='discrete' "
                             f"(run_scheme(..., action_type='discrete')), or train continuous control with 'cc'")
        self.n_agents, self.n_actions = int(rules.n_agents), int(rules.n_actions)
        # the actor: a core learner without a value critic; the collector records env.state() for it
        learner = Learner(self.architecture, self.config, seed, critic_dim=0, name="cf")
        learner.needs_state = True
        self.learners = [learner]
        # the Q critic and its target network
        generator = torch.Generator().manual_seed(int(seed) + 2)
        in_dim = int(rules.state_dim) + self.n_agents + self.n_agents * self.n_actions
        self.critic = COMACritic(in_dim, self.n_actions, self.config.critic_hidden, self.config.activation, generator)
        self.target_critic = copy.deepcopy(self.critic).requires_grad_(False)
        self.critic_optimiser = torch.optim.Adam(self.critic.parameters(), lr=self.config.critic_lr,
                                                 eps=self.config.adam_eps)
        self.critic_steps = 0
        self.synced_at = 0
        self.seats = TeamSeats(probe, self.architecture, learner.actor_parameters(), seed, opponent=opponent,
                               opponent_sampling=opponent_sampling, pfsp_p=pfsp_p, pool_every=pool_every,
                               pool_size=pool_size, team=team)
        self.collector = RolloutCollector(env_fn, self.config.num_envs, seed, seating=self.seats.seating,
                                          opponents=self.seats.opponents(), on_episode=self.seats.record)

    def _iterate(self) -> dict[str, Any]:
        """One iteration: rollout, critic update on TD(lambda) targets, counterfactual advantages,
        the actor's clipped update. The record's losses report the Q critic's loss as
        ``value_loss`` and its explained variance of the targets as ``explained_variance``."""
        config = self.config
        # rollout: the learner's seats in one actor forward per step; states and every seat's action recorded
        rollout, start, collect_time = self._collect()
        learner = self.learners[0]
        lr = annealed_lr(config, self.env_steps, self.total_steps)
        # the critic's inputs of the learner's rows: state, seat id, the others' actions
        T, K, n = rollout.num_steps, rollout.num_envs, self.n_agents
        assert rollout.states is not None
        features = counterfactual_critic_inputs(rollout.states, rollout.env_actions.reshape(T, K, n),
                                                rollout.acting.reshape(T, K, n), self.n_actions).reshape(T, K * n, -1)
        t_idx, s_idx = np.nonzero(rollout.controllers == 0)
        x = torch.from_numpy(np.ascontiguousarray(features[t_idx, s_idx]))
        taken = torch.from_numpy(rollout.env_actions[t_idx, s_idx])
        # critic: TD(lambda) targets from the target network, then minibatch regression on them
        with torch.no_grad():
            q_taken = np.zeros(rollout.rewards.shape, dtype=np.float32)
            q_taken[t_idx, s_idx] = self.target_critic(x).gather(1, taken.unsqueeze(1)).squeeze(1).numpy()
        targets, valid = td_lambda_targets(rollout.rewards, rollout.dones, q_taken, config.gamma, config.td_lambda)
        critic_loss, explained = self._train_critic(x, taken, torch.from_numpy(targets[t_idx, s_idx]),
                                                    torch.from_numpy(valid[t_idx, s_idx]),
                                                    config.critic_lr * lr / config.learning_rate)
        # counterfactual advantages with the trained critic and the policy that collected the rollout
        masks = None if rollout.masks is None else rollout.masks[t_idx, s_idx]
        policy_states = (torch.from_numpy(rollout.policy_states[0][t_idx, s_idx]) if 0 in rollout.policy_states
                         else None)
        probs = policy_probabilities(learner, torch.from_numpy(rollout.obs[t_idx, s_idx]), masks, policy_states)
        with torch.no_grad():
            advantage = counterfactual_advantage(self.critic(x), probs, taken)
        advantages = np.zeros(rollout.rewards.shape, dtype=np.float32)
        advantages[t_idx, s_idx] = advantage.numpy()
        # actor: the core's clipped update on those advantages (no value loss: no value critic)
        stats = self._update(rollout, [0], advantages=advantages)[0]
        stats.value_loss, stats.explained_variance = critic_loss, explained
        self.iteration += 1
        self.seats.after_update(learner, self.collector)
        # log
        record = iteration_record(self, rollout, [stats], start, collect_time)
        record["win_rate"] = self.seats.win_rate()
        record["critic_steps"] = self.critic_steps
        if self.log:
            self.log(format_record(record) + f" win_rate {figure(record['win_rate'], '.2f')} q_ev {figure(explained, '.2f')}")
        return record

    def _train_critic(self, x: torch.Tensor, taken: torch.Tensor, targets: torch.Tensor, valid: torch.Tensor,
                      critic_lr: float) -> tuple[float, float]:
        """``critic_epochs`` passes of squared TD(lambda) error over minibatches of the rows that
        have a target, copying the critic into the target network every ``target_update_interval``
        steps. Returns (mean loss, explained variance of the targets after training)."""
        config = self.config
        rows = torch.nonzero(valid).squeeze(1)
        if rows.numel() == 0:
            return float("nan"), float("nan")
        for group in self.critic_optimiser.param_groups:
            group["lr"] = critic_lr
        size = max(1, math.ceil(rows.numel() / config.critic_minibatches))
        losses = []
        for _ in range(config.critic_epochs):
            order = rows[torch.from_numpy(self.rng.permutation(rows.numel()))]
            for start in range(0, rows.numel(), size):
                mb = order[start: start + size]
                q = self.critic(x[mb]).gather(1, taken[mb].unsqueeze(1)).squeeze(1)
                loss = 0.5 * ((q - targets[mb]) ** 2).mean()
                self.critic_optimiser.zero_grad(set_to_none=True)
                loss.backward()
                nn.utils.clip_grad_norm_(self.critic.parameters(), config.max_grad_norm)
                self.critic_optimiser.step()
                losses.append(loss.item())
                self.critic_steps += 1
                if self.critic_steps - self.synced_at >= config.target_update_interval:
                    self.target_critic.load_state_dict(self.critic.state_dict())
                    self.synced_at = self.critic_steps
        with torch.no_grad():
            predicted = self.critic(x[rows]).gather(1, taken[rows].unsqueeze(1)).squeeze(1)
            variance = float(targets[rows].var()) if rows.numel() > 1 else 0.0
            explained = float("nan") if variance == 0 else 1.0 - float((targets[rows] - predicted).var()) / variance
        return float(np.mean(losses)), explained

    def snapshot_metrics(self, index: int) -> dict[str, Any]:
        """What a snapshot records besides its weights: the critic's settings and the opponents."""
        return {"critic": "Q(state, seat_id, others' actions)", "critic_steps": self.critic_steps,
                **self.seats.describe()}


register_scheme(CF.scheme, paper_runner(CF, CFConfig))
