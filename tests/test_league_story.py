"""One story in every view of a game's ratings: the leaderboard of a game with a base population
shows the members at their frozen ratings and every entrant where its latest placement against
that population put it, so the table says what the ranking said; boards re-rated from the stored
matches stay one choice away, for every method."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from rich.console import Console

from arena_league.league.first_league import quickstart
from arena_league.league.home import open_home
from arena_league.league.leaderboards import METHODS, rank_text, render_terminal
from arena_league.league.populations import import_population, shipped_population
from arena_league.league.service import LEAGUE_WIDE, ensure_scripted_agents, evaluate, leaderboard, rank
from arena_league.policies import init_parameters, save_arena_policy
from arena_league.policies.architecture import Architecture
from arena_league.policies.families import with_spaces
from arena_league.policies.spaces import game_action_spec

GAME = "GoBang-2T1P-v1"
RATINGS = [1150.0, 1080.0, 1000.0, 920.0, 850.0]
RANDOM, HEURISTIC = f"random@{GAME}", f"heuristic@{GAME}"


def small_population(league, folder: Path) -> str:
    """Five small MLPs with fresh weights (near-uniform play), frozen at RATINGS with intervals,
    written as a population folder and imported like a shipped one; returns ``name:version``."""
    arch = with_spaces(Architecture("mlp", 1, "discrete", n_actions=1, hidden=(8,)), game_action_spec(GAME))
    members = []
    for i, rating in enumerate(RATINGS):
        name = f"small.m{i}@{GAME}"
        save_arena_policy(folder / "agents" / f"m{i}", arch, init_parameters(arch, seed=i), GAME, name=name)
        members.append({"name": name, "kind": "base", "artifact": f"agents/m{i}", "format": "arena-policy",
                        "metadata": {"rating": rating, "rating_lower": rating - 60.0, "rating_upper": rating + 55.0},
                        "agent_metadata": {}})
    (folder / "population.json").write_text(json.dumps({"name": "small", "version": 1, "game_id": GAME,
                                                        "provenance": {}, "members": members}))
    return import_population(league, folder)


def board_rank(row) -> str:
    """The rank as the board writes it: rank (lower..upper), ``=`` marking a shared rank."""
    return rank_text(row.rank, row.rank_lower, row.rank_upper, row.tied)


def table_line(board, agent: str, width: int = 120) -> str:
    """The default terminal table's line of ``agent`` (its name shown without the game suffix)."""
    console = Console(width=width, record=True)
    console.print(render_terminal(board))
    short = agent.removesuffix(f"@{board.game_id}")
    return next(line for line in console.export_text().splitlines() if f" {short} " in line)


def assert_row_repeats_placement(row, placed) -> None:
    assert row.status == "placed"
    assert (row.rating, row.lower, row.upper) == (placed.rating, placed.lower, placed.upper)
    assert (row.rank, row.rank_lower, row.rank_upper) == (placed.rank, placed.rank_lower, placed.rank_upper)
    assert row.percentile == placed.percentile
    columns = row.method_columns
    assert (columns["percentile_lower"], columns["percentile_upper"]) == (placed.percentile_lower,
                                                                         placed.percentile_upper)
    assert columns["job_id"] == placed.job_id and columns["placement_matches"] == placed.matches


def test_quickstart_table_agrees_with_its_rank_line(tmp_path):
    """The README's first command: the example's line in the final table is its ranking."""
    with open_home(tmp_path / "league") as league:
        report = quickstart(league, budget=24, matches_per_pair=2)
    ranked, board = report.ranked, report.board
    assert board.basis == "population" and board.population == report.population == ranked.base == "base-v1:1"
    row = next(r for r in board.rows if r.agent == ranked.agent)
    assert_row_repeats_placement(row, ranked)
    assert len(board.rated_rows) == ranked.base_size + 1  # "of 101"
    line = table_line(board, ranked.agent)
    assert f" {board_rank(row)} " in line
    assert f" {ranked.rating:.0f} ({ranked.lower:.0f}..{ranked.upper:.0f}) " in line
    # the members at the ratings frozen with the population, the scripted agents pending (listed)
    manifest = json.loads((shipped_population("Crossroads-2T2P-v1") / "population.json").read_text())
    frozen = {m["name"]: m["metadata"] for m in manifest["members"]}
    members = [r for r in board.rows if r.status == "member"]
    assert len(members) == 100
    assert all((r.rating, r.lower, r.upper) == (frozen[r.agent]["rating"], frozen[r.agent]["rating_lower"],
                                                frozen[r.agent]["rating_upper"]) for r in members)
    assert [r.agent for r in board.rows if r.status == "pending"] == [
        "heuristic@Crossroads-2T2P-v1", "random@Crossroads-2T2P-v1"]
    assert board.nash_p is None and board.win_rate is None  # nothing re-rated from 26 matches


def test_entrants_stand_where_their_latest_placement_against_the_population_put_them(tmp_path):
    with open_home(tmp_path / "league") as league:
        label = small_population(league, tmp_path / "population")
        ensure_scripted_agents(league, GAME)
        first = rank(league, RANDOM, budget=40, population=label)
        # a ranking against every agent of the league is not a placement against the population
        rank(league, HEURISTIC, budget=120, population=LEAGUE_WIDE)
        board = leaderboard(league, GAME)
        assert board.population == label and board.basis == "population"
        assert board.to_dict()["population"] == label
        rows = {r.agent: r for r in board.rows}
        assert_row_repeats_placement(rows[RANDOM], first)
        assert rows[HEURISTIC].status == "pending" and rows[HEURISTIC].rating is None
        assert rows[HEURISTIC].matches > 0 and board.rows[-1].agent == HEURISTIC  # listed last, not hidden
        assert f" {board_rank(rows[RANDOM])} " in table_line(board, RANDOM)
        assert " pending " in table_line(board, HEURISTIC)

        # the newest placement counts; several entrants share the members' scale
        latest = rank(league, RANDOM, budget=40, population=label, seed=1)
        placed = rank(league, HEURISTIC, budget=40, population=label)
        board = leaderboard(league, GAME)
        rows = {r.agent: r for r in board.rows}
        assert rows[RANDOM].rating == latest.rating and rows[RANDOM].method_columns["job_id"] == latest.job_id
        for name, report in ((RANDOM, latest), (HEURISTIC, placed)):
            assert (rows[name].rank, rows[name].rank_lower, rows[name].rank_upper) == (
                report.rank, report.rank_lower, report.rank_upper)
        rated = board.rated_rows
        assert [r.rating for r in rated] == sorted((r.rating for r in rated), reverse=True)
        for row in rated:
            members_above = sum(other.rating > row.rating for other in rated if other.status == "member")
            assert row.rank == 1 + members_above and row.rank_lower <= row.rank <= row.rank_upper
        assert [(r.rating, r.lower, r.upper) for r in rated if r.status == "member"] == [
            (x, x - 60.0, x + 55.0) for x in RATINGS]
        # same league, same board
        assert leaderboard(league, GAME, save=False).to_dict() == leaderboard(league, GAME, save=False).to_dict()
        assert leaderboard(league, GAME, population=label, save=False).to_dict() == board.to_dict()


def test_boards_re_rated_from_matches_keep_every_method(tmp_path):
    with open_home(tmp_path / "league") as league:
        label = small_population(league, tmp_path / "population")
        names = ensure_scripted_agents(league, GAME)
        evaluate(league, GAME, names, matches_per_pair=4)
        rank(league, RANDOM, budget=24, population=label)
        for method in METHODS:
            board = leaderboard(league, GAME, method, population=LEAGUE_WIDE, rounds=20, save=False)
            assert board.basis == "matches" and board.population is None and board.method == method
            assert set(names) <= {r.agent for r in board.rated_rows}
            assert {r.status for r in board.rows} == {"rated", "pending"}  # members without matches listed
            if method != "bt":  # the base population's board is Bradley-Terry's; other methods re-rate
                assert leaderboard(league, GAME, method, rounds=20, save=False).to_dict() == board.to_dict()
        with pytest.raises(ValueError, match="no population 'smal' of GoBang-2T1P-v1.*small:1"):
            leaderboard(league, GAME, population="smal")


def test_a_placement_stored_under_the_old_names_of_the_rank_ends_still_stands_on_the_board(tmp_path):
    from arena_league import registry as reg
    from arena_league.league.views import agent_view

    with open_home(tmp_path / "league") as league:
        label = small_population(league, tmp_path / "population")
        ensure_scripted_agents(league, GAME)
        stored = {"agent": RANDOM, "game_id": GAME, "base": label, "base_size": 5, "rating": 1040.0,
                  "lower": 960.0, "upper": 1110.0, "rank": 3, "rank_best": 2, "rank_worst": 4, "percentile": 40.0,
                  "percentile_lower": 20.0, "percentile_upper": 60.0, "matches": 30, "level": 0.95}
        with league.transaction() as session:
            reg.record_finished_job(session, "rank", {"agent": RANDOM, "game_id": GAME, "base_label": label}, stored)
        row = next(r for r in leaderboard(league, GAME).rows if r.agent == RANDOM)
        assert row.status == "placed" and (row.rank, row.rank_lower, row.rank_upper) == (3, 2, 4)
        placement = agent_view(league, RANDOM)["placements"][0]
        assert (placement["rank_lower"], placement["rank_upper"]) == (2, 4) and "rank_best" not in placement
