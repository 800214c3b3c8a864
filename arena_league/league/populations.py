"""Populations of a game: finding them by name, the game's default base, import and export.

A population is named and versioned per game: ``base-v1:1`` of GoBang and ``base-v1:1`` of Snake
are two populations, and ``name`` alone means the newest version of that name in the game.

The population an entrant is ranked against by default is the game's **base**
(:func:`game_population`): the newest frozen population of the game in the league, or, when the
league has none, the one shipped with the package under ``checkpoints/<game>/base-v1/``, imported
on first use. Imports are idempotent by content: importing a folder whose files are byte for byte
those of a population already imported for that game returns that population (the address of the
folder, as the artifact store computes it, is kept in its provenance under ``imported_from``).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

from arena_league import registry as reg
from arena_league.league.home import did_you_mean, register_game
from arena_league.policies.address import file_address, folder_address
from arena_league.registry import League

__all__ = [
    "POPULATION_MANIFEST",
    "SHIPPED_POPULATIONS",
    "ensure_population",
    "export_population",
    "find_population",
    "game_population",
    "import_population",
    "list_populations",
    "population_folder_address",
    "require_population",
    "shipped_population",
]

POPULATION_MANIFEST = "population.json"

#: Where the base populations shipped with the package lie: ``checkpoints/<game>/<name>/``.
SHIPPED_POPULATIONS = Path(__file__).resolve().parents[2] / "checkpoints"


def list_populations(league: League, game_id: str | None = None) -> list[dict[str, Any]]:
    """Every population of the league (or of ``game_id``): name, version, game, frozen, member count."""
    with league.reading() as session:
        return [{"name": p.name, "version": p.version, "game_id": p.game_id, "frozen": p.frozen,
                 "members": len(p.members)} for p in reg.list_populations(session, game_id=game_id)]


def _parse_label(population: str) -> tuple[str, int | None]:
    name, _, version = population.partition(":")
    if not name:
        raise ValueError(f"population {population!r} has no name; write NAME or NAME:VERSION, e.g. base-v1:1")
    if not version:
        return name, None
    if not version.isdigit() or int(version) < 1:
        raise ValueError(f"population {population!r}: the version after ':' must be a number from 1, e.g. {name}:1")
    return name, int(version)


def find_population(session: Any, game_id: str, population: str) -> reg.Population | None:
    """The population ``name`` (its newest version) or ``name:version`` of ``game_id``, or None."""
    name, version = _parse_label(population)
    return reg.get_population(session, name, version, game_id=game_id)


def _missing(session: Any, game_id: str, population: str) -> ValueError:
    known = [f"{p.name}:{p.version}" for p in reg.list_populations(session, game_id=game_id)]
    names = {p.name for p in reg.list_populations(session, game_id=game_id)} | set(known)
    hint = did_you_mean(population, names)
    elsewhere = sorted({p.game_id for p in reg.list_populations(session)
                        if p.name == population.partition(":")[0] and p.game_id != game_id})
    also = f" ({population.partition(':')[0]} exists for {', '.join(elsewhere)})" if elsewhere else ""
    return ValueError(f"no population {population!r} of {game_id}{also}.{hint} Known for {game_id}: "
                      f"{', '.join(known) or 'none'}. Import one with `arena-league population import FOLDER` "
                      f"(shipped ones lie under checkpoints/{game_id}/) or build one with `arena-league population "
                      f"build {game_id}`")


def require_population(session: Any, game_id: str, population: str) -> reg.Population:
    """:func:`find_population`, raising with the known ones and a suggestion when it is missing."""
    found = find_population(session, game_id, population)
    if found is None:
        raise _missing(session, game_id, population)
    return found


def shipped_population(game_id: str, name: str = "base-v1") -> Path | None:
    """The folder of the population ``name`` shipped for ``game_id``, or None."""
    folder = SHIPPED_POPULATIONS / game_id / name
    return folder if (folder / POPULATION_MANIFEST).is_file() else None


def game_population(league: League, game_id: str) -> str | None:
    """``name:version`` of the population entrants of ``game_id`` are ranked against by default:
    the newest frozen population of the game in the league, else the shipped ``base-v1``
    (imported now), else None."""
    with league.reading() as session:
        frozen = [p for p in reg.list_populations(session, game_id=game_id) if p.frozen]
        if frozen:
            newest = max(frozen, key=lambda p: (p.created_at, p.id))
            return f"{newest.name}:{newest.version}"
    folder = shipped_population(game_id)
    return import_population(league, folder) if folder is not None else None


def ensure_population(league: League, game_id: str, population: str = "base-v1") -> tuple[str, bool]:
    """``population`` (``name`` or ``name:version``) of ``game_id`` in ``league``; a shipped one
    (:func:`shipped_population`) is imported when the league lacks it. Returns (``name:version``,
    whether it was imported now); a population neither registered nor shipped raises, naming the fix."""
    name, version = _parse_label(population)
    with league.reading() as session:
        found = find_population(session, game_id, population)
        if found is not None:
            return f"{found.name}:{found.version}", False
        folder = shipped_population(game_id, name) if version is None else None
        if folder is None:
            raise _missing(session, game_id, population)
    return import_population(league, folder), True


def population_folder_address(folder: str | Path) -> str:
    """The content address of a population folder: every file's address under its relative path."""
    root = Path(folder)
    files = sorted(p for p in root.rglob("*") if p.is_file() and not p.is_symlink())
    return folder_address((p.relative_to(root).as_posix(), file_address(p.read_bytes())) for p in files)


def import_population(league: League, source: str | Path, *, name: str | None = None) -> str:
    """Register a population folder written by :func:`export_population` (or shipped under
    ``checkpoints/<game>/<name>/``): its members become agents of kind ``base`` and the population is
    frozen. Members already registered with the same bytes are reused; a folder already imported
    for its game (same files, same name) returns that population. Returns ``name:version``."""
    src = Path(source)
    manifest_path = src / POPULATION_MANIFEST
    if not manifest_path.is_file():
        raise ValueError(f"{src} has no {POPULATION_MANIFEST}; point at a folder made by `population export` "
                         "or shipped under checkpoints/<game>/<name>/")
    manifest = json.loads(manifest_path.read_text())
    game_id = manifest["game_id"]
    register_game(league, game_id)
    label = name or manifest["name"]
    address = population_folder_address(src)
    with league.transaction() as session:
        for existing in reg.list_populations(session, game_id=game_id):
            imported = (existing.provenance or {}).get("imported_from") or {}
            if existing.name == label and imported.get("address") == address:
                return f"{existing.name}:{existing.version}"
        provenance = {**(manifest.get("provenance") or {}), "imported_from": {"address": address, "path": str(src)}}
        population = reg.create_population(session, label, game_id, provenance=provenance)
        for member in manifest["members"]:
            agent = reg.get_agent(session, member["name"])
            if agent is not None and agent.game_id != game_id:
                raise ValueError(f"member {member['name']} of {src} is already an agent of {agent.game_id}, not "
                                 f"{game_id}; rename the member in {POPULATION_MANIFEST}")
            if agent is None:
                sha = None
                if member.get("artifact"):
                    stored = reg.store_artifact(session, league.home, src / member["artifact"], member["format"])
                    sha = stored.sha256
                kind = "scripted" if member["kind"] == "scripted" else "base"
                agent = reg.create_agent(session, member["name"], game_id, kind, owner=manifest.get("name"),
                                         artifact_sha256=sha, status="active",
                                         metadata=member.get("agent_metadata") or {})
            reg.add_population_member(session, population, agent, member.get("metadata") or {})
        reg.freeze_population(session, population)
        return f"{population.name}:{population.version}"


def export_population(league: League, population: str, destination: str | Path, *,
                      game_id: str | None = None) -> Path:
    """Write a population to a folder: ``population.json`` (name, version, game, provenance, members
    with their metadata) and each member's artifact under ``agents/``. Without ``game_id`` the name
    must belong to one game only."""
    dest = Path(destination)
    with league.reading() as session:
        if game_id is None:
            name, _ = _parse_label(population)
            games = sorted({p.game_id for p in reg.list_populations(session) if p.name == name})
            if len(games) > 1:
                raise ValueError(f"population {name} exists for several games ({', '.join(games)}); say which "
                                 "with --game GAME")
            if not games:
                every = {p.name for p in reg.list_populations(session)}
                raise ValueError(f"no population {population!r}.{did_you_mean(name, every)} See "
                                 "`arena-league population list`")
            game_id = games[0]
        found = require_population(session, game_id, population)
        if dest.exists() and any(dest.iterdir()):
            raise ValueError(f"{dest} exists and is not empty; export into a new folder")
        (dest / "agents").mkdir(parents=True, exist_ok=True)
        members = []
        for member in found.members:
            agent = member.agent
            entry = {"name": agent.name, "kind": agent.kind, "metadata": member.meta or {},
                     "agent_metadata": agent.meta or {}}
            if agent.artifact is not None:
                source = reg.artifact_path(league.home, agent.artifact)
                target = dest / "agents" / (agent.name + (".onnx" if agent.artifact.format == "onnx" else ""))
                if source.is_dir():
                    shutil.copytree(source, target)
                else:
                    shutil.copy2(source, target)
                entry["artifact"] = str(target.relative_to(dest))
                entry["format"] = agent.artifact.format
            members.append(entry)
        provenance = {k: v for k, v in (found.provenance or {}).items() if k != "imported_from"}
        manifest = {"name": found.name, "version": found.version, "game_id": found.game_id, "frozen": found.frozen,
                    "provenance": provenance, "members": members}
    (dest / POPULATION_MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
    return dest
