"""Game options: every game's keyword arguments declared once, as data.

A game lists its options as :class:`Option` records in ``GameRules.options`` (name, type, bounds or
choices, default, meaning). ``make(game_id, **game_kwargs)`` checks the kwargs against them with
:func:`check_options`, so every game refuses an unknown name or a bad value with the same kind of
message (the game, the option, what it accepts, its default, and close names for a typo); the
manual (:func:`options_manual`) and the catalog the tree editor and ``arena-league games`` read
(:func:`options_catalog`) come from the same records.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Option", "check_options", "options_catalog", "options_manual"]

_KINDS = (int, float, str, bool)


@dataclass(frozen=True)
class Option:
    """One game option.

    ``kind`` is ``int``, ``float``, ``bool`` or ``str``; numbers take ``low``/``high`` bounds
    (inclusive, or exclusive at an end named in ``open_ends``: ``"low"``, ``"high"``); a ``str``
    option takes ``choices``. ``default`` is the value used when the option is not given; ``None``
    with ``default_text`` for a default that depends on the layout (``"snakes + 1"``), which the
    game computes.
    """

    name: str
    kind: type
    default: Any
    meaning: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    open_ends: tuple[str, ...] = ()
    default_text: str = ""

    def __post_init__(self) -> None:
        if self.kind not in _KINDS:
            raise TypeError(f"option {self.name}: kind must be one of int, float, bool, str")
        if self.kind is str and not self.choices:
            raise TypeError(f"option {self.name}: a str option lists its choices")

    def accepts(self) -> str:
        """What the option accepts, in words: ``a number in [0.6, 4.0]``, ``one of 'circle', 'box'``."""
        if self.kind is str:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        if self.kind is bool:
            return "true or false"
        noun = "an integer" if self.kind is int else "a number"
        if self.low is None and self.high is None:
            return noun
        left = "(" if "low" in self.open_ends else "["
        right = ")" if "high" in self.open_ends else "]"
        low = "-inf" if self.low is None else _number(self.low)
        high = "inf" if self.high is None else _number(self.high)
        return f"{noun} in {left}{low}, {high}{right}"

    def default_words(self) -> str:
        return self.default_text if self.default is None else _number(self.default)

    def describe(self) -> str:
        """One line: ``goal_width: a number in [0.6, 4.0], default 1.6 (width of each goal mouth)``."""
        return f"{self.name}: {self.accepts()}, default {self.default_words()} ({self.meaning})"

    def check(self, game: str, value: Any) -> Any:
        """``value`` as the option's type; a ValueError naming the game, the option and the fix."""
        if self.kind is bool:
            if isinstance(value, (bool, np.bool_)):
                return bool(value)
        elif self.kind is str:
            if isinstance(value, str) and value in self.choices:
                return value
        else:
            types: tuple[type, ...] = (int, np.integer) if self.kind is int else (int, float, np.integer, np.floating)
            if isinstance(value, types) and not isinstance(value, (bool, np.bool_)) and self._within(value):
                return int(value) if self.kind is int else float(value)
        raise ValueError(f"{game} option {self.name} must be {self.accepts()} (default {self.default_words()}: "
                         f"{self.meaning}), not {value!r}")

    def _within(self, value: float) -> bool:
        if not np.isfinite(value):
            return False
        if self.low is not None and (value < self.low or ("low" in self.open_ends and value == self.low)):
            return False
        return not (self.high is not None
                    and (value > self.high or ("high" in self.open_ends and value == self.high)))


def _number(value: Any) -> str:
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


def check_options(game: str, given: Mapping[str, Any], options: Sequence[Option]) -> dict[str, Any]:
    """Every option of ``options`` given its value from ``given`` or its default (``None`` for a
    default the game computes); an unknown name or a bad value raises one ValueError that names the
    game, the option and what it accepts, and suggests close names."""
    by_name = {option.name: option for option in options}
    unknown = sorted(set(given) - set(by_name), key=str)
    if unknown:
        name = unknown[0]
        close = difflib.get_close_matches(str(name), list(by_name), n=1, cutoff=0.6)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        offered = "; ".join(option.describe() for option in options) or "none"
        raise ValueError(f"{game} has no option {name!r}{hint}; its options: {offered}")
    settings: dict[str, Any] = {}
    for option in options:
        if option.name in given:
            settings[option.name] = option.check(game, given[option.name])
        else:
            settings[option.name] = option.default
    return settings


def options_manual(options: Sequence[Option]) -> str:
    """The options as the manual lists them, one per line (``none`` for a game without options)."""
    if not options:
        return "none"
    return "\n".join(f"``{option.name}`` ({option.accepts()}, default {option.default_words()}): "
                     f"{option.meaning}" for option in options)


def options_catalog(options: Sequence[Option]) -> list[dict[str, Any]]:
    """The options as JSON-ready records, for the tree editor's catalog and ``--json`` views."""
    records = []
    for option in options:
        record: dict[str, Any] = {"name": option.name, "type": option.kind.__name__, "default": option.default,
                                  "meaning": option.meaning, "accepts": option.accepts()}
        if option.kind in (int, float):
            record["low"], record["high"] = option.low, option.high
            record["open_ends"] = list(option.open_ends)
        if option.choices:
            record["choices"] = list(option.choices)
        if option.default is None:
            record["default_text"] = option.default_text
        records.append(record)
    return records
