"""D-PPO: decentralised PPO, one independent learner per agent seat (or per team).

One of the five baselines of Arena (Song et al., "Arena: A General Evaluation Platform and Building
Toolkit for Multi-Agent Intelligence", AAAI 2020): every agent learns with its own PPO (Schulman
et al. 2017) from its own reward, treating the others as part of the environment (independent
learners; de Witt et al., "Is Independent Learning All You Need in the StarCraft Multi-Agent
Challenge?", 2020, call it IPPO). Parameters are not shared: with ``per="agent"`` seat ``i`` of
every env is played by learner ``i``; with ``per="team"`` the members of team ``t`` share learner
``t``. Seats stay fixed, so each learner specialises in its seat; every learner's actor is
still a complete agent of the game (observations are seat-relative) and is snapshotted as one.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from arena_league.policies.architecture import Architecture
from arena_league.training.ppo import Learner, PPOConfig
from arena_league.training.rollout import RolloutCollector
from arena_league.training.trainer import TrainerBase, format_record, iteration_record

__all__ = ["DPPO", "learner_seed"]

PER = ("agent", "team")


def learner_seed(seed: int, index: int) -> int:
    """The initialisation seed of learner ``index`` of a run seeded ``seed`` (distinct per learner)."""
    return int(np.random.SeedSequence([seed, 2, index]).generate_state(1, np.uint64)[0] >> np.uint64(2))


class DPPO(TrainerBase):
    """Independent PPO learners in one set of lockstep envs.

    Args:
        env_fn: makes one env of the game.
        config: hyper-parameters (the same for every learner).
        seed: seeds the learners, env resets and action noise.
        per: ``"agent"`` (one learner per seat) or ``"team"`` (one per team, its members sharing it).
        architecture: the actors' family and sizes (default from ``config``).
        total_steps: env steps of the run, for learning-rate annealing.
        log: called with a line per iteration.
    """

    scheme = "dppo"

    def __init__(self, env_fn: Callable[[], Any], config: PPOConfig | None = None, seed: int = 0, *,
                 per: str = "agent", architecture: Architecture | None = None, total_steps: int | None = None,
                 log: Callable[[str], None] | None = None) -> None:
        if per not in PER:
            raise ValueError(f"per must be 'agent' (one learner per seat) or 'team' (one per team), not {per!r}")
        rules = self._begin(env_fn, config or PPOConfig(), seed, architecture, total_steps, log).rules
        # seat -> learner: the seat itself, or its team
        self.learner_of_seat = (np.arange(rules.n_agents) if per == "agent"
                                else np.asarray(rules.team_of, dtype=np.int64))
        n_learners = int(self.learner_of_seat.max()) + 1
        label = "seat" if per == "agent" else "team"
        self.learners = [Learner(self.architecture, self.config, learner_seed(seed, i), name=f"{label}{i}")
                         for i in range(n_learners)]
        self.per = per
        self.collector = RolloutCollector(env_fn, self.config.num_envs, seed, seating=self._seating)

    def _seating(self, env_index: int, episode: int) -> np.ndarray:
        """Seats stay fixed: the same learner per seat in every episode (a method, so a run pickles)."""
        return self.learner_of_seat

    def _iterate(self) -> dict[str, Any]:
        """One iteration: a shared rollout, then each learner's GAE and update on its own seats."""
        # rollout: every learner acts for its seats of every env, one forward each per step
        rollout, start, collect_time = self._collect()
        # GAE and an independent update per learner, the learners stacked into one computation
        stats = self._update(rollout)
        self.iteration += 1
        record = iteration_record(self, rollout, stats, start, collect_time)
        record["learner_returns"] = _returns_by_learner(rollout, len(self.learners))
        if self.log:
            self.log(format_record(record))
        return record

    def snapshot_metrics(self, index: int) -> dict[str, Any]:
        """What a snapshot of learner ``index`` records besides its weights."""
        seats = np.flatnonzero(self.learner_of_seat == index).tolist()
        return {"per": self.per, "seats": seats}


def _returns_by_learner(rollout: Any, n_learners: int) -> list[float | None]:
    """Mean episode return of each learner's seats over the rollout's finished episodes."""
    sums = np.zeros(n_learners)
    counts = np.zeros(n_learners)
    for episode in rollout.episodes:
        for code, value in zip(episode.controllers, episode.returns):
            if code >= 0:
                sums[code] += value
                counts[code] += 1
    return [float(s / c) if c else None for s, c in zip(sums, counts)]
