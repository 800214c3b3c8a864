"""Paired matches in the match engine: a pair is two matches from one seed with the teams' agents
swapped, decided by the rules' pair points over both halves, and rated as one match."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from arena_league.envs import game_spec
from arena_league.matchmaking import LockstepRunner, MatchResult, MatchSpec, play_matches, specs_for_seatings
from arena_league.policies.scripted import scripted_policy
from arena_league.replay import ReplayRecording, read_replay

YSNP = "YouShallNotPass-2T1P-v1"
GOBANG = "GoBang-2T1P-v1"


def _agents(game_id: str) -> dict:
    return {"heuristic": scripted_policy("heuristic", game_id), "random": scripted_policy("random", game_id)}


def test_a_pair_is_two_halves_from_one_seed_with_the_agents_swapped():
    spec = MatchSpec(7, YSNP, ("a", "b"), league_seed=3, paired=True)
    first, second = spec.halves()
    assert (first.seats, second.seats) == (("a", "b"), ("b", "a"))
    assert first.seed == second.seed == spec.seed and (first.half, second.half) == (0, 1)
    # the same seats' uniforms in both halves: each role gets the same luck whoever holds it
    assert np.array_equal(first.seat_rng().random(5), second.seat_rng().random(5))
    assert MatchSpec.from_dict(spec.to_dict()) == spec and MatchSpec.from_dict(second.to_dict()) == second
    with pytest.raises(ValueError, match="not a pair"):
        first.halves()
    with pytest.raises(ValueError, match="half must be 0 or 1"):
        MatchSpec(1, YSNP, ("a", "b"), half=2)


def test_youshallnotpass_is_played_in_pairs_and_a_pair_is_decided_by_its_runs():
    assert game_spec(YSNP).paired and not game_spec(GOBANG).paired
    specs = specs_for_seatings(YSNP, [("heuristic", "random"), ("random", "heuristic")], league_seed=0)
    assert all(s.paired for s in specs)
    results = play_matches(specs, _agents(YSNP), batch_size=4)
    assert [r.spec for r in results] == specs
    for result in results:
        assert result.paired and len(result.halves) == 2 and result.steps == sum(h.steps for h in result.halves)
        first, second = result.halves
        # the runner (team 0) scores its run in each half; the blocker nothing
        assert first.points[1] == second.points[1] == 0.0
        assert first.seats == result.seats and second.seats == result.seats[::-1]
        total = np.asarray(first.points) + np.asarray(second.points)[::-1]
        assert result.points == tuple(total)
        heuristic = result.seats.index("heuristic")
        # the heuristic runs better than the random agent, whichever side it starts on
        assert result.outcomes[heuristic] == "win" and result.scores[heuristic] == 1.0
    # a pair's result survives the trip through JSON and pickling
    again = MatchResult.from_dict(results[0].to_dict())
    assert again == results[0] and pickle.loads(pickle.dumps(again)) == again


def test_a_pair_plays_alike_on_every_path_batch_size_and_backend():
    specs = specs_for_seatings(YSNP, [("heuristic", "heuristic"), ("heuristic", "random")] * 2, league_seed=5)
    agents = _agents(YSNP)
    reference = play_matches(specs, agents, batch_size=1)
    assert play_matches(specs, agents, batch_size=8) == reference
    for path in ("env", "rules"):
        runner = LockstepRunner(YSNP, agents, batch_size=3, path=path)
        assert runner.play(specs) == reference, path


def test_a_pair_halves_equal_the_two_single_matches_it_stands_for():
    """An unpaired game opted into pairs: half 0 is the single match, half 1 the same start with the
    colours swapped, and the pair goes to the agent with more points over both."""
    agents = _agents(GOBANG)
    pair = MatchSpec(11, GOBANG, ("heuristic", "random"), league_seed=2, paired=True)
    [result] = play_matches([pair], agents)
    [single] = play_matches([MatchSpec(11, GOBANG, ("heuristic", "random"), league_seed=2)], agents)
    first, second = result.halves
    assert (first.scores, first.outcomes, first.steps) == (single.scores, single.outcomes, single.steps)
    assert first.points == first.scores and second.seats == ("random", "heuristic")
    heuristic_points = first.scores[0] + second.scores[1]
    random_points = first.scores[1] + second.scores[0]
    expected = "win" if heuristic_points > random_points else "loss" if heuristic_points < random_points else "draw"
    assert result.outcomes[0] == expected and result.points == (heuristic_points, random_points)


def test_a_paired_spec_needs_two_teams_of_one_size():
    with pytest.raises(ValueError, match="do not split in two"):
        MatchSpec(0, "Snake-4T1P-v1", ("a", "b", "c"), paired=True)
    spec = MatchSpec(0, "Snake-4T1P-v1", ("heuristic",) * 4, paired=True)
    with pytest.raises(ValueError, match="a pair swaps two teams, but Snake-4T1P-v1 has 4"):
        play_matches([spec], _agents("Snake-4T1P-v1"))


def test_each_half_of_a_pair_is_recorded_and_read_back(tmp_path):
    [spec] = specs_for_seatings(YSNP, [("heuristic", "random")], league_seed=1)
    [result] = play_matches([spec], _agents(YSNP), recording=ReplayRecording(tmp_path))
    paths = [h.replay_path for h in result.halves]
    assert result.replay_path == paths[0] and paths[0].endswith("-h0.mcap") and paths[1].endswith("-h1.mcap")
    for k, path in enumerate(paths):
        summary = read_replay(path)
        assert summary.half == k and summary.spec == spec.halves()[k]
        assert summary.result.without_replay() == result.halves[k].without_replay()
    assert result.without_replay() == play_matches([spec], _agents(YSNP))[0]


def test_a_placement_in_a_paired_game_plays_one_pair_per_visit():
    from arena_league.matchmaking import LeastPlayedChooser, play_adaptive

    agents = {**_agents(YSNP), "entrant": scripted_policy("heuristic-period0.4", YSNP)}
    chooser = LeastPlayedChooser(2, budget=4)
    sides = []
    record = chooser.record
    chooser.record = lambda k, score, side=0: (sides.append(side), record(k, score, side))
    results = play_adaptive("entrant", ["heuristic", "random"], chooser, lambda specs: play_matches(specs, agents),
                            YSNP, league_seed=9)
    # four visits, four pairs (each holds both sides already), the entrant first in every pair
    assert len(results) == 4 and all(r.paired and r.seats == ("entrant", r.seats[1]) for r in results)
    assert [r.match_id for r in results] == [0, 1, 2, 3] and sides == [0, 0, 0, 0]
    assert chooser.games.tolist() == [2, 2]
