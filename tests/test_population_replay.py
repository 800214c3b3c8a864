"""Every shipped population's matches replay to the same outcomes.

A population keeps its members and figures, not its round robin's matches. So ``tests/population_replay.py``
drew 200 matches of each population's round robin (its members and the scripted references, as a build
schedules them) and recorded their outcomes at the commit before the 2D games moved onto one engine; here they
are played again and must match exactly: match seed, team 0's score and length. Each population's own recorded
figures are replayed too: its best member against its worst, and against the heuristic, over the same
verification matches the build played (seats alternating, match ids past the round robin's), give the win rate
and score that ``population.json`` records.
"""

from __future__ import annotations

import json

import pytest
from population_replay import (
    CHECKPOINTS,
    RECORDED,
    manifest_of,
    member_key,
    play,
    sample,
    shipped_populations,
)

from arena_league.league.population.build import member_policy
from arena_league.matchmaking import play_matches, specs_for_seatings
from arena_league.policies.scripted import scripted_policy
from arena_league.policies.threads import torch_threads

RECORDS = json.loads(RECORDED.read_text())
#: The first match id of a build's two verification duels: far past any round robin's, so they share none
#: of its seeds (best against worst, then best against the heuristic).
DUELS = {"best_vs_worst": 1 << 40, "best_vs_heuristic": 1 << 41}


def test_every_shipped_population_was_recorded():
    missing = sorted(set(shipped_populations()) - set(RECORDS))
    assert not missing, f"record {missing} with `python tests/population_replay.py --populations ... --write`"
    assert sorted(RECORDS) == shipped_populations(), "the record names populations that are no longer shipped"


@pytest.mark.slow
@pytest.mark.parametrize("population", shipped_populations())
def test_sampled_round_robin_replays_to_the_recorded_outcomes(population):
    recorded = RECORDS[population]
    drawn = sample(population)
    # drawn again rather than read back, so the record cannot drift from the members and the schedule
    assert drawn["agents"] == recorded["agents"]
    assert drawn["matches"] == [match[:3] for match in recorded["matches"]]
    outcomes = play(population, drawn)
    differ = [(match[2], match[3:], now) for match, now in zip(recorded["matches"], outcomes) if match[3:] != now]
    assert not differ, (f"{population}: {len(differ)} of {len(outcomes)} matches differ from the recorded ones "
                        f"(match id, recorded [seed, team 0 score, steps], now): {differ[:5]}")


def _duel(population: str, opponent: str, n: int, first_match_id: int) -> tuple[float, float]:
    """(win rate, score) of the population's best member against ``opponent`` (its worst member's key, or
    ``"heuristic"``) over ``n`` matches, the best seated first in the even ones."""
    manifest = manifest_of(population)
    game, figures = manifest["game_id"], manifest["provenance"]["figures"]
    entries = {member_key(m["name"]): m for m in manifest["members"]}
    best = figures["best"]
    policies = {best: member_policy(CHECKPOINTS / population, entries[best], game),
                opponent: scripted_policy(opponent, game) if opponent == "heuristic"
                else member_policy(CHECKPOINTS / population, entries[opponent], game)}
    seatings = [(best, opponent) if k % 2 == 0 else (opponent, best) for k in range(n)]
    specs = specs_for_seatings(game, seatings, manifest["provenance"]["build"]["seed"], first_match_id)
    with torch_threads(1):
        results = play_matches(specs, policies, batch_size=256)
    own = [r.scores[r.teams.index(0 if k % 2 == 0 else 1)] for k, r in enumerate(results)]
    return sum(s == 1.0 for s in own) / n, sum(own) / n


@pytest.mark.slow
@pytest.mark.parametrize("population", shipped_populations())
def test_recorded_verification_duels_replay_exactly(population):
    figures = manifest_of(population)["provenance"]["figures"]
    replayed = {"best_vs_worst": _duel(population, figures["worst"], figures["best_vs_worst_matches"],
                                       DUELS["best_vs_worst"])}
    if figures.get("best_vs_heuristic_matches"):  # builds before that figure existed lack it
        replayed["best_vs_heuristic"] = _duel(population, "heuristic", figures["best_vs_heuristic_matches"],
                                              DUELS["best_vs_heuristic"])
    for duel, (win_rate, score) in replayed.items():
        assert (round(win_rate, 4), round(score, 4)) == (figures[f"{duel}_win_rate"], figures[f"{duel}_score"]), duel
