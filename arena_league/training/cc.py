"""CC: PPO with a centralised critic, MAPPO-style.

One of the five baselines of Arena (Song et al., "Arena: A General Evaluation Platform and Building
Toolkit for Multi-Agent Intelligence", AAAI 2020), after Yu, Velu, Vinitsky, Gao, Wang, Bayen & Wu,
"The Surprising Effectiveness of PPO in Cooperative Multi-Agent Games" (NeurIPS 2022 Datasets and
Benchmarks), MAPPO:

* **Decentralised actors.** Each seat acts from its own observation only (the game's base
  observation, what an exported agent reads). The seats of the trained team share one actor
  (MAPPO's parameter sharing among homogeneous agents), a
  :class:`~arena_league.policies.families.FamilyNet`, so every snapshot is an ordinary agent.
* **A centralised critic** ``V(s, i)`` reads the global state ``env.state()`` and the seat's id
  (a one-hot seat index: one value function serves every seat, and MAPPO's "agent-specific"
  input tells it whose return to predict). It is used in training only; nothing of it is
  exported.
* **The update is the PPO core's** (:func:`~arena_league.training.ppo.ppo_update`): GAE on the
  centralised values, the clipped surrogate, value clipping and value normalisation (MAPPO's
  ValueNorm), with MAPPO's hyper-parameters (:class:`CCConfig`).

Opponents (:class:`TeamSeats`, also used by the counterfactual learner of :mod:`.cf`): in a game
of several teams the learner plays one team of each episode, by default a different one each
episode (env ``k``'s episode ``e`` gives it team ``(k + e) mod n_teams``, as in self-play), and the
other teams are played by

* ``"self"``: snapshots of the learner itself, drawn with the core's self-play sampling rules
  (:class:`~arena_league.training.selfplay.OpponentPool`: ``"latest"``, ``"uniform"``,
  ``"80/20"``, ``"pfsp_hard"``, ``"pfsp_var"``);
* ``"scripted:heuristic"`` / ``"scripted:random"``, a path to an agent artifact (ONNX, arena-policy
  folder) or any league :class:`~arena_league.policies.policy.Policy`: a fixed opponent;
* ``"none"``: the learner plays every seat (for cooperative social trees, e.g. Crossroads'
  ``all_CL``).

Measured (seed 0, one run each, the shared 2-core machine): on Crossroads-2T2P-v1 (``max_cycles=100``,
default tree) against ``scripted:heuristic`` with :class:`CCConfig`'s defaults, the learner's mean
return went from -100.2 (first 10 iterations of 8 x 128 steps) to -40.9 (last 10 of 150), winning
24% of the last 10 iterations' episodes, in 64 s. (With ``update_epochs=5`` it had not moved
after 150 iterations: the lost race, -100 when the other team arrives, gives advantages a standard
deviation near 22 against a progress signal near 0.1 per step, so MAPPO's 15 epochs per rollout
matter here.)

Not in this learner (MAPPO options the core does not offer): the Huber value loss (the core's
value loss is squared error, clipped) and recurrent data chunks (a GRU actor trains on the
recurrent states recorded at collection, as the core does).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import torch

from arena_league.policies.architecture import Architecture
from arena_league.policies.policy import Policy
from arena_league.training.ppo import Learner, PPOConfig
from arena_league.training.rollout import Episode, Opponent, RolloutCollector
from arena_league.training.schemes import register_scheme, scheme_runner
from arena_league.training.selfplay import OPPONENT_SAMPLING, OpponentPool, load_fixed_opponent
from arena_league.training.stack import snapshot_pool
from arena_league.training.trainer import TrainerBase, figure, format_record, iteration_record

__all__ = ["CC", "CCConfig", "CentralCriticLearner", "TeamSeats", "central_critic_features", "paper_config",
           "paper_runner"]


@dataclass(frozen=True)
class CCConfig(PPOConfig):
    """PPO's hyper-parameters with MAPPO's values (Yu et al. 2022, Appendix tables: the common
    settings and the SMAC ones) where they differ from the core's CleanRL defaults."""

    learning_rate: float = 5e-4
    """Adam step size of actor and critic (MAPPO on SMAC: 5e-4)."""
    anneal_lr: bool = False
    """Linear step-size decay (MAPPO: off by default)."""
    update_epochs: int = 15
    """PPO epochs per rollout (MAPPO on SMAC's easy maps: 15; 5 on the hard ones)."""
    num_minibatches: int = 1
    """Minibatches per epoch (MAPPO: 1, the whole batch)."""
    clip_coef: float = 0.2
    """Surrogate and value clipping epsilon (MAPPO: 0.2)."""
    vf_coef: float = 1.0
    """Value loss coefficient (MAPPO: 1)."""
    max_grad_norm: float = 10.0
    """Global gradient-norm clip (MAPPO: 10)."""
    activation: str = "relu"
    """Hidden activation of actor and critic (MAPPO: ReLU)."""


def paper_config(config_cls: type[PPOConfig], config: PPOConfig | None) -> PPOConfig:
    """``config`` as an instance of ``config_cls`` (a plain :class:`PPOConfig`, as ``run_scheme``
    builds, keeps its values; its extra fields take their defaults); the defaults when None."""
    if config is None or isinstance(config, config_cls):
        return config or config_cls()
    return config_cls(**{f.name: getattr(config, f.name) for f in fields(PPOConfig)})


def paper_runner(trainer_cls: type, config_cls: type[PPOConfig]) -> Callable[..., Any]:
    """The core's runner of ``trainer_cls``, with the :class:`PPOConfig` fields the caller does not
    set taken from ``config_cls`` (the paper's values) instead of the core's defaults, and the
    extra fields of ``config_cls`` passed to the trainer as options (so a finished run's record
    names them all)."""
    base = scheme_runner(trainer_cls)
    defaults = config_cls()
    names = [f.name for f in fields(config_cls)]

    def runner(game_id: str, **kwargs: Any) -> Any:
        return base(game_id, **{name: getattr(defaults, name) for name in names if name not in kwargs}, **kwargs)

    runner.__name__ = f"run_{trainer_cls.scheme}"
    runner.__doc__ = base.__doc__
    runner.trainer_cls = trainer_cls  # type: ignore[attr-defined]  # its options and action_types are read off it
    return runner


# --- the centralised critic's input -----------------------------------------------------------------

def central_critic_features(state: np.ndarray, seat: np.ndarray, n_agents: int) -> np.ndarray:
    """The centralised critic's input rows: the global state, then the seat's one-hot id.

    Args:
        state: ``float32[N, state_dim]`` the env's ``state()`` for each row.
        seat: ``int[N]`` the seat index (0..n_agents-1) each row evaluates.
        n_agents: seats of the game.
    Returns ``float32[N, state_dim + n_agents]``.
    """
    one_hot = np.eye(n_agents, dtype=np.float32)[np.asarray(seat, dtype=np.int64)]
    return np.concatenate([np.asarray(state, dtype=np.float32), one_hot], axis=1)


class CentralCriticLearner(Learner):
    """A core :class:`~arena_league.training.ppo.Learner` whose critic reads ``V(s, i)``: the global
    state and the seat's one-hot id (:func:`central_critic_features`) instead of the observation."""

    #: Ask the collector to record ``env.state()`` every step.
    needs_state = True

    def __init__(self, arch: Architecture, config: PPOConfig, seed: int, *, state_dim: int, n_agents: int,
                 name: str = "cc") -> None:
        super().__init__(arch, config, seed, critic_dim=state_dim + n_agents, name=name)
        self.state_dim = state_dim
        self.n_agents = n_agents

    def critic_features(self, obs: np.ndarray, state: np.ndarray | None, seat: np.ndarray,
                        n_agents: int) -> np.ndarray:
        if state is None:
            raise RuntimeError("the centralised critic reads env.state(), but the collector recorded no state; "
                               "collect with this learner (it sets needs_state) so states are recorded")
        return central_critic_features(state, seat, n_agents)


# --- who plays which seats ----------------------------------------------------------------------------

class TeamSeats:
    """The learner (controller 0) in one team per episode, the opponents in the others.

    Args:
        env: a probe env of the game (its teams and game id).
        architecture: the learner's actor architecture (for snapshot opponents).
        initial_params: the learner's first parameters (the first snapshot opponent).
        seed: seeds the opponent draws.
        opponent: ``"self"``, ``"none"``, ``"scripted:<name>"``, an agent artifact path, or a Policy.
        opponent_sampling: the self-play rule for ``"self"`` (:data:`OPPONENT_SAMPLING`).
        pfsp_p: the exponent of PFSP's ``f_hard``.
        pool_every: learner updates between two snapshots added to the pool (``"self"``).
        pool_size: the most snapshots the pool keeps (``"self"``).
        team: the learner's team in every episode; None: swapped per episode.
    """

    def __init__(self, env: Any, architecture: Architecture, initial_params: dict[str, torch.Tensor], seed: int, *,
                 opponent: str | Policy = "self", opponent_sampling: str = "pfsp_hard", pfsp_p: float = 2.0,
                 pool_every: int = 5, pool_size: int = 64, team: int | None = None) -> None:
        rules = env.rules
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.n_teams = int(rules.n_teams)
        if team is not None and (isinstance(team, bool) or not isinstance(team, int) or not 0 <= team < self.n_teams):
            raise ValueError(f"team must be a team index 0..{self.n_teams - 1} of {env.game_id}, or None to swap "
                             f"teams every episode; got {team!r}")
        if opponent_sampling not in OPPONENT_SAMPLING:
            raise ValueError(f"unknown opponent_sampling {opponent_sampling!r}; valid: {', '.join(OPPONENT_SAMPLING)}")
        if pool_every < 1:
            raise ValueError(f"pool_every must be at least 1 update, not {pool_every}")
        self.team = team
        self.architecture = architecture
        self.opponent_sampling = opponent_sampling
        self.pfsp_p = pfsp_p
        self.pool_every = pool_every
        self.rng = np.random.default_rng(np.random.SeedSequence([seed, 3]))
        self.pool: OpponentPool | None = None
        self.fixed: Policy | None = None
        if isinstance(opponent, Policy):
            self.fixed, self.opponent = opponent, getattr(opponent, "name", "policy")
        elif opponent == "self":
            self.pool = OpponentPool(pool_size)
            self.pool.add(initial_params, 0)
            self.opponent = "self"
        elif opponent == "none":
            self.opponent = "none"
        elif isinstance(opponent, str):
            self.fixed = load_fixed_opponent(opponent, env.game_id, rules.action_type)
            self.opponent = opponent
        else:
            raise TypeError(f"opponent must be 'self', 'none', 'scripted:heuristic', 'scripted:random', an agent "
                            f"path or a Policy, not {type(opponent).__name__}")
        self.scores: list[float] = []

    def opponents(self) -> list[Opponent]:
        """The collector's fixed policies: every pool snapshot (one stacked forward), or the fixed one."""
        if self.pool is not None:
            stacked = snapshot_pool(self.architecture, self.pool.params)
            return [Opponent(stacked, owner=i, name=f"self@{self.pool.added_at[i]}") for i in range(len(self.pool))]
        if self.fixed is not None:
            return [Opponent(self.fixed, name=self.opponent)]
        return []

    def seating(self, env_index: int, episode: int) -> tuple[np.ndarray, np.ndarray]:
        """Controller codes (0 the learner, -1 - j opponent j) and stacked owners of each seat."""
        n = len(self.team_of)
        if self.opponent == "none":
            return np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
        team = self.team if self.team is not None else (env_index + episode) % self.n_teams
        member = self.pool.sample(self.opponent_sampling, self.rng, self.pfsp_p) if self.pool is not None else 0
        return np.where(self.team_of == team, 0, -1 - member), np.full(n, member, dtype=np.int64)

    def record(self, episode: Episode) -> None:
        """The learner's result (its team's score in [0, 1]), and the pool's win rates."""
        score = episode.score_of_controller(0)
        opponent_seats = np.flatnonzero(episode.controllers < 0)
        if score is None or opponent_seats.size == 0:
            return
        self.scores.append(score)
        if self.pool is not None:
            self.pool.record(-1 - int(episode.controllers[opponent_seats[0]]), score)

    def after_update(self, learner: Learner, collector: RolloutCollector) -> None:
        """Every ``pool_every`` updates, the learner as it is now joins the snapshot pool."""
        if self.pool is not None and learner.updates % self.pool_every == 0:
            self.pool.add(learner.actor_parameters(), learner.updates)
            collector.opponents = self.opponents()

    def win_rate(self) -> float:
        """The learner's mean score over the episodes recorded since the last call (NaN: none)."""
        scores, self.scores = self.scores, []
        return float(np.mean(scores)) if scores else float("nan")

    def describe(self) -> dict[str, Any]:
        """What a snapshot records about its opponents."""
        out: dict[str, Any] = {"opponent": self.opponent, "team": "swapped" if self.team is None else self.team}
        if self.pool is not None:
            out.update(opponent_sampling=self.opponent_sampling, pool_size=len(self.pool),
                       mean_pool_win_rate=float(np.mean(self.pool.win_rate)))
        return out


# --- the scheme ------------------------------------------------------------------------------------

class CC(TrainerBase):
    """MAPPO: one team's shared actor trained with a centralised critic ``V(s, i)`` (see the module).

    Args:
        env_fn: makes one env of the game (``arena_league.envs.make(...)``).
        config: hyper-parameters (default :class:`CCConfig`, MAPPO's; a plain PPOConfig keeps its values).
        seed: seeds actor, critic, env resets, action noise and opponent draws.
        opponent, opponent_sampling, pfsp_p, pool_every, pool_size, team: who plays the other
            teams (see :class:`TeamSeats`).
        architecture: the actor's family and sizes (default from ``config``).
        total_steps: env steps of the run, for learning-rate annealing.
        log: called with a line per iteration.
    """

    scheme = "cc"

    def __init__(self, env_fn: Callable[[], Any], config: PPOConfig | None = None, seed: int = 0, *,
                 opponent: str | Policy = "self", opponent_sampling: str = "pfsp_hard", pfsp_p: float = 2.0,
                 pool_every: int = 5, pool_size: int = 64, team: int | None = None,
                 architecture: Architecture | None = None, total_steps: int | None = None,
                 log: Callable[[str], None] | None = None) -> None:
        probe = self._begin(env_fn, paper_config(CCConfig, config), seed, architecture, total_steps, log)
        rules = probe.rules
        learner = CentralCriticLearner(self.architecture, self.config, seed, state_dim=int(rules.state_dim),
                                       n_agents=int(rules.n_agents), name="cc")
        self.learners = [learner]
        self.seats = TeamSeats(probe, self.architecture, learner.actor_parameters(), seed, opponent=opponent,
                               opponent_sampling=opponent_sampling, pfsp_p=pfsp_p, pool_every=pool_every,
                               pool_size=pool_size, team=team)
        self.collector = RolloutCollector(env_fn, self.config.num_envs, seed, seating=self.seats.seating,
                                          opponents=self.seats.opponents(), on_episode=self.seats.record)

    def _iterate(self) -> dict[str, Any]:
        """One iteration: rollout (states recorded), GAE on the centralised values, PPO update."""
        # rollout: the learner's seats in one actor and one critic forward per step
        rollout, start, collect_time = self._collect()
        # GAE over V(s, i), then the core's clipped update of actor and centralised critic
        learner = self.learners[0]
        stats = self._update(rollout, [0])[0]
        self.iteration += 1
        self.seats.after_update(learner, self.collector)
        # log
        record = iteration_record(self, rollout, [stats], start, collect_time)
        record["win_rate"] = self.seats.win_rate()
        if self.log:
            self.log(format_record(record) + f" win_rate {figure(record['win_rate'], '.2f')} "
                     f"ev {figure(stats.explained_variance, '.2f')}")
        return record

    def snapshot_metrics(self, index: int) -> dict[str, Any]:
        """What a snapshot records besides its weights: the critic's input and the opponents."""
        return {"critic": "state+seat_id", **self.seats.describe()}


register_scheme(CC.scheme, paper_runner(CC, CCConfig))
