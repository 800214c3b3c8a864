"""The league a command works on, the games it knows, and suggestions for names typed wrong."""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from pathlib import Path

from arena_league import registry as reg
from arena_league.envs import game_spec
from arena_league.registry import League
from arena_league.registry.db import DB_FILENAME

__all__ = ["did_you_mean", "league_location", "open_home", "register_game", "short_name"]


def open_home(home: str | Path | None = None, url: str | None = None) -> League:
    """Open (and create if needed) the league at ``home`` / ``url`` (``ARENA_LEAGUE_HOME``,
    ``ARENA_LEAGUE_DB``, default ``~/.arena-league``)."""
    return reg.open_league(url, home)


def league_location(home: str | Path | None = None, url: str | None = None) -> str:
    """Where the league at ``home`` / ``url`` lives, as a person reads it: the home folder and, when
    the registry is not the home's own SQLite file, the database URL (without its password)."""
    folder = reg.league_home(home)
    database = reg.league_url(url, home)
    if database.drivername == "sqlite" and database.database == str(folder / DB_FILENAME):
        return str(folder)
    return f"{folder} (database {database.render_as_string(hide_password=True)})"


def register_game(league: League, game_id: str) -> None:
    """Make ``game_id`` known to the league (an unknown id raises, listing the valid ones)."""
    spec = game_spec(game_id)
    with league.transaction() as session:
        reg.ensure_game(session, game_id, spec.n_teams, spec.players_per_team)


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`` Did you mean 'X'?`` for the choices closest to ``word`` (case ignored), or ``""``."""
    by_lower: dict[str, str] = {}
    for choice in choices:
        by_lower.setdefault(choice.lower(), choice)
    close = difflib.get_close_matches(word.lower(), list(by_lower), n=3, cutoff=0.6)
    if not close:
        return ""
    return " Did you mean " + " or ".join(repr(by_lower[c]) for c in close) + "?"


def short_name(name: str, game_id: str) -> str:
    """``name`` without the ``@<game id>`` suffix that scripted and base agents carry."""
    suffix = f"@{game_id}"
    return name[: -len(suffix)] if name.endswith(suffix) and len(name) > len(suffix) else name
