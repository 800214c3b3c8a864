"""Every game id of the catalog through the conformance check a game author runs
(``python -m arena_league.envs.check``), on its quick budget: PettingZoo's API tests, determinism,
copies, bounds, options, the default tree's verification, the heuristic, the headless picture, the
replay scene, a person's controls and throughput. The check itself fails with the fix: the tests
here are that check, one per game and check, and a few of what the command itself answers."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from arena_league.envs import list_games, make
from arena_league.envs.check import CHECKS, QUICK, CheckFailure, check_bounds, check_scene, main, run_check
from arena_league.replay.schemas import scene_update_schema

GAMES = list_games()
#: Checks a game is known to fail today, with why: each passes once its game is mended (strict).
KNOWN_FAILURES: dict[tuple[str, str], str] = {}


def _cases() -> list:
    cases = []
    for game_id in GAMES:
        for check in CHECKS:
            why = KNOWN_FAILURES.get((game_id, check.name))
            marks = [pytest.mark.xfail(strict=True, reason=why)] if why else []
            cases.append(pytest.param(game_id, check.name, marks=marks, id=f"{game_id}-{check.name}"))
    return cases


@pytest.mark.parametrize("game_id, check", _cases())
def test_every_game_passes_the_conformance_check(game_id, check, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)  # the picture and the controls' views need no display
    result = run_check(check, game_id, QUICK)
    assert result.ok, result.detail


@pytest.mark.parametrize("game_id", GAMES)
def test_scene_entities_meet_the_replay_schema(game_id):
    # the check reads the scene as envs.scene builds it; the replay layer's schema is the other side
    required = scene_update_schema()["properties"]["entities"]["items"]["required"]
    env = make(game_id)
    env.reset(seed=0)
    entities = env.rules.scene_entities(1_500_000_000)
    assert entities and all(set(required) <= set(entity) for entity in entities)


class _LeakyBounds:
    """Wraps a game's rules so that one observation cell leaves its bounds at step 3."""

    def __init__(self, rules):
        self.rules = rules
        self.steps = 0

    def __getattr__(self, name):
        return getattr(self.rules, name)

    def reset(self, seed):
        self.steps = 0
        self.rules.reset(seed)

    def step(self, actions):
        self.steps += 1
        self.rules.step(actions)

    def observe(self):
        obs = self.rules.observe()
        if self.steps >= 3:
            obs[0, 2] = 7.5
        return obs


def test_a_cell_out_of_its_bounds_fails_naming_the_cell_the_step_and_the_fix(monkeypatch):
    import arena_league.envs.check as check_module

    def leaky_make(game_id, **kwargs):
        env = make(game_id, **kwargs)
        env.rules = _LeakyBounds(env.rules)
        return env

    monkeypatch.setattr(check_module, "make", leaky_make)
    with pytest.raises(CheckFailure) as failure:
        check_bounds("Soccer-2T1P-v1", QUICK)
    message = str(failure.value)
    assert "player_0's observation cell 2 left its bounds" in message and "(value 7.5) at step 3 of seed 11" in message
    assert message.endswith(": widen observation_bounds() or clip in observe()")


def test_rules_that_draw_outside_their_seeded_generator_fail_determinism(monkeypatch):
    import arena_league.envs.check as check_module

    calls = iter(range(10**6))  # shared by every env, as a module-level cache would be

    def noisy_make(game_id, **kwargs):
        env = make(game_id, **kwargs)
        observe = env.rules.observe

        def noisy_observe():
            obs = observe()
            obs[1, 0] = np.float32(next(calls) % 2)
            return obs

        env.rules.observe = noisy_observe
        return env

    monkeypatch.setattr(check_module, "make", noisy_make)
    result = run_check("determinism", "Snake-2T1P-v1", QUICK)
    assert not result.ok and result.detail.startswith("observations after reset/player_1 cell 0 (1.0 vs 0.0) differs "
                                                      "after reset(seed=3) between two fresh envs")
    assert "draw every random number from self.rng" in result.detail


def test_a_scene_whose_ids_change_fails_with_the_fix(monkeypatch):
    import arena_league.envs.check as check_module
    from arena_league.envs import scene

    def make_with_a_new_id_each_step(game_id, **kwargs):
        env = make(game_id, **kwargs)
        counter = iter(range(10**6))
        env.rules.scene_entities = lambda stamp: [scene.entity(f"thing/{next(counter)}", stamp)]
        return env

    monkeypatch.setattr(check_module, "make", make_with_a_new_id_each_step)
    with pytest.raises(CheckFailure, match=r"at step 1 of seed 1: the entity ids changed .*keep the same ids"):
        check_scene("GoBang-2T1P-v1", QUICK)


def test_a_game_that_raises_fails_the_check_naming_where(monkeypatch):
    import arena_league.envs.check as check_module

    def broken_make(game_id, **kwargs):
        env = make(game_id, **kwargs)

        def heuristic(obs, action_type):
            raise ZeroDivisionError("the heuristic divided by zero")

        env.rules.heuristic = heuristic
        return env

    monkeypatch.setattr(check_module, "make", broken_make)
    result = run_check("heuristic", "Snake-2T1P-v1", QUICK)
    assert not result.ok and "heuristic() raised ZeroDivisionError (the heuristic divided by zero)" in result.detail
    assert "test_envs_conformance.py" in result.detail  # where it was raised


def test_the_command_prints_a_line_per_check_and_a_json_document(capsys):
    assert main(["GoBang-2T1P-v1", "--quick", "--only", "api,render"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 3 and lines[0].split()[:3] == ["GoBang-2T1P-v1", "api", "ok"]
    assert lines[-1].startswith("2 of 2 checks passed over 1 game ids")
    assert main(["GoBang-2T1P-v1", "--quick", "--only", "throughput", "--json", "--floor", "1e9"]) == 1
    document = json.loads(capsys.readouterr().out)
    assert document["ok"] is False and document["budget"] == "quick"
    (result,) = document["results"]
    assert result["check"] == "throughput" and not result["ok"]
    assert "under the floor of 1,000,000,000: the time went to" in result["detail"]


def test_the_command_refuses_an_unknown_id_or_check_in_one_line():
    for arguments, words in ((["Gobang-2T1P-v1"], "did you mean 'GoBang-2T1P-v1'?"),
                             (["GoBang-2T1P-v1", "--only", "speed"], "unknown check 'speed'; valid: api,")):
        done = subprocess.run([sys.executable, "-m", "arena_league.envs.check", *arguments], capture_output=True,
                              text=True, check=False, timeout=120)
        assert done.returncode == 2 and words in done.stderr and len(done.stderr.strip().splitlines()) == 1

