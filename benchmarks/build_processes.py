"""A population build's training and round robin in one process and side by side in several.

Builds the same small population (GoBang-2T1P-v1 by default: SP, PBT and D-PPO runs, then their
round robin) in fresh work folders, once per ``--processes`` count, and prints JSON: each stage's
seconds per count, the speed-up over one process, and whether every count saved the same round-robin
scores (``build_population(processes=N)`` promises that it does)::

    python benchmarks/build_processes.py [--game GoBang-2T1P-v1] [--steps 8192] [--processes 1 2]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import tempfile
from pathlib import Path

from arena_league.league.population.build import build_population


def build(game_id: str, steps: int, processes: int, work: Path) -> dict:
    report = build_population(game_id, size=8, name="bench", schemes=["sp", "pbt", "dppo"], steps_per_scheme=steps,
                              warm_runs_per_scheme=0, top_runs=[], snapshots=8, seed=0, work_dir=work,
                              matches_per_pair=1, processes=processes, stop_after="round_robin")
    digest = hashlib.sha256()
    for chunk in sorted(work.glob("matches/*/chunk-*.json")):
        digest.update(json.dumps(json.loads(chunk.read_text())["scores"]).encode())
    return {"train_s": report.seconds["train"], "round_robin_s": report.seconds["round_robin"],
            "matches": report.matches_played, "scores_sha256": digest.hexdigest()[:16]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--game", default="GoBang-2T1P-v1")
    parser.add_argument("--steps", type=int, default=8192, help="env steps per run")
    parser.add_argument("--processes", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    runs = {}
    with tempfile.TemporaryDirectory() as root:
        for n in args.processes:
            runs[n] = build(args.game, args.steps, n, Path(root) / f"p{n}")
    one = runs[min(runs)]
    print(json.dumps({
        "game": args.game, "steps_per_run": args.steps, "cpus": os.cpu_count(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "runs": {str(n): {**r, "train_speedup": round(one["train_s"] / max(r["train_s"], 1e-9), 2),
                          "round_robin_speedup": round(one["round_robin_s"] / max(r["round_robin_s"], 1e-9), 2)}
                 for n, r in runs.items()},
        "same_scores": len({r["scores_sha256"] for r in runs.values()}) == 1}, indent=1))


if __name__ == "__main__":
    main()
