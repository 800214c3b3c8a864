"""Warm starts by imitation: learners copy an expert (by default the game's scripted heuristic)
before reinforcement learning begins.

AlphaStar's league (Vinyals et al., Nature 2019) starts every agent from a policy learned by
supervised imitation, then improves it with RL; Ross et al.'s DAgger (AISTATS 2011) makes the
imitation robust by labelling the states the *learner* visits with the expert's actions. Here a
warm start is a few DAgger rounds:

* round ``r`` of ``R`` plays ``steps / R`` env steps on the training env (the learner's own
  rollout collector, many envs in lockstep). Each seat of each episode is driven by the learner
  with probability ``r / R`` and by the expert otherwise, so the first round is pure behaviour
  cloning and later rounds visit the learner's own states;
* every acting row of every round (whoever acted) is labelled with the expert's action and added
  to one aggregated data set;
* after each round every learner's actor is fitted to the whole data set by maximum likelihood:
  cross-entropy over legal actions for discrete games, the Gaussian log-likelihood of the expert's
  action at the learner's fixed standard deviation (a squared error on the mean) for continuous
  ones. The critic and the learner's PPO optimiser are left alone; a continuous learner's log
  standard deviation is then set to the log of its residual error (floored at ``min_log_std``):
  left at its initial 1.0, the noise alone would make the copy play far below its expert.

The data come from learner 0's rollouts; every learner is fitted to them with its own shuffling,
so the learners of a population stay distinct. What the warm start did (its accuracy or error on
the data, rows, env steps) is returned, and :func:`arena_league.training.schemes.run_scheme` keeps
it in every snapshot's provenance: env steps spent imitating are *not* counted in a snapshot's
``steps``, which count RL env steps only.

Determinism: the collector's seed, the seating draws and the minibatch order all come from
``seed``, so the same arguments give the same actors.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
import torch

from arena_league.training.ppo import Learner

__all__ = ["WarmStart", "warm_start"]

#: Kept off the exact bounds so that a tanh head's inverse stays finite.
_ACTION_MARGIN = 1e-3


@dataclass(frozen=True)
class WarmStart:
    """How learners imitate an expert before RL (see the module docstring)."""

    expert: str = "scripted:heuristic"
    """The agent imitated, as an agent reference (``scripted:heuristic``, ``arena-policy:folder``, ...)."""
    steps: int = 40_000
    """Env steps played to gather the data, over all rounds."""
    rounds: int = 4
    """DAgger rounds (1: plain behaviour cloning)."""
    epochs: int = 3
    """Passes over the aggregated data after each round."""
    minibatch: int = 512
    learning_rate: float = 1e-3
    num_envs: int = 16
    min_log_std: float = -1.6
    """Continuous actions: after the fit, each learner's log standard deviation is lowered to the log
    of its residual error per action component, but not below this (std 0.2 by default), so that
    the warm-started policy plays close to the expert and RL still explores."""

    def __post_init__(self) -> None:
        for name in ("steps", "rounds", "epochs", "minibatch", "num_envs"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"warm_start.{name} must be a positive integer, not {value!r}")
        if not self.learning_rate > 0:
            raise ValueError(f"warm_start.learning_rate must be positive, not {self.learning_rate!r}")
        if not isinstance(self.expert, str) or not self.expert:
            raise ValueError(f"warm_start.expert must be an agent reference such as 'scripted:heuristic', "
                             f"not {self.expert!r}")

    @classmethod
    def parse(cls, value: WarmStart | Mapping[str, Any] | bool | None) -> WarmStart | None:
        """A :class:`WarmStart` from itself, a dict of its fields, True (the defaults) or None/False."""
        if value is None or value is False:
            return None
        if value is True:
            return cls()
        if isinstance(value, cls):
            return value
        if not isinstance(value, Mapping):
            raise TypeError(f"warm_start must be a dict of {', '.join(f.name for f in fields(cls))}, True or None, "
                            f"not {type(value).__name__}")
        unknown = sorted(set(value) - {f.name for f in fields(cls)})
        if unknown:
            raise TypeError(f"unknown warm_start field(s) {', '.join(unknown)}; valid: "
                            f"{', '.join(f.name for f in fields(cls))}")
        return cls(**dict(value))

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def warm_start(learners: Sequence[Learner], env_fn: Callable[[], Any], game_id: str, options: WarmStart, seed: int,
               *, log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Fit every learner's actor to ``options.expert`` by DAgger (see the module docstring).

    Returns the record kept in the snapshots' provenance: the options, the env steps played, the
    rows gathered and, per learner, the final fit (``accuracy`` for discrete actions, ``mse`` for
    continuous ones) on the aggregated data.
    """
    from arena_league.matchmaking import AgentRef
    from arena_league.training.rollout import Opponent, RolloutCollector

    if not learners:
        raise ValueError("warm_start needs at least one learner")
    probe = env_fn()
    expert = AgentRef.parse(options.expert, game_id, probe.rules.action_type).load()
    discrete = probe.rules.action_type == "discrete"
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 7]))
    share = {"learner": 0.0}

    def seating(env_index: int, episode: int) -> np.ndarray:
        drive = rng.random(probe.rules.n_agents) < share["learner"]
        return np.where(drive, 0, -1).astype(np.int64)

    collector = RolloutCollector(env_fn, options.num_envs, int(seed) + 1, seating,
                                 opponents=[Opponent(expert, name="expert")])
    per_round = max(1, options.steps // (options.rounds * options.num_envs))
    data_obs: list[np.ndarray] = []
    data_act: list[np.ndarray] = []
    data_mask: list[np.ndarray] = []
    optimisers = [torch.optim.Adam(list(lr.actor.parameters()), lr=options.learning_rate) for lr in learners]
    fits: list[dict[str, float]] = []
    env_steps = 0
    for r in range(options.rounds):
        share["learner"] = r / options.rounds
        rollout = collector.collect([learners[0]], per_round)
        env_steps += rollout.env_steps
        rows = rollout.acting.reshape(-1)
        obs = rollout.obs.reshape(-1, rollout.obs.shape[-1])[rows]
        mask = rollout.masks.reshape(-1, rollout.masks.shape[-1])[rows] if rollout.masks is not None else None
        uniforms = rng.random((len(obs), max(1, int(getattr(probe.rules, "act_dim", 1)))))
        labels, _ = expert.act(obs, uniforms, mask)
        data_obs.append(obs)
        data_act.append(np.asarray(labels))
        if mask is not None:
            data_mask.append(mask)
        all_obs = torch.from_numpy(np.concatenate(data_obs).astype(np.float32))
        all_act = torch.from_numpy(np.concatenate(data_act))
        all_mask = torch.from_numpy(np.concatenate(data_mask)) if data_mask else None
        fits = [_fit(lr, opt, all_obs, all_act, all_mask, options, rng, discrete) for lr, opt in zip(learners, optimisers)]
        if log is not None:
            log(f"warm start round {r + 1}/{options.rounds}: {len(all_obs)} rows, learner share {share['learner']:.2f}, "
                + ", ".join(f"{k} {v:.3f}" for k, v in fits[0].items()))
    return {"options": options.as_dict(), "env_steps": int(env_steps), "rows": int(sum(len(o) for o in data_obs)),
            "fit": fits}


def _fit(learner: Learner, optimiser: torch.optim.Optimizer, obs: torch.Tensor, actions: torch.Tensor,
         mask: torch.Tensor | None, options: WarmStart, rng: np.random.Generator, discrete: bool) -> dict[str, float]:
    """``options.epochs`` passes of maximum likelihood of ``actions``, then the fit on the whole data;
    a continuous learner's log std is lowered to its residual per component there (never raised,
    never below ``options.min_log_std``)."""
    n = len(obs)
    if not discrete:
        actions = actions.float().clamp(-1.0 + _ACTION_MARGIN, 1.0 - _ACTION_MARGIN)
        if learner.config.continuous_head == "tanh":
            actions = torch.atanh(actions)
    for _ in range(options.epochs):
        order = torch.from_numpy(rng.permutation(n))
        for start in range(0, n, options.minibatch):
            index = order[start:start + options.minibatch]
            out = _predict(learner, obs[index], None if mask is None else mask[index], discrete)
            loss = (torch.nn.functional.cross_entropy(out, actions[index].long()) if discrete
                    else (out - actions[index]).pow(2).sum(-1).mean())
            optimiser.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(list(learner.actor.parameters()), learner.config.max_grad_norm)
            optimiser.step()
    with torch.no_grad():
        out = _predict(learner, obs, mask, discrete)
        if discrete:
            return {"accuracy": float((out.argmax(1) == actions).float().mean())}
        squared = (out - actions).pow(2)
        residual = squared.mean(0).sqrt().clamp_min(1e-6).log()
        learner.log_std.copy_(torch.minimum(learner.log_std, residual.clamp_min(options.min_log_std)))
        return {"mse": float(squared.mean()), "log_std": float(learner.log_std.detach().mean())}


def _predict(learner: Learner, obs: torch.Tensor, mask: torch.Tensor | None, discrete: bool) -> torch.Tensor:
    """The actor's logits over legal actions (discrete) or its Gaussian mean (continuous)."""
    out, _ = learner.actor(obs, None)
    if discrete:
        return out.masked_fill(~mask, -1e9) if mask is not None else out
    mean, _ = learner._gaussian(out)
    return mean
