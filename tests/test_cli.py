"""The `arena-league` command: each command end to end on a temporary league, JSON on stdout."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from arena_league.cli import main

GAME = "GoBang-2T1P-v1"


@pytest.fixture
def league_args(tmp_path, monkeypatch):
    monkeypatch.delenv("ARENA_LEAGUE_DB", raising=False)
    monkeypatch.delenv("ARENA_LEAGUE_HOME", raising=False)
    return ["--home", str(tmp_path / "home")]


def run(capsys, *argv) -> tuple[int, dict]:
    code = main([str(a) for a in argv])
    out = capsys.readouterr().out
    return code, json.loads(out) if out.strip() else {}


def test_games_lists_every_id_with_its_tree(capsys):
    code, doc = run(capsys, "games", "--json")
    ids = [g["game_id"] for g in doc["games"]]
    assert code == 0 and "Crossroads-2T2P-v1" in ids and "GoBang-2T1P-v1" in ids
    crossroads = next(g for g in doc["games"] if g["game_id"] == "Crossroads-2T2P-v1")
    assert crossroads["default_tree"]["scheme"] == "CP" and crossroads["action_types"] == ["discrete", "continuous"]


def seed_league(capsys, league_args):
    """Scripted agents of GoBang, through a quickstart on that game."""
    code, doc = run(capsys, "quickstart", "--game", GAME, "--matches-per-pair", "4", "--no-base", *league_args,
                    "--json")
    assert code == 0 and doc["evaluation"]["played"] == 4
    return doc


def test_quickstart_evaluate_with_replays_and_replay_gif(capsys, league_args, tmp_path):
    seed_league(capsys, league_args)
    code, doc = run(capsys, "evaluate", GAME, "--matches-per-pair", "6", "--record", *league_args, "--json")
    assert code == 0 and doc["played"] == 2
    code, doc = run(capsys, "matches", GAME, "--limit", "2", *league_args, "--json")
    replay = doc["matches"][0]["replay"]
    assert replay and Path(replay).exists() and replay.endswith(".mcap")
    gif = tmp_path / "match.gif"
    code, summary = run(capsys, "replay", replay, "--gif", gif, "--json")
    assert code == 0 and summary["game_id"] == GAME and summary["gif"]["frames"] > 3 and gif.stat().st_size > 0


def test_queued_job_runs_in_a_worker(capsys, league_args):
    seed_league(capsys, league_args)
    code, doc = run(capsys, "evaluate", GAME, "--matches-per-pair", "8", "--queue", *league_args, "--json")
    assert code == 0 and isinstance(doc["queued"], int)
    code, report = run(capsys, "worker", "--until-idle", "--poll", "0.1", *league_args, "--json")
    assert code == 0 and report["completed"] == 1 and report["jobs"] == [doc["queued"]]
    code, matches = run(capsys, "matches", GAME, "--limit", "100", *league_args, "--json")
    assert len(matches["matches"]) == 8


def test_schedules_and_scheduler_tick(capsys, league_args):
    seed_league(capsys, league_args)
    code, doc = run(capsys, "schedule", "add", "hourly", "--game", GAME, "--every", "3600", *league_args, "--json")
    assert code == 0 and doc["interval_seconds"] == 3600
    code, doc = run(capsys, "schedule", "add", "bad", "--game", GAME, "--cron", "every day", *league_args, "--json")
    assert code == 2 and "cron" in doc["error"]
    code, doc = run(capsys, "schedule", "add", "both", "--game", GAME, "--every", "5", "--cron", "* * * * *",
                    *league_args, "--json")
    assert code == 2 and "exactly one" in doc["error"]
    code, doc = run(capsys, "schedule", "list", *league_args, "--json")
    assert [s["name"] for s in doc["schedules"]] == ["hourly"]
    code, first = run(capsys, "scheduler", "tick", *league_args, "--json")
    code, second = run(capsys, "scheduler", "tick", *league_args, "--json")
    assert len(first["queued"]) == 1 and second["queued"] == []  # not due again for an hour
    code, report = run(capsys, "worker", "--until-idle", "--poll", "0.1", *league_args, "--json")
    assert report["completed"] == 1


def test_population_export_and_import(capsys, league_args, tmp_path):
    seed_league(capsys, league_args)
    from arena_league.league import open_home
    from arena_league.registry import add_population_member, create_population, freeze_population, get_agent

    home = Path(league_args[1])
    with open_home(home) as league, league.transaction() as session:
        population = create_population(session, "scripted", GAME, provenance={"made_by": "test"})
        for name in (f"random@{GAME}", f"heuristic@{GAME}"):
            add_population_member(session, population, get_agent(session, name), {"rating": 1000.0})
        freeze_population(session, population)
    out = tmp_path / "exported"
    code, doc = run(capsys, "population", "export", "--population", "scripted", "--destination", out,
                    *league_args, "--json")
    assert code == 0 and (out / "population.json").exists()
    other = ["--home", str(tmp_path / "other")]
    code, doc = run(capsys, "population", "import", out, "--name", "imported", *other, "--json")
    assert code == 0 and doc["imported"] == "imported:1"
    code, doc = run(capsys, "population", "list", *other, "--json")
    assert doc["populations"] == [{"name": "imported", "version": 1, "game_id": GAME, "frozen": True, "members": 2}]


def test_leaderboard_html_and_methods(capsys, league_args, tmp_path):
    seed_league(capsys, league_args)
    html = tmp_path / "board.html"
    code, doc = run(capsys, "leaderboard", GAME, "--population", "league", "--html", html, *league_args, "--json")
    assert code == 0 and doc["rows"][0]["agent"] == f"heuristic@{GAME}"
    text = html.read_text()
    assert "heuristic@" in text and text.count("data:image/png;base64") >= 3 and 'src="http' not in text
    for method in ("elo", "openskill", "nash", "alpharank"):
        code, doc = run(capsys, "leaderboard", GAME, "--method", method, *league_args, "--json")
        assert code == 0 and doc["method"] == method and len(doc["rows"]) == 2


def test_quickstart_ranks_against_the_shipped_base_population(capsys, league_args):
    code, doc = run(capsys, "quickstart", "--game", GAME, "--matches-per-pair", "2", *league_args, "--json")
    assert code == 0 and doc["population"] == "base-v2:1"  # GoBang's newest shipped population
    code, listing = run(capsys, "population", "list", *league_args, "--json")
    assert listing["populations"][0]["members"] == 100 and listing["populations"][0]["frozen"]


def test_default_quickstart_ranks_the_example_against_crossroads_base_population(capsys, league_args):
    """The README's first command: the example submission placed among the shipped 100 agents."""
    code, doc = run(capsys, "quickstart", "--budget", "24", *league_args, "--json")
    assert code == 0 and doc["population"] == "base-v1:1"
    ranked = doc["rank"]
    assert ranked["agent"] == "example-mlp" and ranked["base_size"] == 100 and ranked["matches"] >= 20
    assert 1 <= ranked["rank_lower"] <= ranked["rank"] <= ranked["rank_upper"] <= 101
    assert ranked["percentile_lower"] <= ranked["percentile"] <= ranked["percentile_upper"]


def test_leaderboard_of_an_empty_league_says_what_to_do(capsys, league_args):
    code, doc = run(capsys, "leaderboard", "Crossroads-2T1P-v1", *league_args, "--json")  # no base ships for it
    assert code == 2 and "arena-league evaluate" in doc["error"]


def test_rank_of_an_unknown_agent(capsys, league_args):
    code, doc = run(capsys, "rank", "nobody", *league_args, "--json")
    assert code == 2 and "nobody" in doc["error"]


def test_train_with_a_warm_start_records_it(capsys, tmp_path):
    code, doc = run(capsys, "train", "Crossroads-2T1P-v1", "--scheme", "ppo", "--steps", "64", "--warm-start", "300",
                    "--hidden", "8", "--eval-matches", "2", "--out", tmp_path / "snaps", "--json")
    assert code == 0 and doc["snapshots"]
    manifest = json.loads((Path(doc["snapshots"][-1]["path"]) / "manifest.json").read_text())
    assert manifest["provenance"]["metrics"]["warm_start"]["options"]["steps"] == 300
    assert manifest["sizes"]["hidden"] == [8]
