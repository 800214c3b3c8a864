"""What every training scheme shares, and the plain scheme built on it.

:class:`TrainerBase` seeds a run first, then gives each iteration a rollout of every env in
lockstep (:class:`~arena_league.training.rollout.RolloutCollector`) and each learner its GAE and
clipped update (:mod:`arena_league.training.ppo`, the PPO core). :class:`PPO` is the plain
scheme: one learner sharing its parameters over every seat of the game (each seat of every team
plays the current policy: naive self-play), readable top to bottom as the model the other schemes
(D-PPO, SP, PBT, CC, CF) follow. :func:`iteration_record` and :func:`format_record` are the log
record and line every scheme prints per iteration.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import torch

from arena_league.policies.architecture import Architecture
from arena_league.policies.threads import torch_threads
from arena_league.training.ppo import Learner, PPOConfig, UpdateStats, game_architecture
from arena_league.training.rollout import RolloutCollector, check_trainable, learner_batch
from arena_league.training.stack import LearnerStack, stackable, stacks_of

__all__ = ["PPO", "TrainerBase", "annealed_lr", "figure", "format_record", "iteration_record"]


class TrainerBase(ABC):
    """The parts every scheme's trainer shares: seeding first (:meth:`_begin`), then per iteration a
    rollout (:meth:`_collect`) and each learner's GAE and clipped update (:meth:`_update`).

    A scheme defines :meth:`_iterate`; :meth:`iterate` runs it on one torch thread (small
    forwards and updates run faster so, and a run's numbers do not depend on the machine's core
    count) and gives the caller's thread count back afterwards."""

    scheme = "base"
    #: Learners that can share one computation do (:mod:`arena_league.training.stack`); False
    #: updates and acts each learner as a stack of its own, with the same results.
    stack_learners: bool = True

    def iterate(self) -> dict[str, Any]:
        """One iteration of the scheme (rollout, GAE, update and the scheme's own steps); its log record."""
        with torch_threads(1):
            return self._iterate()

    @abstractmethod
    def _iterate(self) -> dict[str, Any]:
        """One iteration of the scheme, on the thread count :meth:`iterate` set."""

    def _begin(self, env_fn: Callable[[], Any], config: PPOConfig, seed: int, architecture: Architecture | None,
               total_steps: int | None, log: Callable[[str], None] | None) -> Any:
        """Seed torch, keep the run's settings, check the game and choose the actor; returns a probe env."""
        # seeding first: every draw of the run comes from these
        torch.manual_seed(seed)
        self.config = config
        self.seed = seed
        self.rng = np.random.default_rng(np.random.SeedSequence([seed, 0]))
        self.total_steps = total_steps
        self.log = log
        self.env_steps = 0
        self.iteration = 0
        probe = env_fn()
        check_trainable(probe)
        self.architecture = architecture or game_architecture(self.config, probe)
        return probe

    def _collect(self) -> tuple[Any, float, float]:
        """``config.num_steps`` lockstep steps of every env: (the rollout, its start time, seconds)."""
        start = time.perf_counter()
        rollout = self.collector.collect(self.learners, self.config.num_steps, stacked=self.stack_learners)
        self.env_steps += rollout.env_steps
        return rollout, start, time.perf_counter() - start

    def _update(self, rollout: Any, codes: list[int] | None = None,
                advantages: np.ndarray | None = None, value_loss: bool = True) -> list[UpdateStats]:
        """GAE over the slots each learner of ``codes`` (default: all) held, then their clipped
        updates at the annealed step size: learners that stack update together
        (:class:`~arena_league.training.stack.LearnerStack`), the others one by one. Returns
        each learner's statistics in the order of ``codes``."""
        codes = list(range(len(self.learners))) if codes is None else list(codes)
        stats: dict[int, UpdateStats] = {}
        groups = stacks_of(codes, self.learners) if self.stack_learners else [[c] for c in codes]
        for group in groups:
            learners = [self.learners[c] for c in group]
            batches = [learner_batch(rollout, c, self.learners[c], advantages) for c in group]
            rates = [annealed_lr(lr.config, self.env_steps, self.total_steps) for lr in learners]
            if stackable(learners):
                results = LearnerStack(learners).update(batches, rates, value_loss=value_loss)
            else:
                results = [lr.update(b, lr.rng, rate, value_loss=value_loss)
                           for lr, b, rate in zip(learners, batches, rates)]
            stats.update(zip(group, results))
        return [stats[c] for c in codes]


class PPO(TrainerBase):
    """PPO with one learner sharing its parameters over every seat of every team (each team plays
    the current policy: naive self-play through parameter sharing). The model the other schemes
    follow: seeding first, then per iteration a rollout, GAE, the update, and a log line with the
    env steps per second.

    Args:
        env_fn: makes one env of the game (``arena_league.envs.make(...)``).
        config: hyper-parameters.
        seed: seeds the learner, the env resets and the action noise.
        architecture: the actor's family and sizes (default from ``config``; a CNN needs one).
        total_steps: env steps the run will take, for learning-rate annealing (default: no annealing
            horizon known, so the step size stays fixed).
        log: called with a line per iteration (default: none).
    """

    scheme = "ppo"

    def __init__(self, env_fn: Callable[[], Any], config: PPOConfig | None = None, seed: int = 0, *,
                 architecture: Architecture | None = None, total_steps: int | None = None,
                 log: Callable[[str], None] | None = None) -> None:
        probe = self._begin(env_fn, config or PPOConfig(), seed, architecture, total_steps, log)
        self.learners = [Learner(self.architecture, self.config, seed, name="ppo")]
        self.n_agents = int(probe.rules.n_agents)
        self.collector = RolloutCollector(env_fn, self.config.num_envs, seed, seating=self._seating)

    def _seating(self, env_index: int, episode: int) -> np.ndarray:
        """Every seat of every env plays the one learner (a method, not a closure, so a run pickles)."""
        return np.zeros(self.n_agents, int)

    def _iterate(self) -> dict[str, Any]:
        """One iteration: rollout, GAE, update; returns its log record."""
        # rollout: num_steps lockstep steps of num_envs games, one forward per step for all seats
        rollout, start, collect_time = self._collect()
        # GAE and the update
        stats = self._update(rollout)
        self.iteration += 1
        record = iteration_record(self, rollout, stats, start, collect_time)
        if self.log:
            self.log(format_record(record))
        return record


def annealed_lr(config: PPOConfig, env_steps: int, total_steps: int | None) -> float:
    """Linear annealing (Schulman et al. 2017) over ``total_steps`` env steps, when known."""
    if not config.anneal_lr or not total_steps:
        return config.learning_rate
    frac = max(0.0, 1.0 - env_steps / total_steps)
    return config.learning_rate * max(frac, 1e-3)


def iteration_record(trainer: Any, rollout: Any, stats: list[UpdateStats], start: float,
                     collect_time: float) -> dict[str, Any]:
    """The log record of one iteration of any scheme: steps, speed, returns, losses."""
    elapsed = time.perf_counter() - start
    returns = [e.mean_return for e in rollout.episodes]
    return {
        "scheme": trainer.scheme,
        "iteration": trainer.iteration,
        "env_steps": trainer.env_steps,
        "episodes": len(rollout.episodes),
        "episode_return": float(np.mean(returns)) if returns else float("nan"),
        "episode_length": float(np.mean([e.length for e in rollout.episodes])) if rollout.episodes else float("nan"),
        "steps_per_second": rollout.env_steps / elapsed if elapsed > 0 else float("inf"),
        "collect_steps_per_second": rollout.env_steps / collect_time if collect_time > 0 else float("inf"),
        "losses": [s.as_dict() for s in stats],
    }


def figure(value: float, spec: str) -> str:
    """``value`` formatted by ``spec``, or ``-`` where there is none to show (NaN: nothing measured)."""
    return "-" if value is None or np.isnan(value) else format(value, spec)


def format_record(record: Mapping[str, Any]) -> str:
    """One log line of an iteration record."""
    loss = record["losses"][0] if record["losses"] else {}
    returns = (f"return {record['episode_return']:.3f} ({record['episodes']} episodes)" if record["episodes"]
               else "return - (no episode ended in this iteration)")
    return (f"{record['scheme']} iter {record['iteration']} steps {record['env_steps']} {returns} "
            f"SPS {record['steps_per_second']:.0f} "
            f"pi_loss {loss.get('policy_loss', float('nan')):.4f} v_loss {loss.get('value_loss', float('nan')):.4f} "
            f"entropy {loss.get('entropy', float('nan')):.3f} kl {loss.get('approx_kl', float('nan')):.4f}")
