"""A placement's matches depend on the seed, the entrant and the base only: the same seed gives the
same placement in two leagues (whatever else they played) and, asked again in one league, the stored
one; --more and another seed add matches to it; the report says why it stopped."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from placement_helpers import scripted_base_with_entrant

from arena_league.cli import main
from arena_league.league import leaderboard, open_home, rank
from arena_league.registry import (
    count_matches,
    match_seat_rows,
)

GAME = "Crossroads-2T2P-v1"
PLACEMENT = ("rating", "lower", "upper", "rank", "rank_lower", "rank_upper", "percentile", "percentile_lower",
             "percentile_upper", "matches", "seeds", "stopped", "stop_reason")


def seed_league(home: Path, *, history: bool = False) -> None:
    scripted_base_with_entrant(home, GAME, history=history)


def placement(report) -> dict:
    return {key: getattr(report, key) for key in PLACEMENT}


def entrant_match_seeds(league) -> list[int]:
    with league.reading() as session:
        rows = match_seat_rows(session, GAME, agents=["alice"])
    return [row["seed"] for row in rows if row["agent"] == "alice"]


@pytest.mark.slow
def test_one_seed_gives_one_placement_in_two_leagues_and_is_stored_the_second_time(tmp_path):
    seed_league(tmp_path / "fresh")
    seed_league(tmp_path / "busy", history=True)
    with open_home(tmp_path / "fresh") as league:
        first = rank(league, "alice", budget=30, seed=4)
        first_seeds = entrant_match_seeds(league)
        with league.reading() as session:
            stored_matches = count_matches(session, GAME)
        again = rank(league, "alice", budget=30, seed=4)
        with league.reading() as session:
            assert count_matches(session, GAME) == stored_matches  # nothing played the second time
    with open_home(tmp_path / "busy") as league:
        other = rank(league, "alice", budget=30, seed=4)
        assert entrant_match_seeds(league) == first_seeds
    assert other.job_id != first.job_id and first.played == first.matches >= 20
    assert placement(other) == placement(first)
    assert again.stored and not first.stored and again.played == 0 and again.job_id == first.job_id
    assert placement(again) == placement(first)


@pytest.mark.slow
def test_more_and_another_seed_add_matches_and_the_board_shows_them(tmp_path):
    seed_league(tmp_path / "a")
    seed_league(tmp_path / "b", history=True)
    reports = {}
    for name in ("a", "b"):
        with open_home(tmp_path / name) as league:
            first = rank(league, "alice", budget=30)
            more = rank(league, "alice", budget=30, more=10)
            second_seed = rank(league, "alice", budget=30, seed=1)
            back = rank(league, "alice", seed=0)
            board = leaderboard(league, GAME, population="scripted")
            row = next(r for r in board.rows if r.agent == "alice")
        reports[name] = (first, more, second_seed, back, row)
    first, more, second_seed, back, row = reports["a"]
    assert more.matches == first.matches + 10 and more.played == 10 and more.stopped == "more"
    assert more.upper - more.lower <= first.upper - first.lower
    assert more.rank_upper - more.rank_lower <= first.rank_upper - first.rank_lower
    assert second_seed.seeds == {"0": first.matches + 10, "1": second_seed.played}
    assert second_seed.matches == more.matches + second_seed.played and second_seed.played >= 20
    assert back.stored and placement(back) == placement(second_seed)  # seed 0 is held: the newest placement
    assert row.matches == second_seed.matches and row.rating == pytest.approx(second_seed.rating)
    for mine, theirs in zip(reports["a"][:4], reports["b"][:4]):  # the same asks give the same placements
        assert placement(mine) == placement(theirs)


def test_rank_says_why_it_stopped_and_when_it_is_stored(tmp_path, capsys):
    seed_league(tmp_path / "league")
    league_args = ["--home", str(tmp_path / "league")]
    assert main(["rank", "alice", "--budget", "6", "--seed", "2", *league_args, "--json"]) == 0
    short = json.loads(capsys.readouterr().out)
    assert short["stopped"] == "budget" and short["matches"] == 6
    assert "the budget of 6 matches ran out" in short["stop_reason"] and "evidence" not in short
    assert main(["rank", "alice", "--budget", "60", *league_args]) == 0
    out = capsys.readouterr().out
    assert "played now under seed 0, continuing the stored placement (seeds 2, 0)" in out
    assert "stopped     the rank interval reached the target half-width of 3 places after" in out
    assert main(["rank", "alice", "--budget", "60", *league_args]) == 0
    out = capsys.readouterr().out
    assert "from the stored placement (job" in out and "seeds 2, 0); --more N or another --seed to add evidence" in out
    assert main(["rank", "alice", "--more", "4", *league_args, "--json"]) == 0
    grown = json.loads(capsys.readouterr().out)
    assert grown["played"] == 4 and grown["stopped"] == "more" and not grown["stored"]
    assert main(["rank", "--members", "alice", "--more", "4", *league_args]) == 2
    assert "--more continues one agent's placement" in capsys.readouterr().err


def test_a_placement_stores_only_the_matches_it_counts(tmp_path):
    # an odd --more ends mid-pair: the pair's second match must not be played and stored uncounted
    seed_league(tmp_path / "league")
    with open_home(tmp_path / "league") as league:
        first = rank(league, "alice", budget=6, seed=2)
        grown = rank(league, "alice", more=3)
        assert grown.played == 3 and grown.matches == first.matches + 3
        with league.reading() as session:
            assert count_matches(session, GAME) == grown.matches  # alice played every match of this league


def test_the_queue_says_what_a_queued_placement_will_play(tmp_path):
    from arena_league.league import job_rows, queue_rank

    home = tmp_path / "league"
    seed_league(home)
    with open_home(home) as league:
        queue_rank(league, "alice", seed=3, more=7)
        queue_rank(league, "alice", budget=50)
        what = [row["what"] for row in job_rows(league, kind="rank")]
    # the base is found when the job runs; until then the row says whose it will be
    assert sorted(what) == ["alice against its game's base population, 7 more matches, seed 3",
                            "alice against its game's base population, budget 50, seed 0"]
