"""Fair queues: how long one owner's placement waits behind another owner's burst. Prints one JSON
document.

The league: a fresh home (SQLite file) with Crossroads-2T2P-v1's two scripted agents frozen as the
population ``scripted:1`` and the example submission registered as owner B's agent. Two real
``arena-league worker`` processes run. Owner A queues ``--burst`` tree verifications (the case
study's tree, ``--samples`` paired samples each) through the league's operations as the web does
(``queue_verify`` with A's identity; ``jobs.live_per_owner`` is raised for A's burst, which the
default quota of 10 would refuse, so this measures the claim alone); once both workers run A's
jobs, owner B queues a placement of its agent (``queue_rank``, ``--budget`` matches against
``scripted:1``). B's job is timed from queueing to start and to finish, from its row (the
workers' clocks); then A's remaining jobs are cancelled and the workers stopped.

Figures, side by side:

* ``fair``: B's wait to start and to finish, as measured with the fair claim;
* ``fifo``: the same under the first-in-first-out claim the queue had before, computed from A's
  measured job lengths: two workers take A's jobs in order (each job as long as the measured one
  it stands for, in turn), B's placement starts when a worker is free after the last of them, and
  runs as long as it ran here;
* ``verify_job_s``: A's job lengths (median, min, max, how many ran);
* ``claim_ms``: the cost of one claim with 1,000 jobs queued by 10 owners (median of 200 claims,
  each leaving its job running), and the fair and FIFO orders' candidate SELECT alone (median of
  200) in the same queue.

    python benchmarks/fairness.py [--burst 300] [--samples 4] [--budget 20]
"""

from __future__ import annotations

import argparse
import heapq
import json
import os
import platform
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from itertools import cycle
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sqlalchemy import and_, select

from arena_league import registry as reg
from arena_league.envs.games.crossroads import CASE_STUDY_TREES
from arena_league.league import (
    Identity,
    cancel_job,
    ensure_scripted_agents,
    open_home,
    queue_rank,
    queue_verify,
    set_setting,
    submit,
)
from arena_league.registry.jobs import _fair_order
from arena_league.registry.models import Job, JobStatus, utcnow

GAME = "Crossroads-2T2P-v1"
EXAMPLE = Path(__file__).resolve().parents[1] / "submissions" / "crossroads-2t2p-mlp.onnx"
A, B = Identity("owner-a"), Identity("owner-b")
WORKERS = 2


def build_league(home: Path, burst: int) -> None:
    """The league of the module docstring, before any job is queued."""
    with open_home(home) as league:
        names = ensure_scripted_agents(league, GAME)
        with league.transaction() as session:
            population = reg.create_population(session, "scripted", GAME, provenance={"made_by": "benchmark"})
            for name, rating in zip(names, (900.0, 1100.0), strict=True):
                reg.add_population_member(session, population, reg.get_agent(session, name), {"rating": rating})
            reg.freeze_population(session, population)
        submit(league, EXAMPLE, GAME, "entrant", owner=B.owner)
        set_setting(league, "jobs.live_per_owner", burst + 10)


def start_workers(home: Path) -> list[subprocess.Popen]:
    log = open(home.parent / "workers.log", "w")  # noqa: SIM115 - the workers' output, read after the run
    return [subprocess.Popen([sys.executable, "-m", "arena_league.cli", "worker", "--home", str(home), "--poll", "0.2",
                              "--worker-id", f"bench-{i}"], stdout=log, stderr=subprocess.STDOUT)
            for i in range(WORKERS)]


def job_rows(home: Path) -> list[Job]:
    with open_home(home) as league, league.reading() as session:
        rows = reg.list_jobs(session)
        session.expunge_all()
        return rows


def wait_for(condition, seconds: float, what: str) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what} did not happen within {seconds:.0f} s")
        time.sleep(0.1)


def fifo_start(lengths: list[float], burst: int, b_queued_after: float) -> float:
    """When B's job would start under FIFO, seconds after B queued it: WORKERS workers take A's
    ``burst`` jobs in order (lengths cycled from those measured) from time 0; B queued at
    ``b_queued_after``."""
    free = [0.0] * WORKERS
    for length in (length for length, _ in zip(cycle(lengths), range(burst), strict=False)):
        heapq.heappush(free, heapq.heappop(free) + length)
    return max(min(free), b_queued_after) - b_queued_after


def measure_fairness(burst: int, samples: int, budget: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="fairness-") as folder:
        home = Path(folder) / "home"
        build_league(home, burst)
        workers = start_workers(home)
        try:
            with open_home(home) as league:
                started = time.time()
                a_jobs = [queue_verify(league, GAME, CASE_STUDY_TREES["CL_under_CP"], samples=samples, seed=i, who=A)
                          for i in range(burst)]
                burst_queued_s = time.time() - started

                def both_busy() -> bool:
                    return sum(j.status == JobStatus.RUNNING.value for j in job_rows(home)) == WORKERS

                wait_for(both_busy, 300, "both workers running owner A's jobs")
                b_queued_after = time.time() - started
                b_job = queue_rank(league, "entrant", budget=budget, population="scripted:1", who=B)
                wait_for(lambda: next(j for j in job_rows(home) if j.id == b_job).finished_at is not None, 900,
                         "owner B's placement to finish")
                wait_for(lambda: sum(j.status == JobStatus.DONE.value and j.kind == "verify"
                                     for j in job_rows(home)) >= 10, 300, "ten of A's jobs to finish")
                for job_id in a_jobs:
                    if next(j for j in job_rows(home) if j.id == job_id).finished_at is None:
                        cancel_job(league, job_id)
        finally:
            for worker in workers:
                worker.send_signal(signal.SIGINT)
            for worker in workers:
                try:
                    worker.wait(timeout=60)
                except subprocess.TimeoutExpired:
                    worker.kill()
                    worker.wait()
        rows = {j.id: j for j in job_rows(home)}
        b = rows[b_job]
        lengths = [(j.finished_at - j.started_at).total_seconds() for j in rows.values()
                   if j.kind == "verify" and j.status == JobStatus.DONE.value]
        b_start = (b.started_at - b.created_at).total_seconds()
        b_run = (b.finished_at - b.started_at).total_seconds()
        fifo_wait = fifo_start(lengths, burst, b_queued_after)
        return {
            "burst": burst, "samples": samples, "budget": budget, "workers": WORKERS,
            "burst_queued_s": round(burst_queued_s, 2), "b_status": b.status,
            "verify_job_s": {"median": round(statistics.median(lengths), 2), "min": round(min(lengths), 2),
                             "max": round(max(lengths), 2), "ran": len(lengths)},
            "fair": {"b_wait_to_start_s": round(b_start, 2), "b_wait_to_finish_s": round(b_start + b_run, 2)},
            "fifo": {"b_wait_to_start_s": round(fifo_wait, 1), "b_wait_to_finish_s": round(fifo_wait + b_run, 1)},
        }


def measure_claims(queued: int = 1000, owners: int = 10, claims: int = 200) -> dict:
    with tempfile.TemporaryDirectory(prefix="claims-") as folder, open_home(Path(folder) / "home") as league:
        with league.transaction() as session:
            for i in range(queued):
                reg.enqueue(session, "verify", {"n": i}, priority=60, owner=f"owner-{i % owners}")
        due = and_(Job.status == JobStatus.QUEUED.value, Job.run_after <= utcnow())
        orders = {"fair": [Job.priority.desc(), *_fair_order(), Job.id], "fifo": [Job.priority.desc(), Job.id]}
        selects = {}
        for name, order in orders.items():
            spent = []
            for _ in range(claims):
                with league.reading() as session:
                    moment = time.perf_counter()
                    session.execute(select(Job.id).where(due).order_by(*order).limit(1)).scalar()
                    spent.append((time.perf_counter() - moment) * 1000)
            selects[name] = round(statistics.median(spent), 3)
        spent = []
        for i in range(claims):
            moment = time.perf_counter()
            reg.claim_job(league, f"w{i}")
            spent.append((time.perf_counter() - moment) * 1000)
        return {"queued": queued, "owners": owners, "claim_median_ms": round(statistics.median(spent), 3),
                "select_median_ms": selects}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--burst", type=int, default=300, help="owner A's verification jobs (default 300)")
    parser.add_argument("--samples", type=int, default=4, help="paired samples per verification (default 4)")
    parser.add_argument("--budget", type=int, default=20, help="owner B's placement budget in matches (default 20)")
    args = parser.parse_args()
    report = {"python": platform.python_version(), "cpus": os.cpu_count(),
              "claims": measure_claims(), **measure_fairness(args.burst, args.samples, args.budget)}
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
