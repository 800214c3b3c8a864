"""Names and versions of submitted agents: one rule for ``arena-league submit`` and web uploads.

A name is a series of immutable versions owned by whoever submitted its first: ``alice`` is
version 1; new bytes submitted as ``alice`` by the same owner become ``alice:v2``, ``alice:v3``...;
the same bytes again are the agent already registered for them; anyone else submitting as
``alice`` is refused. A submitted name has no ``:`` (versions are named by the league) and is not
reserved (:func:`~arena_league.league.service.reserved_name_reason`), follows the league's name
policy (:mod:`arena_league.league.names`: one Unicode form, no hidden characters, not a look-alike
of another name of the game, not a name of the agents people play as). An empty file is refused
before anything is stored.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from arena_league import registry as reg
from arena_league.league.errors import ForbiddenError
from arena_league.league.names import agent_name_problem, refuse_confusable, skeleton, suggested_name

__all__ = ["artifact_files", "check_submitted_name", "refuse_empty", "series_of", "version_name", "version_rows"]

_VERSION = re.compile(r"(?P<series>.+):v(?P<version>[0-9]+)")
#: Files of an artifact that hold the agent: one of them empty means there is nothing to register.
_AGENT_FILES = ("manifest.json", "weights.safetensors")


def series_of(name: str) -> tuple[str, int]:
    """``alice:v3`` -> (``alice``, 3); ``alice`` -> (``alice``, 1)."""
    found = _VERSION.fullmatch(name)
    return (found["series"], int(found["version"])) if found else (name, 1)


def version_rows(session: Any, name: str) -> list[dict[str, Any]]:
    """Every version of the series ``name`` belongs to: name, version, status, reason, created."""
    series, _ = series_of(name)
    return [{"name": a.name, "version": series_of(a.name)[1], "status": a.status, "reason": a.reject_reason,
             "created_at": a.created_at.isoformat(timespec="seconds")} for a in reg.series_agents(session, series)]


def check_submitted_name(name: str) -> None:
    """Refuse a name no one may submit under: malformed, with a version suffix, or reserved for
    the league (``ValueError``, or :class:`ForbiddenError` for a reserved one)."""
    from arena_league.league.service import reserved_name_reason

    problem = agent_name_problem(name)
    if problem is not None:
        raise ValueError(problem)
    reserved = reserved_name_reason(name)
    if reserved is not None:
        raise ForbiddenError(f"{reserved}; the name is reserved for the league. Submit under a name of your own, "
                             f"e.g. --name {suggested_name(name)}")


def refuse_empty(files: Iterable[tuple[str, int]]) -> None:
    """Refuse an artifact whose agent file is empty; ``files`` are (file name, size in bytes)."""
    for name, size in files:
        if size == 0 and (name.endswith(".onnx") or name in _AGENT_FILES):
            raise ValueError(f"{name} is empty (0 bytes), so there is no agent to register; export the agent "
                             "again and submit the file (or arena-policy folder) the export wrote")


def artifact_files(path: str | Path) -> list[tuple[str, int]]:
    """(name, size) of the files an artifact at ``path`` (an ONNX file or a folder) is made of."""
    path = Path(path)
    if path.is_dir():
        return [(f.name, f.stat().st_size) for f in sorted(path.iterdir()) if f.is_file()]
    return [(path.name, path.stat().st_size)] if path.is_file() else []


class _GameSkeletons:
    """The series names of one game by UTS #39 skeleton, as of ``count`` agents up to id ``newest``."""

    def __init__(self) -> None:
        self.count, self.newest = 0, 0
        self.by_skeleton: dict[str, set[str]] = {}

    def add(self, rows: list[tuple[int, str]]) -> None:
        for agent_id, name in rows:
            series = series_of(name)[0]
            self.by_skeleton.setdefault(skeleton(series), set()).add(series)
            self.newest = max(self.newest, agent_id)
        self.count += len(rows)


#: Per league and game: brought up to date by the agents added since, so a check over thousands of
#: names reads two numbers and a few new rows instead of every name.
_SKELETONS: dict[tuple[str, str], _GameSkeletons] = {}
_SKELETONS_LOCK = threading.Lock()


def _look_alikes(session: Any, game_id: str, name: str) -> set[str]:
    """The series names of ``game_id`` that share ``name``'s skeleton."""
    key = (str(session.get_bind().url), game_id)
    count, newest = reg.agent_span(session, game_id)
    with _SKELETONS_LOCK:
        known = _SKELETONS.get(key)
        if known is None or (known.count, known.newest) != (count, newest):
            rows = reg.agent_names(session, game_id, after_id=known.newest) if known is not None else []
            if known is None or known.count + len(rows) != count:  # agents removed: read every name again
                known, rows = _GameSkeletons(), reg.agent_names(session, game_id)
            known.add(rows)
            _SKELETONS[key] = known
        return set(known.by_skeleton.get(skeleton(name), ()))


def version_name(session: Any, name: str, game_id: str, owner: str | None) -> tuple[str, int]:
    """The name and version that new bytes submitted as ``name`` by ``owner`` get: ``name`` itself
    when it is free, else the series' next version. Refused when the name is another owner's, is
    not a submission (a base member, a scripted agent), plays another game, or a new name looks like
    another of the game."""
    existing = reg.series_agents(session, name)
    if not existing:
        refuse_confusable(name, _look_alikes(session, game_id, name), "agent name", f"an agent of {game_id}")
        return name, 1
    first = existing[0]
    if first.kind != "submission":
        raise ForbiddenError(f"{name} is a {first.kind} agent of the league, not a submission; submit under a name "
                             "of your own")
    if first.owner != owner:
        raise ForbiddenError(f"the name {name} belongs to another submitter; submit under a name of your own")
    if first.game_id != game_id:
        raise ValueError(f"{name} plays {first.game_id}, not {game_id}; submit {game_id} agents under another name")
    version = series_of(existing[-1].name)[1] + 1
    return f"{name}:v{version}", version
