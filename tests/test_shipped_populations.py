"""The base populations shipped under checkpoints/: each is complete (100 members, stacked bundles that
match the per-member folders), meets the shipped-population criteria by its recorded figures, and really does what
those figures say: replayed here, its best member beats its worst and the random agent sits at the
bottom of a small fresh sample of matches. The newest population of every game has headroom: replayed
here, its best member beats the scripted heuristic in at least 60% of matches."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from arena_league.league.population.build import (
    HEADROOM,
    SCRIPTED_SCHEME,
    TUNED_SCHEME,
    best_against_heuristic,
    criteria_for,
    load_bundles,
    member_policy,
)
from arena_league.league.populations import shipped_population
from arena_league.policies import load_policy
from arena_league.policies.scripted import scripted_policy
from arena_league.policies.threads import torch_threads

ROOT = Path(__file__).resolve().parent.parent / "checkpoints"
SHIPPED = sorted(p.parent for p in ROOT.glob("*/*/population.json"))
#: The games that ship a base population. The quickstart ranks against Crossroads'.
REQUIRED = {"AirHockey-2T1P-v1", "BattleCity-2T1P-v1", "BlowBlow-2T1P-v1", "Boomer-2T1P-v1", "CaptureFlag-2T1P-v1",
            "Crossroads-2T2P-v1", "FightForFood-2T1P-v1", "Fighter-2T1P-v1", "GoBang-2T1P-v1", "PushBox-2T2P-v1",
            "RunToGoal-2T1P-v1", "Snake-2T2P-v1", "Soccer-2T2P-v1", "Sumo-2T1P-v1", "Tennis-2T1P-v1",
            "YouShallNotPass-2T1P-v1"}
#: The newest population of each game: the one entrants are ranked against by default.
NEWEST = sorted({shipped_population(p.parent.name) for p in SHIPPED})
#: Games whose newest population still lacks headroom, and why (each must get a population that has it).
#: (FightForFood's base-v1 was here: its best won 11 of these 20 replays; base-v2's searchers model contacts.
#: CaptureFlag's base-v1 too: its best, a tuned heuristic, won 109 of 200; base-v2's best is a search agent.)
WITHOUT_HEADROOM: dict[str, str] = {}


def _manifest(folder: Path) -> dict:
    return json.loads((folder / "population.json").read_text())


def test_every_required_game_ships_a_population():
    games = {p.parent.name for p in SHIPPED}
    assert games >= REQUIRED, f"missing base populations: {sorted(REQUIRED - games)}"


@pytest.mark.parametrize("folder", SHIPPED, ids=lambda p: p.parent.name)
def test_population_meets_the_criteria_by_its_figures(folder):
    manifest = _manifest(folder)
    figures = manifest["provenance"]["figures"]
    assert manifest["frozen"] and len(manifest["members"]) == figures["size"] == 100
    # a game played in pairs is judged in pair terms, with the random agent last and the heuristic not on top
    for criterion, (figure, comparison, threshold) in criteria_for(manifest["game_id"]).items():
        value = figures[figure]
        assert value >= threshold if comparison == ">=" else value <= threshold, (criterion, value)
    assert manifest["provenance"]["passed"]
    schemes = {m["metadata"]["scheme"] for m in manifest["members"]}
    built_in = {SCRIPTED_SCHEME, TUNED_SCHEME}
    assert len(schemes - built_in) >= 3 and schemes <= {"sp", "pbt", "dppo", "cc", "cf"} | built_in


@pytest.mark.parametrize("folder", SHIPPED, ids=lambda p: p.parent.name)
def test_bundles_match_the_member_folders(folder):
    manifest = _manifest(folder)
    game = manifest["game_id"]
    policies = load_bundles(folder)
    scripted = [m for m in manifest["members"] if m["kind"] == "scripted"]
    assert sum(len(p.member_names) for p in policies) + len(scripted) == 100
    # a built-in member carries no artifact: its name and budget (a tuned heuristic's options) say what it is
    assert all(not m["artifact"] and m["agent_metadata"]["scripted"] and m["metadata"]["budget"] for m in scripted)
    by_name = {m["name"]: m for m in manifest["members"]}
    rng = np.random.default_rng(0)
    for stacked in policies:
        index = int(rng.integers(len(stacked.member_names)))
        member = by_name[stacked.member_names[index]]
        single = load_policy(folder / member["artifact"], game)
        obs = rng.standard_normal((3, single.spec.obs_dim)).astype(np.float32)
        # the member's own folder and its row of the stacked bundle act alike
        uniforms = rng.random((3, 8))
        solo, _ = single.act(obs, uniforms)
        together, _ = stacked.act(obs, uniforms, owners=np.full(3, index))
        assert np.allclose(solo, together, atol=1e-5)


@pytest.mark.parametrize("folder", SHIPPED, ids=lambda p: p.parent.name)
def test_best_member_beats_worst_and_random_in_fresh_matches(folder):
    from arena_league.matchmaking import play_matches, specs_for_seatings

    manifest = _manifest(folder)
    game = manifest["game_id"]
    members = sorted(manifest["members"], key=lambda m: m["metadata"]["rating"])
    best, worst = members[-1], members[0]
    agents = {"best": member_policy(folder, best, game), "worst": member_policy(folder, worst, game),
              "random": scripted_policy("random", game)}
    seatings = [("best", "worst"), ("worst", "best"), ("best", "random"), ("random", "best")] * 4
    specs = specs_for_seatings(game, seatings, league_seed=12345, first_match_id=0)
    with torch_threads(1):
        results = play_matches(specs, agents, backend="inprocess", batch_size=len(specs))
    score = {"worst": [], "random": []}
    for seats, result in zip(seatings, results):
        team = seats.index("best")
        score[seats[1 - team]].append(result.team_scores()[team])
    assert np.mean(score["worst"]) >= 0.75 and np.mean(score["random"]) >= 0.75, score


@pytest.mark.parametrize("folder", [
    pytest.param(f, marks=pytest.mark.xfail(strict=True, reason=WITHOUT_HEADROOM[f.parent.name]))
    if f.parent.name in WITHOUT_HEADROOM else f for f in NEWEST], ids=lambda p: f"{p.parent.name}/{p.name}")
def test_newest_population_has_headroom_above_the_heuristic(folder):
    """The best member against the scripted heuristic, replayed (20 fresh matches, seats balanced),
    and as the build recorded it over its own matches."""
    manifest = _manifest(folder)
    figure, _, threshold = HEADROOM
    recorded = manifest["provenance"]["figures"].get(figure)  # builds before the figure existed lack it
    assert recorded is None or recorded >= threshold
    _, won, _ = best_against_heuristic(folder, 20, seed=54321)
    assert won / 20 >= threshold, won
