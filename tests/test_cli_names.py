"""The command's side of the league's one set of rules (the web's side is in test_web_api.py):
names are series of versions, an empty file is refused, a placement's budget has one limit; and
`train` and `serve` say what they really did."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_helpers import gobang_agent, run

pytest_plugins = ["cli_helpers"]  # the home fixture
GAME = "GoBang-2T1P-v1"


def test_new_bytes_under_your_name_become_its_next_version(capsys, home, tmp_path):
    code, first, err = run(capsys, "submit", gobang_agent(tmp_path / "a", 1), "--game", GAME, "--name", "alice", "--json")
    assert code == 0 and first["agent"] == "alice" and first["created"], err
    code, second, err = run(capsys, "submit", gobang_agent(tmp_path / "b", 2), "--game", GAME, "--name", "alice",
                            "--json")
    assert code == 0 and second["agent"] == "alice:v2" and second["created"], err
    assert "next version" in second["note"]
    code, again, _ = run(capsys, "submit", tmp_path / "b", "--game", GAME, "--name", "alice", "--json")
    assert code == 0 and again["agent"] == "alice:v2" and not again["created"]
    assert "rename" not in again["note"] and "rank alice:v2" in again["note"]
    code, detail, _ = run(capsys, "agent", "alice", "--json")
    assert [(v["name"], v["version"]) for v in detail["versions"]] == [("alice", 1), ("alice:v2", 2)]
    code, _, err = run(capsys, "agent", "alice:v2")
    assert code == 0, err


def test_names_refused_by_the_command_are_refused_as_the_web_refuses_them(capsys, home, tmp_path):
    run(capsys, "submit", gobang_agent(tmp_path / "a", 1), "--game", GAME, "--name", "alice", "--owner", "alice")
    agent = gobang_agent(tmp_path / "b", 2)
    cases = [(("--name", "alice", "--owner", "mallory"), "alice belongs to another submitter"),
             (("--name", "alice:v7"), "versions are named for you"),
             (("--name", f"random@{GAME}"), "reserved for the league")]
    for options, words in cases:
        code, doc, err = run(capsys, "submit", agent, "--game", GAME, *options, "--json")
        assert code == 2 and words in doc["error"], doc
        assert err.count("\n") == 1 and "Traceback" not in err
    (tmp_path / "empty.onnx").write_bytes(b"")
    code, doc, err = run(capsys, "submit", tmp_path / "empty.onnx", "--game", GAME, "--name", "carol", "--json")
    assert code == 2 and doc["error"].startswith("empty.onnx is empty (0 bytes)") and "export" in doc["error"]
    code, listed, _ = run(capsys, "agents", "--json")
    assert [a["name"] for a in listed["agents"]] == ["alice"]


def test_a_board_short_name_is_refused_as_a_submitted_name(capsys, home, tmp_path):
    # a board shows random@GAME and base members without @GAME; a submission under that short name
    # would make one name on the board mean two agents
    agent = gobang_agent(tmp_path / "a", 1)
    for name in ("random", "heuristic", "base-v1.cc-s0-cc-100352"):
        code, doc, err = run(capsys, "submit", agent, "--game", GAME, "--name", name, "--json")
        assert code == 2 and "reserved for the league" in doc["error"] and "--name my-" in doc["error"], doc
        assert "Traceback" not in err
    code, listed, _ = run(capsys, "agents", "--json")
    assert listed["agents"] == []


def test_a_placement_budget_over_the_league_limit_is_refused_before_it_plays(capsys, home, tmp_path):
    run(capsys, "submit", gobang_agent(tmp_path / "a", 1), "--game", GAME, "--name", "alice")
    code, doc, _ = run(capsys, "rank", "alice", "--budget", "5001", "--json")
    assert code == 2 and "over 5000" in doc["error"] and "rank.max_budget" in doc["error"]
    code, doc, _ = run(capsys, "rank", "alice", "--budget", "1", "--json")
    assert code == 2 and "at least 2" in doc["error"]
    code, _, err = run(capsys, "settings", "set", "rank.max_budget", "20")
    assert code == 0, err
    code, doc, _ = run(capsys, "rank", "alice", "--budget", "21", "--json")
    assert code == 2 and "over 20" in doc["error"]
    code, doc, _ = run(capsys, "rank", "alice", "--more", "1000000", "--json")
    assert code == 2 and "--more 1000000 is over 20" in doc["error"]  # more matches have the same bound
    code, jobs, _ = run(capsys, "jobs", "--json")
    assert jobs["jobs"] == []  # refused before anything was queued


@pytest.mark.slow
def test_train_reports_the_steps_it_trained_and_keeps_snapshots_in_the_league_home(capsys, home):
    runs = []
    for _ in range(2):
        code, doc, err = run(capsys, "train", "Crossroads-2T1P-v1", "--scheme", "ppo", "--steps", "10", "--hidden",
                             "8", "--eval-matches", "2", "--json")
        assert code == 0, err
        assert doc["steps"] == 10 and doc["env_steps"] == doc["history"][-1]["env_steps"] > 10
        runs.append(Path(doc["snapshots"][-1]["path"]).parent.parent)
    # a second run never overwrites the first
    assert runs == [home / "runs" / f"Crossroads-2T1P-v1-ppo-seed0-{k}" for k in (1, 2)]


def test_a_stopped_train_resumes_when_the_same_command_runs_again(capsys, home, monkeypatch, tmp_path):
    from arena_league import cli

    argv = ["train", "Crossroads-2T1P-v1", "--scheme", "ppo", "--steps", "3000", "--hidden", "8", "--eval-matches",
            "2", "--eval-inline", "--checkpoint-seconds", "0"]
    code, straight, err = run(capsys, *argv, "--out", tmp_path / "straight", "--json")
    assert code == 0, err
    console = cli.stderr

    class Stopping:
        """The terminal as Ctrl-C reaches it inside the second iteration, after the first one's checkpoint."""

        def print(self, line, **kwargs):
            if " iter 2 " in str(line):
                raise KeyboardInterrupt
            console.print(line, **kwargs)

    monkeypatch.setattr(cli, "stderr", Stopping())
    code, _, _ = run(capsys, *argv)
    monkeypatch.setattr(cli, "stderr", console)
    folder = home / "runs" / "Crossroads-2T1P-v1-ppo-seed0-1"
    assert code == 130 and (folder / "ppo-seed0" / "checkpoint.pt").exists()
    code, _, err = run(capsys, *argv)
    said = err.replace("\n", "")  # the terminal wraps long lines
    assert code == 0 and f"resumed from {folder / 'ppo-seed0' / 'checkpoint.pt'} at iteration 1" in said, err
    # the resumed run's snapshot is the uninterrupted run's, bit for bit, in the folder the stop left
    assert not (home / "runs" / "Crossroads-2T1P-v1-ppo-seed0-2").exists()
    last = max((folder / "ppo-seed0").glob("*/weights.safetensors"))
    same = tmp_path / "straight" / "ppo-seed0" / last.parent.name / "weights.safetensors"
    assert last.read_bytes() == same.read_bytes() and Path(straight["snapshots"][-1]["path"]).name == last.parent.name


def test_train_prints_the_rounded_steps_and_no_nan(home):
    done = subprocess.run([sys.executable, "-m", "arena_league.cli", "train", "Crossroads-2T1P-v1", "--scheme", "ppo",
                           "--steps", "10", "--hidden", "8", "--eval-matches", "2"], capture_output=True, text=True, check=False,
                          timeout=300, env={**os.environ, "COLUMNS": "200"})
    assert done.returncode == 0, done.stderr
    assert "10 asked for, rounded up to whole iterations" in done.stdout
    assert "evaluation: 1 evaluation(s) played" in done.stdout and "training waited" in done.stdout
    assert "nan" not in done.stderr and "return - (no episode ended in this iteration)" in done.stderr


def test_serve_on_a_busy_port_is_one_line_and_no_banner(capsys, home):
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        port = holder.getsockname()[1]
        code, _, err = run(capsys, "serve", "--port", port)
    assert code == 2 and err.count("\n") == 1
    assert f"127.0.0.1:{port}" in err and "--port" in err and "serving" not in err


def test_serve_names_the_league_home_it_serves(home, tmp_path):
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    log = tmp_path / "serve.log"
    with open(log, "w") as out:
        process = subprocess.Popen([sys.executable, "-m", "arena_league.cli", "serve", "--port", str(port),
                                    "--no-worker"], stdout=out, stderr=subprocess.STDOUT,
                                   env={**os.environ, "COLUMNS": "400"})
        try:
            deadline = time.monotonic() + 60
            while "serving" not in log.read_text() and process.poll() is None and time.monotonic() < deadline:
                time.sleep(0.1)
        finally:
            process.send_signal(signal.SIGINT)
            process.wait(timeout=30)
    text = log.read_text()
    assert f"serving the league at {home.resolve()} on http://127.0.0.1:{port}" in text, text
    assert "$ARENA_LEAGUE_HOME" not in text

