"""The league service through the `arena-league` command: submissions and their refusals, jobs,
ranking, crash recovery, and the same league on PostgreSQL."""

from __future__ import annotations

import json
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import onnx
import pytest
import torch
from onnx import TensorProto, helper, numpy_helper

from arena_league.cli import main
from arena_league.envs import make_rules
from arena_league.league import ensure_scripted_agents, evaluate, leaderboard, open_home, rank, submit
from arena_league.registry import count_matches, list_agents, match_seat_rows

GAME = "Crossroads-2T2P-v1"
EXAMPLE = Path(__file__).resolve().parent.parent / "submissions" / "crossroads-2t2p-mlp.onnx"


def run_cli(capsys, *argv: str) -> tuple[int, dict | None, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    document = json.loads(out) if out.strip().startswith("{") else None
    return code, document, err


def linear_onnx(path: Path, obs_dim: int, n_actions: int, *, nan: bool = False) -> Path:
    """A one-layer ONNX policy `logits = obs @ W (+ NaN)` in the league's ONNX I/O names."""
    weights = np.random.default_rng(0).normal(size=(obs_dim, n_actions)).astype(np.float32)
    nodes = [helper.make_node("MatMul", ["obs", "W"], ["z" if nan else "logits"])]
    inits = [numpy_helper.from_array(weights, "W")]
    if nan:
        inits.append(numpy_helper.from_array(np.full((n_actions,), np.nan, np.float32), "B"))
        nodes.append(helper.make_node("Add", ["z", "B"], ["logits"]))
    graph = helper.make_graph(
        nodes, "policy",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, ["N", obs_dim])],
        [helper.make_tensor_value_info("logits", TensorProto.FLOAT, ["N", n_actions])], inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, path)
    return path


@pytest.fixture
def home(tmp_path, monkeypatch):
    monkeypatch.setenv("ARENA_LEAGUE_HOME", str(tmp_path / "league"))
    monkeypatch.delenv("ARENA_LEAGUE_DB", raising=False)
    return tmp_path / "league"


def snapshot(home: Path) -> dict:
    """What is stored: agents (name, status) and artifact files."""
    with open_home(home) as league, league.reading() as session:
        agents = sorted((a.name, a.status) for a in list_agents(session))
    files = sorted(str(p.relative_to(home)) for p in (home / "artifacts").rglob("*") if p.is_file()
                   and "incoming" not in p.parts) if (home / "artifacts").exists() else []
    return {"agents": agents, "files": files}


def test_submit_example_then_same_bytes_again(home, capsys):
    code, doc, _ = run_cli(capsys, "submit", str(EXAMPLE), "--game", GAME, "--name", "alice-v1", "--json")
    assert code == 0 and doc["status"] == "active" and doc["created"]
    code, again, _ = run_cli(capsys, "submit", str(EXAMPLE), "--game", GAME, "--name", "alice-v2", "--json")
    assert code == 0 and again["agent"] == "alice-v1" and not again["created"]
    assert snapshot(home)["agents"] == [("alice-v1", "active")]


def test_a_name_another_owner_holds_is_refused_and_changes_nothing(home, tmp_path, capsys):
    rules = make_rules(GAME)
    run_cli(capsys, "submit", str(EXAMPLE), "--game", GAME, "--name", "alice", "--owner", "alice", "--json")
    before = snapshot(home)
    other = linear_onnx(tmp_path / "other.onnx", rules.obs_dim, rules.n_actions)
    code, doc, _err = run_cli(capsys, "submit", str(other), "--game", GAME, "--name", "alice", "--owner", "bob",
                              "--json")
    assert code == 2 and "alice belongs to another submitter" in doc["error"]
    assert snapshot(home) == before
    code, doc, _err = run_cli(capsys, "submit", str(other), "--game", GAME, "--name", "alice", "--owner", "alice",
                              "--json")
    assert code == 0 and doc["agent"] == "alice:v2" and doc["created"]


@pytest.mark.parametrize("maker, words", [
    ("pickle", "pickle"),
    ("torchscript", "TorchScript"),
    ("truncated", "truncated"),
])
def test_unsafe_or_broken_files_are_refused_and_nothing_is_stored(home, tmp_path, capsys, maker, words):
    run_cli(capsys, "submit", str(EXAMPLE), "--game", GAME, "--name", "alice", "--json")
    before = snapshot(home)
    path = tmp_path / "agent.onnx"
    if maker == "pickle":
        path.write_bytes(pickle.dumps({"weights": [1, 2, 3]}))
    elif maker == "torchscript":
        torch.jit.save(torch.jit.script(torch.nn.Linear(4, 2)), str(path))
    else:
        path.write_bytes(EXAMPLE.read_bytes()[: EXAMPLE.stat().st_size // 2])
    code, doc, _ = run_cli(capsys, "submit", str(path), "--game", GAME, "--name", "mallory", "--json")
    assert code == 2 and words.lower() in doc["error"].lower()
    assert snapshot(home) == before


def test_two_gigabyte_file_is_refused_before_reading(home, tmp_path, capsys):
    path = tmp_path / "huge.onnx"
    with open(path, "wb") as handle:
        handle.truncate(2 * 1024**3)  # sparse: takes no disk
    start = time.perf_counter()
    code, doc, _ = run_cli(capsys, "submit", str(path), "--game", GAME, "--name", "huge", "--json")
    assert code == 2 and ("large" in doc["error"] or "limit" in doc["error"])
    assert time.perf_counter() - start < 5, "refused from its size, not after reading it"
    assert snapshot(home)["agents"] == []


@pytest.mark.parametrize("kind, reason", [("wrong_size", "obs"), ("nan", "finite")])
def test_invalid_onnx_is_rejected_with_its_reason_and_log(home, tmp_path, capsys, kind, reason):
    rules = make_rules(GAME)
    obs_dim = rules.obs_dim + 3 if kind == "wrong_size" else rules.obs_dim
    path = linear_onnx(tmp_path / f"{kind}.onnx", obs_dim, rules.n_actions, nan=kind == "nan")
    code, doc, _ = run_cli(capsys, "submit", str(path), "--game", GAME, "--name", f"bad-{kind}", "--json")
    assert code == 1 and doc["status"] == "rejected"
    assert reason in doc["reason"].lower() and doc["log"]
    with open_home(home) as league, league.reading() as session:
        agent = next(a for a in list_agents(session) if a.name == f"bad-{kind}")
        assert agent.status == "rejected" and agent.reject_reason and agent.validation_log


def test_unknown_game_lists_the_valid_ids(home, capsys):
    code, doc, _ = run_cli(capsys, "submit", str(EXAMPLE), "--game", "Crosroads-2T2P-v1", "--name", "a", "--json")
    assert code == 2 and "unknown game id" in doc["error"] and GAME in doc["error"]


def test_database_file_that_is_not_a_database(tmp_path, capsys):
    junk = tmp_path / "league.db"
    junk.write_bytes(b"this is a spreadsheet, not a league\n" * 100)
    before = junk.read_bytes()
    code, doc, _ = run_cli(capsys, "matches", GAME, "--db", f"sqlite:///{junk}", "--home", str(tmp_path), "--json")
    assert code == 2 and "not" in doc["error"] and "database" in doc["error"]
    assert junk.read_bytes() == before


def test_evaluate_rank_and_leaderboard(home):
    with open_home(home) as league:
        base = ensure_scripted_agents(league, GAME)
        submit(league, EXAMPLE, GAME, "alice")
        report = evaluate(league, GAME, base, matches_per_pair=6)
        assert report.played == 6 and report.stored == 6
        assert evaluate(league, GAME, base, matches_per_pair=6).played == 0  # the pair is full
        placed = rank(league, "alice", budget=24, population="league")
        assert placed.matches >= 20 and placed.lower <= placed.rating <= placed.upper
        assert 1 <= placed.rank_lower <= placed.rank <= placed.rank_upper <= 3
        board = leaderboard(league, GAME, population="league")
        names = [row.agent for row in board.rows]
        assert set(names) == {"alice", *base}
        assert names.index(f"heuristic@{GAME}") < names.index(f"random@{GAME}")


def test_same_seed_same_matches(tmp_path):
    outcomes = []
    for run in range(2):
        with open_home(tmp_path / f"league{run}") as league:
            base = ensure_scripted_agents(league, GAME)
            evaluate(league, GAME, base, matches_per_pair=4, seed=3)
            with league.reading() as session:
                outcomes.append([(r["match_key"], r["agent"], r["score"]) for r in match_seat_rows(session, GAME)])
    assert outcomes[0] == outcomes[1] and len(outcomes[0]) == 4 * 4


def test_worker_killed_mid_job_completes_once_without_duplicates(home):
    game = "GoBang-2T1P-v1"
    with open_home(home) as league:
        base = ensure_scripted_agents(league, game)
    env = {**os.environ, "ARENA_LEAGUE_HOME": str(home), "PYTHONUNBUFFERED": "1"}
    queued = subprocess.run([sys.executable, "-m", "arena_league.cli", "evaluate", game, "--matches-per-pair", "3000",
                             "--queue", "--json"], env=env, capture_output=True, text=True, check=True)
    job_id = json.loads(queued.stdout)["queued"]
    worker = subprocess.Popen([sys.executable, "-m", "arena_league.cli", "worker", "--lease", "2", "--poll", "0.2",
                               "--max-jobs", "1"], env=env, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    try:
        deadline = time.time() + 120
        with open_home(home) as league:
            while time.time() < deadline:
                with league.reading() as session:
                    if count_matches(session, game) > 0:
                        break
                time.sleep(0.05)
        worker.send_signal(signal.SIGKILL)
    finally:
        worker.wait()
    with open_home(home) as league, league.reading() as session:
        partial = count_matches(session, game)
    assert 0 < partial < 3000, "the worker was killed mid-job"
    time.sleep(2.5)  # the lease expires
    second = subprocess.run([sys.executable, "-m", "arena_league.cli", "worker", "--lease", "5", "--poll", "0.2",
                             "--until-idle", "--json"], env=env, capture_output=True, text=True, timeout=300,
                            check=False)
    assert json.loads(second.stdout)["completed"] == 1
    with open_home(home) as league, league.reading() as session:
        assert count_matches(session, game) == 3000
        rows = match_seat_rows(session, game)
        keys = [r["match_key"] for r in rows if r["seat"] == 0]
        assert len(keys) == len(set(keys)) == 3000
        assert all(k.startswith(f"job:{job_id}:") for k in keys)
        assert {r["agent"] for r in rows} == set(base)


def _postgres_url() -> str | None:
    import psycopg

    for user in ("postgres", "root"):
        try:
            with psycopg.connect(f"host=127.0.0.1 port=5432 dbname=test user={user}", connect_timeout=3):
                return f"postgresql+psycopg://{user}@127.0.0.1:5432/test"
        except psycopg.Error:
            continue
    return None


@pytest.mark.postgres
def test_league_on_postgresql(tmp_path):
    url = _postgres_url()
    if url is None:
        pytest.skip("no PostgreSQL server reachable at 127.0.0.1:5432 (database test, trust auth)")
    import sqlalchemy

    schema = f"league_{os.getpid()}_{int(time.time() * 1000) % 10**8}"
    engine = sqlalchemy.create_engine(url)
    with engine.begin() as conn:
        conn.execute(sqlalchemy.text(f'CREATE SCHEMA "{schema}"'))
    try:
        scoped = f"{url}?options=-csearch_path%3D{schema}"
        with open_home(tmp_path, scoped) as league:
            base = ensure_scripted_agents(league, GAME)
            assert evaluate(league, GAME, base, matches_per_pair=4).stored == 4
            board = leaderboard(league, GAME, population="league")
            assert next(r.agent for r in board.rows) == f"heuristic@{GAME}"
    finally:
        with engine.begin() as conn:
            conn.execute(sqlalchemy.text(f'DROP SCHEMA "{schema}" CASCADE'))
        engine.dispose()
