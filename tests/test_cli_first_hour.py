"""A new user's first hour through the command: ranking against the shipped base population by
default, populations per game, jobs that can be listed and cancelled, agents that can be found,
a command that forgives typos and says what it will do, and errors that are one line on stderr."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_helpers import gobang_agent, run

from arena_league.cli import main
from arena_league.policies import Architecture, init_parameters
from arena_league.policies.artifacts import save_arena_policy

pytest_plugins = ["cli_helpers"]  # the home fixture
GAME = "GoBang-2T1P-v1"
ROOT = Path(__file__).resolve().parent.parent




def test_rank_with_no_options_places_against_the_shipped_base_population(capsys, home, tmp_path):
    code, submitted, _ = run(capsys, "submit", gobang_agent(tmp_path / "a"), "--game", GAME, "--name", "alice",
                             "--json")
    assert code == 0 and submitted["status"] == "active"
    code, placed, err = run(capsys, "rank", "alice", "--budget", "40", "--json")
    # the newest population shipped for the game: base-v2, whose top rungs are search agents
    assert code == 0 and placed["base"] == "base-v2:1" and placed["base_size"] == 100
    assert placed["matches"] <= 40 and placed["lower"] <= placed["rating"] <= placed["upper"]
    assert "against base-v2:1 (100 agents), at most 40 matches" in err
    # the import happened once: a second ranking uses the same population, no new version
    code, again, _ = run(capsys, "rank", "alice", "--budget", "20", "--json")
    code, listed, _ = run(capsys, "population", "list", "--json")
    assert again["base"] == "base-v2:1" and [(p["name"], p["version"]) for p in listed["populations"]] == \
        [("base-v2", 1)]
    code, board, _ = run(capsys, "leaderboard", GAME, "--json")
    rows = {row["agent"]: row for row in board["rows"]}
    assert code == 0 and len(rows) == 101 and rows["alice"]["status"] == "placed"
    assert rows["alice"]["rating"] == pytest.approx(again["rating"])  # the board repeats the placement


def test_a_league_holding_base_v1_ranks_against_the_newer_shipped_base_v2(capsys, home, tmp_path):
    code, doc, _ = run(capsys, "population", "import", ROOT / "checkpoints" / GAME / "base-v1", "--json")
    assert code == 0 and doc["imported"] == "base-v1:1"
    run(capsys, "submit", gobang_agent(tmp_path / "a"), "--game", GAME, "--name", "alice", "--json")
    code, placed, err = run(capsys, "rank", "alice", "--budget", "10", "--json")
    assert code == 0 and placed["base"] == "base-v2:1" and "against base-v2:1" in err
    code, placed, _ = run(capsys, "rank", "alice", "--budget", "10", "--population", "base-v1", "--json")
    assert code == 0 and placed["base"] == "base-v1:1"  # the older one, when asked for


def test_a_shipped_population_named_for_rank_is_imported_on_first_use(capsys, home, tmp_path):
    run(capsys, "submit", gobang_agent(tmp_path / "a"), "--game", GAME, "--name", "alice", "--json")
    code, placed, err = run(capsys, "rank", "alice", "--budget", "10", "--population", "base-v1", "--json")
    assert code == 0 and placed["base"] == "base-v1:1" and "against base-v1:1" in err
    code, listed, _ = run(capsys, "population", "list", "--json")
    assert [(p["name"], p["version"]) for p in listed["populations"]] == [("base-v1", 1)]
    code, _, err = run(capsys, "rank", "alice", "--budget", "10", "--population", "base-v9")
    assert code == 2 and "no population 'base-v9'" in err and "population build" in err


def test_population_versions_count_per_game_and_imports_are_idempotent(capsys, home, tmp_path):
    labels = []
    for game in ("Snake-2T2P-v1", "GoBang-2T1P-v1"):
        code, doc, _ = run(capsys, "population", "import", ROOT / "checkpoints" / game / "base-v1", "--json")
        labels.append(doc["imported"])
    assert labels == ["base-v1:1", "base-v1:1"]
    code, doc, _ = run(capsys, "population", "import", ROOT / "checkpoints" / GAME / "base-v1", "--json")
    assert doc["imported"] == "base-v1:1"  # same files: the same population, not a new version
    code, doc, err = run(capsys, "population", "export", "--population", "base-v1", "--destination",
                         tmp_path / "out", "--json")
    assert code == 2 and "several games" in err and "--game" in err and not (tmp_path / "out").exists()
    code, doc, _ = run(capsys, "population", "export", "--population", "base-v1", "--game", GAME,
                       "--destination", tmp_path / "out", "--json")
    assert code == 0 and json.loads((tmp_path / "out" / "population.json").read_text())["game_id"] == GAME
    code, doc, err = run(capsys, "rank", "nobody", "--population", "base-v2")
    assert code == 2 and "no agent 'nobody'" in err


def test_league_wide_ranking_is_explicit_announced_and_within_budget(capsys, home, tmp_path):
    for seed, name in ((1, "a"), (2, "b"), (3, "c")):
        run(capsys, "submit", gobang_agent(tmp_path / name, seed), "--game", GAME, "--name", name)
    code, doc, err = run(capsys, "rank", "a", "--league-wide", "--budget", "4")
    assert code == 2 and "round robin of 4 matches" in err and "--budget" in err
    code, doc, err = run(capsys, "rank", "a", "--league-wide", "--budget", "12", "--json")
    assert code == 0 and doc["base"] == "all active agents"
    assert "first a round robin of 4 matches among 2 agents" in err
    assert doc["matches"] <= 12 - 4


def test_evaluate_says_what_it_will_play_and_caps_it(capsys, home, tmp_path):
    for seed, name in ((1, "a"), (2, "b"), (3, "c")):
        run(capsys, "submit", gobang_agent(tmp_path / name, seed), "--game", GAME, "--name", name)
    code, doc, err = run(capsys, "evaluate", GAME, "--matches-per-pair", "4", "--max-matches", "5", "--json")
    assert code == 0 and doc["played"] == 5
    assert "5 matches to play" in err and "topped up to 4 matches per pair" in err and "--max-matches" in err
    code, doc, err = run(capsys, "evaluate", GAME, "--matches-per-pair", "2", "--record", "--json")
    assert code == 0 and doc["played"] == 1 and "1 matches to play" in err
    code, doc, err = run(capsys, "evaluate", GAME, "--matches-per-pair", "2", "--record", "--json")
    assert doc["played"] == 0 and "nothing to play" in err and "raise --matches-per-pair" in err


def test_jobs_can_be_listed_shown_and_cancelled(capsys, home, tmp_path):
    for seed, name in ((1, "a"), (2, "b")):
        run(capsys, "submit", gobang_agent(tmp_path / name, seed), "--game", GAME, "--name", name)
    code, doc, _ = run(capsys, "evaluate", GAME, "--queue", "--json")
    job = doc["queued"]
    code, doc, _ = run(capsys, "jobs", "--json")
    assert [(j["id"], j["status"]) for j in doc["jobs"]] == [(job, "queued")]
    code, doc, _ = run(capsys, "jobs", "show", job, "--json")
    assert doc["payload"]["game_id"] == GAME and doc["matches_stored"] == 0
    code, doc, _ = run(capsys, "jobs", "cancel", job, "--json")
    assert doc["status"] == "cancelled"
    code, doc, _ = run(capsys, "worker", "--until-idle", "--poll", "0.1", "--json")
    assert doc["completed"] == 0 and doc["jobs"] == []  # a cancelled job is not run
    code, doc, err = run(capsys, "jobs", "cancel", job)
    assert code == 0
    code, doc, err = run(capsys, "jobs", "cancel", 999)
    assert code == 2 and "no job 999" in err


def test_ctrl_c_cancels_the_running_job_without_a_traceback(home, tmp_path):
    env = {**os.environ, "ARENA_LEAGUE_HOME": str(home)}
    env.pop("ARENA_LEAGUE_DB", None)
    for seed, name in ((1, "a"), (2, "b")):
        main(["submit", str(gobang_agent(tmp_path / name, seed)), "--game", GAME, "--name", name])
    command = [sys.executable, "-m", "arena_league.cli", "evaluate", GAME, "--matches-per-pair", "20000"]
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:  # wait until the job runs
        listed = subprocess.run([sys.executable, "-m", "arena_league.cli", "jobs", "--json"], env=env,
                                capture_output=True, text=True, check=True)
        if any(j["status"] == "running" for j in json.loads(listed.stdout)["jobs"]):
            break
        time.sleep(0.3)
    process.send_signal(signal.SIGINT)
    _out, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "Traceback" not in err and "interrupted" in err
    listed = subprocess.run([sys.executable, "-m", "arena_league.cli", "jobs", "--json"], env=env,
                            capture_output=True, text=True, check=True)
    assert [j["status"] for j in json.loads(listed.stdout)["jobs"]] == ["cancelled"]


def test_agents_and_one_agent_show_status_reason_and_log(capsys, home, tmp_path):
    run(capsys, "submit", gobang_agent(tmp_path / "a"), "--game", GAME, "--name", "alice")
    wrong = tmp_path / "wrong"
    arch = Architecture("mlp", obs_dim=455, action_type="discrete", n_actions=224, hidden=(4,))
    save_arena_policy(wrong, arch, init_parameters(arch, 0), GAME, name="wrong")
    code, doc, err = run(capsys, "submit", wrong, "--game", GAME, "--name", "bob")
    assert code == 1 and "rejected:" in err and "224" in err  # the reason goes to stderr
    code, doc, _ = run(capsys, "agents", GAME, "--json")
    by_name = {a["name"]: a for a in doc["agents"]}
    assert by_name["bob"]["status"] == "rejected" and "224" in by_name["bob"]["reason"]
    code, detail, _ = run(capsys, "agent", "bob", "--json")
    assert "rejected" in detail["validation_log"] and detail["reason"] == by_name["bob"]["reason"]
    assert by_name["alice"]["status"] == "active"
    code, detail, _ = run(capsys, "agent", "alice", "--json")
    assert "accepted" in detail["validation_log"] and detail["matches_played"] == 0
    code, doc, err = run(capsys, "agent", "alcie")
    assert code == 2 and "Did you mean 'alice'" in err


def test_same_bytes_under_another_name_names_the_existing_agent(capsys, home, tmp_path):
    folder = gobang_agent(tmp_path / "a")
    run(capsys, "submit", folder, "--game", GAME, "--name", "alice")
    code, doc, _ = run(capsys, "submit", folder, "--game", GAME, "--name", "alice2", "--json")
    assert code == 0 and doc["agent"] == "alice" and not doc["created"]
    assert "already agent alice" in doc["note"] and "alice2" in doc["note"]


def test_a_mistyped_option_is_refused_by_its_subcommand_with_suggestions(capsys, home):
    with pytest.raises(SystemExit) as exit_info:
        main(["evaluate", GAME, "--matches", "3"])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and "usage: arena-league evaluate" in err
    assert "--matches-per-pair" in err.split("error:")[1] and "--max-matches" in err.split("error:")[1]
    with pytest.raises(SystemExit):
        main(["evaluate", GAME, "--matches-per", "3"])  # no abbreviations
    assert "unrecognized arguments" in capsys.readouterr().err


def test_every_option_has_help_and_every_league_command_takes_home_and_db():
    from arena_league.cli import build_parser

    parser = build_parser()
    commands = parser.get_default("commands")
    reads_no_league = {"games", "verify", "replay", "train", "experiment", "population pull", "population index"}
    parsers = dict(commands)
    for name, command in commands.items():  # a command with actions: each action is checked as a command
        actions = command.get_default("actions") or {}
        parsers.update({f"{name} {action}": p for action, p in actions.items()})
        if actions:
            del parsers[name]
    for name, command in parsers.items():
        options = {o for action in command._actions for o in action.option_strings}
        for action in command._actions:
            assert action.help, f"{name} {action.option_strings or action.dest} has no help"
        if name not in reads_no_league:
            assert {"--home", "--db", "--json"} <= options, name
        assert "--json" in options, name


def test_population_actions_refuse_options_meant_for_another_action(capsys, home):
    """Each population action takes its own options: one meant for another is refused in one line
    that names the action it is for."""
    refused = [(["list", "--seed", "3"], "--seed is for `population build`"),
               (["list", "--mirror", "x"], "--mirror is for `population pull`"),
               (["import", "folder", "--size", "8"], "--size is for `population build`"),
               (["export", "--write"], "--write is for `population index`"),
               (["pull", GAME, "--destination", "x"], "--destination is for `population export`"),
               (["index", "--scripted", "heuristic"], "--scripted is for `population build`"),
               (["build", GAME, "--all"], "--all is for `population pull`"),
               (["import", "folder", "base-v1"], "it takes FOLDER; 'base-v1' is more than that")]
    for argv, message in refused:
        with pytest.raises(SystemExit) as exit_info:
            main(["population", *argv])
        err = capsys.readouterr().err
        assert exit_info.value.code == 2 and message in err and len(err.strip().splitlines()) == 1, (argv, err)


def test_population_build_takes_its_defaults_from_the_library():
    """``population build``'s options are the library's BuildOptions fields, with their defaults."""
    from arena_league.cli import parse_args
    from arena_league.league.population.options import BuildOptions, command_line_options

    args = parse_args(["population", "build", GAME])
    defaults = BuildOptions()
    for option in command_line_options():
        assert getattr(args, option.field) == getattr(defaults, option.field), option.field
    assert parse_args(["population", "build", GAME, "--steps", "512", "--seed", "3"]).steps_per_scheme == 512


def test_errors_are_one_line_on_stderr_and_debug_shows_the_traceback(capsys, home):
    code, doc, err = run(capsys, "rank", "nobody", "--json")
    assert code == 2 and doc["kind"] == "NotFoundError" and "Traceback" not in err
    with pytest.raises(ValueError, match="no agent"):
        main(["rank", "nobody", "--debug"])


def test_commands_that_only_read_the_league_load_no_engine(home):
    main(["jobs", "--json"])  # creating the league migrates it (Alembic); reading it later needs none
    probe = ("import sys; from arena_league.cli import main; main(['agents', '--json']); main(['jobs', '--json']); "
             "main(['population', 'list', '--json']); "
             "heavy = [m for m in ('torch', 'onnxruntime', 'pymunk', 'mujoco', 'scipy', 'matplotlib', 'alembic') "
             "if m in sys.modules]; print(json.dumps(heavy))")
    env = {**os.environ, "ARENA_LEAGUE_HOME": str(home)}
    env.pop("ARENA_LEAGUE_DB", None)
    out = subprocess.run([sys.executable, "-c", "import json; " + probe], env=env, capture_output=True,
                         text=True, check=True).stdout
    assert json.loads(out.strip().splitlines()[-1]) == []


@pytest.mark.slow
def test_population_build_plays_the_round_robin_it_is_told(capsys, home, tmp_path):
    """``--matches-per-pair`` reaches the build (the shipped populations' READMEs give theirs): two
    tuned heuristics and the two references meet once per pair, six matches."""
    out = tmp_path / "base-t1"
    code, _, err = run(capsys, "population", "build", "PushBox-2T2P-v1", "--schemes", "none", "--scripted",
                       "heuristic-lane0.6", "heuristic-lane1", "--size", "2", "--matches-per-pair", "1",
                       "--work-dir", tmp_path / "work", "--out-dir", out, "--json")
    assert code == 0, err
    assert "round robin: 4 agents, 6 matches in 1 chunks" in err
    assert json.loads((out / "population.json").read_text())["provenance"]["build"]["matches_per_pair"] == 1
