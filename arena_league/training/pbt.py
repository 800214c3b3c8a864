"""PBT: population-based training of PPO learners that play each other.

One of the five baselines of Arena (Song et al., "Arena: A General Evaluation Platform and Building
Toolkit for Multi-Agent Intelligence", AAAI 2020), after Jaderberg et al. ("Population Based
Training of Neural Networks", 2017; and "Human-level performance in 3D multiplayer games with
population-based reinforcement learning", Science 2019, whose capture-the-flag agents used the
rule below).

* **Population**: ``population_size`` PPO learners, each with its own hyper-parameters (the
  perturbable ones, ``hyperparameters``, start at the configured value times ``2^u``, u uniform in
  [-1, 1], drawn from the seed).
* **Matchmaking**: each episode of each env seats learners drawn uniformly without replacement, one
  per team (with more teams than learners, draws repeat); every seated learner learns from its
  seats.
* **Elo**: after every episode each pair of teams updates the online Elo ratings of their learners
  (K = ``elo_k``, scale 400) from the pair's result.
* **Exploit and explore**: every ``interval`` updates, each learner (in a seeded random order) that
  played at least ``min_matches`` matches since it last changed picks another learner at random;
  if its Elo-predicted chance of beating that one, ``1 / (1 + 10^((r_other - r_own) / 400))``, is
  below ``threshold`` (30%), it copies the other's weights, value statistics and hyper-parameters
  and its rating, then multiplies each perturbable hyper-parameter by 0.8 or 1.2 (a seeded coin per
  hyper-parameter).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import fields, replace
from typing import Any

import numpy as np

from arena_league.policies.architecture import Architecture
from arena_league.rating import elo_expected_score
from arena_league.training.dppo import learner_seed
from arena_league.training.ppo import Learner, PPOConfig
from arena_league.training.rollout import Episode, RolloutCollector
from arena_league.training.trainer import TrainerBase, format_record, iteration_record

__all__ = ["PBT", "PERTURB_FACTORS"]

#: The explore step's multiplicative perturbations (Jaderberg et al. 2017).
PERTURB_FACTORS = (0.8, 1.2)
#: Hyper-parameters that stay meaningful when multiplied by 0.8 or 1.2.
PERTURBABLE = ("learning_rate", "ent_coef", "clip_coef", "vf_coef", "max_grad_norm")


class PBT(TrainerBase):
    """A population of PPO learners trained against each other (see the module docstring).

    Args:
        env_fn: makes one env of the game.
        config: the base hyper-parameters.
        seed: seeds the learners, their initial hyper-parameters, matchmaking, env resets, action
            noise and the exploit/explore draws.
        population_size: learners in the population.
        interval: learner updates between two exploit/explore steps.
        threshold: a learner copies another when its Elo-predicted chance of beating it is below this.
        hyperparameters: the perturbed ones (fields of :class:`PPOConfig` in :data:`PERTURBABLE`).
        min_matches: matches a learner plays before it may copy another.
        elo_k: the Elo K-factor.
        initial_rating: everyone's starting Elo.
        architecture: the actors' family and sizes (default from ``config``).
        total_steps: env steps of the run, for learning-rate annealing.
        log: called with a line per iteration.
    """

    scheme = "pbt"

    def __init__(self, env_fn: Callable[[], Any], config: PPOConfig | None = None, seed: int = 0, *,
                 population_size: int = 4, interval: int = 10, threshold: float = 0.3,
                 hyperparameters: Sequence[str] = ("learning_rate", "ent_coef"), min_matches: int = 10,
                 elo_k: float = 32.0, initial_rating: float = 1000.0, architecture: Architecture | None = None,
                 total_steps: int | None = None, log: Callable[[str], None] | None = None) -> None:
        if population_size < 2:
            raise ValueError(f"population_size must be at least 2 (learners play each other), not {population_size}")
        unknown = [h for h in hyperparameters if h not in PERTURBABLE]
        if unknown:
            raise ValueError(f"cannot perturb {', '.join(unknown)} by x0.8 / x1.2; perturbable: {', '.join(PERTURBABLE)}")
        if not 0 < threshold < 1:
            raise ValueError(f"threshold is a probability in (0, 1), not {threshold}")
        probe = self._begin(env_fn, config or PPOConfig(), seed, architecture, total_steps, log)
        self.match_rng = np.random.default_rng(np.random.SeedSequence([seed, 4]))
        self.pbt_rng = np.random.default_rng(np.random.SeedSequence([seed, 5]))
        self.team_of = np.asarray(probe.rules.team_of, dtype=np.int64)
        self.n_teams = int(probe.rules.n_teams)
        self.hyperparameters = tuple(hyperparameters)
        self.learners = []
        for i in range(population_size):
            spread = {h: getattr(self.config, h) * 2.0 ** self.pbt_rng.uniform(-1.0, 1.0) for h in self.hyperparameters}
            self.learners.append(Learner(self.architecture, replace(self.config, **spread), learner_seed(seed, i),
                                         name=f"pbt{i}"))
        self.ratings = np.full(population_size, float(initial_rating))
        self.matches = np.zeros(population_size, dtype=np.int64)
        """Matches each learner played since it last changed (by exploit)."""
        self.lineage: list[list[str]] = [[] for _ in range(population_size)]
        """Per learner, the exploit events it went through ("copied pbt2 at update 30")."""
        self.threshold = threshold
        self.interval = interval
        self.min_matches = min_matches
        self.elo_k = elo_k
        self.collector = RolloutCollector(env_fn, self.config.num_envs, seed, seating=self._seating,
                                          on_episode=self._record)

    # --- matchmaking and ratings ------------------------------------------------------------------
    def _seating(self, env_index: int, episode: int) -> np.ndarray:
        """One learner per team, drawn uniformly (distinct while there are enough learners)."""
        population = len(self.learners)
        if population >= self.n_teams:
            chosen = self.match_rng.choice(population, size=self.n_teams, replace=False)
        else:
            chosen = self.match_rng.integers(population, size=self.n_teams)
        return chosen[self.team_of]

    def _record(self, episode: Episode) -> None:
        """Online Elo from every pair of teams of the episode."""
        team_learner = {int(t): int(c) for c, t in zip(episode.controllers, episode.team_of)}
        for i in set(team_learner.values()):
            self.matches[i] += 1
        teams = sorted(team_learner)
        for a_index, a in enumerate(teams):
            for b in teams[a_index + 1:]:
                i, j = team_learner[a], team_learner[b]
                if i == j:
                    continue
                score_a, score_b = episode.team_scores[a], episode.team_scores[b]
                score = 1.0 if score_a > score_b else 0.0 if score_a < score_b else 0.5
                delta = self.elo_k * (score - float(elo_expected_score(self.ratings[i], self.ratings[j])))
                self.ratings[i] += delta
                self.ratings[j] -= delta

    # --- exploit and explore ----------------------------------------------------------------------
    def exploit_and_explore(self) -> list[str]:
        """The PBT step (see the module docstring); returns what changed, one line per event."""
        events = []
        population = len(self.learners)
        for i in self.pbt_rng.permutation(population).tolist():
            others = [j for j in range(population) if j != i]
            j = others[int(self.pbt_rng.integers(len(others)))]
            chance = float(elo_expected_score(self.ratings[i], self.ratings[j]))
            if self.matches[i] < self.min_matches or chance >= self.threshold:
                continue
            source = self.learners[j]
            perturbed = {h: getattr(source.config, h) * PERTURB_FACTORS[int(self.pbt_rng.integers(2))]
                         for h in self.hyperparameters}
            self.learners[i].copy_from(source, replace(source.config, **perturbed))
            self.ratings[i] = self.ratings[j]
            self.matches[i] = 0
            event = (f"{self.learners[i].name} (P(win)={chance:.2f}) copied {source.name} at update "
                     f"{source.updates}: " + ", ".join(f"{h}={v:.3g}" for h, v in perturbed.items()))
            self.lineage[i].append(event)
            events.append(event)
        return events

    # --- training ---------------------------------------------------------------------------------
    def _iterate(self) -> dict[str, Any]:
        """One iteration: a rollout of matches among the population, every learner's update, and
        every ``interval`` updates the exploit/explore step."""
        # rollout: each seated learner acts for its seats in one forward per step
        rollout, start, collect_time = self._collect()
        # GAE and an update per learner that played
        played = set(np.unique(rollout.controllers).tolist())
        stats = self._update(rollout, [code for code in range(len(self.learners)) if code in played])
        self.iteration += 1
        events = self.exploit_and_explore() if self.iteration % self.interval == 0 else []
        record = iteration_record(self, rollout, stats, start, collect_time)
        record["elo"] = self.ratings.tolist()
        record["pbt_events"] = events
        if self.log:
            self.log(format_record(record) + " elo " + " ".join(f"{r:.0f}" for r in self.ratings)
                     + "".join(f"\n  {e}" for e in events))
        return record

    def snapshot_metrics(self, index: int) -> dict[str, Any]:
        """What a snapshot of learner ``index`` records: its Elo and its hyper-parameters."""
        learner = self.learners[index]
        return {"elo": float(self.ratings[index]),
                "hyperparameters": {f.name: getattr(learner.config, f.name) for f in fields(learner.config)
                                    if f.name in self.hyperparameters},
                "lineage": list(self.lineage[index])}
