"""The PPO core every learner of arena-league is built on.

Proximal Policy Optimization (Schulman, Wolski, Dhariwal, Radford & Klimov, "Proximal Policy
Optimization Algorithms", 2017) with Generalized Advantage Estimation (Schulman, Moritz, Levine,
Jordan & Abbeel, "High-Dimensional Continuous Control Using Generalized Advantage Estimation",
ICLR 2016) and the implementation details catalogued by Huang, Dossa, Raffin, Kanervisto & Wang
("The 37 Implementation Details of Proximal Policy Optimization", ICLR blog track 2022, whose
single-file CleanRL ``ppo.py`` this module follows): orthogonal initialisation, Adam with
``eps=1e-5``, linear learning-rate annealing, per-minibatch advantage normalisation, the clipped
surrogate objective, value clipping, an entropy bonus and global gradient-norm clipping. Value
normalisation (a running mean and standard deviation of the returns, the critic predicting
normalised returns) follows MAPPO (Yu et al., "The Surprising Effectiveness of PPO in Cooperative
Multi-Agent Games", NeurIPS 2022).

The pieces, in the order one iteration uses them:

* :class:`PPOConfig`: the hyper-parameters, each with its default's source;
* :class:`Learner`: an actor (a :class:`~arena_league.policies.families.FamilyNet`, so a
  snapshot is an arena-policy / ONNX agent as it stands), a critic, the optimiser and the value
  normaliser; :meth:`Learner.act` samples actions from caller-given noise (deterministic);
* :func:`gae`: advantages and returns of ``[T, N]`` trajectories;
* :class:`Batch`: the flat samples one update consumes;
* :func:`ppo_update`: the optimisation epochs over minibatches (separate from collection, so the
  centralised-critic and counterfactual learners reuse it with their own advantages and critics).

The schemes drive these pieces from :mod:`arena_league.training.trainer` (the trainer base and
the plain parameter-shared PPO scheme) and :mod:`arena_league.training.rollout` (collection).

Heads: discrete actions are a categorical over the actor's logits, restricted to the legal ones
when the game masks actions; continuous actions are a Gaussian around the actor's ``tanh`` output
with a state-independent learned log standard deviation, either clipped to [-1, 1] by the env
(``continuous_head="clip"``, CleanRL's choice) or squashed by ``tanh`` (``"tanh"``, with the
log-determinant correction of Haarnoja et al. 2018). The exported agent plays the actor's
deterministic ``tanh`` output. GRU actors are re-evaluated, step by step, from the recurrent
state each step started from (stored at collection), so gradients do not flow back through time.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from itertools import pairwise
from typing import Any

import numpy as np
import torch
from torch import nn

from arena_league.policies.architecture import Architecture
from arena_league.policies.families import FamilyNet, TorchPolicy, build_module, legal_mask
from arena_league.policies.policy import sample_from_logits

__all__ = [
    "Batch",
    "Learner",
    "PPOConfig",
    "RunningMeanStd",
    "UpdateStats",
    "ValueNet",
    "gae",
    "learner_architecture",
    "ppo_update",
]

#: Logit given to illegal actions: finite, so ``p log p`` stays 0 rather than NaN.
_ILLEGAL_LOGIT = -1e8
#: Keeps ``log(1 - tanh(u)^2)`` finite for the squashed Gaussian.
_SQUASH_EPS = 1e-6
#: The noise (``families.NOISES``) a snapshot of each continuous head samples with.
_SNAPSHOT_NOISE = {"clip": "gaussian", "tanh": "squashed"}


@dataclass(frozen=True)
class PPOConfig:
    """Hyper-parameters of PPO. Defaults are CleanRL ``ppo.py``'s, i.e. the Atari settings of
    Schulman et al. (2017, Table 5) with the details of Huang et al. (2022), unless noted."""

    learning_rate: float = 2.5e-4
    """Adam step size (Schulman et al. 2017: 2.5e-4)."""
    anneal_lr: bool = True
    """Decay the step size linearly to 0 over the run (Schulman et al. 2017)."""
    num_envs: int = 8
    """Copies of the game stepped in lockstep (CleanRL: 8 for Atari)."""
    num_steps: int = 128
    """Steps per env per rollout, the horizon T (Schulman et al. 2017: 128)."""
    gamma: float = 0.99
    """Discount factor (Schulman et al. 2017: 0.99)."""
    gae_lambda: float = 0.95
    """GAE lambda (Schulman et al. 2017: 0.95)."""
    num_minibatches: int = 4
    """Minibatches per epoch (CleanRL: 4)."""
    update_epochs: int = 4
    """Optimisation epochs per rollout (CleanRL: 4; Schulman et al. 2017: 3)."""
    norm_adv: bool = True
    """Normalise advantages per minibatch (Huang et al. 2022, detail 7)."""
    clip_coef: float = 0.1
    """Surrogate clipping epsilon (Schulman et al. 2017: 0.1 on Atari)."""
    clip_vloss: bool = True
    """Clip the value loss around the old predictions (Huang et al. 2022, detail 9)."""
    ent_coef: float = 0.01
    """Entropy bonus coefficient (Schulman et al. 2017: 0.01)."""
    vf_coef: float = 0.5
    """Value loss coefficient (CleanRL: 0.5)."""
    max_grad_norm: float = 0.5
    """Global gradient-norm clip (Huang et al. 2022, detail 11)."""
    target_kl: float | None = None
    """Stop the epochs early once the approximate KL exceeds this (None: never; CleanRL)."""
    norm_value: bool = True
    """Critic predicts returns normalised by their running mean and std (MAPPO's ValueNorm)."""
    adam_eps: float = 1e-5
    """Adam epsilon (Huang et al. 2022, detail 3)."""
    family: str = "mlp"
    """Actor family: "mlp" or "gru" ("cnn" needs an explicit Architecture with its grid)."""
    hidden: tuple[int, ...] = (64, 64)
    """Hidden layer widths of the actor (CleanRL: 64, 64)."""
    activation: str = "tanh"
    """Hidden activation of actor and critic (CleanRL: tanh)."""
    gru_size: int = 64
    """Recurrent state size of a "gru" actor."""
    critic_hidden: tuple[int, ...] = (64, 64)
    """Hidden layer widths of the critic (CleanRL: 64, 64)."""
    continuous_head: str = "clip"
    """Continuous actions: "clip" a Gaussian to [-1, 1] (CleanRL) or squash it with "tanh"."""
    init_log_std: float = 0.0
    """Initial log standard deviation of the Gaussian head (CleanRL: 0)."""

    def __post_init__(self) -> None:
        for name in ("num_envs", "num_steps", "num_minibatches", "update_epochs"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"PPOConfig.{name} must be a positive integer, not {value!r}")
        for name in ("learning_rate", "gamma", "gae_lambda", "clip_coef", "max_grad_norm", "adam_eps"):
            if not getattr(self, name) > 0:
                raise ValueError(f"PPOConfig.{name} must be positive, not {getattr(self, name)!r}")
        if not (0 < self.gamma <= 1 and 0 <= self.gae_lambda <= 1):
            raise ValueError(f"PPOConfig: gamma must lie in (0, 1] and gae_lambda in [0, 1], got {self.gamma}, "
                             f"{self.gae_lambda}")
        if self.continuous_head not in ("clip", "tanh"):
            raise ValueError(f"PPOConfig.continuous_head must be 'clip' or 'tanh', not {self.continuous_head!r}")
        if self.family not in ("mlp", "gru"):
            raise ValueError(f"PPOConfig.family must be 'mlp' or 'gru', not {self.family!r}; for a 'cnn' actor pass "
                             "architecture=Architecture('cnn', ..., grid=GridLayout(...)) to the scheme")
        object.__setattr__(self, "hidden", tuple(int(h) for h in self.hidden))
        object.__setattr__(self, "critic_hidden", tuple(int(h) for h in self.critic_hidden))

    @property
    def batch_size(self) -> int:
        """Env steps per rollout: ``num_envs * num_steps``."""
        return self.num_envs * self.num_steps

    @classmethod
    def with_overrides(cls, base: PPOConfig | None = None, **overrides: Any) -> PPOConfig:
        """``base`` (default: the defaults) with the named fields replaced; unknown names raise."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise TypeError(f"unknown PPOConfig field(s) {', '.join(unknown)}; valid: {', '.join(sorted(known))}")
        return replace(base or cls(), **overrides)


def learner_architecture(config: PPOConfig, obs_dim: int, action_type: str, n_actions: int = 0,
                         act_dim: int = 0) -> Architecture:
    """The actor :class:`Architecture` ``config`` asks for, for a game's spaces."""
    return Architecture(config.family, obs_dim, action_type, n_actions=n_actions if action_type == "discrete" else 0,
                        act_dim=act_dim if action_type == "continuous" else 0, hidden=config.hidden,
                        activation=config.activation, gru_size=config.gru_size if config.family == "gru" else 0)


# --- value normalisation and the critic -------------------------------------------------------------

class RunningMeanStd:
    """Running mean and variance of a stream of returns (Chan et al.'s parallel update), float64."""

    def __init__(self, epsilon: float = 1e-4) -> None:
        self.mean = 0.0
        self.var = 1.0
        self.count = epsilon

    def update(self, x: np.ndarray | torch.Tensor) -> None:
        x = np.asarray(x, dtype=np.float64).reshape(-1)
        if x.size == 0:
            return
        batch_mean, batch_var, n = float(x.mean()), float(x.var()), x.size
        delta = batch_mean - self.mean
        total = self.count + n
        self.mean += delta * n / total
        self.var = (self.var * self.count + batch_var * n + delta**2 * self.count * n / total) / total
        self.count = total

    @property
    def std(self) -> float:
        return math.sqrt(max(self.var, 1e-8))

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.mean) / self.std

    def denormalize(self, x: np.ndarray) -> np.ndarray:
        return x * self.std + self.mean

    def state(self) -> dict[str, float]:
        return {"mean": self.mean, "var": self.var, "count": self.count}

    def load_state(self, state: Mapping[str, float]) -> None:
        self.mean, self.var, self.count = float(state["mean"]), float(state["var"]), float(state["count"])


class ValueNet(nn.Module):
    """The critic: ``[Linear -> act] * len(hidden) -> Linear(1)``, orthogonally initialised
    (gain sqrt 2 in the body, 1 at the output; Huang et al. 2022, detail 2)."""

    def __init__(self, in_dim: int, hidden: tuple[int, ...], activation: str, generator: torch.Generator) -> None:
        super().__init__()
        widths = (in_dim, *hidden)
        self.hidden = nn.ModuleList(nn.Linear(a, b) for a, b in pairwise(widths))
        self.head = nn.Linear(widths[-1], 1)
        self._act = torch.tanh if activation == "tanh" else torch.relu
        with torch.no_grad():
            for layer, gain in [(h, math.sqrt(2.0)) for h in self.hidden] + [(self.head, 1.0)]:
                nn.init.orthogonal_(layer.weight, gain=gain, generator=generator)
                layer.bias.zero_()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        for layer in self.hidden:
            x = self._act(layer(x))
        return self.head(x).squeeze(-1)


# --- the learner ------------------------------------------------------------------------------------

@dataclass
class ActResult:
    """What :meth:`Learner.act` returns for N rows (numpy)."""

    env_actions: np.ndarray
    """What the env receives: ``int64[N]``, or ``float32[N, act_dim]`` in [-1, 1]."""
    actions: np.ndarray
    """What the loss re-evaluates: the discrete index, or the Gaussian sample before clip / tanh."""
    logprobs: np.ndarray
    values: np.ndarray
    """Denormalised value estimates (0 without a critic)."""
    value_preds: np.ndarray
    """The critic's raw outputs (normalised when ``norm_value``), for value clipping."""
    policy_state: np.ndarray | None


class Learner:
    """One PPO agent: actor, critic, optimiser, value normaliser and hyper-parameters.

    Args:
        arch: the actor's architecture (its spaces must be the game's; see :func:`learner_architecture`).
        config: hyper-parameters (a PBT learner carries its own).
        seed: initialises actor (``init_parameters(arch, seed)``) and critic.
        critic_dim: input width of the critic (default ``arch.obs_dim``; a centralised critic passes
            its own and overrides :meth:`critic_features`); 0 builds no critic (a learner whose
            advantages come from elsewhere, e.g. a counterfactual baseline).
        name: for logs and snapshots.
    """

    #: True when :meth:`critic_features` reads the env's global state (the collector then records
    #: ``env.state()`` every step).
    needs_state: bool = False

    def __init__(self, arch: Architecture, config: PPOConfig, seed: int, *, critic_dim: int | None = None,
                 name: str = "learner") -> None:
        self.architecture = arch
        self.config = config
        self.name = name
        self.seed = int(seed)
        generator = torch.Generator().manual_seed(int(seed) + 1)
        self.actor: FamilyNet = build_module(arch, seed=int(seed)).train()
        width = arch.obs_dim if critic_dim is None else int(critic_dim)
        self.critic: ValueNet | None = (ValueNet(width, config.critic_hidden, config.activation, generator)
                                        if width > 0 else None)
        self.log_std: nn.Parameter | None = None
        if arch.action_type == "continuous":
            self.log_std = nn.Parameter(torch.full((arch.act_dim,), float(config.init_log_std)))
        self.value_norm: RunningMeanStd | None = RunningMeanStd() if config.norm_value and self.critic else None
        self.optimiser = torch.optim.Adam(self.trainable_parameters(), lr=config.learning_rate, eps=config.adam_eps)
        self.updates = 0
        #: Draws this learner's minibatches: its own, so its updates do not depend on the learners
        #: it is stacked with.
        self.rng = np.random.default_rng(np.random.SeedSequence([int(seed), 6]))

    # --- parameters -------------------------------------------------------------------------------
    def trainable_parameters(self) -> list[nn.Parameter]:
        params = list(self.actor.parameters())
        if self.critic is not None:
            params += list(self.critic.parameters())
        if self.log_std is not None:
            params.append(self.log_std)
        return params

    def actor_parameters(self) -> dict[str, torch.Tensor]:
        """The actor's float32 parameters in the arena-policy (safetensors) layout."""
        return {k: v.detach().clone() for k, v in self.actor.state_dict().items()}

    @property
    def snapshot_architecture(self) -> Architecture:
        """The architecture a snapshot is saved with: a continuous actor's carries its noise (PPO's
        "clip" head samples ``"gaussian"``, the "tanh" head ``"squashed"``), so the saved agent
        samples as the learner does."""
        if self.log_std is None:
            return self.architecture
        return replace(self.architecture, noise=_SNAPSHOT_NOISE[self.config.continuous_head])

    def snapshot_parameters(self) -> dict[str, torch.Tensor]:
        """:meth:`actor_parameters` plus, for a continuous actor, its ``log_std``."""
        params = self.actor_parameters()
        if self.log_std is not None:
            params["log_std"] = self.log_std.detach().clone()
        return params

    def policy(self, greedy: bool = False, name: str | None = None) -> TorchPolicy:
        """The actor as a league :class:`~arena_league.policies.policy.Policy` (a frozen copy)."""
        return TorchPolicy(self.architecture, self.actor_parameters(), name=name or self.name, greedy=greedy,
                           compute_dtype=torch.float32)

    def copy_from(self, other: Learner, config: PPOConfig | None = None) -> None:
        """Take ``other``'s weights, value statistics and (unless given) hyper-parameters; the
        optimiser starts afresh (PBT's exploit step)."""
        self.actor.load_state_dict(other.actor.state_dict())
        if self.critic is not None and other.critic is not None:
            self.critic.load_state_dict(other.critic.state_dict())
        if self.log_std is not None and other.log_std is not None:
            with torch.no_grad():
                self.log_std.copy_(other.log_std)
        if self.value_norm is not None and other.value_norm is not None:
            self.value_norm.load_state(other.value_norm.state())
        self.config = config or other.config
        self.optimiser = torch.optim.Adam(self.trainable_parameters(), lr=self.config.learning_rate,
                                          eps=self.config.adam_eps)

    # --- acting -----------------------------------------------------------------------------------
    def initial_state(self, n: int) -> np.ndarray | None:
        return np.zeros((n, self.architecture.gru_size), dtype=np.float32) if self.architecture.recurrent else None

    def critic_features(self, obs: np.ndarray, state: np.ndarray | None, seat: np.ndarray,
                        n_agents: int) -> np.ndarray:
        """The critic's input for rows with these observations, env states (one row each, or None
        when not recorded) and seat indices. The plain critic reads the observation; a centralised
        critic overrides this (e.g. the state and a one-hot seat id)."""
        return obs

    @torch.no_grad()
    def act(self, obs: np.ndarray, noise: np.ndarray, mask: np.ndarray | None = None,
            policy_state: np.ndarray | None = None, critic_input: np.ndarray | None = None) -> ActResult:
        """Sample actions for N rows from caller-given noise (so a run is a function of its seeds).

        Args:
            obs: ``float32[N, obs_dim]`` the actor's observations.
            noise: discrete: ``float64[N]`` uniforms (inverse-CDF sampling, as the match engine does);
                continuous: ``float64[N, act_dim]`` standard normal draws.
            mask: ``bool[N, n_actions]`` legal actions, or None.
            policy_state: ``float32[N, gru_size]`` recurrent states (GRU actors).
            critic_input: the critic's input rows (default ``obs``).
        """
        x = torch.from_numpy(np.ascontiguousarray(obs, dtype=np.float32))
        h = torch.from_numpy(policy_state) if policy_state is not None else None
        out, h_out = self.actor(x, h)
        n = x.shape[0]
        if self.architecture.action_type == "discrete":
            logits = out.numpy()
            mask = legal_mask(mask, logits.shape)
            actions = sample_from_logits(logits, np.asarray(noise, dtype=np.float64).reshape(n, 1), mask)
            logprobs = _categorical_logprob(logits, actions, mask)
            env_actions = actions
        else:
            mean, std = self._gaussian(out)
            raw = mean + std * torch.from_numpy(np.asarray(noise, dtype=np.float32).reshape(n, -1))
            logprobs = self._continuous_logprob(mean, std, raw)
            actions = raw.numpy()
            env_actions = (torch.tanh(raw) if self.config.continuous_head == "tanh" else raw.clamp(-1.0, 1.0)).numpy()
            logprobs = logprobs.numpy()
        values = value_preds = np.zeros(n, dtype=np.float32)
        if self.critic is not None:
            features = obs if critic_input is None else critic_input
            value_preds = self.critic(torch.from_numpy(np.ascontiguousarray(features, dtype=np.float32))).numpy()
            values = self.denormalize(value_preds)
        return ActResult(env_actions, actions, logprobs.astype(np.float32), values, value_preds,
                         None if h_out is None else h_out.numpy())

    @torch.no_grad()
    def values(self, critic_input: np.ndarray) -> np.ndarray:
        """Denormalised value estimates of critic input rows."""
        if self.critic is None:
            return np.zeros(len(critic_input), dtype=np.float32)
        return self.denormalize(self.critic(torch.from_numpy(np.ascontiguousarray(critic_input,
                                                                                  dtype=np.float32))).numpy())

    def denormalize(self, value_preds: np.ndarray) -> np.ndarray:
        if self.value_norm is None:
            return value_preds.astype(np.float32)
        return self.value_norm.denormalize(value_preds.astype(np.float64)).astype(np.float32)

    # --- the policy's distribution ------------------------------------------------------------------
    def _gaussian(self, mean: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        assert self.log_std is not None
        if self.config.continuous_head == "tanh":  # the actor's tanh output is the squashed median
            mean = torch.atanh(mean.clamp(-1.0 + _SQUASH_EPS, 1.0 - _SQUASH_EPS))
        return mean, self.log_std.exp().expand_as(mean)

    def _continuous_logprob(self, mean: torch.Tensor, std: torch.Tensor, raw: torch.Tensor) -> torch.Tensor:
        logprob = torch.distributions.Normal(mean, std).log_prob(raw).sum(-1)
        if self.config.continuous_head == "tanh":
            logprob = logprob - torch.log(1.0 - torch.tanh(raw).pow(2) + _SQUASH_EPS).sum(-1)
        return logprob

    def evaluate(self, obs: torch.Tensor, actions: torch.Tensor, mask: torch.Tensor | None = None,
                 policy_state: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """Log-probabilities of ``actions`` and the policy's entropy, with gradients."""
        out, _ = self.actor(obs, policy_state)
        if self.architecture.action_type == "discrete":
            logits = out.masked_fill(~mask, _ILLEGAL_LOGIT) if mask is not None else out
            log_p = torch.log_softmax(logits, dim=1)
            entropy = -(log_p.exp() * log_p).sum(1)
            return log_p.gather(1, actions.long().unsqueeze(1)).squeeze(1), entropy
        mean, std = self._gaussian(out)
        # The Gaussian's entropy (the squashed one has none in closed form; it is the usual stand-in).
        entropy = torch.distributions.Normal(mean, std).entropy().sum(-1)
        return self._continuous_logprob(mean, std, actions), entropy

    # --- learning ---------------------------------------------------------------------------------
    def update(self, batch: Batch, rng: np.random.Generator, learning_rate: float | None = None, *,
               value_loss: bool = True) -> UpdateStats:
        """One PPO update on ``batch`` (see :func:`ppo_update`)."""
        stats = ppo_update(self, batch, self.config, self.optimiser, rng, learning_rate=learning_rate,
                           value_loss=value_loss)
        self.updates += 1
        return stats


def _categorical_logprob(logits: np.ndarray, actions: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
    """``log softmax(logits)[action]`` over the legal actions, in float64 (numpy: a few
    microseconds where the torch ops cost tens on small batches)."""
    z = logits.astype(np.float64)
    if mask is not None:
        z = np.where(mask, z, -np.inf)
    z -= z.max(axis=1, keepdims=True)
    log_total = np.log(np.exp(z).sum(axis=1))
    return z[np.arange(len(actions)), actions] - log_total


# --- advantages -------------------------------------------------------------------------------------

def gae(rewards: np.ndarray, values: np.ndarray, dones: np.ndarray, next_values: np.ndarray, gamma: float,
        gae_lambda: float) -> tuple[np.ndarray, np.ndarray]:
    """Generalized Advantage Estimation over ``[T, N]`` arrays (N independent trajectories).

    ``dones[t]`` marks that the episode ended *with* step t (a game's cut at ``max_cycles`` is a
    real end here: the rules give that match its result), so step t does not bootstrap;
    ``next_values[n]`` is the value of the observation after the last step. Returns
    (advantages, returns = advantages + values), float32.
    """
    T = rewards.shape[0]
    advantages = np.zeros(rewards.shape, dtype=np.float64)
    last = np.zeros(rewards.shape[1:], dtype=np.float64)
    for t in reversed(range(T)):
        following = next_values if t == T - 1 else values[t + 1]
        nonterminal = 1.0 - dones[t]
        delta = rewards[t] + gamma * following * nonterminal - values[t]
        last = delta + gamma * gae_lambda * nonterminal * last
        advantages[t] = last
    return advantages.astype(np.float32), (advantages + values).astype(np.float32)


# --- the update -------------------------------------------------------------------------------------

@dataclass
class Batch:
    """The flat samples of one PPO update (torch tensors, B rows).

    ``policy_mask`` marks rows whose action counted (an active seat; the seat to move in a
    turn-based game): only they enter the policy and entropy terms. Every row enters the value
    loss (its state is a real state of the seat). ``values`` are the critic's raw outputs at
    collection (normalised when the learner normalises values), ``returns`` are not normalised.
    """

    obs: torch.Tensor
    actions: torch.Tensor
    logprobs: torch.Tensor
    advantages: torch.Tensor
    returns: torch.Tensor
    values: torch.Tensor
    critic_input: torch.Tensor | None = None
    """The critic's input rows (None: ``obs``)."""
    masks: torch.Tensor | None = None
    """``bool[B, n_actions]`` legal actions."""
    policy_states: torch.Tensor | None = None
    """``float32[B, gru_size]``: the recurrent state each step started from (GRU actors)."""
    policy_mask: torch.Tensor | None = None

    def __len__(self) -> int:
        return int(self.obs.shape[0])

    def rows(self, index: torch.Tensor) -> Batch:
        """The sub-batch of rows ``index``."""
        return Batch(**{f.name: (None if getattr(self, f.name) is None else getattr(self, f.name)[index])
                        for f in fields(self)})


@dataclass
class UpdateStats:
    """Means over the minibatches of one update (CleanRL's logged losses)."""

    policy_loss: float = 0.0
    value_loss: float = 0.0
    entropy: float = 0.0
    approx_kl: float = 0.0
    clip_fraction: float = 0.0
    explained_variance: float = float("nan")
    learning_rate: float = 0.0
    epochs: int = 0

    def as_dict(self) -> dict[str, float]:
        return dict(self.__dict__)


def ppo_update(learner: Learner, batch: Batch, config: PPOConfig, optimiser: torch.optim.Optimizer,
               rng: np.random.Generator, *, learning_rate: float | None = None,
               value_loss: bool = True) -> UpdateStats:
    """Optimise ``learner`` on ``batch``: ``update_epochs`` passes over ``num_minibatches``
    minibatches of the clipped surrogate, the (clipped) value loss and the entropy bonus.

    Args:
        learner: holds the actor (:meth:`Learner.evaluate`), critic and value normaliser.
        batch: the samples; ``advantages`` may come from any estimator (GAE, a counterfactual baseline).
        config: hyper-parameters.
        optimiser: over the learner's trainable parameters.
        rng: draws the minibatch permutations.
        learning_rate: this update's step size (annealed by the caller); default ``config.learning_rate``.
        value_loss: False trains the actor only (a learner whose critic is trained elsewhere).
    """
    lr = config.learning_rate if learning_rate is None else learning_rate
    for group in optimiser.param_groups:
        group["lr"] = lr
    critic = learner.critic if value_loss else None
    critic_input = batch.obs if batch.critic_input is None else batch.critic_input
    returns = batch.returns
    if critic is not None and learner.value_norm is not None:
        learner.value_norm.update(batch.returns.numpy())
        returns = learner.value_norm.normalize(batch.returns.double()).float()
    policy_mask = batch.policy_mask if batch.policy_mask is not None else torch.ones(len(batch), dtype=torch.bool)
    stats = UpdateStats(learning_rate=lr)
    n_minibatch = 0
    minibatch_size = max(1, math.ceil(len(batch) / config.num_minibatches))
    for epoch in range(config.update_epochs):
        order = torch.from_numpy(rng.permutation(len(batch)))
        kls = []
        for start in range(0, len(batch), minibatch_size):
            rows = order[start: start + minibatch_size]
            mb = batch.rows(rows)
            acting = policy_mask[rows]
            # policy: the clipped surrogate of Schulman et al. (2017), eq. 7, over acting rows
            new_logprob, entropy = learner.evaluate(mb.obs, mb.actions, mb.masks, mb.policy_states)
            log_ratio = new_logprob - mb.logprobs
            ratio = log_ratio.exp()
            with torch.no_grad():
                approx_kl = _masked_mean((ratio - 1) - log_ratio, acting)  # Schulman's k3 estimator
                clip_fraction = _masked_mean(((ratio - 1.0).abs() > config.clip_coef).float(), acting)
            advantages = mb.advantages
            if config.norm_adv and int(acting.sum()) > 1:
                chosen = advantages[acting]
                advantages = (advantages - chosen.mean()) / (chosen.std() + 1e-8)
            surrogate = torch.max(-advantages * ratio,
                                  -advantages * ratio.clamp(1 - config.clip_coef, 1 + config.clip_coef))
            policy_loss = _masked_mean(surrogate, acting)
            entropy_loss = _masked_mean(entropy, acting)
            loss = policy_loss - config.ent_coef * entropy_loss
            # value: squared error to the returns, clipped around the old prediction
            v_loss = torch.zeros(())
            if critic is not None:
                new_value = critic(critic_input[rows])
                target = returns[rows]
                unclipped = (new_value - target) ** 2
                if config.clip_vloss:
                    clipped = mb.values + (new_value - mb.values).clamp(-config.clip_coef, config.clip_coef)
                    v_loss = 0.5 * torch.max(unclipped, (clipped - target) ** 2).mean()
                else:
                    v_loss = 0.5 * unclipped.mean()
                loss = loss + config.vf_coef * v_loss
            # optimise: one Adam step with the global gradient norm clipped
            optimiser.zero_grad(set_to_none=True)
            loss.backward()
            nn.utils.clip_grad_norm_(learner.trainable_parameters(), config.max_grad_norm)
            optimiser.step()
            n_minibatch += 1
            kls.append(float(approx_kl))
            stats.policy_loss += policy_loss.item()
            stats.value_loss += v_loss.item()
            stats.entropy += entropy_loss.item()
            stats.approx_kl += float(approx_kl)
            stats.clip_fraction += float(clip_fraction)
        stats.epochs = epoch + 1
        if config.target_kl is not None and np.mean(kls) > config.target_kl:
            break
    for name in ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction"):
        setattr(stats, name, getattr(stats, name) / max(n_minibatch, 1))
    if critic is not None:
        with torch.no_grad():
            predicted = critic(critic_input)
            target = returns
            variance = float(target.var()) if len(target) > 1 else 0.0
            stats.explained_variance = float("nan") if variance == 0 else 1.0 - float((target - predicted).var()) / variance
    return stats


def _masked_mean(x: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    if bool(mask.all()):
        return x.mean()
    count = mask.sum()
    return (x * mask).sum() / count.clamp(min=1)


def game_architecture(config: PPOConfig, env: Any) -> Architecture:
    """The actor architecture of ``config`` for the base observation and actions of ``env``."""
    rules = env.rules
    return learner_architecture(config, rules.obs_dim, rules.action_type, getattr(rules, "n_actions", 0),
                                getattr(rules, "act_dim", 0))
