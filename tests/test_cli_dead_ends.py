"""No dead ends at the terminal: a board of a game whose base population ships but is not
imported yet imports it; every name a board shows is taken by the commands that take an agent;
a match is one id, the one its web page carries, in `matches` and `replay`."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import GOBANG, run

from arena_league.league import ensure_scripted_agents, evaluate, open_home, short_name

pytest_plugins = ["cli_helpers"]  # the home fixture
CROSSROADS = "Crossroads-2T2P-v1"


@pytest.fixture
def two_games(home):
    """A league with the scripted agents of GoBang and Crossroads (both named random and heuristic
    on their boards), one match each."""
    with open_home(home) as league:
        for game in (GOBANG, CROSSROADS):
            ensure_scripted_agents(league, game)
            evaluate(league, game, matches_per_pair=1)
    return home


@pytest.mark.slow
def test_the_board_of_a_shipped_but_not_imported_base_imports_it(home, capsys):
    code, board, err = run(capsys, "leaderboard", CROSSROADS, "--json")
    assert code == 0, err
    assert board["population"] == "base-v1:1" and len(board["rows"]) == 100
    assert f"importing base-v1 of {CROSSROADS}" in err


def test_a_board_no_command_can_fill_says_what_does(home, capsys):
    code, _, err = run(capsys, "leaderboard", "Soccer-2T3P-v1")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "no base population ships" in err and "arena-league submit" in err
    code, _, err = run(capsys, "leaderboard", CROSSROADS, "--method", "elo")
    assert code == 2 and f"`arena-league leaderboard {CROSSROADS}` imports the shipped base population" in err


def test_every_name_a_board_shows_is_taken_by_the_agent_commands(two_games, capsys):
    for game in (GOBANG, CROSSROADS):
        code, board, _ = run(capsys, "leaderboard", game, "--method", "elo", "--json")
        assert code == 0
        for row in board["rows"]:
            shown = short_name(row["agent"], game)
            assert shown != row["agent"]  # the board drops the @game suffix
            code, detail, err = run(capsys, "agent", shown, "--game", game, "--json")
            assert code == 0, err
            assert detail["name"] == row["agent"]
    code, matches, _ = run(capsys, "matches", GOBANG, "--agent", "heuristic", "--json")
    assert code == 0 and matches["matches"]
    code, _, err = run(capsys, "reinstate", "random", "--game", GOBANG)
    assert code == 2 and f"agent random@{GOBANG} is active, not suspended" in err


def test_a_short_name_of_several_games_or_a_typo_is_one_line_with_the_fix(two_games, capsys):
    code, _, err = run(capsys, "agent", "random")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert f"random@{CROSSROADS}, random@{GOBANG}" in err and "--game GAME" in err
    code, _, err = run(capsys, "agent", "rando", "--game", GOBANG)
    assert code == 2 and "Did you mean 'random'?" in err
    code, _, err = run(capsys, "matches", CROSSROADS, "--agent", f"heuristic@{GOBANG}")
    assert code == 2 and f"plays {GOBANG}, not {CROSSROADS}" in err


def test_a_match_is_one_id_in_matches_replay_and_its_page(two_games, capsys):
    code, listed, _ = run(capsys, "matches", GOBANG, "--json")
    [match] = listed["matches"]
    assert match["page"] == f"/matches/{match['id']}" and match["match_key"].startswith("job:")
    assert match["replay"] is None
    code, _, err = run(capsys, "replay", match["id"])
    assert code == 2 and f"`arena-league replay {match['id']} --record`" in err
    code, replay, err = run(capsys, "replay", match["id"], "--record", "--json")
    assert code == 0, err
    assert replay["match"] == match["id"] and replay["page"] == match["page"]
    assert Path(replay["path"]).is_file()
    code, listed, _ = run(capsys, "matches", GOBANG, "--json")
    assert listed["matches"][0]["replay"] == replay["path"]
    # the table shows the id, the page and the whole replay path (folded, never cut)
    assert main_table_column(capsys, "matches", GOBANG) == replay["path"]


def main_table_column(capsys, *argv) -> str:
    """The last column of the one row of the table ``arena-league ARGV`` prints, its folded lines joined."""
    from arena_league.cli import main

    main(list(argv))
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("│")]
    return "".join(line.split("│")[-2].strip() for line in lines)


def test_a_match_id_that_is_not_one_is_one_line_with_the_fix(two_games, capsys):
    for given, expected in (("99999", "there is no match 99999"), ("abc", "'abc' is not a match id"),
                            ("job:1:5", "there is no match job:1:5")):
        code, _, err = run(capsys, "replay", given)
        assert code == 2 and len(err.strip().splitlines()) == 1 and expected in err


def test_matches_links_each_page_on_the_server_it_is_given(two_games, capsys):
    code, listed, _ = run(capsys, "matches", GOBANG, "--server", "http://127.0.0.1:8000/", "--json")
    [match] = listed["matches"]
    assert code == 0 and match["page"] == f"http://127.0.0.1:8000/matches/{match['id']}"
    code, _, err = run(capsys, "matches", GOBANG, "--server", "localhost:8000")
    assert code == 2 and "must start with http:// or https://" in err


def test_a_match_reads_as_one_result_per_team_in_the_table_and_its_json(two_games, capsys):
    code, listed, _ = run(capsys, "matches", CROSSROADS, "--json")
    assert code == 0
    [match] = listed["matches"]
    teams = {}
    for seat in match["seats"]:
        teams.setdefault(seat["team"], (short_name(seat["agent"], CROSSROADS), seat["outcome"]))
    # two seats of a team held by one agent name it once, with the team's outcome
    assert match["result"] == " vs ".join(f"{name} ({outcome})" for name, outcome in teams.values())
    from arena_league.cli import main

    main(["matches", CROSSROADS])
    table = capsys.readouterr().out
    assert all(name in table for name, _ in teams.values()) and f"@{CROSSROADS}" not in table
