"""SP: self-play against snapshots of oneself, with prioritised fictitious self-play.

One of the five baselines of Arena (Song et al., "Arena: A General Evaluation Platform and Building
Toolkit for Multi-Agent Intelligence", AAAI 2020). One PPO learner plays one team of each episode;
every other team is played by a frozen snapshot of the learner drawn from its *pool* (the learner's
parameters are added to the pool every ``pool_every`` updates; the initial ones are its first
member). Seats are swapped per episode: env ``k``'s episode ``e`` gives the learner team
``(k + e) mod n_teams``, so the learner plays every team in turn. In a game whose roles differ
(YouShallNotPass: a runner and a blocker), ``learner_teams`` weights them: the learner plays team
``learner_teams[(k + e) mod len(learner_teams)]``, so ``(0, 1, 1, 1)`` gives the blocker three
episodes of every four.

Opponent sampling (``opponent_sampling``):

* ``"latest"``: the most recent snapshot;
* ``"uniform"``: uniform over the pool (fictitious self-play, Heinrich et al. 2015; Bansal et al.,
  "Emergent Complexity via Multi-Agent Competition", ICLR 2018);
* ``"80/20"``: the latest with probability 0.8, else uniform over the older ones (the mix OpenAI
  Five played; Berner et al. 2019);
* ``"pfsp_hard"`` / ``"pfsp_var"``: prioritised fictitious self-play (Vinyals et al., "Grandmaster
  level in StarCraft II using multi-agent reinforcement learning", Nature 2019): snapshot ``j`` is
  drawn with probability proportional to ``f(x_j)``, where ``x_j`` is the learner's recent win
  rate against it (draws count half); ``f_hard(x) = (1 - x)^p`` favours the snapshots the learner
  still loses to, ``f_var(x) = x (1 - x)`` those it beats about half the time.

Win rates are tracked from the results of the learner's episodes: each snapshot starts at 0.5 (a
prior worth one match) and then follows a running mean whose step never falls below
``win_rate_step`` (0.05), so old results fade as the learner changes. With more than two teams one
opponent snapshot plays all other teams of an episode, and the learner's score is its team's
``team_result()`` scaled to [0, 1].

Fixed opponents (``fixed_opponents``, ``fixed_share``): agents that are not snapshots of the learner,
such as ``scripted:random`` and ``scripted:heuristic`` or a frozen member of another run, take a
share ``fixed_share`` of the episodes (one of them, uniformly), the rest going to the pool as above.
A learner that only meets itself can learn to defend rather than to finish (Soccer), and fixed
anchors keep it scoring against weak teams, as the main agents of AlphaStar's league keep playing
past players and exploiters. The learner's running score against each is logged.

The pool holds at most ``pool_size`` snapshots; once full, a new snapshot replaces the oldest in
place. All pool members play as one stacked policy (one batched forward for every opponent seat
of every env, with owner indices; :func:`~arena_league.training.stack.snapshot_pool`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch

from arena_league.policies.architecture import Architecture
from arena_league.policies.policy import Policy
from arena_league.training.ppo import Learner, PPOConfig
from arena_league.training.rollout import Episode, Opponent, RolloutCollector
from arena_league.training.stack import snapshot_pool
from arena_league.training.trainer import TrainerBase, figure, format_record, iteration_record

__all__ = ["OPPONENT_SAMPLING", "OpponentPool", "RunningScores", "SelfPlay", "load_fixed_opponent", "pfsp_weights"]

OPPONENT_SAMPLING = ("latest", "uniform", "80/20", "pfsp_hard", "pfsp_var")


def pfsp_weights(win_rates: np.ndarray, weighting: str, p: float = 2.0) -> np.ndarray:
    """PFSP sampling probabilities from win rates ``x`` against each opponent (Vinyals et al. 2019):
    ``"hard"``: ``(1 - x)^p``; ``"variance"``: ``x (1 - x)``. Uniform when every weight is 0."""
    x = np.clip(np.asarray(win_rates, dtype=np.float64), 0.0, 1.0)
    if weighting == "hard":
        weights = (1.0 - x) ** p
    elif weighting == "variance":
        weights = x * (1.0 - x)
    else:
        raise ValueError(f"PFSP weighting must be 'hard' or 'variance', not {weighting!r}")
    total = weights.sum()
    return np.full(x.size, 1.0 / x.size) if total <= 0 else weights / total


def load_fixed_opponent(reference: str, game_id: str, action_type: str) -> Policy:
    """A fixed opponent of a trainer (SP's ``fixed_opponents``, CC's ``opponent``): an agent reference
    (``scripted:random``, ``onnx:agent.onnx``, ``arena-policy:folder``) or an artifact path. Loading
    it for the game's action type checks its spaces; a bad name or path is explained by the loader."""
    from arena_league.policies import load_policy

    kind, sep, rest = reference.partition(":")
    path = rest if sep and kind in ("onnx", "arena-policy") else reference
    return load_policy(path, game_id, action_type=action_type)


class RunningScores:
    """The learner's running score (1 win, 0.5 draw, 0 loss) against each of a list of opponents:
    0.5 at first, a prior worth one match, then a running mean whose step never falls below
    ``win_rate_step``."""

    def __init__(self, win_rate_step: float = 0.05, opponents: int = 0) -> None:
        self.win_rate_step = win_rate_step
        self.win_rate: list[float] = [0.5] * opponents
        self.games: list[int] = [0] * opponents

    def track(self, index: int | None = None) -> None:
        """Start a score at the prior: a new opponent (``index`` None) or one replaced in place."""
        if index is None:
            self.win_rate.append(0.5)
            self.games.append(0)
        else:
            self.win_rate[index], self.games[index] = 0.5, 0

    def record(self, index: int, score: float) -> None:
        """The learner scored ``score`` against opponent ``index``."""
        self.games[index] += 1
        step = max(1.0 / (self.games[index] + 1), self.win_rate_step)  # the 0.5 prior counts as one match
        self.win_rate[index] += step * (score - self.win_rate[index])


class OpponentPool(RunningScores):
    """Snapshots of the learner, their ages and the learner's running win rate against each."""

    def __init__(self, capacity: int, win_rate_step: float = 0.05) -> None:
        if capacity < 1:
            raise ValueError(f"pool_size must be at least 1, not {capacity}")
        super().__init__(win_rate_step)
        self.capacity = capacity
        self.params: list[dict[str, torch.Tensor]] = []
        self.added_at: list[int] = []
        """The learner update count at which each member was added."""
        self.latest = -1

    def __len__(self) -> int:
        return len(self.params)

    def add(self, params: dict[str, torch.Tensor], update: int) -> int:
        """Add a snapshot (replacing the oldest when full); returns its index."""
        if len(self.params) < self.capacity:
            self.params.append(params)
            self.added_at.append(update)
            self.track()
            index = len(self.params) - 1
        else:
            index = int(np.argmin(self.added_at))
            self.params[index], self.added_at[index] = params, update
            self.track(index)
        self.latest = index
        return index

    def sample(self, rule: str, rng: np.random.Generator, pfsp_p: float) -> int:
        """One member index under the sampling rule."""
        n = len(self.params)
        if rule == "latest" or n == 1:
            return self.latest
        if rule == "uniform":
            return int(rng.integers(n))
        if rule == "80/20":
            if rng.random() < 0.8:
                return self.latest
            past = [i for i in range(n) if i != self.latest]
            return past[int(rng.integers(len(past)))]
        weights = pfsp_weights(np.asarray(self.win_rate), "hard" if rule == "pfsp_hard" else "variance", pfsp_p)
        return int(rng.choice(n, p=weights))


class SelfPlay(TrainerBase):
    """Self-play of one PPO learner against its own snapshots (see the module docstring).

    Args:
        env_fn: makes one env of the game.
        config: hyper-parameters.
        seed: seeds the learner, env resets, action noise and opponent draws.
        opponent_sampling: one of :data:`OPPONENT_SAMPLING`.
        pfsp_p: the exponent of ``f_hard``.
        pool_every: learner updates between two snapshots added to the pool.
        pool_size: the most snapshots the pool keeps.
        win_rate_step: the smallest step of the running win rates.
        fixed_opponents: agent references (``scripted:random``, ``arena-policy:folder``,
            ``onnx:file.onnx``) that play a share ``fixed_share`` of the episodes.
        fixed_share: the share of episodes against a fixed opponent, in [0, 1].
        learner_teams: the teams the learner plays, in turn (a team may repeat, to weight it);
            None: every team in turn.
        architecture: the actor's family and sizes (default from ``config``).
        total_steps: env steps of the run, for learning-rate annealing.
        log: called with a line per iteration.
    """

    scheme = "sp"

    def __init__(self, env_fn: Callable[[], Any], config: PPOConfig | None = None, seed: int = 0, *,
                 opponent_sampling: str = "pfsp_hard", pfsp_p: float = 2.0, pool_every: int = 5,
                 pool_size: int = 64, win_rate_step: float = 0.05, fixed_opponents: Sequence[str] = (),
                 fixed_share: float = 0.0, learner_teams: Sequence[int] | None = None,
                 architecture: Architecture | None = None, total_steps: int | None = None, log: Callable[[str], None] | None = None) -> None:
        if isinstance(fixed_opponents, str):
            fixed_opponents = (fixed_opponents,)
        if not 0.0 <= float(fixed_share) <= 1.0:
            raise ValueError(f"fixed_share must lie in [0, 1], not {fixed_share}")
        if fixed_share > 0 and not fixed_opponents:
            raise ValueError(f"fixed_share {fixed_share} needs fixed_opponents, e.g. "
                             "fixed_opponents=('scripted:random', 'scripted:heuristic')")
        if opponent_sampling not in OPPONENT_SAMPLING:
            raise ValueError(f"unknown opponent_sampling {opponent_sampling!r}; valid: {', '.join(OPPONENT_SAMPLING)}")
        if pool_every < 1:
            raise ValueError(f"pool_every must be at least 1 update, not {pool_every}")
        probe = self._begin(env_fn, config or PPOConfig(), seed, architecture, total_steps, log)
        self.opponent_rng = np.random.default_rng(np.random.SeedSequence([seed, 3]))
        self.team_of = np.asarray(probe.rules.team_of, dtype=np.int64)
        self.n_teams = int(probe.rules.n_teams)
        self.learner_teams = self._learner_teams(learner_teams, self.n_teams, probe.game_id)
        self.learners = [Learner(self.architecture, self.config, seed, name="sp")]
        self.opponent_sampling = opponent_sampling
        self.pfsp_p = pfsp_p
        self.pool_every = pool_every
        self.pool = OpponentPool(pool_size, win_rate_step)
        self.pool.add(self.learners[0].actor_parameters(), 0)
        self.fixed_share = float(fixed_share)
        self.fixed = self._fixed_opponents(probe, tuple(fixed_opponents))
        self.fixed_rates = RunningScores(win_rate_step, len(self.fixed))
        self.collector = RolloutCollector(env_fn, self.config.num_envs, seed, seating=self._seating,
                                          opponents=self._pool_opponents(), on_episode=self._record)

    @staticmethod
    def _learner_teams(teams: Sequence[int] | None, n_teams: int, game_id: str) -> tuple[int, ...]:
        if teams is None:
            return tuple(range(n_teams))
        listed = isinstance(teams, Sequence) and not isinstance(teams, (str, bytes)) and len(teams) > 0
        if not listed or not all(isinstance(t, (int, np.integer)) and not isinstance(t, bool) and 0 <= t < n_teams
                                 for t in teams):
            raise ValueError(f"learner_teams must list team indices 0..{n_teams - 1} of {game_id} (a team may "
                             f"repeat to weight it), e.g. [0, 1, 1, 1]; got {teams!r}")
        return tuple(int(t) for t in teams)

    # --- opponents --------------------------------------------------------------------------------
    @staticmethod
    def _fixed_opponents(probe: Any, references: tuple[str, ...]) -> list[Opponent]:
        """The fixed opponents, loaded for the probe env's game and action type."""
        return [Opponent(load_fixed_opponent(text, probe.game_id, probe.rules.action_type), name=text)
                for text in references]

    def _fixed_scores(self) -> dict[str, float]:
        """The learner's running score against each fixed opponent."""
        return {o.name: self.fixed_rates.win_rate[j] for j, o in enumerate(self.fixed)}

    def _pool_opponents(self) -> list[Opponent]:
        """The fixed opponents first (their codes never move), then every pool member as an opponent
        of one stacked policy (one forward for all their seats)."""
        stacked = snapshot_pool(self.architecture, self.pool.params)
        return self.fixed + [Opponent(stacked, owner=i, name=f"sp@{self.pool.added_at[i]}")
                             for i in range(len(self.pool))]

    def _seating(self, env_index: int, episode: int) -> tuple[np.ndarray, np.ndarray]:
        """The learner's team follows ``learner_teams`` episode by episode; a fixed opponent (a share
        ``fixed_share`` of the episodes) or one sampled snapshot plays the other teams."""
        learner_team = self.learner_teams[(env_index + episode) % len(self.learner_teams)]
        if self.fixed and self.opponent_rng.random() < self.fixed_share:
            index = int(self.opponent_rng.integers(len(self.fixed)))
            owner = -1
        else:
            owner = self.pool.sample(self.opponent_sampling, self.opponent_rng, self.pfsp_p)
            index = len(self.fixed) + owner
        codes = np.where(self.team_of == learner_team, 0, -1 - index)
        return codes, np.full(len(codes), owner)

    def _record(self, episode: Episode) -> None:
        opponent_seats = np.flatnonzero(episode.controllers < 0)
        score = episode.score_of_controller(0)
        if opponent_seats.size and score is not None:
            index = -1 - int(episode.controllers[opponent_seats[0]])
            if index < len(self.fixed):
                self.fixed_rates.record(index, score)
            else:
                self.pool.record(index - len(self.fixed), score)

    # --- training ---------------------------------------------------------------------------------
    def _iterate(self) -> dict[str, Any]:
        """One iteration: rollout against pool snapshots, GAE, update, and maybe a new snapshot."""
        # rollout: the learner's seats in one forward, the snapshots' seats in one stacked forward
        rollout, start, collect_time = self._collect()
        # GAE and the update
        learner = self.learners[0]
        stats = self._update(rollout, [0])[0]
        self.iteration += 1
        # the pool: add the learner as it is now
        if learner.updates % self.pool_every == 0:
            self.pool.add(learner.actor_parameters(), learner.updates)
            self.collector.opponents = self._pool_opponents()
        record = iteration_record(self, rollout, [stats], start, collect_time)
        scores = [s for s in (e.score_of_controller(0) for e in rollout.episodes) if s is not None]
        record["win_rate"] = float(np.mean(scores)) if scores else float("nan")
        record["pool_size"] = len(self.pool)
        fixed = ""
        if self.fixed:
            record["fixed_win_rates"] = self._fixed_scores()
            fixed = " " + " ".join(f"vs {k} {v:.2f}" for k, v in record["fixed_win_rates"].items())
        if self.log:
            self.log(format_record(record) + f" win_rate {figure(record['win_rate'], '.2f')} pool {len(self.pool)}{fixed}")
        return record

    def snapshot_metrics(self, index: int) -> dict[str, Any]:
        """What a snapshot records besides its weights: the sampling rule and pool win rates."""
        metrics = {"opponent_sampling": self.opponent_sampling, "pool_size": len(self.pool),
                   "mean_pool_win_rate": float(np.mean(self.pool.win_rate))}
        if self.fixed:
            metrics["fixed_share"] = self.fixed_share
            metrics["fixed_win_rates"] = self._fixed_scores()
        return metrics
