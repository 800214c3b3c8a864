"""The toy 2D game written by following docs/adding-a-game.md (``tests/toy_game.py``), in the catalog
only for these tests: it passes the conformance check every game passes, and plays as its manual says."""

from __future__ import annotations

import numpy as np
import pytest
from toy_game import PuckPushRules

from arena_league.envs import list_games, make
from arena_league.envs.catalog import registered_rules
from arena_league.envs.check import CHECKS, QUICK, run_check

IDS = ("PuckPush-2T1P-v1", "PuckPush-2T2P-v1")


@pytest.fixture(scope="module")
def toy_ids():
    with registered_rules(PuckPushRules) as ids:
        yield ids


def test_the_toy_game_joins_the_catalog_only_while_registered(toy_ids):
    assert tuple(toy_ids) == IDS and set(IDS) <= set(list_games())
    with pytest.raises(ValueError, match="the catalog already has PuckPush-2T1P-v1, PuckPush-2T2P-v1"), \
            registered_rules(PuckPushRules):
        pass


@pytest.mark.parametrize("check", [check.name for check in CHECKS])
@pytest.mark.parametrize("game_id", IDS)
def test_the_toy_game_passes_the_conformance_check(toy_ids, game_id, check):
    result = run_check(check, game_id, QUICK)
    assert result.ok, result.detail


@pytest.mark.parametrize("team", [0, 1])
def test_pushing_the_puck_over_the_far_line_wins(toy_ids, team):
    env = make("PuckPush-2T1P-v1", max_cycles=200)
    env.reset(seed=0)
    heuristic = PuckPushRules.heuristic
    others = 1 - team
    for _ in range(200):
        obs = env.rules.observe()
        actions = {f"player_{team}": int(heuristic(obs[team: team + 1], "discrete")[0]), f"player_{others}": 0}
        _, rewards, terminated, _, _ = env.step(actions)
        if terminated[f"player_{team}"]:
            break
    assert env.rules.game_over and env.rules.events() == [{"kind": "score", "team": team}]
    assert list(env.team_result()) == [1.0 - team, float(team)] and rewards[f"player_{team}"] > 0


def test_a_match_cut_at_max_cycles_is_a_draw(toy_ids):
    env = make("PuckPush-2T2P-v1", max_cycles=5)
    env.reset(seed=1)
    for _ in range(5):
        _, _, _, truncated, _ = env.step(dict.fromkeys(env.possible_agents, 0))
    assert all(truncated.values()) and list(env.team_result()) == [0.5, 0.5]
    assert np.all(env.rules.measures.outcome == 0)


def test_options_are_refused_with_what_they_accept(toy_ids):
    with pytest.raises(ValueError, match=r"PuckPush option line must be a number in \[1.0, 2.6\]"):
        make("PuckPush-2T1P-v1", line=3.0)
    assert make("PuckPush-2T1P-v1", line=1.5).rules.line == 1.5


class _UnrecordedSteps(PuckPushRules):
    """PuckPush as an author who forgot to record the steps copies replay would write it."""

    name = "PuckPushUnrecorded"

    def _record(self, method, *args):
        if method != "step":
            super()._record(method, *args)


def test_forgetting_to_record_the_steps_fails_the_copies_check_with_the_fix():
    with registered_rules(_UnrecordedSteps) as ids:
        result = run_check("copies", ids[0], QUICK)
    assert not result.ok and "copy of PuckPushUnrecorded-2T1P-v1 (action_type='discrete') mid-episode" in result.detail
    assert "mix in core.ReplayedMatch and record every call that changes the match" in result.detail
