"""Interval estimates over runs: arena-league's vectorised stratified bootstrap beside rliable's, in one run.

Prints one JSON document: for a score table of ``--runs`` runs x ``--tasks`` tasks per method (two
methods), the seconds each implementation takes for the IQM interval and for the probability-of-
improvement interval, both with ``--reps`` stratified bootstrap resamples (percentile intervals),
their point estimates and intervals side by side, and whether the same seed gave the same interval
twice. rliable's interval needs its ``library`` module and ``arch`` older than 8 (arch 8 no longer
takes the ``random_state`` rliable passes), and arch 7 does not import with pandas 3; where the peer
cannot run, its side says why instead of a figure. A virtual environment where it runs:

    python -m venv /tmp/rlenv && /tmp/rlenv/bin/pip install "pandas<3" "arch<8" rliable scipy
    PYTHONPATH=. /tmp/rlenv/bin/python benchmarks/aggregate_stats.py [--runs 10] [--tasks 8] [--reps 2000]
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from arena_league.rating.aggregate import iqm, probability_of_improvement, stratified_bootstrap_ci


def timed(fn):
    start = time.perf_counter()
    out = fn()
    return out, round(time.perf_counter() - start, 4)


def ours(x: np.ndarray, y: np.ndarray, reps: int, seed: int) -> dict:
    iqm_ci, iqm_s = timed(lambda: stratified_bootstrap_ci(x, iqm, reps=reps, rng=seed))
    poi_ci, poi_s = timed(lambda: stratified_bootstrap_ci((x, y), probability_of_improvement, reps=reps, rng=seed))
    again = stratified_bootstrap_ci((x, y), probability_of_improvement, reps=reps, rng=seed)
    return {"iqm": {"seconds": iqm_s, **iqm_ci.as_dict()},
            "probability_of_improvement": {"seconds": poi_s, **poi_ci.as_dict()},
            "same_seed_same_interval": (again.lower, again.upper) == (poi_ci.lower, poi_ci.upper)}


def peer(x: np.ndarray, y: np.ndarray, reps: int, seed: int) -> dict:
    try:
        from rliable import library, metrics
    except Exception as error:  # the peer is optional (arch may not import): say why it did not run
        return {"available": False, "why": f"{type(error).__name__}: {error}"}

    def poi_interval(state: int) -> tuple:
        point, ci = library.get_interval_estimates({"x,y": (x, y)}, metrics.probability_of_improvement,
                                                   reps=reps, random_state=np.random.RandomState(state))
        return point["x,y"], ci["x,y"]

    try:
        (iqm_point, iqm_ci), iqm_s = timed(lambda: library.get_interval_estimates(
            {"x": x}, metrics.aggregate_iqm, reps=reps, random_state=np.random.RandomState(seed)))
        (poi_point, poi_ci), poi_s = timed(lambda: poi_interval(seed))
        _, again = poi_interval(seed)
    except TypeError as error:  # arch 8 no longer takes random_state, which rliable passes
        return {"available": False, "why": f"{type(error).__name__}: {' '.join(str(error).split())}"}
    return {"available": True,
            "iqm": {"seconds": iqm_s, "point": float(iqm_point["x"]), "lower": float(np.ravel(iqm_ci["x"])[0]),
                    "upper": float(np.ravel(iqm_ci["x"])[1])},
            "probability_of_improvement": {"seconds": poi_s, "point": float(poi_point),
                                           "lower": float(np.ravel(poi_ci)[0]), "upper": float(np.ravel(poi_ci)[1])},
            "same_seed_same_interval": bool(np.array_equal(again, poi_ci))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--tasks", type=int, default=8)
    parser.add_argument("--reps", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    x = rng.beta(5, 3, size=(args.runs, args.tasks))
    y = rng.beta(4, 3, size=(args.runs, args.tasks))
    mine = ours(x, y, args.reps, args.seed)
    theirs = peer(x, y, args.reps, args.seed)
    speedup = {}
    if theirs.get("available"):
        speedup = {k: round(theirs[k]["seconds"] / max(mine[k]["seconds"], 1e-9), 1)
                   for k in ("iqm", "probability_of_improvement")}
    print(json.dumps({"benchmark": "aggregate_stats", "runs": args.runs, "tasks": args.tasks, "reps": args.reps,
                      "python": platform.python_version(), "arena_league": mine, "rliable": theirs,
                      "speedup": speedup}, indent=1))


if __name__ == "__main__":
    main()
