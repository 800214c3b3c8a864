"""A game played in pairs through the league: evaluated, stored with both halves, rated with a seat
term, viewed and replayed half by half (terminal, JSON and page), and played by a person in both
roles."""

from __future__ import annotations

import json

import numpy as np
import pytest
from web_helpers import running_server

from arena_league.cli import main
from arena_league.league import (
    ensure_scripted_agents,
    evaluate,
    leaderboard,
    match_replay,
    match_replay_file,
    match_view,
    open_home,
    recent_matches,
)
from arena_league.league.human import LiveMatch
from arena_league.matchmaking import MatchSpec
from arena_league.policies.scripted import scripted_policy

pytest_plugins = ["cli_helpers"]  # the home fixture

YSNP = "YouShallNotPass-2T1P-v1"


def test_a_pair_is_stored_rated_viewed_and_replayed_half_by_half(tmp_path):
    home = tmp_path / "league"
    with open_home(home) as league:
        random, heuristic = sorted(ensure_scripted_agents(league, YSNP), key=lambda n: not n.startswith("random"))
        report = evaluate(league, YSNP, [random, heuristic], matches_per_pair=2)
        assert report.played == report.stored == 2  # two pairs, each of two halves
        listed = recent_matches(league, YSNP)
        assert all(m["paired"] and len(m["halves"]) == 2 and m["result"].endswith("(a pair)") for m in listed)
        match_id = listed[0]["id"]
        view = match_view(league, match_id)
        assert view["paired"] and [h["half"] for h in view["halves"]] == [0, 1]
        winner = next(t for t in view["teams"] if t["outcome"] == "win")
        assert winner["agents"] == [heuristic] and winner["points"] > max(t["points"] for t in view["teams"]
                                                                          if t is not winner)
        first, second = (h["teams"] for h in view["halves"])
        # the second half swaps the agents: whoever ran first blocks second
        assert [t["agents"] for t in first] == [t["agents"] for t in second][::-1]
        board = leaderboard(league, YSNP, population="league")
        assert [r.agent for r in board.rated_rows] == [heuristic, random]
        assert board.seat_term is not None and board.to_dict()["seat_term"]["text"].startswith("the first seat wins")

        with pytest.raises(Exception, match="no recorded replay"):
            match_replay(league, match_id, 1)
        _, path = match_replay_file(league, match_id, record=True)  # plays the pair again and keeps both halves
        assert path.name.endswith("-h0.mcap")
        halves = [match_replay(league, match_id, half)["match"] for half in (0, 1)]
        assert [d["seats"] for d in halves] == [h["seats"] for h in listed[0]["halves"]]
        assert [d["steps"] for d in halves] == [h["steps"] for h in view["halves"]]
        assert match_view(league, match_id)["replay"]
    with running_server(home) as server, server.client() as client:
        page = client.get(f"/matches/{match_id}", headers={"accept": "text/html"}).text
        api = client.get(f"/api/matches/{match_id}").json()
        second = client.get(f"/api/matches/{match_id}/replay", params={"half": 1})
        wrong = client.get(f"/api/matches/{match_id}/replay", params={"half": 2})
        game = client.get(f"/games/{YSNP}.json").json()
    assert f'data-src="/api/matches/{match_id}/replay?half=1"' in page and "Half 2" in page
    assert [h["teams"] for h in api["halves"]] == [h["teams"] for h in view["halves"]] and second.status_code == 200
    assert second.json()["match"]["steps"] == api["halves"][1]["steps"] and wrong.status_code == 422
    assert game["paired"]


def test_an_unpaired_match_has_no_halves(tmp_path):
    with open_home(tmp_path / "league") as league:
        game = "GoBang-2T1P-v1"
        evaluate(league, game, ensure_scripted_agents(league, game), matches_per_pair=1)
        [listed] = recent_matches(league, game)
        assert not listed["paired"] and listed["halves"] == []
        with pytest.raises(ValueError, match="not a pair, so it has no halves"):
            match_replay(league, listed["id"], 1)


def test_a_person_plays_both_halves_of_a_pair():
    spec = MatchSpec(1, YSNP, ("base", "base"), league_seed=4, paired=True)
    match = LiveMatch(spec, scripted_policy("heuristic", YSNP), 0, "base", 1000.0, "human:1:1")
    assert (match.half, match.side, match.seat) == (0, 0, 0)
    sides, events = set(), []
    while not match.over:
        command = None
        if match.needs_command():
            command, problem = match.controls.parse("d 20")  # trot right: toward the runner's line
            assert problem is None
        sides.add((match.half, match.side))
        events += match.step(command)
    # the person ran first (team 0) and blocked second (team 1), the same start both times
    assert sides == {(0, 0), (1, 1)} and match.team == 0
    half_time = [e for e in events if e["kind"] == "half_time"]
    assert len(half_time) == 1 and "you now play team 1" in match.describe_event(half_time[0], [])
    scores = match.finish()
    first, second = match.half_points
    mine, theirs = first[0] + second[1], first[1] + second[0]
    assert scores.tolist() == [float(np.sign(mine - theirs) * 0.5 + 0.5), float(np.sign(theirs - mine) * 0.5 + 0.5)]
    assert match.steps > match.half_steps and "the pair ended" in match.end_reason([])


def test_an_entrant_is_placed_against_the_youshallnotpass_population_in_pairs(home, capsys):
    with open_home(home) as league:
        heuristic = next(n for n in ensure_scripted_agents(league, YSNP) if n.startswith("heuristic"))
    assert main(["rank", heuristic, "--budget", "24", "--json"]) == 0
    placed = json.loads(capsys.readouterr().out)
    assert placed["unit"] == "pairs" and placed["base"] == "base-v1:1" and 20 <= placed["matches"] <= 24
    assert placed["lower"] <= placed["rating"] <= placed["upper"]
    assert 1 <= placed["rank_lower"] <= placed["rank"] <= placed["rank_upper"] <= 101
    # the scripted heuristic is not on top of the population, and its placement says so
    assert placed["rank"] > 1
    assert main(["rank", heuristic]) == 0  # the stored placement, read back in the terminal
    out = " ".join(capsys.readouterr().out.split())
    assert f"{placed['matches']} pairs:" in out and f"rank {placed['rank']} of 101" in out
