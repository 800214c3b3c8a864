"""Parsing JSON and YAML that a person hands in (a social tree file, a play message, a request
body) within bounds on its size and nesting, so that no document can cost the parser's recursion or
grow in memory far beyond its own size.

The nesting of JSON text is counted by a scan of its brackets (strings taken out first), without
recursion, before the parser sees it. YAML is composed by a loader that refuses anchors and aliases
(a few hundred bytes of aliases expand to gigabytes: "billion laughs") and counts its nesting as it
composes. Every refusal is one :class:`BoundedInputError` (a ``ValueError``) naming the limit and
the fix.
"""

from __future__ import annotations

import json
import re
from typing import Any

import numpy as np
import yaml

__all__ = ["MAX_DEPTH", "MAX_TEXT_BYTES", "BoundedInputError", "check_json_nesting", "json_nesting", "load_json",
           "load_yaml"]

#: The deepest nesting of arrays and objects (mappings and sequences) a document may have.
MAX_DEPTH = 64
#: The most a document may hold, in bytes (UTF-8).
MAX_TEXT_BYTES = 1 << 20

_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_BRACKETS = b"[]{}"
_NOT_BRACKETS = bytes(b for b in range(256) if b not in _BRACKETS)


class BoundedInputError(ValueError):
    """A document over a size or nesting bound, or written in a way that is refused (YAML aliases)."""


def json_nesting(text: str | bytes) -> int:
    """The deepest nesting of arrays and objects in JSON ``text`` (0 for a scalar), counted without
    recursion; brackets inside strings do not count."""
    data = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else bytes(text)
    brackets = _STRING.sub(b"", data).translate(None, _NOT_BRACKETS)
    if not brackets:
        return 0
    codes = np.frombuffer(brackets, dtype=np.uint8)
    steps = np.where((codes == ord("[")) | (codes == ord("{")), 1, -1)
    return int(np.cumsum(steps).max(initial=0))


def check_json_nesting(text: str | bytes, what: str, *, max_depth: int = MAX_DEPTH,
                       max_bytes: int = MAX_TEXT_BYTES) -> None:
    """Raise :class:`BoundedInputError` when JSON ``text`` is over ``max_bytes`` or nests deeper
    than ``max_depth``; ``what`` names the document in the message."""
    size = len(text.encode("utf-8", "surrogatepass")) if isinstance(text, str) else len(text)
    if size > max_bytes:
        raise BoundedInputError(f"{what} is {size} bytes, over the limit of {max_bytes}; send a smaller document")
    depth = json_nesting(text)
    if depth > max_depth:
        raise BoundedInputError(f"{what} nests arrays and objects {depth} deep, deeper than the limit of {max_depth}; "
                                "write it with less nesting")


def load_json(text: str | bytes, what: str, *, max_depth: int = MAX_DEPTH, max_bytes: int = MAX_TEXT_BYTES) -> Any:
    """JSON ``text`` parsed once its size and nesting are within bounds; :class:`BoundedInputError`
    over a bound or when it is not valid JSON (``what`` names the document)."""
    check_json_nesting(text, what, max_depth=max_depth, max_bytes=max_bytes)
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as error:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        raise BoundedInputError(f"{what} is not valid JSON: {error}") from None


class _BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader that refuses anchors and aliases and counts how deep it composes."""

    max_depth = MAX_DEPTH
    what = "the document"

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self.depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None) is not None:
            marker = "*" if isinstance(event, yaml.AliasEvent) else "&"
            raise BoundedInputError(f"{self.what} uses a YAML anchor or alias ({marker}{event.anchor}, line "
                                    f"{event.start_mark.line + 1}), which is not allowed: write the nodes out in full")
        self.depth += 1
        if self.depth > self.max_depth:
            raise BoundedInputError(f"{self.what} nests mappings and lists deeper than the limit of {self.max_depth} "
                                    f"(line {event.start_mark.line + 1}); write it with less nesting")
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


def load_yaml(text: str, what: str, *, max_depth: int = MAX_DEPTH, max_bytes: int = MAX_TEXT_BYTES) -> Any:
    """YAML ``text`` parsed safely (plain data only) with no anchors or aliases, within ``max_bytes``
    and ``max_depth``; :class:`BoundedInputError` over a bound, for an alias, or when it is not
    valid YAML (``what`` names the document)."""
    size = len(text.encode("utf-8", "surrogatepass"))
    if size > max_bytes:
        raise BoundedInputError(f"{what} is {size} bytes, over the limit of {max_bytes}; send a smaller document")
    loader = _BoundedLoader(text)
    loader.max_depth, loader.what = max_depth, what
    try:
        return loader.get_single_data()
    except BoundedInputError:
        raise
    except (yaml.YAMLError, ValueError, RecursionError) as error:  # ValueError: e.g. an integer of 5000 digits
        mark = getattr(error, "problem_mark", None)
        problem = getattr(error, "problem", None) or " ".join(str(error).split())
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise BoundedInputError(f"{what} is not valid YAML: {problem}{where}") from None
    finally:
        loader.dispose()
