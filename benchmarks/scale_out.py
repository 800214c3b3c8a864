"""A league's expensive work on one process, a process pool and Ray clusters of one and two nodes.

Prints one JSON document with two parts, measured in the same run:

* **round robin**: the base population of Crossroads-2T2P-v1 (its first ``--agents`` members, 100 by
  default) plays every pair ``--matches-per-pair`` times (10: 49,500 matches) with each backend of
  :func:`arena_league.matchmaking.play_matches`: in process, a process pool of 2 workers, and Ray on
  a local cluster of one node and of two (one CPU each, started and ended by this script). Each row
  gives the seconds, matches per second, the speed-up over one process, and whether its results equal
  the in-process ones (they must: a match's result depends on its spec and agents only).
* **population build**: the same ``--build-size`` build (16 members by default; four training runs,
  SP and D-PPO with two seeds each, at ``--build-steps`` env steps each) in one process and on the two-node cluster; each stage's seconds,
  the training phase's speed-up, and whether the frozen populations are identical.

From the per-match and per-run costs it also projects, naming the assumptions in ``projection``,
what a 100-agent build, the full round robin and the paper's experiments at 10 million steps per
run would take on 16, 64 and 256 CPUs.

    PYTHONPATH=. python benchmarks/scale_out.py [--agents 100] [--matches-per-pair 10]
                                                [--build-size 16] [--build-steps 131072] [--skip-build]
                                                [--backends inprocess pool ray1 ray2]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from arena_league.matchmaking import AgentRef, play_matches, round_robin, specs_for_seatings
from arena_league.policies.threads import torch_threads

GAME = "Crossroads-2T2P-v1"
POPULATION = Path(__file__).resolve().parents[1] / "checkpoints" / GAME / "base-v1"


def member_refs(count: int) -> dict[str, AgentRef]:
    """The first ``count`` members of the shipped population, as references any process loads."""
    manifest = json.loads((POPULATION / "population.json").read_text())
    members = manifest["members"][:count]
    return {m["name"]: AgentRef("arena-policy", str(POPULATION / m["artifact"]), GAME) for m in members}


@contextlib.contextmanager
def ray_nodes(nodes: int, log_dir: Path) -> Iterator[str]:
    """A local Ray cluster of ``nodes`` one-CPU nodes, joined by this process for the block."""
    import ray

    from arena_league.matchmaking.cluster import local_cluster

    with local_cluster(log_dir, nodes=nodes) as cluster:
        saved = {key: os.environ.get(key) for key in cluster.env}
        os.environ.update(cluster.env)
        try:
            yield cluster.address
        finally:
            ray.shutdown()
            for key, value in saved.items():
                if value is None:
                    os.environ.pop(key, None)
                else:
                    os.environ[key] = value


def time_round_robin(specs: list, refs: dict[str, AgentRef], **options) -> tuple[float, list]:
    start = time.perf_counter()
    results = play_matches(specs, refs, **options)
    return time.perf_counter() - start, [r.without_replay() for r in results]


#: The round robin's backends, by the name ``--backends`` takes, and each row's label.
BACKENDS = {"inprocess": "in process (1 CPU)", "pool": "process pool (2 workers)",
            "ray1": "ray, 1 node (1 CPU each)", "ray2": "ray, 2 nodes (1 CPU each)"}


def round_robin_part(agents: int, matches_per_pair: int, log_dir: Path, backends: list[str]) -> dict:
    refs = member_refs(agents)
    seatings = round_robin(list(refs), matches_per_pair)
    specs = specs_for_seatings(GAME, seatings, league_seed=0)
    rows, played = {}, {}
    for backend in backends:
        label = BACKENDS[backend]
        if backend == "inprocess":
            # one torch thread, as the league's worker and every pool or Ray worker play: the batched
            # forwards are small, and a second thread's hand-offs cost more than it computes
            with torch_threads(1):
                rows[label], played[label] = time_round_robin(specs, refs, backend="inprocess")
        elif backend == "pool":
            rows[label], played[label] = time_round_robin(specs, refs, backend="process", workers=2)
        else:
            with ray_nodes(int(backend[-1]), log_dir / backend) as address:
                rows[label], played[label] = time_round_robin(specs, refs, backend="ray", ray_address=address)
    # every row against the first one run (a match's result depends on its spec and agents only)
    reference = played[BACKENDS[backends[0]]]
    one = rows.get(BACKENDS["inprocess"])
    out = {
        "agents": agents, "matches_per_pair": matches_per_pair, "matches": len(specs),
        "mean_steps_per_match": round(sum(r.steps for r in reference) / len(reference), 1),
        "backends": {label: {"seconds": round(s, 1), "matches_per_second": round(len(specs) / s, 1),
                             **({"speedup_over_one_process": round(one / s, 2)} if one else {}),
                             "same_results": played[label] == reference}
                     for label, s in rows.items()},
    }
    ray_one, ray_two, pool = (rows.get(BACKENDS[b]) for b in ("ray1", "ray2", "pool"))
    if ray_one and ray_two:
        out["ray_two_nodes_over_one"] = round(ray_one / ray_two, 2)
    if ray_two and pool:
        out["ray_overhead_over_pool_same_cores"] = round(ray_two / pool - 1.0, 3)
    # the faster of the one-CPU runs: the in-process one also pays for this process's other threads
    one_cpu = [t for t in (one, ray_one) if t]
    if one_cpu:
        out["seconds_per_match_one_cpu"] = round(min(one_cpu) / len(specs), 5)
    return out


#: The build's training runs: two schemes, two seeds each, so that two nodes can share them evenly.
BUILD_SCHEMES, BUILD_RUNS_PER_SCHEME = ("sp", "dppo"), 2


def build_part(size: int, steps: int, log_dir: Path) -> dict:
    from arena_league.league.population.build import build_population

    def build(work: Path, out: Path, **backend) -> tuple[dict, dict]:
        report = build_population(GAME, size=size, name="bench", schemes=list(BUILD_SCHEMES),
                                  runs_per_scheme=BUILD_RUNS_PER_SCHEME, steps_per_scheme=steps, warm_runs_per_scheme=0,
                                  top_runs=[], snapshots=8, seed=0,
                                  work_dir=work, out_dir=out, matches_per_pair=1, **backend)
        manifest = json.loads((out / "population.json").read_text())
        manifest["provenance"]["build"].pop("code", None)
        return report.seconds, {"members": manifest["members"], "figures": manifest["provenance"]["figures"]}

    local_seconds, local = build(log_dir / "work-local", log_dir / "out-local", processes=1)
    with ray_nodes(2, log_dir / "build2") as address:
        ray_seconds, on_ray = build(log_dir / "work-ray", log_dir / "out-ray", processes=2, backend="ray",
                                    ray_address=address)
    return {
        "size": size, "steps_per_run": steps, "runs": len(BUILD_SCHEMES) * BUILD_RUNS_PER_SCHEME,
        "one_process_seconds": local_seconds, "ray_two_nodes_seconds": ray_seconds,
        "training_speedup": round(local_seconds["train"] / max(ray_seconds["train"], 1e-9), 2),
        "round_robin_speedup": round(local_seconds["round_robin"] / max(ray_seconds["round_robin"], 1e-9), 2),
        "same_population": local == on_ray,
    }


def projection(round_robin: dict, build: dict | None) -> dict | None:
    """Wall time on C CPUs from the measured one-CPU costs, assuming perfect spreading over the CPUs
    up to the number of independent tasks (matches in chunks of 256; one training run per CPU),
    no overhead, and the same CPU speed as here."""
    per_match = round_robin.get("seconds_per_match_one_cpu")
    if per_match is None:
        return None  # no one-CPU row was run
    full_round_robin = 100 * 99 // 2 * 10
    out = {"assumptions": projection.__doc__.split("\n\n")[0].replace("\n    ", " "),
           "seconds_per_match_one_cpu": per_match}
    build_round_robin = 245 * 244 // 2 * 2  # a 100-agent build: about 245 candidates, 2 matches per pair
    if build is not None:
        per_step = build["one_process_seconds"]["train"] / (build["runs"] * build["steps_per_run"])
        out["seconds_per_env_step_one_cpu"] = round(per_step, 7)
    else:
        per_step = None
    for cpus in (16, 64, 256):
        row = {"full_round_robin_100x100x10_minutes": round(per_match * full_round_robin / cpus / 60, 1),
               "build_round_robin_minutes": round(per_match * build_round_robin / cpus / 60, 1)}
        if per_step is not None:
            # a 100-agent build's training: 18 runs of about 90,000 env steps (the ant recipe) run side by side
            row["build_training_minutes"] = round(per_step * 90_000 * max(1, -(-18 // cpus)) / 60, 1)
            # the paper's experiments at 10 M steps per run: 12 social-study runs and 20 baseline runs
            row["experiments_10M_hours"] = round(per_step * 10_000_000 * -(-32 // min(cpus, 32)) / 3600, 1)
        out[f"{cpus}_cpus"] = row
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--agents", type=int, default=100, help="population members in the round robin")
    parser.add_argument("--matches-per-pair", type=int, default=10)
    parser.add_argument("--build-size", type=int, default=16)
    parser.add_argument("--build-steps", type=int, default=131_072, help="env steps of each build run")
    parser.add_argument("--skip-build", action="store_true", help="the round robin only")
    parser.add_argument("--backends", nargs="+", choices=list(BACKENDS), default=list(BACKENDS),
                        help="the round robin's backends, in this order (default: all four)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="scale-") as root:
        rr = round_robin_part(args.agents, args.matches_per_pair, Path(root), args.backends)
        print(json.dumps({"round_robin": rr}), file=sys.stderr, flush=True)  # kept should the build part fail
        build = None if args.skip_build else build_part(args.build_size, args.build_steps, Path(root))
    print(json.dumps({
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": sys.platform,
                    "load_average": [round(x, 2) for x in os.getloadavg()]},
        "game": GAME, "round_robin": rr, "population_build": build, "projection": projection(rr, build),
    }, indent=1))


if __name__ == "__main__":
    main()
