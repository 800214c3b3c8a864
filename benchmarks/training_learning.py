"""Learning is unchanged: each scheme's win rate after a small budget, over seeds, optionally beside an older tree.

Prints one JSON document. For each scheme that applies to the game (``ppo``, ``dppo``, ``sp``,
``pbt``, ``cc``, ``cf``; Crossroads-2T2P-v1 by default), it trains ``--seeds`` runs of ``--steps``
env steps with the scheme's own defaults (its trainer class built with no config: the core's
:class:`~arena_league.training.PPOConfig` for ppo, dppo, sp and pbt; MAPPO's and COMA's values for
cc and cf), one process per run, each pinned to a core of its own and computing on one torch thread,
``--jobs`` at once. Each run's learners then play the game's scripted agents (``scripted:random``,
``scripted:heuristic``) through the league's match engine
(:func:`arena_league.training.curves.evaluate_learners`: ``--matches`` matches per learner and
reference, the learner's team rotating, a draw counting half). A run's win rate is the mean over its
learners; the document gives each seed's, and their mean with a 95% Student-t interval over seeds,
against each reference and over both (``population_performance``).

With ``--against PATH`` (another checkout of the repository, e.g. ``git worktree add /tmp/old
347ea07``) every run is repeated with ``PYTHONPATH=PATH`` (same seeds, same evaluation matches), and
each scheme says whether this tree's mean lies within the old interval and the old mean within this
tree's (two trees that learn alike should both say yes), with the difference of the means and
Welch's t-test p-value (an interval of zero width, every seed at the same win rate, says no to
any other mean: read the difference then).

    PYTHONPATH=. python benchmarks/training_learning.py                  # about 6 minutes on 2 cores
    PYTHONPATH=. python benchmarks/training_learning.py --against /tmp/old   # about 12 minutes
    PYTHONPATH=. python benchmarks/training_learning.py --schemes ppo --seeds 2 --steps 20000 --matches 4
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from training import SCHEMES, Cores, launch_command, parse_list, trainer_class

ROOT = Path(__file__).resolve().parent.parent
GAME = "Crossroads-2T2P-v1"
REFERENCES = ("scripted:random", "scripted:heuristic")


def worker(game_id: str, scheme: str, steps: int, seed: int, matches: int) -> dict:
    """Train one run and evaluate its learners (in a process of its own)."""
    import torch

    import arena_league
    from arena_league.matchmaking import AgentRef
    from arena_league.training import make_env_fn
    from arena_league.training.curves import evaluate_learners

    torch.set_num_threads(1)
    cls, options = trainer_class(scheme)
    references = {text: AgentRef.parse(text, game_id, None) for text in REFERENCES}
    trainer = cls(make_env_fn(game_id), None, seed, total_steps=steps, **options)
    # the same matches before training: what "learning shows" is measured against
    untrained = evaluate_learners(trainer.learners, game_id, references, matches, league_seed=seed)
    start = time.perf_counter()
    returns = []
    while trainer.env_steps < steps:
        record = trainer.iterate()
        returns.append(record.get("episode_return"))
    train_seconds = time.perf_counter() - start
    evaluation = evaluate_learners(trainer.learners, game_id, references, matches, league_seed=seed)
    finite = [r for r in returns if r is not None and np.isfinite(r)]
    return {"env_steps": int(trainer.env_steps), "train_seconds": round(train_seconds, 1),
            "eval_seconds": round(time.perf_counter() - start - train_seconds, 1),
            "learners": len(trainer.learners), "population_performance": evaluation["population_performance"],
            "per_reference": evaluation["per_reference"], "per_learner": evaluation["per_learner"],
            "untrained": {"population_performance": untrained["population_performance"],
                          "per_reference": untrained["per_reference"]},
            "episode_return_last": round(float(np.mean(finite[-10:])), 3) if finite else None,
            "arena_league": str(Path(arena_league.__file__).parent.parent)}


def interval(values: list[float]) -> dict:
    """Mean and 95% Student-t interval of ``values`` (the spread of the seeds' means)."""
    from scipy import stats

    data = np.asarray(values, dtype=float)
    mean = float(data.mean())
    if len(data) < 2:
        return {"mean": round(mean, 4), "ci95": None, "n": len(data)}
    half = float(stats.t.ppf(0.975, len(data) - 1) * data.std(ddof=1) / np.sqrt(len(data)))
    return {"mean": round(mean, 4), "ci95": [round(mean - half, 4), round(mean + half, 4)], "n": len(data)}


def summary(runs: list[dict]) -> dict:
    ok = [r for r in runs if "error" not in r]
    if not ok:
        return {"error": "every run failed"}
    out = {"population_performance": interval([r["population_performance"] for r in ok])}
    for ref in REFERENCES:
        out[ref] = interval([r["per_reference"][ref] for r in ok])
    out["untrained"] = {"population_performance": interval([r["untrained"]["population_performance"] for r in ok])}
    out["train_seconds_mean"] = round(float(np.mean([r["train_seconds"] for r in ok])), 1)
    return out


def welch(new: list[float], old: list[float]) -> dict:
    """The difference of the two trees' means over seeds, and Welch's two-sided t-test p-value
    (None when both sides have no spread, e.g. every seed at 0)."""
    from scipy import stats

    difference = float(np.mean(new) - np.mean(old))
    p_value = None
    if len(new) > 1 and len(old) > 1 and (np.std(new) > 0 or np.std(old) > 0):
        p_value = round(float(stats.ttest_ind(new, old, equal_var=False).pvalue), 4)
    return {"difference": round(difference, 4), "welch_p": p_value}


def figure_of(run: dict, key: str) -> float:
    return run["population_performance"] if key == "population_performance" else run["per_reference"][key]


def within(value: dict, bounds: dict) -> bool | None:
    if bounds.get("ci95") is None:
        return None
    low, high = bounds["ci95"]
    return low <= value["mean"] <= high


def benchmark(args: argparse.Namespace) -> dict:
    from arena_league.envs import list_games, make
    from arena_league.training.schemes import scheme_action_types

    if args.game not in set(list_games()):
        raise ValueError(f"unknown game {args.game!r}; e.g. {GAME}")
    schemes = parse_list(args.schemes, SCHEMES, "scheme")
    for name, value, least in (("--seeds", args.seeds, 1), ("--steps", args.steps, 1),
                               ("--matches", args.matches, 1), ("--jobs", args.jobs, 1)):
        if value < least:
            raise ValueError(f"{name} must be at least {least}, not {value}")
    against = Path(args.against).resolve() if args.against else None
    if against is not None and not (against / "arena_league" / "__init__.py").exists():
        raise ValueError(f"--against {args.against}: no arena_league package there; give a checkout of the "
                         "repository, e.g. git worktree add /tmp/old 347ea07")
    action_type = make(args.game).rules.action_type
    trees = {"new": ROOT} | ({"old": against} if against is not None else {})
    skipped = {s: f"{s} does not train {action_type} actions" for s in schemes
               if action_type not in scheme_action_types(s)}
    tasks = [(side, scheme, seed) for scheme in schemes if scheme not in skipped
             for seed in range(args.seeds) for side in trees]
    cores = Cores(args.jobs)

    def run(task):
        side, scheme, seed = task
        cmd = ["--worker", scheme, "--seed", str(seed), "--game", args.game, "--steps", str(args.steps),
               "--matches", str(args.matches)]
        return task, launch_command(cores, Path(__file__).resolve(), cmd, trees[side], timeout=1800)

    start = time.perf_counter()
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        results = list(pool.map(run, tasks))
    document_schemes: dict[str, Any] = {s: {"skipped": why} for s, why in skipped.items()}
    for (side, scheme, seed), result in results:
        cell = document_schemes.setdefault(scheme, {})
        cell.setdefault(side, {"runs": {}})["runs"][f"seed{seed}"] = result
    for cell in document_schemes.values():
        if "skipped" in cell:
            continue
        for side in trees:
            cell[side]["summary"] = summary(list(cell[side]["runs"].values()))
        if against is not None and "error" not in cell["new"]["summary"] and "error" not in cell["old"]["summary"]:
            new, old = cell["new"]["summary"], cell["old"]["summary"]
            new_runs = [r for r in cell["new"]["runs"].values() if "error" not in r]
            old_runs = [r for r in cell["old"]["runs"].values() if "error" not in r]
            cell["unchanged"] = {key: {"new_mean_within_old_ci": within(new[key], old[key]),
                                       "old_mean_within_new_ci": within(old[key], new[key]),
                                       **welch([figure_of(r, key) for r in new_runs],
                                               [figure_of(r, key) for r in old_runs])}
                                 for key in ("population_performance", *REFERENCES)}
    return {
        "benchmark": "training_learning",
        "game_id": args.game,
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform(),
                    "load_average_at_end": [round(x, 2) for x in os.getloadavg()]},
        "settings": {"steps_per_run": args.steps, "seeds": list(range(args.seeds)), "matches_per_reference":
                     args.matches, "references": list(REFERENCES), "jobs": args.jobs,
                     "pinned_one_core_per_process": cores.taskset, "torch_threads_per_process": 1,
                     "config": "each scheme's own defaults; pbt: population_size 4",
                     "win_rate": "share of points against the reference (draw = half), mean over a run's learners",
                     "interval": "95% Student-t over seeds", "against": str(against) if against else None},
        "wall_seconds": round(time.perf_counter() - start, 1),
        "schemes": document_schemes,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--game", default=GAME, help="game id (default: %(default)s)")
    parser.add_argument("--schemes", default=",".join(SCHEMES), help="comma-separated schemes (default: %(default)s)")
    parser.add_argument("--seeds", type=int, default=4, help="runs per scheme, seeds 0.. (default: %(default)s)")
    parser.add_argument("--steps", type=int, default=100_000, help="env steps per run (default: %(default)s)")
    parser.add_argument("--matches", type=int, default=40,
                        help="evaluation matches per learner and reference (default: %(default)s)")
    parser.add_argument("--against", metavar="PATH", help="another checkout: run every scheme with it too")
    parser.add_argument("--jobs", type=int, default=min(2, len(os.sched_getaffinity(0)) if hasattr(
        os, "sched_getaffinity") else 1), help="runs at once, one core each (default: %(default)s)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--seed", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.game, args.worker, args.steps, args.seed, args.matches)))
        return 0
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    try:
        document = benchmark(args)
    except ValueError as error:
        print(f"training_learning benchmark: {error}", file=sys.stderr)
        return 2
    print(json.dumps(document, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
