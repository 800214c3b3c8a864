"""Match specs: seeds come from (match id, league seed) only; results map team scores to seats."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.matchmaking import MatchResult, MatchSpec, match_seed, seat_rng, specs_for_seatings


def test_seed_depends_on_match_id_and_league_seed_only():
    a = MatchSpec(5, "GoBang-2T1P-v1", ("x", "y"), league_seed=9)
    b = MatchSpec(5, "Crossroads-2T2P-v1", ("p", "q", "r", "s"), league_seed=9)
    assert a.seed == b.seed == match_seed(5, 9)
    expected = int(np.random.SeedSequence([9, 5]).generate_state(1, np.uint64)[0] >> np.uint64(1))
    assert a.seed == expected and 0 <= a.seed < 2**63
    assert MatchSpec(6, "GoBang-2T1P-v1", ("x", "y"), 9).seed != a.seed
    assert MatchSpec(5, "GoBang-2T1P-v1", ("x", "y"), 10).seed != a.seed
    # the seats' uniforms: a stream of its own, the same for the same (match id, league seed)
    assert np.array_equal(a.seat_rng().random(8), b.seat_rng().random(8))
    assert np.array_equal(a.seat_rng().random(8), seat_rng(5, 9).random(8))
    assert not np.array_equal(a.seat_rng().random(8), np.random.default_rng(a.seed).random(8))


def test_bad_specs_are_refused_with_the_reason():
    with pytest.raises(ValueError, match="match_id"):
        MatchSpec(-1, "GoBang-2T1P-v1", ("x", "y"))
    with pytest.raises(ValueError, match="league_seed"):
        MatchSpec(0, "GoBang-2T1P-v1", ("x", "y"), league_seed=1.5)
    with pytest.raises(ValueError, match="seats"):
        MatchSpec(0, "GoBang-2T1P-v1", ())
    with pytest.raises(ValueError, match="2 teams"):
        specs_for_seatings("GoBang-2T1P-v1", [("a", "b", "c")])
    with pytest.raises(ValueError, match="unknown game id"):
        specs_for_seatings("Chess-2T1P-v1", [("a", "b")])


def test_team_seatings_fill_every_seat_of_the_team():
    specs = specs_for_seatings("Crossroads-2T2P-v1", [("a", "b"), ("b", "a")], league_seed=3, first_match_id=10)
    assert [s.match_id for s in specs] == [10, 11]
    assert specs[0].seats == ("a", "a", "b", "b") and specs[1].seats == ("b", "b", "a", "a")
    assert MatchSpec.from_dict(specs[0].to_dict()) == specs[0]


def test_two_team_outcomes():
    spec = MatchSpec(0, "Crossroads-2T2P-v1", ("a", "a", "b", "b"))
    won = MatchResult.from_team_result(spec, [0, 0, 1, 1], [1.0, 0.0], steps=40)
    assert won.outcomes == ("win", "win", "loss", "loss") and won.scores == (1.0, 1.0, 0.0, 0.0)
    assert won.positions is None and won.team_scores() == {0: 1.0, 1: 0.0}
    drawn = MatchResult.from_team_result(spec, [0, 0, 1, 1], [0.5, 0.5], steps=300)
    assert drawn.outcomes == ("draw",) * 4
    assert MatchResult.from_dict(won.to_dict()) == won
    rows = won.seat_rows()
    assert rows[2] == {"seat": 2, "agent": "b", "team": 1, "score": 0.0, "outcome": "loss", "position": None}


def test_more_teams_get_finishing_positions():
    spec = MatchSpec(1, "Snake-4T1P-v1", ("a", "b", "c", "d"))
    result = MatchResult.from_team_result(spec, [0, 1, 2, 3], [0.0, 2.5, 2.5, 1.0], steps=90)
    assert result.positions == (4, 1, 1, 3)
    assert result.outcomes == ("loss", "draw", "draw", "loss")
    alone = MatchResult.from_team_result(spec, [0, 1, 2, 3], [3.0, 2.0, 1.0, 0.0], steps=90)
    assert alone.outcomes == ("win", "loss", "loss", "loss") and alone.positions == (1, 2, 3, 4)
    assert MatchResult.from_dict(alone.to_dict()) == alone
