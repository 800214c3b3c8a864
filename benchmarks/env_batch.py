"""Env steps/s of a rollout's K envs: K separate envs (``EnvList``) against the game's whole-array
engine (``EngineBatch``), for the games that have one.

Prints one JSON document. For each game, both batches of ``--envs`` envs (default 8, default social
tree and options) play the same random actions in one process, through the protocol a rollout
follows each step: read observations, acting seats (and masks, in games that mask), step, and for
every env whose episode ended read its result and reset it with the next seed. Actions are drawn
beforehand from a seeded generator (GoBang's: a random legal cell from the masks, picked outside the
timing), so only the batches' own calls are timed. Rates are env steps per wall-clock second (K per
batch step) and per CPU second of the process (all threads: the robot engine steps MuJoCo on a pool
of threads), the best of ``--repeats`` runs of ``--steps`` batch steps; both batches' rewards are
summed and compared, as a check that they played the same episodes.

For the engine batch the step is split in two: the engine's own step (boards or physics, batched)
and the social trees, evaluated once per env in a Python loop (``tree_us_per_env_step``, with its
share of the whole step), so the figures say what vectorising the trees could still win.

    PYTHONPATH=. python benchmarks/env_batch.py [--envs 8] [--steps 400] [--repeats 3]
                                                [--games Snake-2T2P-v1 GoBang-2T1P-v1 Sumo-2T1P-v1 ...]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

from arena_league.envs import make
from arena_league.training.engine_batch import EngineBatch
from arena_league.training.vector import EnvBatch, EnvList

GAMES = ("Snake-2T2P-v1", "GoBang-2T1P-v1", "Sumo-2T1P-v1", "RunToGoal-2T1P-v1")


def _play(batch: EnvBatch, steps: int, seed: int) -> tuple[float, float, float]:
    """``steps`` lockstep steps of ``batch`` with random actions; returns (wall seconds, CPU
    seconds, the sum of every reward) of the batch's own calls."""
    rng = np.random.default_rng(seed)
    seeds = np.random.default_rng(seed + 1)
    k, n = batch.n_envs, batch.n_agents
    if batch.discrete:
        actions = rng.integers(batch.n_actions, size=(steps, k, n))
        keys = rng.random((k, n, batch.n_actions)) if batch.masked else None
    else:
        actions = rng.uniform(-1.0, 1.0, (steps, k, n, batch.act_dim)).astype(np.float32)
        keys = None
    wall = cpu = 0.0
    total = 0.0
    for slot in range(k):
        batch.reset(slot, int(seeds.integers(2**32)))
    for step in range(steps):
        wall0, cpu0 = time.perf_counter(), time.process_time()
        batch.observations()
        batch.acting()
        masks = batch.action_masks()
        wall += time.perf_counter() - wall0
        cpu += time.process_time() - cpu0
        chosen = actions[step]
        if masks is not None:  # a random legal cell: the policy's part, not timed
            chosen = np.argmax(np.roll(keys, step, axis=2) * masks, axis=2)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        rewards, ended = batch.step(chosen)
        total += float(rewards.sum())
        for slot in np.flatnonzero(ended):
            batch.team_result(int(slot))
            batch.reset(int(slot), int(seeds.integers(2**32)))
        wall += time.perf_counter() - wall0
        cpu += time.process_time() - cpu0
    return wall, cpu, total


class _TreeClock:
    """Wall-clock seconds an engine batch spends in its social trees (wraps ``_evaluate_trees``)."""

    def __init__(self, batch: EngineBatch) -> None:
        self.seconds = 0.0
        evaluate = batch._evaluate_trees

        def timed(ended: np.ndarray) -> None:
            start = time.perf_counter()
            evaluate(ended)
            self.seconds += time.perf_counter() - start

        batch._evaluate_trees = timed  # type: ignore[method-assign]


def measure(game_id: str, n_envs: int, steps: int, repeats: int) -> dict:
    out: dict = {}
    sums = {}
    for name in ("env_list", "engine_batch"):
        best: dict = {}
        for repeat in range(repeats):
            if name == "env_list":
                batch: EnvBatch = EnvList([make(game_id) for _ in range(n_envs)])
                clock = None
            else:
                batch = EngineBatch(make(game_id), n_envs)
                clock = _TreeClock(batch)
            try:
                wall, cpu, total = _play(batch, steps, seed=repeat)
            finally:
                batch.close()
            sums.setdefault(repeat, []).append(total)
            rate = n_envs * steps / wall
            if rate > best.get("steps_per_s", 0.0):
                best = {"steps_per_s": round(rate, 1), "steps_per_cpu_s": round(n_envs * steps / cpu, 1),
                        "us_per_batch_step": round(1e6 * wall / steps, 1)}
                if clock is not None:
                    best["tree_us_per_env_step"] = round(1e6 * clock.seconds / (steps * n_envs), 2)
                    best["tree_share"] = round(clock.seconds / wall, 3)
        out[name] = best
    out["speedup"] = round(out["engine_batch"]["steps_per_s"] / out["env_list"]["steps_per_s"], 2)
    out["same_rewards"] = all(a == b for a, b in sums.values())
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=8, help="envs per batch (K)")
    parser.add_argument("--steps", type=int, default=400, help="batch steps per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs per figure; the best is kept")
    parser.add_argument("--games", nargs="+", default=list(GAMES), help="game ids with a whole-array engine")
    args = parser.parse_args(argv)
    if args.envs < 1 or args.steps < 1 or args.repeats < 1:
        print("--envs, --steps and --repeats must be positive integers", file=sys.stderr)
        return 2
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    report = {"benchmark": "env_batch", "envs": args.envs, "steps": args.steps, "repeats": args.repeats,
              "cpus_usable": cpus, "load_average": [round(x, 2) for x in os.getloadavg()],
              "python": platform.python_version(), "games": {}}
    for game_id in args.games:
        try:
            probe = make(game_id)
        except ValueError as exc:
            print(exc, file=sys.stderr)
            return 2
        if type(probe.rules).batched_matches is None:
            print(f"{game_id} has no whole-array engine; games with one: {', '.join(GAMES)}", file=sys.stderr)
            return 2
        report["games"][game_id] = measure(game_id, args.envs, args.steps, args.repeats)
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
