"""Opponent selection: round robin pairs the least-played first, balances seats, is deterministic."""

from __future__ import annotations

import itertools
from collections import Counter

import pytest

from arena_league.matchmaking import (
    LeastPlayedChooser,
    OpponentChooser,
    berger_round,
    pair_counts,
    play_adaptive,
    play_matches,
    round_robin,
)
from arena_league.matchmaking.agents import AgentRef

AGENTS = [f"agent-{i}" for i in range(7)]


def _pair(seating):
    return tuple(sorted(seating))


def test_every_pair_reaches_the_target_with_balanced_seats():
    seatings = round_robin(AGENTS, 4)
    assert len(seatings) == 21 * 4
    per_pair = Counter(_pair(s) for s in seatings)
    assert set(per_pair.values()) == {4} and len(per_pair) == 21
    oriented = Counter(seatings)
    for a, b in itertools.combinations(AGENTS, 2):
        assert oriented[(a, b)] == oriented[(b, a)] == 2
    assert round_robin(AGENTS, 4) == seatings  # deterministic


def test_least_played_pairs_come_first_and_rounds_spread_agents():
    seatings = round_robin(AGENTS, 2)
    # the first 21 seatings are one full round robin: every pair once
    assert len({_pair(s) for s in seatings[:21]}) == 21
    # the first 3 (one circle-method round of 7 agents, one bye) involve 6 distinct agents
    assert len({a for s in seatings[:3] for a in s}) == 6
    played = {("agent-0", "agent-1"): 3, ("agent-2", "agent-3"): 1}
    schedule = round_robin(AGENTS, 3, played)
    assert ("agent-0", "agent-1") not in schedule and ("agent-1", "agent-0") not in schedule
    first_level = schedule[:20]  # every pair except the one that played 3 and the one that played 1
    assert _pair(("agent-2", "agent-3")) not in {_pair(s) for s in first_level}
    counts = Counter(_pair(s) for s in schedule)
    assert counts[("agent-2", "agent-3")] == 2 and counts[("agent-0", "agent-2")] == 3


def test_played_seats_are_balanced_by_the_schedule():
    played = {("agent-0", "agent-1"): 2}  # agent-0 held team 0 twice
    schedule = round_robin(AGENTS, 4, played)
    assert Counter(s for s in schedule if _pair(s) == ("agent-0", "agent-1")) == {("agent-1", "agent-0"): 2}


def test_circle_method_rounds_pair_everyone_once():
    for n in (6, 7):
        m = n + n % 2
        for r in range(m - 1):
            pairs = [(i, j) for i in range(m) for j in range(i + 1, m) if berger_round(i, j, m) == r]
            assert len(pairs) == m // 2
            assert len({a for p in pairs for a in p}) == m


def test_entrant_and_limit():
    schedule = round_robin(AGENTS, 2, entrant="agent-3")
    assert len(schedule) == 12 and all("agent-3" in s for s in schedule)
    assert Counter(s[0] == "agent-3" for s in schedule) == {True: 6, False: 6}
    assert round_robin(AGENTS, 2, limit=5) == round_robin(AGENTS, 2)[:5]
    with pytest.raises(ValueError, match="entrant"):
        round_robin(AGENTS, 2, entrant="nobody")


def test_adaptive_placement_hook_plays_the_chosen_opponents():
    game = "GoBang-2T1P-v1"
    agents = {"entrant": AgentRef("scripted", "heuristic", game), "r0": AgentRef("scripted", "random", game),
              "r1": AgentRef("scripted", "random", game)}
    chooser = LeastPlayedChooser(2, budget=4)
    assert isinstance(chooser, OpponentChooser)
    results = play_adaptive("entrant", ["r0", "r1"], chooser, lambda specs: play_matches(specs, agents), game,
                            league_seed=4, first_match_id=100)
    assert [r.match_id for r in results] == [100, 101, 102, 103]
    assert [r.seats for r in results] == [("entrant", "r0"), ("r0", "entrant"), ("entrant", "r1"), ("r1", "entrant")]
    assert chooser.games.tolist() == [2, 2] and chooser.points.tolist() == [2.0, 2.0]  # the heuristic wins
    assert pair_counts(results) == {("entrant", "r0"): 1, ("r0", "entrant"): 1, ("entrant", "r1"): 1,
                                    ("r1", "entrant"): 1}


def test_the_rating_engines_adaptive_placement_is_an_opponent_chooser():
    from arena_league.rating.placement import AdaptivePlacement

    game = "GoBang-2T1P-v1"
    agents = {"entrant": AgentRef("scripted", "heuristic", game), "weak": AgentRef("scripted", "random", game),
              "strong": AgentRef("scripted", "heuristic", game)}
    chooser = AdaptivePlacement([-200.0, 200.0], budget=6)
    assert isinstance(chooser, OpponentChooser)
    results = play_adaptive("entrant", ["weak", "strong"], chooser, lambda specs: play_matches(specs, agents), game,
                            league_seed=2)
    assert len(results) == chooser.matches == 6
    assert [r.match_id for r in results] == list(range(6))
    assert chooser.placement.matches == 6
