"""``arena-league train`` end to end at its defaults: how much of the run its evaluations take.

Prints one JSON document. Each mode runs in a fresh process, so imports and start-up count:

* ``training_only``: the scheme's training alone (:func:`~arena_league.training.run_scheme`, no
  evaluation, no plots): what the command cannot go below.
* ``background``: ``arena-league train GAME --scheme S --steps N`` (its evaluations in a background
  process while training goes on, the default on a machine with more than one core).
* ``inline``: the same with ``--eval-inline`` (every evaluation played between two iterations).

For the two command modes it also gives the report's ``timing`` (the evaluations' play and its CPU
time, the time training waited for them and its share of the run); ``training_only`` gives its CPU
time too, so the evaluations' CPU time can be set beside the training's. The machine's load average is printed before
and after: on a shared machine, compare modes of one document only.

    PYTHONPATH=. python benchmarks/train_evaluation.py [--game Crossroads-2T2P-v1] [--scheme dppo]
        [--steps 100000] [--modes training_only background inline]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

MODES = ("training_only", "background", "inline")

TRAINING_ONLY = """
import sys
from arena_league.training import run_scheme
game, scheme, steps, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
run_scheme(scheme, game, steps=steps, seed=0, snapshot_every=None, out_dir=out)
"""


def run_mode(mode: str, game: str, scheme: str, steps: int) -> dict:
    env = {**os.environ, "PYTHONPATH": os.getcwd() + os.pathsep + os.environ.get("PYTHONPATH", "")}
    with tempfile.TemporaryDirectory(prefix="bench-train-") as work:
        if mode == "training_only":
            command = [sys.executable, "-c", TRAINING_ONLY, game, scheme, str(steps), work]
        else:
            command = [sys.executable, "-m", "arena_league.cli", "train", game, "--scheme", scheme, "--steps",
                       str(steps), "--home", work, "--json"] + (["--eval-inline"] if mode == "inline" else [])
        started, cpu = time.perf_counter(), _children_cpu()
        done = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
        seconds, cpu = time.perf_counter() - started, _children_cpu() - cpu
    if done.returncode != 0:
        raise SystemExit(f"{mode} failed:\n{done.stderr[-2000:]}")
    out = {"seconds": round(seconds, 2)}
    if mode == "training_only":  # CPU time, which other loads on the machine do not inflate as much
        out["cpu_seconds"] = round(cpu, 2)
    else:
        report = json.loads(done.stdout)
        out["env_steps"] = report["env_steps"]
        out["timing"] = report["timing"]
        out["evaluations"] = [{"env_steps": e["env_steps"], "population_performance": e["population_performance"],
                               "eval_seconds": e["eval_seconds"]} for e in report["evaluations"]]
    return out


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--game", default="Crossroads-2T2P-v1")
    parser.add_argument("--scheme", default="dppo")
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES))
    args = parser.parse_args()
    document: dict = {"game": args.game, "scheme": args.scheme, "steps": args.steps, "cores": os.cpu_count(),
                      "load_before": os.getloadavg()[0]}
    for mode in args.modes:
        document[mode] = run_mode(mode, args.game, args.scheme, args.steps)
        document[mode]["env_steps_per_s"] = round(args.steps / document[mode]["seconds"])
    base = document.get("training_only", {}).get("seconds")
    for mode in ("background", "inline"):
        if base and mode in document:
            document[mode]["over_training_only"] = round(document[mode]["seconds"] / base - 1, 3)
    document["load_after"] = os.getloadavg()[0]
    print(json.dumps(document, indent=1))


if __name__ == "__main__":
    main()
