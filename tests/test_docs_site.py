"""The docs site covers what exists: every game id, shipped population, command, option, setting and
web API route has its place in the built site (``mkdocs build --strict``), and a fake addition
without a page is caught."""

from __future__ import annotations

import argparse
import html
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("mkdocs") is None and not (Path(sys.executable).parent / "mkdocs").exists(),
                       reason="mkdocs is not installed: pip install -e '.[dev]'"),
]


@dataclass
class Expected:
    """What the site must mention, each in the page that documents it."""

    games: list[str] = field(default_factory=list)
    populations: list[tuple[str, str]] = field(default_factory=list)
    commands: dict[str, list[str]] = field(default_factory=dict)
    """Command (``population build``) -> its options (``--steps``)."""
    settings: list[str] = field(default_factory=list)
    routes: list[str] = field(default_factory=list)


def expected() -> Expected:
    from arena_league.cli import build_parser
    from arena_league.envs import list_games
    from arena_league.league.settings import SETTINGS

    commands: dict[str, list[str]] = {}

    def walk(parser: argparse.ArgumentParser, path: tuple[str, ...]) -> None:
        options = [s for a in parser._actions for s in a.option_strings if s.startswith("--") and s != "--help"]
        if path:
            commands[" ".join(path)] = options
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, (*path, name))

    walk(build_parser(), ())
    populations = sorted((p.parent.name, p.name) for p in (ROOT / "checkpoints").glob("*/*") if p.is_dir())
    return Expected(games=list_games(), populations=populations, commands=commands, settings=sorted(SETTINGS),
                    routes=sorted(_routes()))


def _routes() -> set[str]:
    import tempfile

    from arena_league.web.app import create_app

    with tempfile.TemporaryDirectory() as home:
        document = create_app(Path(home) / "home").openapi()
    return set(document["paths"])


def _text(page: Path) -> str:
    """A built page's text, tags dropped and entities decoded (a route's braces, an option's dashes)."""
    return html.unescape(re.sub(r"<[^>]+>", " ", page.read_text()))


def missing(site: Path, wanted: Expected) -> list[str]:
    """What the built ``site`` does not document, one line each (empty: everything is there)."""
    gaps = []
    for game in wanted.games:
        if not (site / "games" / game / "index.html").is_file():
            gaps.append(f"game {game}: no page games/{game}/")
    for game, name in wanted.populations:
        if not (site / "populations" / f"{game}-{name}" / "index.html").is_file():
            gaps.append(f"population {game} {name}: no page populations/{game}-{name}/")
    commands = _text(site / "reference" / "commands" / "index.html")
    for command, options in wanted.commands.items():
        if f"arena-league {command}" not in commands:
            gaps.append(f"command {command}: not in reference/commands")
        gaps += [f"option {command} {o}: not in reference/commands" for o in options if o not in commands]
    settings = _text(site / "reference" / "settings" / "index.html")
    gaps += [f"setting {key}: not in reference/settings" for key in wanted.settings if key not in settings]
    api = _text(site / "reference" / "web-api" / "index.html")
    gaps += [f"route {route}: not in reference/web-api" for route in wanted.routes if route not in api]
    return gaps


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    mkdocs = shutil.which("mkdocs") or str(Path(sys.executable).parent / "mkdocs")
    done = subprocess.run([mkdocs, "build", "--strict", "--site-dir", str(out)], cwd=ROOT, capture_output=True,
                          text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-4000:]
    return out


def test_the_site_documents_every_game_population_command_setting_and_route(site):
    wanted = expected()
    assert wanted.games and wanted.commands and wanted.settings and wanted.routes
    assert missing(site, wanted) == []


def test_a_game_command_or_setting_added_without_a_page_is_caught(site):
    wanted = expected()
    wanted.games.append("Fake-2T1P-v1")
    wanted.commands["fake-command"] = ["--fake-option"]
    wanted.commands["games"] = [*wanted.commands["games"], "--fake-flag"]
    wanted.settings.append("fake.setting")
    wanted.routes.append("/api/fake/{thing}")
    assert missing(site, wanted) == [
        "game Fake-2T1P-v1: no page games/Fake-2T1P-v1/",
        "option games --fake-flag: not in reference/commands",
        "command fake-command: not in reference/commands",
        "option fake-command --fake-option: not in reference/commands",
        "setting fake.setting: not in reference/settings",
        "route /api/fake/{thing}: not in reference/web-api",
    ]


def test_getting_started_runs_as_written_in_a_fresh_league_home(tmp_path):
    """Every line of the page's ``shell`` blocks, run in order from the checkout's root with a fresh
    league home, succeeds (as a reader pasting them would see)."""
    import os
    import shlex

    page = (ROOT / "docs" / "getting-started.md").read_text()
    lines = [line.strip() for block in re.findall(r"```shell\n(.*?)```", page, flags=re.DOTALL)
             for line in block.splitlines() if line.strip() and not line.strip().startswith("#")]
    assert len(lines) >= 5 and all(line.startswith("arena-league ") for line in lines)
    env = {**os.environ, "ARENA_LEAGUE_HOME": str(tmp_path / "league")}
    env.pop("ARENA_LEAGUE_DB", None)
    for line in lines:
        done = subprocess.run([sys.executable, "-m", "arena_league.cli", *shlex.split(line)[1:]], cwd=ROOT, env=env,
                              capture_output=True, text=True, timeout=300, check=False)
        assert done.returncode == 0, f"{line}: {done.stderr[-2000:]}"
        assert done.stdout.strip(), line
