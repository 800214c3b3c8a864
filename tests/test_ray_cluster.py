"""Matches and population builds on a real Ray cluster of two nodes on this machine
(:mod:`ray_cluster`): the same results as in this process, the work spread over both nodes, and no
process of the cluster left once it is stopped."""

from __future__ import annotations

import json
import time
from pathlib import Path
from types import SimpleNamespace

import pytest
from cli_helpers import run
from ray_cluster import NodeRecording, count_setup, fail, ray_cluster, ray_executable, where_and_setups

from arena_league.league.population import round_robin as round_robin_module
from arena_league.league.population.processes import run_tasks
from arena_league.league.population.records import REFERENCES
from arena_league.matchmaking import AgentRef, play_matches, round_robin, specs_for_seatings

pytest_plugins = ["cli_helpers"]  # the home fixture

ray = pytest.importorskip("ray", reason="the Ray cluster tests need Ray (pip install 'arena-league[ray]')")
if ray_executable() is None:
    pytest.skip("Ray's `ray` command is not installed", allow_module_level=True)

RECORDED = Path(__file__).parent / "data" / "population_build_crossroads_size8.json"


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    with ray_cluster(tmp_path_factory.mktemp("ray-logs")) as running:
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


@pytest.mark.slow
def test_a_crossroads_build_on_two_nodes_gives_the_recorded_population(capsys, home, tmp_path, monkeypatch):
    recorded = json.loads(RECORDED.read_text())
    out = tmp_path / "out"
    with ray_cluster(tmp_path / "ray-logs") as running:
        monkeypatch.delenv("RAY_ADDRESS", raising=False)
        for name, value in running.env.items():
            monkeypatch.setenv(name, value)
        try:
            code, report, err = run(capsys, *recorded["argv"], "--backend", "ray", "--address", running.address,
                                    "--work-dir", tmp_path / "work", "--out-dir", out, "--json")
        finally:
            ray.shutdown()
    assert running.left() == []
    assert code == 0, err
    assert "as Ray tasks" in err  # the runs and the round robin went to the cluster
    built = json.loads((out / "population.json").read_text())
    assert built["provenance"]["build"].pop("code")
    expected = recorded["population"]
    assert {m["name"]: m["metadata"]["rating"] for m in built["members"]} == \
        {m["name"]: m["metadata"]["rating"] for m in expected["members"]}
    assert built == expected
    assert report["stage"] == "register"
