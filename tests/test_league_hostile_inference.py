"""Hostile agents through the command: each attack of an uploaded ONNX graph, tried as an attacker
would, ends in a named refusal, a forfeit or a suspension, never in a hung or killed worker.

Every command runs in a subprocess under an address-space limit (:data:`MEMORY_LIMIT`, inherited
by the inference sandbox, which sets its own tighter one), so a regression fails a test instead
of taking the machine down; the sandbox's time budget per call is lowered to keep the tests short.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import hostile_agents as hostile
import pytest
from cli_helpers import gobang_agent, run
from test_league_hostile_imports import population_folder, store_files

from arena_league import registry as reg
from arena_league.league import open_home, register_game
from arena_league.policies import Architecture, game_action_spec, init_parameters, save_arena_policy

pytest_plugins = ["cli_helpers"]  # the home fixture
#: Address space of every command run here (torch and onnxruntime map about 1-2 GiB).
MEMORY_LIMIT = 6 << 30
#: The sandbox's budget per call in these leagues.
CALL_SECONDS = 0.5
CROSSROADS = "Crossroads-2T2P-v1"
#: Four players a team: 64 matches in flight put more than 100 of one agent's seats in one call.
WIDE = "Crossroads-2T4P-v1"


def command(home: Path, *argv, timeout: float = 300) -> tuple[int, dict, str, float]:
    """``arena-league ARGV --json`` in a subprocess under MEMORY_LIMIT: exit code, JSON document,
    stderr, seconds."""
    def limit_memory() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))

    env = {**os.environ, "ARENA_LEAGUE_HOME": str(home)}
    env.pop("ARENA_LEAGUE_DB", None)
    start = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "arena_league.cli", *map(str, argv), "--json"], env=env,
                          capture_output=True, text=True, timeout=timeout, preexec_fn=limit_memory, check=False)
    seconds = time.monotonic() - start
    document = json.loads(done.stdout) if done.stdout.lstrip().startswith("{") else {}
    assert "Traceback" not in done.stderr, done.stderr
    return done.returncode, document, done.stderr, seconds


@pytest.fixture
def league_home(home):
    code, _, err, _ = command(home, "settings", "set", "sandbox.call_seconds", CALL_SECONDS)
    assert code == 0, err
    return home


def mlp_folder(folder: Path, game_id: str, seed: int) -> Path:
    spec = game_action_spec(game_id)
    arch = Architecture("mlp", obs_dim=spec.obs_dim, action_type=spec.action_type, n_actions=spec.n_actions,
                        hidden=(16,))
    return save_arena_policy(folder, arch, init_parameters(arch, seed), game_id, name=f"mlp-{seed}")


def submit(home: Path, path: Path, game_id: str, name: str) -> tuple[int, dict, str, float]:
    return command(home, "submit", path, "--game", game_id, "--name", name)


# --- submissions: refused at validation, within the budgets -------------------------------------

@pytest.mark.parametrize(("label", "model", "words"), [
    ("a Loop of 10^15 iterations", hostile.hanging, ["ran past its 0.5 s budget"]),
    ("a hang only at the validation match's size (4 rows: one per seat), timed before the match",
     lambda g: hostile.hanging(g, exactly=4), ["at a batch of 4 rows", "ran past its 0.5 s budget"]),
    ("a hang only past 100 rows", lambda g: hostile.hanging(g, above=100),
     ["largest batch (256 rows", "ran past its 0.5 s budget"]),
    ("a failure only past 100 rows", lambda g: hostile.failing(g, above=100),
     ["largest batch (256 rows", "onnxruntime failed in a Reshape node"]),
    ("a 12.8 GB tensor", lambda g: hostile.allocating(g, 12_800_000_000), ["ran out of memory"]),
], ids=["loop", "match-only", "above-100", "fail-above-100", "12.8GB"])
def test_a_hostile_submission_is_rejected_within_its_budgets(league_home, tmp_path, label, model, words):
    path = hostile.save(model(CROSSROADS), tmp_path / "agent.onnx")
    code, doc, err, seconds = submit(league_home, path, CROSSROADS, "attacker")
    assert code == 1 and doc["status"] == "rejected", (label, err)
    for word in words:
        assert word in doc["reason"], (label, doc["reason"])
    assert seconds < 120, (label, seconds)
    code, agent, _, _ = command(league_home, "agent", "attacker")
    assert agent["status"] == "rejected" and agent["reason"] == doc["reason"]


def test_an_agent_that_allocates_a_gigabyte_per_step_is_rejected_with_the_figures(league_home, tmp_path):
    path = hostile.save(hostile.allocating(CROSSROADS, 1_200_000_000), tmp_path / "greedy.onnx")
    command(league_home, "settings", "set", "sandbox.call_seconds", 20)  # the time budget is not the point here
    code, doc, err, _ = submit(league_home, path, CROSSROADS, "greedy")
    assert code == 1, err
    assert "uses too much memory" in doc["reason"] and "over the 512 MiB an agent may use" in doc["reason"]
    megabytes = int(doc["reason"].split("uses too much memory: ")[1].split(" MiB")[0])
    assert 1000 <= megabytes <= 1400  # 1.2 GB, measured in the sandbox


def test_a_well_behaved_submission_logs_its_size_at_the_largest_batch(league_home, tmp_path):
    code, doc, err, _ = submit(league_home, mlp_folder(tmp_path / "fine", WIDE, 1), WIDE, "fine")
    assert code == 0, err
    size = next(line for line in doc["log"].splitlines() if line.startswith("[size]"))
    assert "a forward of 512 rows (the largest batch)" in size and "budget 512 MiB" in size


# --- agents that misbehave only in play: forfeits and suspension ----------------------------------

def register_unvalidated(home: Path, path: Path, game_id: str, name: str) -> None:
    """Register an artifact as an active agent without validating it: an agent accepted before the
    league validated at full size (or one whose behaviour changes in play)."""
    with open_home(home) as league:
        register_game(league, game_id)
        with league.transaction() as session:
            stored = reg.store_artifact(session, league.home, path.read_bytes(), "onnx")
            reg.create_agent(session, name, game_id, "submission", owner="mallory", artifact_sha256=stored.sha256,
                             status="active", metadata={"action_type": "discrete"})


@pytest.mark.parametrize(("make", "words"), [
    (lambda: hostile.hanging(WIDE, above=100), "ran past its 0.5 s budget for a call of"),
    (lambda: hostile.failing(WIDE, above=100), "onnxruntime failed in a Reshape node"),
    (lambda: hostile.allocating(WIDE, 12_800_000_000, above=100), "ran out of memory"),
], ids=["hang", "fail", "oom"])
def test_a_worker_finishes_the_job_records_the_forfeits_and_suspends_the_agent(league_home, tmp_path, make, words):
    for seed in (1, 2):
        code, _, err, _ = submit(league_home, mlp_folder(tmp_path / f"good{seed}", WIDE, seed), WIDE, f"good{seed}")
        assert code == 0, err
    register_unvalidated(league_home, hostile.save(make(), tmp_path / "bad.onnx"), WIDE, "bad")
    code, queued, err, _ = command(league_home, "evaluate", WIDE, "--matches-per-pair", 20, "--max-matches", 60,
                                   "--queue")
    assert code == 0, err
    code, summary, err, seconds = command(league_home, "worker", "--until-idle", "--poll", 0.1)
    assert code == 0 and summary["completed"] == 1 and summary["failed"] == 0, err
    assert seconds < 240
    code, job, _, _ = command(league_home, "jobs", "show", queued["queued"])
    result = job["result"]
    assert job["status"] == "done" and set(result["suspended"]) == {"bad"}
    assert result["forfeits"]["bad"] >= 3 and set(result["forfeits"]) == {"bad"}
    # the good pair played all its matches; every match of `bad` was a forfeit or was skipped
    assert result["played"] + result["skipped"] == 60
    code, agent, _, _ = command(league_home, "agent", "bad")
    assert agent["status"] == "suspended" and words in agent["reason"]
    assert agent["matches_forfeited"] == result["forfeits"]["bad"]
    assert all(words in f["reason"] for f in agent["forfeits"])
    code, listing, _, _ = command(league_home, "agents", WIDE)
    assert {a["name"]: a["status"] for a in listing["agents"]} == {"good1": "active", "good2": "active",
                                                                    "bad": "suspended"}
    # a suspended agent plays no more, and an operator may reinstate it
    code, _, err, _ = command(league_home, "evaluate", WIDE, "--agents", "good1", "bad")
    assert code == 2 and "bad is suspended" in err
    code, doc, _, _ = command(league_home, "reinstate", "bad")
    assert doc["status"] == "active" and doc["matches_forfeited"] == agent["matches_forfeited"]


def test_rank_of_an_entrant_that_always_fails_ends_with_it_suspended(league_home, tmp_path):
    register_unvalidated(league_home, hostile.save(hostile.failing(CROSSROADS), tmp_path / "bad.onnx"), CROSSROADS,
                         "bad")
    code, report, err, _ = command(league_home, "rank", "bad", "--budget", 40)
    assert code == 0, err
    # a placement plays one match at a time: the third forfeit reaches the league's limit of 3
    assert report["forfeits"] == report["matches"] == 3
    assert "suspended after forfeiting 3 matches (the league suspends at 3)" in report["suspended"]
    assert report["rank"] == report["base_size"] + 1  # three losses: last
    assert report["stopped"] == "suspended" and report["stop_reason"].startswith(
        "the entrant was suspended after 3 new matches (suspended after forfeiting 3 matches")
    code, agent, _, _ = command(league_home, "agent", "bad")
    assert agent["status"] == "suspended"


# --- imports: members are validated at full size --------------------------------------------------

def test_an_imported_member_that_hangs_past_100_rows_refuses_the_import(league_home, tmp_path, capsys):
    game = "GoBang-2T1P-v1"
    folder = population_folder(tmp_path / "pop", ["agents/m0", "agents/m1"])
    hostile.save(hostile.hanging(game, above=100), folder / "agents" / "m1.onnx")
    manifest = json.loads((folder / "population.json").read_text())
    manifest["members"][1].update(artifact="agents/m1.onnx", format="onnx")
    (folder / "population.json").write_text(json.dumps(manifest))
    before = store_files(league_home)
    code, doc, err, seconds = command(league_home, "population", "import", folder)
    assert code == 2, err
    assert "member hostile.m1@GoBang-2T1P-v1" in doc["error"] and "largest batch (128 rows" in doc["error"]
    assert "ran past its 0.5 s budget" in doc["error"] and seconds < 120
    assert store_files(league_home) == before
    code, listing, _ = run(capsys, "population", "list", "--json")
    assert listing["populations"] == []


def test_the_budgets_are_league_settings_checked_before_they_are_stored(league_home, capsys):
    code, doc, _ = run(capsys, "settings", "--json")
    assert doc["settings"]["sandbox.call_seconds"] == {**doc["settings"]["sandbox.call_seconds"],
                                                       "value": CALL_SECONDS, "changed": True}
    assert doc["settings"]["forfeits.suspend_after"]["value"] == 3
    code, _, err = run(capsys, "settings", "set", "sandbox.memory_mib", "lots")
    assert code == 2 and "sandbox.memory_mib takes a whole number" in err
    code, _, err = run(capsys, "settings", "set", "sandbox.call_second", 1)
    assert code == 2 and "Did you mean 'sandbox.call_seconds'" in err
    code, doc, _ = run(capsys, "settings", "reset", "sandbox.call_seconds", "--json")
    assert doc == {"key": "sandbox.call_seconds", "value": 2.0}


def test_a_gobang_agent_is_played_in_the_sandbox_and_agrees_with_its_validation(league_home, tmp_path, capsys):
    # the plain path still works end to end: two submitted agents evaluated in the sandbox
    for seed, name in ((1, "a"), (2, "b")):
        code, _, err = run(capsys, "submit", gobang_agent(tmp_path / name, seed), "--game", "GoBang-2T1P-v1",
                           "--name", name, "--json")
        assert code == 0, err
    code, doc, err = run(capsys, "evaluate", "GoBang-2T1P-v1", "--matches-per-pair", 6, "--json")
    assert code == 0 and doc["played"] == 6 and doc["forfeits"] == {} and doc["suspended"] == {}, err
