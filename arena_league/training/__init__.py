"""The training layer: Arena's baselines on one PPO core.

After Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence" (AAAI 2020), whose base populations come from several training schemes:

* :mod:`.ppo`: the PPO core (config, learner, GAE, the update);
* :mod:`.trainer`: what every scheme shares, and the plain parameter-shared PPO scheme;
* :mod:`.rollout`: K envs in lockstep, every seat's action from one batched forward per controller;
* :mod:`.dppo`: independent learners, one per seat or team;
* :mod:`.selfplay`: self-play against snapshots ("latest", "uniform", "80/20", PFSP);
* :mod:`.pbt`: population-based training with Elo matchmaking, exploit and explore;
* :mod:`.schemes`: ``run_scheme(scheme, game_id, ...) -> list[Snapshot]`` and the scheme registry;
* :mod:`.curves`: ``train(...)`` with reward and population-performance curves (PNG).

    from arena_league.training import run_scheme
    snapshots = run_scheme("sp", "Crossroads-2T2P-v1", steps=200_000, seed=1, snapshot_every=50_000,
                           out_dir="runs/", opponent_sampling="pfsp_hard")
"""

from arena_league.training.dppo import DPPO
from arena_league.training.pbt import PBT
from arena_league.training.ppo import (
    Batch,
    Learner,
    PPOConfig,
    RunningMeanStd,
    UpdateStats,
    gae,
    ppo_update,
)
from arena_league.training.rollout import Episode, Opponent, Rollout, RolloutCollector, learner_batch
from arena_league.training.schemes import (
    SCHEMES,
    Snapshot,
    make_env_fn,
    register_scheme,
    run_scheme,
    run_trainer,
    scheme_runner,
)
from arena_league.training.selfplay import OPPONENT_SAMPLING, SelfPlay, pfsp_weights
from arena_league.training.trainer import PPO, TrainerBase

__all__ = [
    "DPPO", "OPPONENT_SAMPLING", "PBT", "PPO", "SCHEMES",
    "Batch", "Episode", "Learner", "Opponent", "PPOConfig", "Rollout", "RolloutCollector", "RunningMeanStd",
    "SelfPlay", "Snapshot", "TrainerBase", "UpdateStats",
    "gae", "learner_batch", "make_env_fn", "pfsp_weights", "ppo_update", "register_scheme", "run_scheme",
    "run_trainer", "scheme_runner", "train",
]


def __getattr__(name: str):
    # curves pulls in matplotlib: imported on first use of train()
    if name == "train":
        from arena_league.training.curves import train

        return train
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
