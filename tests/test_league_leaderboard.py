"""Leaderboards from stored matches: every method on simulated leagues of known strength; the board
of a base population (members frozen, entrants placed); the views' columns and widths."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

from arena_league.league import leaderboards
from arena_league.league.leaderboards import (
    AGENT_LINE_WIDTH,
    METHODS,
    EntrantPlacement,
    FrozenRating,
    Leaderboard,
    LeaderboardError,
    compute_leaderboard,
    leaderboard_table,
    outcome_table,
    population_leaderboard,
    rank_text,
    render_terminal,
    short_name,
)
from arena_league.rating import bootstrap, place_entrant

GAME = "Duel-2T1P-v1"
STRENGTHS = [-300.0, -150.0, 0.0, 100.0, 250.0, 400.0]  # Elo points; agent-5 is the best


def simulated_league(strengths, n_matches, seed=0, draw_share=0.05, prefix="agent"):
    """Seat rows of a two-team league, one agent per team, Bradley-Terry outcomes on the Elo scale."""
    rng = np.random.default_rng(seed)
    names = [f"{prefix}-{i}" for i in range(len(strengths))]
    strengths = np.asarray(strengths, dtype=float)
    rows = []
    for match in range(n_matches):
        a, b = rng.choice(len(names), 2, replace=False)
        p_first = 1.0 / (1.0 + 10 ** ((strengths[b] - strengths[a]) / 400.0))
        u = rng.random()
        if u < draw_share:
            outcomes = ("draw", "draw")
        elif u < draw_share + (1 - draw_share) * p_first:
            outcomes = ("win", "loss")
        else:
            outcomes = ("loss", "win")
        for seat, (agent, outcome) in enumerate(zip((a, b), outcomes)):
            rows.append({"match_id": match, "seat": seat, "agent": names[agent], "team": seat,
                         "score": 1.0 if outcome == "win" else 0.0, "outcome": outcome, "position": None})
    return rows, names


def free_for_all(strengths, n_matches, n_teams=4, seed=0):
    """Seat rows of free-for-all matches with finishing positions drawn from Plackett-Luce."""
    rng = np.random.default_rng(seed)
    names = [f"ffa-{i}" for i in range(len(strengths))]
    theta = np.asarray(strengths, dtype=float) * math.log(10) / 400.0
    rows = []
    for match in range(n_matches):
        seated = rng.choice(len(names), n_teams, replace=False)
        finish = np.argsort(-(theta[seated] + rng.gumbel(size=n_teams)))
        position = np.empty(n_teams, dtype=int)
        position[finish] = np.arange(1, n_teams + 1)
        for team, (agent, pos) in enumerate(zip(seated, position)):
            rows.append({"match_id": f"m{match}", "seat": team, "agent": names[agent], "team": team,
                         "score": float(n_teams - pos), "outcome": "win" if pos == 1 else "loss",
                         "position": int(pos)})
    return rows, names


def cyclic_league(per_pair=50, wins=40):
    """Rock-paper-scissors: rock beats scissors, scissors beat paper, paper beats rock, 40 of 50."""
    rows = []
    match = 0
    for winner, loser in (("rock", "scissors"), ("scissors", "paper"), ("paper", "rock")):
        for k in range(per_pair):
            first, second = (winner, loser) if k < wins else (loser, winner)
            for seat, (agent, outcome) in enumerate(((first, "win"), (second, "loss"))):
                rows.append({"match_id": match, "seat": seat, "agent": agent, "team": seat, "score": 0.0,
                             "outcome": outcome, "position": None})
            match += 1
    return rows


def kinds(names, kind="trained"):
    return {name: {"kind": kind} for name in names}


@pytest.fixture(scope="module")
def league():
    rows, names = simulated_league(STRENGTHS, 600, seed=3)
    info = kinds(names) | {"idle-submission": {"kind": "submission"}}
    return rows, names, info


def walk(value):
    """Every leaf of a nested JSON-like value."""
    if isinstance(value, dict):
        for item in value.values():
            yield from walk(item)
    elif isinstance(value, list):
        for item in value:
            yield from walk(item)
    else:
        yield value


def test_bradley_terry_recovers_the_true_order_with_intervals(league):
    rows, names, info = league
    board = compute_leaderboard(rows, info, GAME, "bt", rounds=100, seed=0)
    rated = board.rated_rows
    assert [r.agent for r in rated] == names[::-1]  # strongest first
    assert board.agents == names[::-1] and board.n_matches == 600
    for position, row in enumerate(rated, start=1):
        assert row.lower <= row.rating <= row.upper
        assert row.rank == position and row.rank_lower <= row.rank <= row.rank_upper
        assert 0.0 <= row.win_rate <= 1.0
        assert row.kind == "trained"
    assert sum(r.matches for r in rated) == 2 * 600
    assert rated[0].percentile == 100.0 and rated[-1].percentile == 0.0
    assert rated[0].rank == 1 and rated[-1].rank_upper == len(names)
    # 700 Elo points between the ends: ratings spread accordingly around the mean of 1000
    assert 500 < rated[0].rating - rated[-1].rating < 900
    assert np.isclose(np.mean([r.rating for r in rated]), 1000.0)
    # every method's point estimates come with the board
    assert {"nash_mass", "nash_score", "alpharank_mass", "percentile_lower"} <= set(rated[0].method_columns)
    assert rated[0].method_columns["nash_mass"] == pytest.approx(1.0, abs=1e-6)  # transitive league


def test_an_agent_without_matches_is_listed_unrated_at_the_bottom(league):
    rows, names, info = league
    board = compute_leaderboard(rows, info, GAME, "bt")
    idle = board.rows[-1]
    assert idle.agent == "idle-submission" and idle.kind == "submission"
    assert idle.rating is None and idle.rank is None and idle.matches == 0 and not idle.rated
    assert "idle-submission" not in board.agents
    assert len(board.rows) == len(names) + 1


def test_win_rate_matrix_holds_counts_in_leaderboard_order(league):
    rows, names, info = league
    board = compute_leaderboard(rows, info, GAME, "bt")
    W, games = board.win_rate, board.games
    assert W.shape == games.shape == (len(names), len(names))
    played = games > 0
    np.testing.assert_allclose((W + W.T)[played], 1.0)
    assert games.sum() / 2 == 600
    # the best agent beats the worst far more often than not
    assert W[0, -1] > 0.8
    match_counts = {r.agent: r.matches for r in board.rated_rows}
    np.testing.assert_array_equal(games.sum(axis=1), [match_counts[a] for a in board.agents])


def test_to_dict_is_plain_json_and_deterministic(league):
    rows, _, info = league
    first = compute_leaderboard(rows, info, GAME, "nash", rounds=20, seed=1).to_dict()
    second = compute_leaderboard(rows, info, GAME, "nash", rounds=20, seed=1).to_dict()
    assert json.dumps(first, allow_nan=False) == json.dumps(second, allow_nan=False)
    assert all(v is None or type(v) in (str, int, float, bool) for v in walk(first))
    assert first["method"] == "nash" and first["n_rated"] == 6 and first["n_agents"] == 7
    assert first["win_rate"][0][0] == 0.5
    assert len(first["rows"]) == 7 and first["rows"][-1]["rating"] is None
    # a pair that never played has no win rate: NaN in the board, null in JSON
    chain = [{"match_id": m, "seat": s, "agent": agent, "team": s, "score": 0.0, "outcome": outcome}
             for m, pair in enumerate((("a", "b"), ("b", "c"), ("b", "a"))) for s, (agent, outcome) in
             enumerate(zip(pair, ("win", "loss")))]
    board = compute_leaderboard(chain, kinds("abc"), GAME, "bt", rounds=10)
    a, c = board.agents.index("a"), board.agents.index("c")
    assert np.isnan(board.win_rate[a, c]) and board.to_dict()["win_rate"][a][c] is None


def test_elo_is_sorted_by_online_elo_with_bradley_terry_columns(league):
    rows, names, info = league
    board = compute_leaderboard(rows, info, GAME, "elo")
    rated = board.rated_rows
    elo = [r.rating for r in rated]
    assert elo == sorted(elo, reverse=True)
    assert rated[0].agent == names[-1] and rated[-1].agent == names[0]
    for row in rated:
        assert row.lower is None and row.upper is None
        c = row.method_columns
        assert c["bt_lower"] <= c["bt_rating"] <= c["bt_upper"]
        assert c["bt_rank_lower"] <= c["bt_rank"] <= c["bt_rank_upper"]
    assert board.params["elo_k"] == 32.0
    # online Elo starts everyone at 1000 and is zero-sum
    assert np.mean(elo) == pytest.approx(1000.0)


def test_nash_and_alpharank_are_uniform_on_rock_paper_scissors():
    rows = cyclic_league()
    info = kinds(["rock", "paper", "scissors"])
    nash = compute_leaderboard(rows, info, GAME, "nash", rounds=50)
    np.testing.assert_allclose(nash.nash_p, 1 / 3, atol=1e-6)
    np.testing.assert_allclose([r.rating for r in nash.rows], 0.0, atol=1e-9)  # all in the support
    assert all(r.lower <= r.upper for r in nash.rows)
    assert nash.intransitivity > 0.99
    alpharank = compute_leaderboard(rows, info, GAME, "alpharank", rounds=50)
    np.testing.assert_allclose(alpharank.alpharank_pi, 1 / 3, atol=1e-6)
    np.testing.assert_allclose([r.rating for r in alpharank.rows], 1 / 3, atol=1e-6)
    assert all(r.lower <= r.rating + 1e-9 and r.rating - 1e-9 <= r.upper for r in alpharank.rows)
    assert alpharank.params["alpha_from_sweep"] and alpharank.alpharank_alpha > 0
    # equal masses share rank 1, shown as a tie, and each interval spans the three places
    assert all((r.rank, r.rank_lower, r.rank_upper, r.tied) == (1, 1, 3, True) for r in alpharank.rows)
    # win rates: 80% around the cycle
    assert nash.win_rate[nash.agents.index("rock"), nash.agents.index("scissors")] == pytest.approx(0.8)


def test_nash_and_alpharank_favour_the_strong_in_a_transitive_league(league):
    rows, names, info = league
    nash = compute_leaderboard(rows, info, GAME, "nash", rounds=30)
    assert nash.rated_rows[0].agent == names[-1] and nash.rated_rows[0].rating == pytest.approx(0.0, abs=1e-9)
    assert all(r.rating <= 1e-9 for r in nash.rated_rows)
    alpharank = compute_leaderboard(rows, info, GAME, "alpharank", rounds=30, alpha=1.0)
    assert alpharank.alpharank_alpha == 1.0 and not alpharank.params["alpha_from_sweep"]
    masses = {r.agent: r.rating for r in alpharank.rated_rows}
    assert masses[names[-1]] > masses[names[0]]
    assert sum(masses.values()) == pytest.approx(1.0)


def test_openskill_rates_a_four_team_free_for_all_by_position():
    rows, names = free_for_all([-400.0, -200.0, 0.0, 200.0, 400.0], 400, n_teams=4, seed=5)
    board = compute_leaderboard(rows, kinds(names), "Race-4T1P-v1", "openskill")
    rated = board.rated_rows
    assert rated[0].agent == "ffa-4" and rated[-1].agent == "ffa-0"
    conservative = [r.method_columns["conservative"] for r in rated]
    assert conservative == sorted(conservative, reverse=True) and board.sort_by == "lower"
    for row in rated:
        c = row.method_columns
        assert c["sigma"] > 0 and c["mu"] == row.rating
        assert row.lower == pytest.approx(c["mu"] - 3 * c["sigma"]) and row.upper == pytest.approx(c["mu"] + 3 * c["sigma"])
    # 4 seats per match, the winner beats 3 teams
    assert sum(r.matches for r in rated) == 4 * 400
    assert rated[0].win_rate > 0.6 and rated[-1].win_rate < 0.4
    # one agent per team: the free-for-all still reduces to pairwise results for Nash and alpha-Rank
    assert board.nash_p is not None and board.alpharank_pi is not None
    assert board.games.sum() / 2 == 6 * 400


@pytest.mark.parametrize("method", ["bt", "elo", "nash", "alpharank"])
def test_pairwise_methods_refuse_free_for_all_and_name_openskill(method):
    rows, names = free_for_all([0.0, 100.0, 200.0, 300.0], 20)
    with pytest.raises(LeaderboardError, match="openskill"):
        compute_leaderboard(rows, kinds(names), "Race-4T1P-v1", method)


def test_teams_of_mixed_agents_need_openskill():
    rng = np.random.default_rng(0)
    names = ["a", "b", "c", "d"]
    strength = {"a": 2.0, "b": 1.0, "c": 0.0, "d": -1.0}
    rows = []
    for match in range(200):
        lineup = rng.permutation(names)
        teams = (lineup[:2], lineup[2:])
        edge = sum(strength[x] for x in teams[0]) - sum(strength[x] for x in teams[1])
        first_wins = rng.random() < 1 / (1 + math.exp(-edge))
        for seat, agent in enumerate(lineup):
            team = seat // 2
            won = first_wins == (team == 0)
            rows.append({"match_id": match, "seat": seat, "agent": str(agent), "team": team, "score": 0.0,
                         "outcome": "win" if won else "loss", "position": None})
    board = compute_leaderboard(rows, kinds(names), "Soccer-2T2P-v1", "openskill")
    assert board.rated_rows[0].agent == "a" and board.rated_rows[-1].agent == "d"
    assert board.win_rate is None and board.nash_p is None and board.intransitivity is None
    assert json.dumps(board.to_dict(), allow_nan=False)
    with pytest.raises(LeaderboardError, match="openskill"):
        compute_leaderboard(rows, kinds(names), "Soccer-2T2P-v1", "bt")


@pytest.mark.parametrize("method", METHODS)
def test_no_matches_says_to_play_matches_first(method):
    with pytest.raises(LeaderboardError, match=f"arena-league evaluate {GAME}"):
        compute_leaderboard([], kinds(["a", "b"]), GAME, method)


def test_fewer_than_two_rated_agents_says_to_play_matches_first():
    # an agent against copies of itself (the validation match) rates nobody
    mirror = [{"match_id": 1, "seat": s, "agent": "solo", "team": s, "score": 0.0, "outcome": o,
               "position": None} for s, o in enumerate(("win", "loss"))]
    with pytest.raises(LeaderboardError, match="at least two.*arena-league evaluate"):
        compute_leaderboard(mirror, kinds(["solo", "other"]), GAME, "bt")
    with pytest.raises(LeaderboardError, match="arena-league evaluate"):
        compute_leaderboard(mirror, kinds(["solo"]), GAME, "openskill")


def test_matches_against_itself_are_not_counted(league):
    rows, names, info = league
    mirror = [{"match_id": "self", "seat": s, "agent": names[0], "team": s, "score": 0.0, "outcome": o,
               "position": None} for s, o in enumerate(("win", "loss"))]
    plain = compute_leaderboard(rows, info, GAME, "bt", rounds=20)
    with_mirror = compute_leaderboard(rows + mirror, info, GAME, "bt", rounds=20)
    assert with_mirror.n_matches == 601
    before = {r.agent: (r.matches, r.win_rate, r.rating) for r in plain.rows}
    after = {r.agent: (r.matches, r.win_rate, r.rating) for r in with_mirror.rows}
    assert before == after


def test_seated_agents_missing_from_agents_info_are_listed_without_kind(league):
    rows, names, _ = league
    board = compute_leaderboard(rows, kinds(names[1:]), GAME, "bt", rounds=20)
    stray = next(r for r in board.rows if r.agent == names[0])
    assert stray.kind is None and stray.rated


def test_bad_input_is_refused_with_the_reason():
    with pytest.raises(LeaderboardError, match="unknown leaderboard method 'glicko'"):
        compute_leaderboard([], {}, GAME, "glicko")
    partial = [{"match_id": 1, "seat": 0, "agent": "a", "team": 0, "score": 0.0, "outcome": "win", "position": 1},
               {"match_id": 1, "seat": 1, "agent": "b", "team": 1, "score": 0.0, "outcome": "loss",
                "position": None}]
    with pytest.raises(LeaderboardError, match="position for some seats only"):
        compute_leaderboard(partial, {}, GAME, "openskill")
    with pytest.raises(LeaderboardError, match="lacks outcome"):
        outcome_table([{"match_id": 1, "seat": 0, "agent": "a", "team": 0, "score": 0.0}])
    both_win = [{"match_id": 1, "seat": s, "agent": a, "team": s, "score": 0.0, "outcome": "win"}
                for s, a in enumerate("ab")]
    with pytest.raises(LeaderboardError, match="every team has outcome 'win'"):
        compute_leaderboard(both_win, {}, GAME, "bt")


def test_positions_order_a_free_for_all_and_words_do_without_them():
    table = outcome_table([
        {"match_id": 1, "seat": 0, "agent": "a", "team": 0, "score": 0, "outcome": "loss", "position": 3},
        {"match_id": 1, "seat": 1, "agent": "b", "team": 1, "score": 0, "outcome": "win", "position": 1},
        {"match_id": 1, "seat": 2, "agent": "c", "team": 2, "score": 0, "outcome": "loss", "position": 2},
        {"match_id": 2, "seat": 0, "agent": "a", "team": 0, "score": 0, "outcome": "win"},
        {"match_id": 2, "seat": 1, "agent": "b", "team": 1, "score": 0, "outcome": "loss"},
        {"match_id": 2, "seat": 2, "agent": "c", "team": 2, "score": 0, "outcome": "loss"},
    ])
    assert table.place.tolist() == [2, 0, 1, 0, 1, 1]


def test_terminal_table_shows_rank_ranges_intervals_and_method_columns(league):
    rows, names, info = league
    for method, header in (("bt", "BT rating"), ("elo", "Elo"), ("openskill", "mu - 3 sigma"),
                           ("nash", "Nash score"), ("alpharank", "alpha-Rank mass")):
        board = compute_leaderboard(rows, info, GAME, method, rounds=20)
        console = Console(record=True, width=250)
        console.print(render_terminal(board, wide=True))
        text = console.export_text()
        assert header in text and "Win rate" in text and "Matches" in text
        assert all(name in text for name in names) and "unrated" in text
        if method != "elo":
            assert "±" in text or "+" in text
        # the default table: rank, agent, kind, the rating with its interval, matches
        console = Console(record=True, width=250)
        console.print(render_terminal(board))
        head = next(line for line in console.export_text().splitlines() if "Agent" in line)
        assert [cell.strip() for cell in head.strip("┃ ").split("┃")][:2] == ["Rank", "Agent"]
        assert "Kind" in head and "Matches" in head and "Win rate" not in head and "Percentile" not in head
    # a close league has uncertain ranks, shown as ranges
    close_rows, close_names = simulated_league([0.0, 10.0, 20.0, 30.0], 80, seed=1)
    console = Console(record=True, width=250)
    console.print(render_terminal(compute_leaderboard(close_rows, kinds(close_names), GAME, "bt")))
    assert "(1..4)" in console.export_text()


def seat_rows(matches):
    """Seat rows of (first agent, second agent, whether the first won) matches."""
    rows = []
    for match, (first, second, won) in enumerate(matches):
        for seat, (agent, outcome) in enumerate(((first, "win" if won else "loss"),
                                                 (second, "loss" if won else "win"))):
            rows.append({"match_id": 100_000 + match, "seat": seat, "agent": agent, "team": seat, "score": 0.0,
                         "outcome": outcome, "position": None})
    return rows


def test_a_method_whose_order_may_mislead_says_why_beside_the_table(league):
    rows, names, info = league
    # one lucky win against the best agent puts a newcomer on top of the Bradley-Terry board
    lucky = rows + seat_rows([("newcomer", names[-1], True)])
    everyone = info | {"newcomer": {"kind": "human"}}
    board = compute_leaderboard(lucky, everyone, GAME, "bt", rounds=20)
    assert board.rows[0].agent == "newcomer"
    assert any("newcomer (1, 1 match)" in note and "fewer than 10 matches" in note for note in board.notes)
    assert board.to_dict()["notes"] == board.notes
    console = Console(width=120, record=True)
    console.print(render_terminal(board))
    assert "newcomer (1, 1 match)" in " ".join(console.export_text().split())
    # a streak of wins early and of losses late: online Elo replayed backwards puts the other agent first
    streaks = seat_rows([("early", "late", True)] * 12 + [("early", "late", False)] * 12)
    elo = compute_leaderboard(streaks, kinds(["early", "late"]), GAME, "elo", rounds=20)
    assert elo.rows[0].agent == "late"
    assert "online Elo depends on match order: replayed in reverse order, 2 of 2 agents change rank and early " \
           "is first instead of late" in elo.notes
    # a ring where each agent met its two neighbours only: Nash and alpha-Rank fill the rest with 50%
    ring = seat_rows([(f"r{i}", f"r{(i + 1) % 12}", k % 3 != 0) for i in range(12) for k in range(5)])
    for method in ("nash", "alpharank"):
        sparse = compute_leaderboard(ring, kinds([f"r{i}" for i in range(12)]), GAME, method, rounds=20)
        assert any(note.startswith("only 12 of 66 pairs of agents met") for note in sparse.notes)
    # a balanced, well-played league has nothing to say
    assert compute_leaderboard(rows, info, GAME, "bt", rounds=20).notes == []


def test_every_method_returns_a_board(league):
    rows, _, info = league
    for method in METHODS:
        board = compute_leaderboard(rows, info, GAME, method, rounds=10)
        assert isinstance(board, Leaderboard) and board.method == method
        assert len(board.rated_rows) == 6 and board.rows[-1].agent == "idle-submission"
        assert board.nash_p is not None and board.alpharank_pi is not None
        assert 0.0 <= board.intransitivity < 0.3  # a transitive league


# --- each figure computed at most once, and only where the board shows it ------------------------

LEAGUE_FIGURES = ("bootstrap_ratings", "nash_averaging", "alpha_rank_sweep", "intransitivity")
"""Computed for the league beside any method whose matches reduce to pairwise results."""
OWN_FIGURES = {"elo": "elo_online", "openskill": "openskill_ratings", "nash": "nash_intervals",
               "alpharank": "alpha_rank_intervals"}
"""What one method alone computes."""


def count_calls(monkeypatch, module, names):
    """Wraps ``module``'s functions ``names`` to count their calls; returns the counts by name."""
    calls = dict.fromkeys(names, 0)
    for name in names:
        original = getattr(module, name)

        def counted(*args, _name=name, _original=original, **kwargs):
            calls[_name] += 1
            return _original(*args, **kwargs)

        monkeypatch.setattr(module, name, counted)
    return calls


def refuse(monkeypatch, module, names):
    """Makes ``module``'s functions ``names`` fail if called."""
    for name in names:
        def refused(*args, _name=name, **kwargs):
            raise AssertionError(f"{_name} was computed for a board that does not show it")

        monkeypatch.setattr(module, name, refused)


@pytest.mark.parametrize("method", METHODS)
def test_a_board_computes_each_figure_once_and_no_other_method_s(league, method, monkeypatch):
    rows, _, info = league
    refuse(monkeypatch, leaderboards, [own for other, own in OWN_FIGURES.items() if other != method])
    calls = count_calls(monkeypatch, leaderboards, [*LEAGUE_FIGURES, *OWN_FIGURES.get(method, "").split()])
    board = compute_leaderboard(rows, info, GAME, method, rounds=10)
    assert board.nash_p is not None and board.alpharank_pi is not None and board.intransitivity is not None
    # online Elo is played once more, backwards, to tell whether its order depends on the match order
    assert calls == {**dict.fromkeys(calls, 1), **({"elo_online": 2} if method == "elo" else {})}


def test_choosing_elo_runs_no_nash_or_alpharank_bootstrap_and_no_openskill(league, monkeypatch):
    rows, names, info = league
    plain = compute_leaderboard(rows, info, GAME, "elo", rounds=20).to_dict()
    refuse(monkeypatch, leaderboards, ["nash_intervals", "alpha_rank_intervals", "openskill_ratings"])
    assert compute_leaderboard(rows, info, GAME, "elo", rounds=20).to_dict() == plain
    refuse(monkeypatch, leaderboards, ["elo_online"])
    assert compute_leaderboard(rows, info, GAME, "bt", rounds=20).rated_rows[0].agent == names[-1]


def test_an_openskill_board_of_mixed_teams_computes_no_pairwise_figure(monkeypatch):
    rng = np.random.default_rng(1)
    rows = []
    for match in range(60):
        lineup = rng.permutation(["a", "b", "c", "d"])
        rows += [{"match_id": match, "seat": s, "agent": str(agent), "team": s // 2, "score": 0.0,
                  "outcome": "win" if s // 2 == match % 2 else "loss", "position": None}
                 for s, agent in enumerate(lineup)]
    refuse(monkeypatch, leaderboards, [*LEAGUE_FIGURES, "alpha_rank", "elo_online", "nash_intervals",
                                       "alpha_rank_intervals"])
    board = compute_leaderboard(rows, kinds("abcd"), "Soccer-2T2P-v1", "openskill")
    assert len(board.rated_rows) == 4 and board.nash_p is None


def test_a_method_s_own_score_is_solved_once_on_the_whole_league(league, monkeypatch):
    """The Nash method's point score is the league's Nash solve, not a second one; so with alpha-Rank.
    The whole league is solved once and each bootstrap replicate once: rounds + 1 solves."""
    rows, _, info = league
    nash = count_calls(monkeypatch, leaderboards, ["nash_averaging"])
    nash_replicates = count_calls(monkeypatch, bootstrap, ["nash_averaging"])
    compute_leaderboard(rows, info, GAME, "nash", rounds=12)
    assert nash["nash_averaging"] + nash_replicates["nash_averaging"] == 12 + 1
    alpha = count_calls(monkeypatch, leaderboards, ["alpha_rank"])
    alpha_replicates = count_calls(monkeypatch, bootstrap, ["alpha_rank"])
    compute_leaderboard(rows, info, GAME, "alpharank", rounds=12, alpha=1.0)
    assert alpha["alpha_rank"] + alpha_replicates["alpha_rank"] == 12 + 1


# --- the board of a base population, and the views' columns ------------------------------------------

SHIPPED = sorted((Path(__file__).resolve().parents[1] / "checkpoints").glob("*/base-v1/population.json"))
ENTRANT = "example-submission-v2"


def shipped_board(manifest_path: Path) -> Leaderboard:
    """The board of a shipped base population with one entrant placed by 40 matches against the
    members around the middle (it wins against the weaker ones), the scripted agents pending."""
    manifest = json.loads(manifest_path.read_text())
    game, label = manifest["game_id"], f"{manifest['name']}:1"
    members = {m["name"]: FrozenRating(m["metadata"]["rating"], m["metadata"].get("rating_lower"),
                                       m["metadata"].get("rating_upper")) for m in manifest["members"]}
    info = {m["name"]: {"kind": m["kind"]} for m in manifest["members"]}
    info |= {ENTRANT: {"kind": "submission"}, f"random@{game}": {"kind": "scripted"},
             f"heuristic@{game}": {"kind": "scripted"}}
    names = sorted(members, key=lambda name: members[name].rating)
    middle = names[len(names) // 2 - 10: len(names) // 2 + 10]
    rows, wins = [], np.zeros(len(names))
    for match, opponent in enumerate(middle * 2):
        won = names.index(opponent) < len(names) // 2
        wins[names.index(opponent)] += won
        for seat, (agent, outcome) in enumerate(((ENTRANT, "win" if won else "loss"),
                                                 (opponent, "loss" if won else "win"))):
            rows.append({"match_id": match, "seat": seat, "agent": agent, "team": seat, "score": 0.0,
                         "outcome": outcome, "position": None})
    placement = place_entrant(*_shipped_placement_input(manifest_path))
    return population_leaderboard(rows, info, game, label, members, {ENTRANT: EntrantPlacement(placement, 7)})


def _shipped_placement_input(manifest_path: Path) -> tuple[list[float], np.ndarray, np.ndarray]:
    """(base ratings, wins, losses) of the entrant of :func:`shipped_board`."""
    manifest = json.loads(manifest_path.read_text())
    ratings = sorted(m["metadata"]["rating"] for m in manifest["members"])
    n = len(ratings)
    played = np.where((np.arange(n) >= n // 2 - 10) & (np.arange(n) < n // 2 + 10), 2.0, 0.0)
    wins = np.where(np.arange(n) < n // 2, played, 0.0)
    return ratings, wins, played - wins


def test_a_population_board_keeps_frozen_ratings_and_places_the_entrant_on_their_scale():
    board = shipped_board(SHIPPED[0])
    assert board.basis == "population" and board.population == "base-v1:1" and board.method == "bt"
    assert [r.status for r in board.rows[-2:]] == ["pending", "pending"]
    rated = board.rated_rows
    assert len(rated) == 101 and [r.rating for r in rated] == sorted((r.rating for r in rated), reverse=True)
    entrant = next(r for r in rated if r.agent == ENTRANT)
    assert entrant.status == "placed" and entrant.matches == 40 and 0.0 < entrant.win_rate < 1.0
    assert entrant.lower < entrant.rating < entrant.upper and entrant.method_columns["job_id"] == 7
    # ranks count the members alone: the entrant's is its placement's, and the members' run 1..100
    placement = place_entrant(*_shipped_placement_input(SHIPPED[0]))
    assert (entrant.rank, entrant.rank_lower, entrant.rank_upper) == (
        placement.rank, placement.rank_lower, placement.rank_upper)
    members = [row for row in rated if row.status == "member"]
    assert [row.rank for row in members] == [1 + sum(other.rating > row.rating for other in members)
                                             for row in members]
    assert members[-1].rank <= 100 and len(members) == 100
    for row in rated:
        assert row.rank_lower <= row.rank <= row.rank_upper
    assert entrant.tied and sum(row.rank == entrant.rank for row in rated) >= 2
    document = board.to_dict()
    assert json.dumps(document, allow_nan=False) and document["basis"] == "population"
    assert set(document) == set(compute_leaderboard(*cyclic_board_input(), GAME, "bt", rounds=10).to_dict())


def cyclic_board_input():
    return cyclic_league(), kinds(["rock", "paper", "scissors"])


def printed_names(lines: list[str], agent: int) -> list[str]:
    """The agent column's names, a name folded onto further lines (their other cells blank) joined."""
    names: list[str] = []
    for cells in (line.split("│")[1:-1] for line in lines if line.startswith("│")):
        if any(cell.strip() for k, cell in enumerate(cells) if k != agent):
            names.append(cells[agent].strip())
        else:
            names[-1] += cells[agent].strip()
    return names


@pytest.mark.parametrize("manifest", SHIPPED, ids=lambda path: path.parent.parent.name)
@pytest.mark.parametrize(("width", "wide"), [(80, False), (120, True), (80, True)])
def test_a_hundred_agent_board_fits_the_terminal_with_every_name_whole(manifest, width, wide):
    board = shipped_board(manifest)
    console = Console(width=width, record=True)
    console.print(render_terminal(board, wide=wide))
    text = console.export_text()
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= width
    assert "…" not in text  # no cell cut, the agent's least of all
    head = next(line for line in lines if "Agent" in line)
    headers = [cell.strip() for cell in head.strip("┃ ").split("┃")]
    assert printed_names(lines, headers.index("Agent")) == [short_name(row.agent, board.game_id) for row in board.rows]
    assert all(f"@{board.game_id}" not in line for line in lines if line.startswith("│"))
    # ranks as the board holds them, ties marked; the caption says what they mean
    ranks = [line.split("│")[1].strip() for line in lines if line.startswith("│") and line.split("│")[1].strip()]
    assert ranks == [rank_text(r.rank, r.rank_lower, r.rank_upper, r.tied) for r in board.rows]
    caption = " ".join(text.split())
    assert "rank: 1 + the members of base-v1:1 rated higher" in caption
    # rank, agent and rating always; the others where they fit, the caption naming those left out
    every = leaderboard_table(board, wide=wide).headers
    left_out = [h for h in every if h not in headers]
    assert headers == [h for h in every if h in headers] and {"Rank", "Agent", "Rating (95% CI)"} <= set(headers)
    if left_out:
        assert f"left out to fit {width} columns: {', '.join(left_out)}" in caption
    if not wide:
        assert every == ["Rank", "Agent", "Status", "Rating (95% CI)", "Matches"]
    # room for names of up to AGENT_LINE_WIDTH on one line before any other column
    longest = max(len(short_name(row.agent, board.game_id)) for row in board.rows)
    column = len(head.strip("┃").split("┃")[headers.index("Agent")]) - 2
    assert column >= min(longest, AGENT_LINE_WIDTH)
    if width == 120:
        assert len(headers) >= (6 if wide else 5)


def test_a_long_name_folds_rather_than_being_cut():
    rows, names = simulated_league([0.0, 100.0], 40, prefix="team-" + "x" * 110)
    console = Console(width=80, record=True)
    console.print(render_terminal(compute_leaderboard(rows, kinds(names), GAME, "bt", rounds=10), wide=True))
    lines = console.export_text().splitlines()
    assert max(len(line) for line in lines) <= 80 and "…" not in "".join(lines)
    # the agent column's pieces, line after line, spell each name whole
    agent_cells = "".join(line.split("│")[2].strip() for line in lines if line.startswith("│"))
    assert agent_cells == "".join(sorted(names, reverse=True))


def test_columns_without_information_are_left_out_of_the_views_but_kept_in_json():
    board = compute_leaderboard(*cyclic_board_input(), GAME, "bt", rounds=20)
    view = leaderboard_table(board, wide=True)
    # rock-paper-scissors: every Nash score is 0, every agent trained, every win rate 50%
    assert "Nash score" not in view.headers and "Kind" not in view.headers and "Win rate" not in view.headers
    assert {"Nash score 0.000 for every agent", "Kind trained for every agent", "Win rate 50.0% for every agent",
            "Matches 100 for every agent"} <= set(view.same)
    assert all(len(line) == len(view.headers) for line in view.cells)
    assert {"Rank", "Agent", "BT rating (95% CI)"} <= set(view.headers)  # shown whatever they hold
    console = Console(width=250, record=True)
    console.print(render_terminal(board, wide=True))
    assert "Nash score 0.000 for every agent" in console.export_text()
    assert all(row["method_columns"]["nash_score"] == pytest.approx(0.0, abs=1e-9) for row in board.to_dict()["rows"])
    # a column blank for the unrated agent and equal for the rated ones says so
    rows, names = simulated_league([0.0, 0.0], 2, seed=0, draw_share=1.0)
    board = compute_leaderboard(rows, kinds(names) | {"idle": {"kind": "trained"}}, GAME, "bt", rounds=10)
    assert "Win rate 50.0% for every rated agent" in leaderboard_table(board, wide=True).same
