"""The guide (the built docs site) under ``/guide``, and each game's manual in the terminal, the
JSON and the web game page."""

from __future__ import annotations

import json

import pytest
from starlette.testclient import TestClient

from arena_league.cli import main
from arena_league.league import game_manual
from arena_league.web.app import GUIDE_ENV, create_app

GAME = "GoBang-2T1P-v1"


def test_a_built_guide_is_served_under_guide_with_its_own_policy(tmp_path, monkeypatch):
    site = tmp_path / "site"
    (site / "games" / GAME).mkdir(parents=True)
    (site / "index.html").write_text("<html><script>var scope = 1;</script>the guide's home</html>")
    (site / "games" / GAME / "index.html").write_text("the GoBang page")
    monkeypatch.setenv(GUIDE_ENV, str(site))
    with TestClient(create_app(tmp_path / "home")) as client:
        home = client.get("/guide/")
        assert home.status_code == 200 and "the guide's home" in home.text
        assert "script-src 'self' 'unsafe-inline'" in home.headers["content-security-policy"]
        assert client.get(f"/guide/games/{GAME}/").text == "the GoBang page"
        assert client.get("/guide/%2e%2e/pyproject.toml").status_code == 404
        # the rest of the service keeps its strict policy, and the game page links to the guide
        page = client.get(f"/games/{GAME}", headers={"accept": "text/html"})
        assert "script-src 'self';" in page.headers["content-security-policy"]
        assert f'href="/guide/games/{GAME}/"' in page.text


def test_without_a_built_guide_guide_says_how_to_build_it(tmp_path, monkeypatch):
    monkeypatch.setenv(GUIDE_ENV, str(tmp_path / "not-built"))
    with TestClient(create_app(tmp_path / "home")) as client:
        answer = client.get("/guide/games/whatever")
        assert answer.status_code == 404 and "mkdocs build" in answer.json()["detail"]
        page = client.get(f"/games/{GAME}", headers={"accept": "text/html"})
        assert "/guide/" not in page.text
        assert 'data-role="manual"' in page.text and "five in a row" in page.text


@pytest.mark.parametrize("game", ["GoBang-2T1P-v1", "Crossroads-2T2P-v1", "Sumo-2T1P-v1"])
def test_arena_league_games_game_prints_its_manual(capsys, game):
    manual = game_manual(game)
    assert len(manual.splitlines()) > 10
    assert main(["games", game]) == 0
    out = capsys.readouterr().out
    assert manual.splitlines()[0] in out and manual.splitlines()[-1].strip() in out
    assert main(["games", game, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["games"][0]["manual"] == manual
