"""Every shipped population's matches replay to the same outcomes.

A population keeps its members and figures, not its round robin's matches. So ``tests/population_replay.py``
drew 200 matches of each population's round robin (its members and the scripted references, as a build
schedules them) and recorded their outcomes at the commit before the 2D games moved onto one engine; here they
are played again and must match exactly: match seed, team 0's score and length. Each population's own recorded
figure is replayed too, for the newest population of each game (the one entrants meet; an older one's members
are still replayed by its sampled round robin): its best member against its worst, over the same 200 verification
matches the build played (seats alternating, match ids past the round robin's), gives the win rate and score that
``population.json`` records. (The build's duel of the best member against the heuristic replays as well, but
where the best member is a search agent it costs minutes; ``test_shipped_populations.py`` plays fresh ones.)
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
from arena_league.league.populations import shipped_population
from arena_league.matchmaking import play_matches, specs_for_seatings
from arena_league.policies.threads import torch_threads

RECORDS = json.loads(RECORDED.read_text())
#: The first match id of a build's duel of its best member against its worst: far past any round robin's,
#: so they share none of its seeds.
BEST_VS_WORST_FIRST_MATCH = 1 << 40
#: The newest population of each game, as ``game/name``.
NEWEST = sorted({f"{shipped_population(p.split('/')[0]).parent.name}/{shipped_population(p.split('/')[0]).name}"
                 for p in shipped_populations()})


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


@pytest.mark.slow
@pytest.mark.parametrize("population", NEWEST)
def test_recorded_best_against_worst_replays_exactly(population):
    manifest = manifest_of(population)
    game, figures = manifest["game_id"], manifest["provenance"]["figures"]
    entries = {member_key(m["name"]): m for m in manifest["members"]}
    best, worst, n = figures["best"], figures["worst"], figures["best_vs_worst_matches"]
    policies = {key: member_policy(CHECKPOINTS / population, entries[key], game) for key in (best, worst)}
    seatings = [(best, worst) if k % 2 == 0 else (worst, best) for k in range(n)]
    specs = specs_for_seatings(game, seatings, manifest["provenance"]["build"]["seed"], BEST_VS_WORST_FIRST_MATCH)
    with torch_threads(1):
        results = play_matches(specs, policies, batch_size=256)
    best_scores = [r.scores[r.teams.index(k % 2)] for k, r in enumerate(results)]
    win_rate, score = sum(s == 1.0 for s in best_scores) / n, sum(best_scores) / n
    assert (round(win_rate, 4), round(score, 4)) == (figures["best_vs_worst_win_rate"],
                                                     figures["best_vs_worst_score"])
