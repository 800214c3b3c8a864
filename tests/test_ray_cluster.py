"""Matches and population builds on a real Ray cluster of two nodes on this machine
(:mod:`ray_cluster`): the same results as in this process, the work spread over both nodes, and no
process of the cluster left once it is stopped."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pytest
from cli_helpers import run
from ray_cluster import (
    JOB_EXCLUDES,
    NodeRecording,
    count_setup,
    fail,
    ray_cluster,
    ray_executable,
    where_and_setups,
)
from test_league_experiments import _without_timings
from test_league_worker_backends import _evaluated

from arena_league.league import (
    agent_rows,
    ensure_scripted_agents,
    job_detail,
    job_rows,
    open_home,
    queue_evaluation,
    recent_matches,
    run_worker,
)
from arena_league.league.population import round_robin as round_robin_module
from arena_league.league.population import runs as runs_module
from arena_league.league.population.processes import run_tasks
from arena_league.league.population.records import REFERENCES
from arena_league.matchmaking import AgentRef, play_matches, round_robin, specs_for_seatings
from arena_league.matchmaking.cluster import NODE_IP, NODE_IP_VARIABLE, PACKAGE_ROOT

pytest_plugins = ["cli_helpers", "registry_fixtures"]  # the home and pg_url fixtures

ray = pytest.importorskip("ray", reason="the Ray cluster tests need Ray (pip install 'arena-league[ray]')")
if ray_executable() is None:
    pytest.skip("Ray's `ray` command is not installed", allow_module_level=True)

RECORDED = Path(__file__).parent / "data" / "population_build_crossroads_size8.json"
GOBANG = "GoBang-2T1P-v1"
#: The checkout a Ray job is sent from (its working folder).
CHECKOUT = PACKAGE_ROOT


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    with ray_cluster(tmp_path_factory.mktemp("ray-logs"), dashboard=True) as running:
        yield running
    assert running.left() == []


@pytest.fixture
def joined(cluster, monkeypatch):
    """The cluster, with this process set to join it (its token and node address); Ray is shut
    down in this process after the test."""
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    for name, value in cluster.env.items():
        monkeypatch.setenv(name, value)
    yield cluster
    ray.shutdown()


def test_play_matches_on_two_nodes_gives_the_in_process_results(joined):
    game = "GoBang-2T1P-v1"
    agents = {name: AgentRef("scripted", name, game) for name in ("random", "heuristic")}
    specs = specs_for_seatings(game, round_robin(list(agents), 6), league_seed=11)
    expected = play_matches(specs, agents)
    # a worker process on each node first: matches of a few milliseconds could otherwise all be
    # played on the head while the other node is still starting its worker (seen on a busy machine)
    warm = []
    run_tasks(dict.fromkeys(range(4), (where_and_setups, ("warm", 0.5))), lambda key, found: warm.append(found[0]),
              backend="ray", address=joined.address)
    assert len(set(warm)) == 2
    results = play_matches(specs, agents, backend="ray", ray_address=joined.address, chunk_size=1, batch_size=1,
                           recording=NodeRecording())
    assert [r.without_replay() for r in results] == expected
    nodes = {n["NodeID"] for n in ray.nodes() if n["Alive"]}
    assert len(nodes) == 2 and {r.replay_path for r in results} == nodes  # every match says where it was played


def test_ray_tasks_run_the_initializer_once_per_worker_process(joined):
    finished = []
    run_tasks(dict.fromkeys(range(8), (where_and_setups, ("build", 0.5))),
              lambda key, result: finished.append((key, result)), backend="ray", address=joined.address,
              initializer=count_setup, initargs=("build",))
    assert sorted(key for key, _ in finished) == list(range(8))
    assert all(setups == 1 for _, (_, _, setups) in finished)  # per process, however many tasks it ran
    assert len({node for _, (node, _, _) in finished}) == 2
    assert len({pid for _, (_, pid, _) in finished}) < 8  # worker processes ran several tasks each


def test_a_failing_ray_task_fails_the_call_and_the_others_are_cancelled(joined):
    # one task per CPU, the slow one running when the other fails: Ray can lose a cancel that
    # reaches a task as it is dispatched (processes.py says so), which a queued task would race
    tasks = {"slow": (where_and_setups, ("x", 600.0)), "bad": (fail, ("bad seed", 2.0))}
    with pytest.raises(ValueError, match="bad seed"):
        run_tasks(tasks, lambda key, result: None, backend="ray", address=joined.address)
    # the cancelled tasks give their CPUs back (not cancelled, they would hold them for ten minutes)
    deadline = time.monotonic() + 120
    while ray.available_resources().get("CPU", 0) < 2 and time.monotonic() < deadline:
        time.sleep(0.5)
    assert ray.available_resources().get("CPU", 0) == 2


def test_a_round_robin_interrupted_on_ray_resumes_here_with_the_same_scores(joined, tmp_path, monkeypatch):
    """Chunks played as Ray tasks are saved here as they come back: interrupted after the first,
    the round robin resumes from its work folder in this process and scores as one process does."""
    monkeypatch.setattr(round_robin_module, "CHUNK_MATCHES", 4)
    game = "GoBang-2T1P-v1"
    schedule = round_robin_module.Schedule(game, list(REFERENCES), 12, seed=3)
    policies = round_robin_module.round_robin_policies(game, [])

    def interrupt(stage, done, total):
        raise KeyboardInterrupt

    def play(work, progress=None, **where):
        report = SimpleNamespace(matches_played=0, matches_reused=0)
        table = schedule.play(work, policies, 4, report, progress, lambda line: None, **where)
        return table, report

    with pytest.raises(KeyboardInterrupt):
        play(tmp_path / "work", interrupt, backend="ray", address=joined.address)
    assert len(list((tmp_path / "work" / "matches").glob("*/chunk-*.json"))) == 1
    resumed, report = play(tmp_path / "work")
    assert (report.matches_reused, report.matches_played) == (4, 8)
    alone, _ = play(tmp_path / "alone")
    assert resumed.tolist() == alone.tolist()


def test_an_experiment_on_two_nodes_gives_the_report_of_runs_here(joined, capsys, tmp_path):
    """The baselines' runs trained and placed as Ray tasks: the report of the same runs trained here."""
    argv = ["experiment", "baselines", "Crossroads-2T2P-v1", "--methods", "dppo", "--seeds", "0", "1",
            "--steps", "1024", "--checkpoints", "2", "--budget", "2", "--max-cycles", "40", "--json"]
    code, here, err = run(capsys, *argv, "--out", tmp_path / "here")
    assert code == 0, err
    code, on_ray, err = run(capsys, *argv, "--out", tmp_path / "ray", "--backend", "ray", "--address", joined.address)
    assert code == 0, err
    assert _without_timings(on_ray) == _without_timings(here)


def test_a_worker_on_two_nodes_stores_what_an_in_process_worker_stores(joined, tmp_path):
    here = _evaluated(tmp_path / "here")
    on_ray = _evaluated(tmp_path / "ray", backend="ray", address=joined.address)
    assert len(here) == 6 and on_ray == here


def test_a_submitted_agent_plays_in_the_sandbox_on_the_nodes(joined, tmp_path):
    """A submitted agent whose graph fails in onnxruntime, played by a Ray worker: its matches are
    forfeits recorded with the sandbox's reason, and it is suspended, as a worker here does."""
    import hostile_agents as hostile
    from test_league_hostile_inference import register_unvalidated

    outcomes = {}
    for label, worker in (("here", {}), ("ray", {"backend": "ray", "address": joined.address})):
        home = tmp_path / label
        register_unvalidated(home, hostile.save(hostile.failing(GOBANG), tmp_path / "bad.onnx"), GOBANG, "bad")
        with open_home(home) as league:
            agents = [*ensure_scripted_agents(league, GOBANG), "bad"]
            job = queue_evaluation(league, GOBANG, agents, matches_per_pair=4, seed=3)
            summary = run_worker(league, until_idle=True, **worker)
            assert summary.completed == 1 and summary.failed == 0
            result = job_detail(league, job)["result"]
            status = {a["name"]: a["status"] for a in agent_rows(league, GOBANG)}
        assert set(result["suspended"]) == {"bad"} and status["bad"] == "suspended"
        assert result["forfeits"]["bad"] >= 3 and "onnxruntime failed" in result["suspended"]["bad"]
        outcomes[label] = {k: v for k, v in result.items() if k != "seconds"}
    assert outcomes["ray"] == outcomes["here"]


@pytest.mark.postgres
def test_two_ray_workers_share_one_postgresql_league(cluster, pg_url, tmp_path):
    """Two worker processes, each a driver of the cluster, take the queued evaluations of one
    PostgreSQL league between them: each job once, each match stored once, and the matches those
    of a worker here."""
    jobs = [("GoBang-2T1P-v1", 1), ("GoBang-2T2P-v1", 2), ("Snake-2T1P-v1", 3), ("Snake-2T2P-v1", 4)]

    def queue(league) -> None:
        for game, seed in jobs:
            queue_evaluation(league, game, ensure_scripted_agents(league, game), matches_per_pair=2, seed=seed)

    home = tmp_path / "shared"
    with open_home(home, pg_url) as league:
        queue(league)
    env = {**os.environ, **cluster.env, "ARENA_LEAGUE_HOME": str(home), "ARENA_LEAGUE_DB": pg_url}
    env.pop("RAY_ADDRESS", None)
    workers = [subprocess.Popen([sys.executable, "-m", "arena_league.cli", "worker", "--backend", "ray", "--address",
                                 cluster.address, "--max-jobs", "2", "--poll", "0.2", "--json"], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    try:
        summaries = []
        for worker in workers:
            out, err = worker.communicate(timeout=600)
            assert worker.returncode == 0, err
            summaries.append(json.loads(out))
    finally:
        for worker in workers:
            if worker.poll() is None:
                worker.kill()
    assert [(s["completed"], s["failed"]) for s in summaries] == [(2, 0), (2, 0)]  # two jobs each

    with open_home(tmp_path / "alone") as league:
        queue(league)
        assert run_worker(league, until_idle=True).completed == 4
        alone = {game: _stored(league, game) for game, _ in jobs}
    with open_home(home, pg_url) as league:
        shared = {game: _stored(league, game) for game, _ in jobs}
        assert [job["status"] for job in job_rows(league)] == ["done"] * len(jobs)
    assert shared == alone
    assert all(len(keys) == len(set(keys)) for keys in ([m[0] for m in ms] for ms in shared.values()))


def _stored(league, game: str) -> list[tuple]:
    return sorted((m["match_key"], m["seed"], tuple((s["agent"], s["outcome"]) for s in m["seats"]))
                  for m in recent_matches(league, game, limit=1000))


@pytest.mark.slow
def test_a_build_stopped_on_ray_resumes_as_a_ray_job_and_freezes_the_recorded_population(
        joined, capsys, home, tmp_path, monkeypatch):
    """Each training run saves its snapshots in the work folder as its Ray task ends. A build
    interrupted once its first run is back is sent again with ``ray job submit``, the checkout as its
    working folder (as the docs give it): the job reads the finished runs back, plays what is left as
    Ray tasks, and freezes the population recorded in one process."""
    recorded = json.loads(RECORDED.read_text())
    folders = ["--work-dir", str(tmp_path / "work"), "--out-dir", str(tmp_path / "out")]
    real_run_tasks = runs_module.run_tasks

    def interrupted_after_the_first(tasks, done, **where):
        def first_then_stop(key, result):
            done(key, result)
            raise KeyboardInterrupt
        real_run_tasks(tasks, first_then_stop, **where)

    monkeypatch.setattr(runs_module, "run_tasks", interrupted_after_the_first)
    code, _, err = run(capsys, *recorded["argv"], *folders, "--backend", "ray", "--address", joined.address)
    assert code == 130 and "interrupted" in err
    assert not (tmp_path / "out" / "population.json").exists()
    ray.shutdown()  # the job is the cluster's next driver

    runtime_env = {"excludes": JOB_EXCLUDES, "env_vars": {"ARENA_LEAGUE_HOME": str(home), NODE_IP_VARIABLE: NODE_IP}}
    command = [ray_executable(), "job", "submit", "--address", joined.dashboard, "--working-dir", str(CHECKOUT),
               "--runtime-env-json", json.dumps(runtime_env), "--", sys.executable, "-m", "arena_league.cli",
               *recorded["argv"], *folders, "--backend", "ray"]
    env = {**os.environ, **joined.env}
    env.pop("RAY_ADDRESS", None)
    # a head just started answers before its job agent has joined; such a refusal makes no job
    deadline = time.monotonic() + 120
    while True:
        submitted = subprocess.run(command, env=env, capture_output=True, text=True, timeout=900, check=False)
        if "No available agent to submit job" not in submitted.stderr or time.monotonic() > deadline:
            break
        time.sleep(2.0)
    logs = " ".join((submitted.stdout + submitted.stderr).split())  # the job's console wraps its lines
    assert submitted.returncode == 0 and "succeeded" in logs, submitted.stdout[-6000:] + submitted.stderr[-1000:]
    # the run back before the stop is read back (the other may have ended in the same moment, before
    # its cancel reached it); what is left, the round robin at least, runs as Ray tasks
    assert "(finished run: reading it back)" in logs and "as Ray tasks" in logs, submitted.stdout[-6000:]
    built = json.loads((tmp_path / "out" / "population.json").read_text())
    assert built["provenance"]["build"].pop("code")
    assert built == recorded["population"]
