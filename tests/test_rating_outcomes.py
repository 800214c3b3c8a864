"""Outcome tables, pairwise results and deduplicated counts."""

import inspect

import numpy as np
import pytest

from arena_league.rating import (
    PSEUDO_COUNT,
    OutcomeTable,
    PairCounts,
    SeatResult,
    alpha_rank_intervals,
    nash_intervals,
    openskill_ratings,
)


def test_from_registry_rows_two_teams_of_two_seats():
    rows = [
        # match 7: alice (seats 0, 1) beat bob (seats 2, 3)
        (7, 0, "alice", 0, 3.0, "win"), (7, 1, "alice", 0, 1.0, "win"),
        (7, 2, "bob", 1, 0.0, "loss"), (7, 3, "bob", 1, 0.0, "loss"),
        # match 9: bob drew carol
        {"match_id": 9, "seat": 0, "agent": "bob", "team": 0, "score": 1.0, "outcome": "draw"},
        {"match_id": 9, "seat": 1, "agent": "carol", "team": 1, "score": 1.0, "outcome": "draw"},
    ]
    table = OutcomeTable.from_rows(rows)
    assert table.agents == ["alice", "bob", "carol"]
    assert table.match_ids == [7, 9] and table.n_matches == 2
    results = table.pairwise()
    assert results.first.tolist() == [0, 1] and results.second.tolist() == [1, 2]
    assert results.score.tolist() == [1.0, 0.5]
    counts = table.pair_counts()
    assert counts.wins[0, 1] == 1 and counts.wins.sum() == 1
    assert counts.draws[1, 2] == counts.draws[2, 1] == 1
    assert counts.n_matches == 2
    np.testing.assert_array_equal(counts.games, counts.games.T)


def test_free_for_all_finishing_places():
    rows = [SeatResult(1, s, name, s, 0.0, place) for s, (name, place) in
            enumerate([("a", 2), ("b", 0), ("c", 1), ("d", 1)])]
    results = OutcomeTable.from_rows(rows).pairwise()
    # 4 teams -> 6 pairwise results; c and d tie for second
    assert len(results) == 6
    outcome = {(int(f), int(s)): float(x) for f, s, x in zip(results.first, results.second, results.score)}
    assert outcome[(0, 1)] == 0.0 and outcome[(1, 2)] == 1.0 and outcome[(2, 3)] == 0.5


def test_fixed_agent_order_and_errors():
    with pytest.raises(ValueError, match="not in the agents list"):
        OutcomeTable.from_rows([(1, 0, "x", 0, 0, "win"), (1, 1, "y", 1, 0, "loss")], agents=["x"])
    with pytest.raises(ValueError, match="both a 'win' and a 'draw'"):
        OutcomeTable.from_rows([(1, 0, "x", 0, 0, "win"), (1, 1, "y", 1, 0, "draw")])
    with pytest.raises(ValueError, match="every team"):
        OutcomeTable.from_rows([(1, 0, "x", 0, 0, "win"), (1, 1, "y", 1, 0, "win")])
    with pytest.raises(ValueError, match="mixes outcome words"):
        OutcomeTable.from_rows([(1, 0, "x", 0, 0, "win"), (1, 1, "y", 1, 0, 1)])
    with pytest.raises(ValueError, match="fewer than two teams"):
        OutcomeTable.from_rows([(1, 0, "x", 0, 0, 0), (1, 1, "y", 0, 0, 0)])
    with pytest.raises(ValueError, match="seats of one team"):
        OutcomeTable.from_rows([(1, 0, "x", 0, 0, "win"), (1, 1, "x", 0, 0, "loss"),
                                (1, 2, "y", 1, 0, "loss")])
    with pytest.raises(ValueError, match="occurs twice"):
        OutcomeTable.from_rows([(1, 0, "x", 0, 0, "win"), (1, 0, "y", 1, 0, "loss")])
    with pytest.raises(ValueError, match="outcome 'won'"):
        OutcomeTable.from_rows([(1, 0, "x", 0, 0, "won"), (1, 1, "y", 1, 0, "loss")])
    table = OutcomeTable.from_rows([(1, 0, "x", 0, 0, "win"), (1, 1, "y", 1, 0, "loss")], agents=["y", "x"])
    assert table.agents == ["y", "x"] and table.agent.tolist() == [1, 0]


def test_mixed_teams_need_openskill():
    rows = [(1, 0, "a", 0, 0, "win"), (1, 1, "b", 0, 0, "win"),
            (1, 2, "c", 1, 0, "loss"), (1, 3, "d", 1, 0, "loss")]
    table = OutcomeTable.from_rows(rows)
    with pytest.raises(ValueError, match="openskill"):
        table.pairwise()


def test_self_play_results_are_left_out():
    rows = [(1, 0, "a", 0, 0, "win"), (1, 1, "a", 1, 0, "loss"),
            (2, 0, "a", 0, 0, "loss"), (2, 1, "b", 1, 0, "win")]
    counts = OutcomeTable.from_rows(rows).pair_counts()
    assert counts.wins.tolist() == [[0, 0], [1, 0]]


def test_win_rates_and_logits():
    counts = PairCounts.from_matrices([[0, 3, 0], [1, 0, 0], [0, 0, 0]], [[0, 0, 0], [0, 0, 2], [0, 2, 0]])
    rate = counts.win_rate()
    assert rate[0, 1] == 0.75 and rate[1, 0] == 0.25 and rate[1, 2] == 0.5
    assert np.isnan(rate[0, 2]) and np.diag(rate).tolist() == [0.5] * 3
    shrunk = counts.win_rate(pseudo_count=0.5)
    assert shrunk[0, 2] == 0.5
    A = counts.logit_payoff()
    np.testing.assert_allclose(A, -A.T)
    assert A[0, 1] == pytest.approx(np.log(3.5 / 1.5))
    with pytest.raises(ValueError, match="symmetric"):
        PairCounts.from_matrices([[0, 1], [1, 0]], [[0, 1], [0, 0]])


def test_one_pseudo_count_is_every_default():
    from arena_league.league import leaderboards

    assert PSEUDO_COUNT == 0.5 and leaderboards.PSEUDO_COUNT is PSEUDO_COUNT
    for function in (PairCounts.logit_payoff, nash_intervals, alpha_rank_intervals):
        assert inspect.signature(function).parameters["pseudo_count"].default is PSEUDO_COUNT
    # an unbeaten pair keeps a finite logit: log((3 + 1/2) / (0 + 1/2))
    assert PairCounts.from_matrices([[0, 3], [0, 0]]).logit_payoff()[0, 1] == pytest.approx(np.log(7.0))


def test_resampling_keeps_the_number_of_matches():
    rng = np.random.default_rng(0)
    counts = PairCounts.from_matrices([[0, 30, 5], [10, 0, 7], [2, 8, 0]], [[0, 4, 0], [4, 0, 1], [0, 1, 0]])
    wins, draws = counts.resample(rng, 500)
    assert wins.shape == (500, 3, 3)
    totals = wins.sum(axis=(1, 2)) + draws.sum(axis=(1, 2)) / 2
    assert (totals == counts.n_matches).all()
    np.testing.assert_array_equal(draws, draws.transpose(0, 2, 1))
    # cells never observed are never drawn; the mean replicate is the data
    assert (wins[:, 0, 0] == 0).all()
    np.testing.assert_allclose(wins.mean(0), counts.wins, rtol=0.1)


def test_openskill_teams_and_free_for_all():
    rows = []
    for m in range(30):
        # strong + mid always beat weak + mid2
        rows += [(m, 0, "strong", 0, 0, "win"), (m, 1, "mid", 0, 0, "win"),
                 (m, 2, "weak", 1, 0, "loss"), (m, 3, "mid2", 1, 0, "loss")]
    for m in range(30, 50):
        # free-for-all of three single-agent teams
        rows += [(m, 0, "strong", 0, 0, 0), (m, 1, "mid", 1, 0, 1), (m, 2, "weak", 2, 0, 2)]
    rows += [(99, 0, "mid", 0, 0, "win"), (99, 1, "mid", 1, 0, "loss")]  # a mirror match
    skill = openskill_ratings(OutcomeTable.from_rows(rows))
    order = {name: i for i, name in enumerate(skill.agents)}
    assert skill.conservative[order["strong"]] > skill.conservative[order["mid"]] > skill.conservative[order["weak"]]
    assert skill.skipped == 1
    assert skill.matches[order["strong"]] == 50 and skill.matches[order["mid2"]] == 30
    np.testing.assert_allclose(skill.conservative, skill.mu - 3 * skill.sigma)
    assert (skill.sigma < 25 / 3).all()
