"""Game options declared once: ``make`` checks them, and the catalog the tree editor fetches, the
games API, the game page and ``arena-league games`` list them from the same declaration."""

from __future__ import annotations

import json
import sys

import pytest

from arena_league.cli import main
from arena_league.envs import game_options, list_games, make
from arena_league.envs.catalog import game_rules_classes
from arena_league.envs.options import options_catalog

DECLARED = ("GoBang", "Snake", "Sumo", "RunToGoal", "YouShallNotPass", "PushBox")


def _declared_ids() -> list[str]:
    return [g for g in list_games() if g.split("-")[0] in DECLARED]


def test_the_grid_and_robot_games_declare_every_option_they_take():
    names = {rules.name: [o.name for o in rules.options] for rules in game_rules_classes()}
    assert names["GoBang"] == ["size", "n_in_row"]
    assert names["Snake"] == ["size", "n_food", "start_length", "view_radius"]
    assert names["Sumo"] == ["ring_radius", "start_jitter", "frame_skip", "anneal"]
    assert names["RunToGoal"] == ["field_length", "start_jitter", "frame_skip", "anneal"]
    assert names["YouShallNotPass"] == ["field_length", "blocker_distance", "start_jitter", "frame_skip", "anneal"]
    assert names["PushBox"] == ["target_radius", "box_distance", "start_jitter", "frame_skip", "anneal"]


@pytest.mark.parametrize("name", DECLARED)
def test_each_manual_names_every_declared_option_and_its_default(name):
    rules = next(r for r in game_rules_classes() if r.name == name)
    manual = sys.modules[rules.__module__].__doc__
    section = manual[manual.index("Game kwargs"):]
    section = " ".join(section[:section.index("\n\n")].split())
    for option in rules.options:
        assert f"``{option.name}`` (" in section, option.name
        mentioned = section[section.index(f"``{option.name}`` ("):]
        assert f"default {option.default_words()}" in mentioned[:mentioned.index(")")], option.name
    assert f"{rules.__name__}.options" in section


@pytest.mark.parametrize("game_id", ["GoBang-2T1P-v1", "Snake-2T2P-v1", "Sumo-2T1P-v1", "PushBox-2T2P-v1"])
def test_each_declared_default_is_what_the_game_plays_without_options(game_id):
    rules = make(game_id).rules
    defaults = {o.name: o.default for o in game_options(game_id)}
    given = make(game_id, **{k: v for k, v in defaults.items() if v is not None}).rules
    assert given.obs_dim == rules.obs_dim and given.state_dim == rules.state_dim
    settings = getattr(rules, "settings", None)
    if settings is not None:  # the robot games keep their settings, pickled as their arguments
        assert settings == defaults and [type(v) for v in settings.values()] == [o.kind for o in game_options(game_id)]


@pytest.mark.parametrize("game_id", ["GoBang-2T2P-v1", "Snake-4T1P-v1", "RunToGoal-2T1P-v1", "YouShallNotPass-2T1P-v1"])
def test_a_bad_option_is_one_line_naming_the_game_the_option_its_bounds_and_default(game_id):
    name = game_id.split("-")[0]
    first = game_options(game_id)[0]
    with pytest.raises(ValueError) as bad:
        make(game_id, **{first.name: "big"})
    message = str(bad.value)
    assert "\n" not in message
    assert message == (f"{name} option {first.name} must be {first.accepts()} (default {first.default_words()}: "
                       f"{first.meaning}), not 'big'")
    with pytest.raises(ValueError, match=rf"^{name} has no option '{first.name}x' \(did you mean '{first.name}'\?\); "
                                         rf"its options: {first.name}: "):
        make(game_id, **{f"{first.name}x": 1})


def test_the_api_catalogs_and_the_game_page_list_the_declared_options(tmp_path):
    from fastapi.testclient import TestClient

    from arena_league.league import open_home
    from arena_league.web.app import create_app

    home = tmp_path / "home"
    with open_home(home):
        pass
    with TestClient(create_app(home)) as client:
        for game_id in ("GoBang-2T1P-v1", "YouShallNotPass-2T1P-v1"):
            declared = json.loads(json.dumps(options_catalog(game_options(game_id))))
            catalog = client.get(f"/api/games/{game_id}/tree-catalog")
            assert catalog.status_code == 200 and catalog.json()["options"] == declared
            assert client.get(f"/games/{game_id}.json").json()["options"] == declared
        games = {g["game_id"]: g for g in client.get("/api/games").json()}
        snake = games["Snake-2T1P-v1"]["options"]
        assert [o["name"] for o in snake] == ["size", "n_food", "start_length", "view_radius"]
        n_food = snake[1]
        assert n_food["default"] is None and n_food["default_text"] == "snakes + 1" and n_food["low"] == 0
        assert games["Sumo-2T1P-v1"]["options"][-1] == {
            "name": "anneal", "type": "float", "default": 1.0, "low": 0.0, "high": 1.0, "open_ends": [],
            "accepts": "a number in [0.0, 1.0]", "meaning": game_options("Sumo-2T1P-v1")[-1].meaning}
        page = client.get("/games/Snake-2T1P-v1", headers={"accept": "text/html"})
        assert page.status_code == 200
        assert "<code>n_food</code>" in page.text and "an integer in [0, inf], default\n    snakes + 1." in page.text


def test_arena_league_games_shows_a_games_options(capsys):
    assert main(["games", "--json"]) == 0
    rows = {row["game_id"]: row for row in json.loads(capsys.readouterr().out)["games"]}
    for game_id in _declared_ids():
        assert rows[game_id]["options"] == json.loads(json.dumps(options_catalog(game_options(game_id))))
    assert main(["games", "PushBox-2T2P-v1"]) == 0
    out = capsys.readouterr().out
    lines = [line.strip() for line in out.splitlines()]
    assert "Options (make(game_id, **options)):" in lines
    assert ("box_distance: a number in [1.5, 4.0], default 2.0 (distance from each box's start to the target, in m)"
            in lines)
    assert "frame_skip: an integer in [1, 20], default 5 (MuJoCo sub-steps of 0.01 s per match step)" in lines
    assert main(["games", "PushBox-2T1P-v1"]) == 2
    assert "unknown game id 'PushBox-2T1P-v1'" in capsys.readouterr().err
