"""Search agents: names carry bounded budgets, only games whose observation holds the whole state
offer one, GoBang's rollout search replays exactly and, seeing how the heuristic answers, beats it;
a descriptor asking for an unbounded search is refused at the gate."""

from __future__ import annotations

import json

import numpy as np
import pytest

from arena_league.envs.games import gobang
from arena_league.matchmaking import play_matches, specs_for_seatings
from arena_league.policies import ArtifactError, read_artifact, validate_submission
from arena_league.policies.scripted import (
    SEARCH_LIMITS,
    is_scripted_name,
    scripted_descriptor,
    scripted_policy,
    search_budget,
)

GAME = "GoBang-2T1P-v1"


def test_a_search_name_carries_its_budget():
    assert search_budget("search-w8-r4-h30-e0.1") == {"width": 8, "rollouts": 4, "horizon": 30, "epsilon": 0.1}
    assert search_budget("scripted:search-w2-r1-h5") == {"width": 2, "rollouts": 1, "horizon": 5, "epsilon": 0.0}
    assert search_budget("heuristic") is None and search_budget("search-w8") is None
    assert is_scripted_name("search-w8-r4-h30") and is_scripted_name("random")
    assert not is_scripted_name("search-w99-r4-h30") and not is_scripted_name("minimax")
    # a later version of a game's search adds -vV; the first has no suffix, so one agent has one name
    assert search_budget("search-w8-r1-h40-v2") == {"width": 8, "rollouts": 1, "horizon": 40, "epsilon": 0.0,
                                                   "version": 2}
    assert search_budget("search-w8-r4-h30-e0.1-v2")["version"] == 2
    with pytest.raises(ValueError, match="named without -v; leave -v1 out: search-w8-r1-h40-e0.1"):
        search_budget("search-w8-r1-h40-e0.1-v1")
    assert scripted_descriptor("search-w8-r1-h40-v2") != scripted_descriptor("search-w8-r1-h40")


@pytest.mark.parametrize("name, words", [
    ("search-w17-r1-h10", "width must be from 1 to 16"),
    ("search-w4-r0-h10", "rollouts must be from 1 to 16"),
    ("search-w16-r16-h40", "over the bound of 2048"),
])
def test_budgets_past_their_bounds_are_refused_with_the_bound(name, words):
    with pytest.raises(ValueError, match=words):
        search_budget(name)
    assert not is_scripted_name(name)


def test_games_without_a_search_agent_say_so():
    with pytest.raises(ValueError, match=r"no search agent \(games with one: Boomer, CaptureFlag, FightForFood, GoBang, Snake\)"):
        scripted_policy("search-w4-r1-h10", "Sumo-2T1P-v1")
    with pytest.raises(ValueError, match="unknown scripted agent 'minimax'.*search-wW-rR-hH"):
        scripted_policy("minimax", GAME)


def test_a_version_the_game_lacks_is_refused_where_the_agent_is_made():
    with pytest.raises(ValueError, match="GoBang-2T1P-v1's search agent has version 1, not 2; leave -v out"):
        scripted_policy("search-w4-r1-h10-v2", GAME)
    with pytest.raises(ValueError, match="versions 1, 2, not 3; the first is named without -v"):
        scripted_policy("search-w4-r1-h10-v3", "FightForFood-2T1P-v1")
    refused = validate_submission("scripted:search-w4-r1-h10-v2", GAME)
    assert not refused.ok and "version 1, not 2" in refused.reason
    assert scripted_policy("search-w4-r1-h10-v2", "FightForFood-2T1P-v1").budget["version"] == 2


def test_rollout_search_replays_exactly_and_plays_legal_cells():
    rng = np.random.default_rng(3)
    cells = rng.random((6, 225))
    own, opponent = cells < 0.08, (cells >= 0.08) & (cells < 0.16)
    uniforms = rng.random(6)
    first = gobang.rollout_moves(own, opponent, uniforms, width=6, rollouts=3, horizon=12, epsilon=0.2)
    again = gobang.rollout_moves(own, opponent, uniforms, width=6, rollouts=3, horizon=12, epsilon=0.2)
    assert (first == again).all()
    assert not (own | opponent)[np.arange(6), first].any()
    # a winning cell is played at once: four in a row with an open end
    own, opponent = np.zeros((1, 225), bool), np.zeros((1, 225), bool)
    own[0, [112, 113, 114, 115]] = True
    opponent[0, [111, 0, 1, 2]] = True
    assert gobang.rollout_moves(own, opponent, np.zeros(1), width=4, rollouts=2, horizon=6, epsilon=0.5)[0] == 116


def test_rollouts_that_fill_the_board_end_undecided():
    """Two empty cells on a board where no line can reach five, and only random rollout moves: the
    rollouts fill the board and stop undecided."""
    rows, cols = np.divmod(np.arange(225), 15)
    own = (((cols + 2 * rows) // 2) % 2 == 0)[None]  # runs of at most two stones in every direction
    opponent = ~own
    own[0, [223, 224]] = opponent[0, [223, 224]] = False
    attack, threat = gobang.line_values(own, opponent)
    assert max(attack[0, 223:].max(), threat[0, 223:].max()) < gobang.WIN_VALUE
    move = gobang.rollout_moves(own, opponent, np.full(1, 0.5), width=2, rollouts=4, horizon=10, epsilon=1.0)
    assert move[0] in (223, 224)


def test_the_exact_rollout_search_beats_the_heuristic_from_either_seat():
    agents = {"search": scripted_policy("search-w6-r1-h30", GAME), "heuristic": scripted_policy("heuristic", GAME)}
    seatings = [("search", "heuristic"), ("heuristic", "search")]
    results = play_matches(specs_for_seatings(GAME, seatings, 7, 0), agents, backend="inprocess")
    assert [r.team_scores()[s.index("search")] for s, r in zip(seatings, results)] == [1.0, 1.0]


def test_the_gate_reads_validates_and_bounds_search_descriptors(tmp_path):
    artifact = read_artifact("scripted:search-w4-r2-h10")
    assert artifact.kind == "scripted" and artifact.files["scripted.json"] == scripted_descriptor("search-w4-r2-h10")
    verdict = validate_submission("scripted:search-w4-r2-h10", GAME, match_cycles=20)
    assert verdict.ok, verdict.reason
    assert "built-in agent: not timed" in verdict.log
    refused = validate_submission("scripted:search-w4-r2-h10", "Sumo-2T1P-v1")
    assert not refused.ok and "no search agent" in refused.reason
    refused = validate_submission("scripted:search-w4-r2-h10", "Snake-2T2P-v1")  # a budget the game cannot search
    assert not refused.ok and "R = 1" in refused.reason
    # a descriptor file asking for more than the bounds allow is refused before anything runs
    hostile = tmp_path / "agent.json"
    hostile.write_text(json.dumps({"format": "arena-scripted", "name": f"search-w16-r16-h{SEARCH_LIMITS['horizon']}"}))
    with pytest.raises(ArtifactError, match="names scripted agent"):
        read_artifact(hostile)
