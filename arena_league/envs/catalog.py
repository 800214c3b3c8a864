"""The game catalog: ids in Arena's convention ``<Game>-<x>T<y>P-v<N>`` mapped to game rules.

Each module listed in :data:`GAME_MODULES` defines ``RULES``, a :class:`GameRules` subclass whose
``layouts`` give the ids it offers. A game is that one module: its rules also declare how a person
plays a seat, its replay scene and its whole-array engine, if any (see :mod:`arena_league.envs.core`),
so adding a game means adding its module here and touches no other package.

A rules class outside :data:`GAME_MODULES` (a game being written, a test's toy game) joins the
catalog for a while with :func:`registered_rules` (see ``docs/adding-a-game.md``).
"""

from __future__ import annotations

import difflib
import importlib
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache

from arena_league.envs.core import GameRules

#: Game modules under ``arena_league.envs.games``, one per game.
GAME_MODULES: tuple[str, ...] = ("crossroads", "soccer", "gobang", "snake", "sumo", "runtogoal", "youshallnotpass", "pushbox", "airhockey",
                                 "fightforfood", "blowblow", "tennis", "captureflag", "boomer", "battlecity",
                                 "fighter")

_ID_RE = re.compile(r"^(?P<name>[A-Za-z][A-Za-z0-9]*)-(?P<teams>\d+)T(?P<players>\d+)P-v(?P<version>\d+)$")


@dataclass(frozen=True)
class GameSpec:
    """One game id and the rules class behind it."""

    game_id: str
    rules: type[GameRules]
    n_teams: int
    players_per_team: int

    @property
    def n_agents(self) -> int:
        return self.n_teams * self.players_per_team

    @property
    def paired(self) -> bool:
        """Whether the game's matches are played in pairs with the seats swapped
        (``GameRules.match_format``)."""
        return self.rules.match_format == "paired"


def format_game_id(name: str, n_teams: int, players_per_team: int, version: int) -> str:
    return f"{name}-{n_teams}T{players_per_team}P-v{version}"


@cache
def game_rules_classes() -> tuple[type[GameRules], ...]:
    classes = []
    for module_name in GAME_MODULES:
        module = importlib.import_module(f"arena_league.envs.games.{module_name}")
        classes.append(module.RULES)
    return tuple(classes)


#: Rules classes registered for a while by :func:`registered_rules`, beside the game modules'.
_REGISTERED: list[type[GameRules]] = []


def _ids_of(rules: type[GameRules]) -> list[GameSpec]:
    rules.check_match_format()
    return [GameSpec(format_game_id(rules.name, n_teams, players, rules.version), rules, n_teams, players)
            for n_teams, players in rules.layouts]


@cache
def _catalog() -> dict[str, GameSpec]:
    specs: dict[str, GameSpec] = {}
    for rules in (*game_rules_classes(), *_REGISTERED):
        for spec in _ids_of(rules):
            specs[spec.game_id] = spec
    return specs


@contextmanager
def registered_rules(rules: type[GameRules]) -> Iterator[list[str]]:
    """The catalog with ``rules`` in it, for the ``with`` block: its ids (yielded) work with
    ``make``, ``game_spec`` and the conformance check (``arena_league.envs.check``) as a game module's
    do, and are gone after the block. For a game being written, before its module joins
    :data:`GAME_MODULES`, and for tests' toy games; an id the catalog already has is refused."""
    if not (isinstance(rules, type) and issubclass(rules, GameRules)):
        raise TypeError(f"registered_rules takes a GameRules subclass, not {rules!r}")
    taken = [spec.game_id for spec in _ids_of(rules) if spec.game_id in _catalog()]
    if taken:
        raise ValueError(f"the catalog already has {', '.join(taken)}: give {rules.__name__} another name or "
                         "version")
    _REGISTERED.append(rules)
    _catalog.cache_clear()
    try:
        yield [spec.game_id for spec in _ids_of(rules)]
    finally:
        _REGISTERED.remove(rules)
        _catalog.cache_clear()


def list_games() -> list[str]:
    """Every game id, sorted."""
    return sorted(_catalog())


def game_spec(game_id: str) -> GameSpec:
    """The spec of ``game_id``; an unknown id raises ``ValueError`` listing the valid ones."""
    specs = _catalog()
    if not isinstance(game_id, str):
        raise TypeError(f"a game id is a string such as 'Crossroads-2T2P-v1', not {type(game_id).__name__}")
    if game_id in specs:
        return specs[game_id]
    by_lower = {g.lower(): g for g in specs}
    if game_id.lower() in by_lower:
        raise ValueError(f"unknown game id {game_id!r}: did you mean {by_lower[game_id.lower()]!r}? (ids are "
                         "case-sensitive)")
    close = difflib.get_close_matches(game_id.lower(), list(by_lower), n=3, cutoff=0.6)
    suggestion = f" Did you mean {' or '.join(repr(by_lower[c]) for c in close)}?" if close else ""
    match = _ID_RE.match(game_id)
    same_game = [g for g in specs if match and g.split("-")[0].lower() == match["name"].lower()]
    if not match:
        hint = "ids follow '<Game>-<x>T<y>P-v<N>' (x teams of y players)"
    elif same_game:
        hint = f"{match['name']} is offered as: {', '.join(same_game)}"
    else:
        hint = f"there is no game named {match['name']!r}"
    raise ValueError(f"unknown game id {game_id!r}: {hint}.{suggestion} Valid ids: {', '.join(sorted(specs))}")
