"""A griffe extension for the Python API pages: the package's docstrings cross-reference with Sphinx
roles (``:func:`~arena_league.training.run_scheme```), which mkdocstrings would show as raw text;
each role becomes inline code of its target (the last name with ``~``, as Sphinx shows it)."""

from __future__ import annotations

import re
from typing import Any

import griffe

_ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|attr|data|exc|obj|const):`(~?)([^`]+)`")


def _as_code(match: re.Match) -> str:
    short, target = match.group(1), match.group(2)
    return f"`{target.rsplit('.', 1)[-1] if short else target}`"


class SphinxRoles(griffe.Extension):
    """Rewrites every object's docstring once griffe has loaded it."""

    def on_object(self, *, obj: Any, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = _ROLE.sub(_as_code, obj.docstring.value)
