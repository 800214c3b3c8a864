"""Populations of a game: finding them by name, the game's default base, import and export.

A population is named and versioned per game: ``base-v1:1`` of GoBang and ``base-v1:1`` of Snake
are two populations, and ``name`` alone means the newest version of that name in the game.

The population an entrant is ranked against by default is the game's **base**
(:func:`game_population`): the league's newest frozen population of the game, or, when the league
has none or only shipped ones the package has since superseded, the newest population shipped with
the package for the game (``base-v2`` where it exists, else ``base-v1``; the package's index
names them, :mod:`.population_index` finds their folders and checks them), imported on first use. Imports are idempotent by content: importing a folder whose files are byte for byte
those of a population already imported for that game returns that population (the address of the
folder, as the artifact store computes it, is kept in its provenance under ``imported_from``).

An import goes through the same gate as a submission, and is refused whole (nothing stored,
nothing registered) when any member fails it:

* a member's artifact path is relative to the folder and, resolved (links followed), stays inside
  it: no absolute paths, no ``..`` leading out, no link pointing out;
* each member is read with ``read_artifact`` (code-carrying formats such as pickle and over-size
  files are refused before their content is read) and checked with ``validate_submission`` in an
  inference sandbox with few probe rows and a validation match of :data:`IMPORT_MATCH_CYCLES` steps
  (read, load against the game's spaces, probe forwards including one at the largest batch the
  engine plays, its time and memory against the league's budgets, a few steps of play): enough to
  refuse an artifact that cannot play or that hangs or swells at full size (frozen members then
  play in the worker itself), affordable for the hundred members of a shipped population on first
  use. The stored bytes are those that were read and validated, not the file as it may be by then;
* a member whose name an agent already holds is reused only when that agent plays the same game
  with the same bytes (same artifact digest; for a scripted member, the same built-in agent);
  any other holder is a conflict that refuses the import, naming the agent.

The members' frozen ratings (their ``metadata``) are kept as shipped.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from arena_league import registry as reg
from arena_league.league.home import did_you_mean, register_game
from arena_league.league.population_index import (
    CHECKOUT_POPULATIONS,
    Located,
    index_entry,
    indexed_member_names,
    indexed_populations,
    locate_population,
    population_folder_address,
    population_source,
    shipped_rows,
    verified_population,
)
from arena_league.league.quotas import enqueue_owned, live_job_limit
from arena_league.league.tokens import Identity
from arena_league.registry import League
from arena_league.registry.jobs import live_jobs

__all__ = [
    "POPULATION_MANIFEST",
    "SHIPPED_POPULATIONS",
    "base_import",
    "base_to_import",
    "default_population",
    "describe_population",
    "ensure_population",
    "export_population",
    "find_population",
    "game_population",
    "handle_import",
    "import_population",
    "list_populations",
    "list_shipped",
    "population_folder_address",
    "queue_import",
    "require_population",
    "shipped_member_names",
    "shipped_population",
    "shipped_populations",
]

POPULATION_MANIFEST = "population.json"

#: A checkout's shipped populations, ``checkpoints/<game>/<name>/`` (see :mod:`.population_index`
#: for the cache and the wheel's own).
SHIPPED_POPULATIONS = CHECKOUT_POPULATIONS
#: Steps of the validation match each imported member plays (a submission plays a whole one).
IMPORT_MATCH_CYCLES = 8
#: Probe rows per probe set when an imported member is validated.
IMPORT_PROBE_ROWS = 4


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
    every = reg.list_populations(session)
    known = [f"{p.name}:{p.version}" for p in every if p.game_id == game_id]
    shipped = shipped_populations(game_id)
    hint = did_you_mean(population, {p.name for p in every if p.game_id == game_id} | set(known) | set(shipped))
    elsewhere = sorted({p.game_id for p in every if p.name == population.partition(":")[0] and p.game_id != game_id})
    also = f" ({population.partition(':')[0]} exists for {', '.join(elsewhere)})" if elsewhere else ""
    ships = f" (shipped for {game_id}: {', '.join(shipped)}, imported by name)" if shipped else ""
    return ValueError(f"no population {population!r} of {game_id}{also}.{hint} Known for {game_id}: "
                      f"{', '.join(known) or 'none'}{ships}. Import one with `arena-league population import "
                      f"FOLDER` or build one with `arena-league population build {game_id}`")


def require_population(session: Any, game_id: str, population: str) -> reg.Population:
    """:func:`find_population`, raising with the known ones and a suggestion when it is missing."""
    found = find_population(session, game_id, population)
    if found is None:
        raise _missing(session, game_id, population)
    return found


def shipped_populations(game_id: str) -> list[str]:
    """The names of the populations shipped for ``game_id`` (the package's index), oldest first
    (``base-v1``, ``base-v2``, ...), whether or not their files are on this machine."""
    return indexed_populations(game_id)


def shipped_population(game_id: str, name: str | None = None) -> Path | None:
    """The folder of the population ``name`` shipped for ``game_id`` (default: the newest shipped)
    where it is on this machine (checkout, cache or package, unchecked), or None."""
    if name is None:
        names = shipped_populations(game_id)
        name = names[-1] if names else None
    found = locate_population(game_id, name) if name is not None else None
    return found.folder if found is not None else None


def import_shipped_population(league: League, game_id: str, name: str) -> tuple[str, Located]:
    """Import the population ``name`` shipped for ``game_id`` from the folder that holds it, checked
    against the index first (:func:`~.population_index.verified_population`: a population not on this
    machine, or a folder holding other files, raises naming the pull that fixes it)."""
    found = verified_population(game_id, name)
    return import_population(league, found.folder), found


def game_population(league: League, game_id: str, *, import_shipped: bool = True) -> str | None:
    """``name:version`` of the population entrants of ``game_id`` are ranked against by default:
    the league's newest frozen population of the game, unless that is a shipped population the
    package has since superseded (``base-v1`` where ``base-v2`` is shipped) or there is none: then
    the newest population shipped for the game, imported now (unless ``import_shipped`` is False:
    importing validates every member, which a web request must not do); else None."""
    return default_population(league, game_id, import_shipped=import_shipped)[0]


def default_population(league: League, game_id: str, *, import_shipped: bool = True) -> tuple[str | None, bool]:
    """:func:`game_population` and whether it imported the shipped population just now."""
    with league.reading() as session:
        frozen = [p for p in reg.list_populations(session, game_id=game_id) if p.frozen]
        newest = max(frozen, key=lambda p: (p.created_at, p.id)) if frozen else None
        label = f"{newest.name}:{newest.version}" if newest is not None else None
    name = base_to_import(league, game_id) if import_shipped else None
    if name is None:
        return label, False
    return import_shipped_population(league, game_id, name)[0], True


def base_to_import(league: League, game_id: str) -> str | None:
    """The name of the shipped population :func:`game_population` would import now (the league
    has no frozen population of the game, or only shipped ones the package has since superseded),
    or None."""
    shipped = shipped_populations(game_id)
    if not shipped:
        return None
    from sqlalchemy import select

    superseded = set(shipped[:-1])  # shipped populations with a newer one shipped
    with league.reading() as session:  # the newest frozen one's name alone: boards ask this on every view
        newest = session.scalar(select(reg.Population.name)
                                .where(reg.Population.game_id == game_id, reg.Population.frozen.is_(True))
                                .order_by(reg.Population.created_at.desc(), reg.Population.id.desc()).limit(1))
    return shipped[-1] if newest is None or newest in superseded else None


def ensure_population(league: League, game_id: str, population: str = "base-v1") -> tuple[str, bool]:
    """``population`` (``name`` or ``name:version``) of ``game_id`` in ``league``; a shipped one
    (:func:`shipped_population`) is imported when the league lacks it. Returns (``name:version``,
    whether it was imported now); a population neither registered nor shipped raises, naming the fix."""
    name, version = _parse_label(population)
    with league.reading() as session:
        found = find_population(session, game_id, population)
        if found is not None:
            return f"{found.name}:{found.version}", False
        if version is not None or index_entry(game_id, name) is None:
            raise _missing(session, game_id, population)
    return import_shipped_population(league, game_id, name)[0], True


def shipped_member_names() -> frozenset[str]:
    """The member names of every population shipped with the package (its index, whether or not
    the files are here): names only the league may register (by importing the population)."""
    return indexed_member_names()


def list_shipped(league: League, game_id: str | None = None) -> list[dict[str, Any]]:
    """Every population shipped with the package (of ``game_id``), where it is on this machine
    (:func:`~.population_index.shipped_rows`) and the league's population of that name
    (``imported``: ``name:version``, or None while it is not imported)."""
    rows = shipped_rows(game_id)
    with league.reading() as session:
        imported = {}
        for population in reg.list_populations(session, game_id=game_id):
            imported[(population.game_id, population.name)] = f"{population.name}:{population.version}"
    return [{**row, "imported": imported.get((row["game_id"], row["name"]))} for row in rows]


def describe_population(league: League, game_id: str, label: str) -> str:
    """``base-v1:1 of Crossroads-2T2P-v1 (100 agents, from the package)``: a population of the
    league and the folder it was imported from (the checkout, the cache, the package or a folder)."""
    with league.reading() as session:
        found = require_population(session, game_id, label)
        imported = (found.provenance or {}).get("imported_from") or {}
        size = len(found.members)
        label = f"{found.name}:{found.version}"
    origin = f"from {population_source(imported['path'])}" if imported.get("path") else "built in this league"
    return f"{label} of {game_id} ({size} agents, {origin})"


@dataclass(frozen=True)
class _Member:
    """A member that passed the gate: its entry, and the artifact read (None for a scripted member)."""

    entry: dict[str, Any]
    artifact: Any
    digest: str | None


def _read_manifest(src: Path) -> dict[str, Any]:
    manifest_path = src / POPULATION_MANIFEST
    if not manifest_path.is_file():
        raise ValueError(f"{src} has no {POPULATION_MANIFEST}; point at a folder made by `population export` "
                         "or shipped under checkpoints/<game>/<name>/")
    try:
        manifest = json.loads(manifest_path.read_text())
    except (ValueError, UnicodeDecodeError) as error:
        raise ValueError(f"{manifest_path} is not JSON ({error}); export the population again") from None
    fix = f"; {manifest_path} must be written by `population export`"
    malformed = not isinstance(manifest, dict) or not isinstance(manifest.get("game_id"), str) \
        or not isinstance(manifest.get("name"), str) or not isinstance(manifest.get("members"), list)
    if malformed:
        raise ValueError(f"{manifest_path} lacks a game_id, a name or a list of members{fix}")
    seen: set[str] = set()
    for member in manifest["members"]:
        nameless = not isinstance(member, dict) or not isinstance(member.get("name"), str)
        if nameless:
            raise ValueError(f"{manifest_path} has a member without a name{fix}")
        if member["name"] in seen:
            raise ValueError(f"{manifest_path} lists member {member['name']} twice{fix}")
        seen.add(member["name"])
        for key in ("metadata", "agent_metadata"):
            malformed = not isinstance(member.get(key) or {}, dict)
            if malformed:
                raise ValueError(f"member {member['name']} of {manifest_path}: {key} must be an object{fix}")
    return manifest


def _member_path(src: Path, member: dict[str, Any]) -> Path:
    """The member's artifact inside ``src``; refuses paths that are absolute or lead out of it."""
    name, raw = member["name"], member.get("artifact")
    fix = f"member artifacts must lie inside the population folder {src}, written as relative paths"
    if not isinstance(raw, str) or not raw or "\x00" in raw:
        raise ValueError(f"member {name} of {src}: artifact {raw!r} is not a path; {fix}")
    relative = Path(raw)
    if relative.is_absolute() or raw.startswith(("/", "\\")) or relative.drive:
        raise ValueError(f"member {name} of {src}: artifact {raw!r} is an absolute path; {fix}")
    root = src.resolve()
    path = src / relative
    resolved = path.resolve()
    if not resolved.is_relative_to(root) or resolved == root:
        raise ValueError(f"member {name} of {src}: artifact {raw!r} leads out of the folder (to {resolved}); {fix}")
    return path


def _check_member(src: Path, game_id: str, member: dict[str, Any], sandbox: Any) -> _Member:
    """Read and validate one member as a submission is (see the module docstring), in ``sandbox``."""
    from arena_league.policies import ArtifactError, read_artifact, validate_submission

    name = member["name"]
    if not member.get("artifact"):
        scripted = (member.get("agent_metadata") or {}).get("scripted")
        if member.get("kind") != "scripted" or not isinstance(scripted, str):
            raise ValueError(f"member {name} of {src} has no artifact and is not a built-in scripted agent; "
                             "export the population again so every learned member carries its artifact")
        try:
            verdict = validate_submission(f"scripted:{scripted}", game_id, n_probes=IMPORT_PROBE_ROWS,
                                          match_cycles=IMPORT_MATCH_CYCLES, sandbox=sandbox)
        except ArtifactError as error:
            raise ValueError(f"member {name} of {src}: {error}") from None
        if not verdict.ok:
            raise ValueError(f"member {name} of {src}: {verdict.reason}")
        return _Member(member, None, None)
    path = _member_path(src, member)
    try:
        artifact = read_artifact(path)
    except (ArtifactError, OSError) as error:
        raise ValueError(f"member {name} of {src} was refused: {error}. Nothing was imported; replace the "
                         "member's artifact with an ONNX file or an arena-policy folder") from None
    if artifact.kind not in ("onnx", "arena-policy"):
        raise ValueError(f"member {name} of {src}: {member['artifact']} is a {artifact.kind} description, not "
                         "an ONNX file or an arena-policy folder; list built-in agents without an artifact")
    declared = member.get("format")
    if declared is not None and declared != artifact.kind:
        raise ValueError(f"member {name} of {src}: {member['artifact']} is {artifact.kind}, not {declared!r} as "
                         f"{POPULATION_MANIFEST} says; correct its format")
    verdict = validate_submission(artifact, game_id, n_probes=IMPORT_PROBE_ROWS, match_cycles=IMPORT_MATCH_CYCLES,
                                  sandbox=sandbox)
    if not verdict.ok:
        raise ValueError(f"member {name} of {src} failed validation: {verdict.reason}. Nothing was imported; "
                         f"replace {path} with an artifact that plays {game_id}")
    return _Member(member, artifact, artifact.digest)


def _conflict(session: Any, src: Path, game_id: str, member: _Member) -> reg.Agent | None:
    """The agent already holding the member's name, when it is the same agent; raises when it is not."""
    name = member.entry["name"]
    agent = reg.get_agent(session, name)
    if agent is None:
        return None
    if member.artifact is None:
        same = agent.kind == "scripted" and (agent.meta or {}).get("scripted") == \
            (member.entry.get("agent_metadata") or {}).get("scripted")
    else:
        same = agent.artifact_sha256 == member.digest
    if agent.game_id == game_id and same:
        return agent
    what = f"an agent of {agent.game_id}" if agent.game_id != game_id else "another agent (different bytes)"
    owner = f", owned by {agent.owner}" if agent.owner else ""
    raise ValueError(f"member {name} of {src} is already {what} in this league ({agent.kind} agent #{agent.id}"
                     f"{owner}, {agent.status}); the import would adopt it, so nothing was imported. Rename the "
                     f"member in {POPULATION_MANIFEST}, or import into a league where {name} is free")


def import_population(league: League, source: str | Path, *, name: str | None = None) -> str:
    """Register a population folder written by :func:`export_population` (or shipped under
    ``checkpoints/<game>/<name>/``): its members become agents of kind ``base`` and the population is
    frozen, with the members' ratings as written. Every member passes the gate of the module
    docstring first; one that does not refuses the whole import (nothing is stored). Members already
    registered under their name with the same bytes are reused; a folder already imported for its
    game (same files, same name) returns that population. Returns ``name:version``."""
    from arena_league.policies import write_artifact

    src = Path(source)
    manifest = _read_manifest(src)
    game_id = manifest["game_id"]
    register_game(league, game_id)
    label = name or manifest["name"]
    address = population_folder_address(src)
    with league.reading() as session:
        for existing in reg.list_populations(session, game_id=game_id):
            imported = (existing.provenance or {}).get("imported_from") or {}
            if existing.name == label and imported.get("address") == address:
                return f"{existing.name}:{existing.version}"
    from arena_league.league.settings import sandbox_limits
    from arena_league.policies.sandbox import InferenceSandbox

    with InferenceSandbox(sandbox_limits(league)) as sandbox:  # one child validates every member in turn
        members = [_check_member(src, game_id, member, sandbox) for member in manifest["members"]]
    with league.reading() as session:
        for member in members:
            _conflict(session, src, game_id, member)
    with tempfile.TemporaryDirectory() as scratch, league.transaction() as session:
        for existing in reg.list_populations(session, game_id=game_id):
            imported = (existing.provenance or {}).get("imported_from") or {}
            if existing.name == label and imported.get("address") == address:
                return f"{existing.name}:{existing.version}"
        provenance = {**(manifest.get("provenance") or {}), "imported_from": {"address": address, "path": str(src)}}
        population = reg.create_population(session, label, game_id, provenance=provenance)
        for index, member in enumerate(members):
            entry = member.entry
            agent = _conflict(session, src, game_id, member)  # again, under the write lock
            if agent is None:
                sha = None
                if member.artifact is not None:
                    # store the bytes that were validated, not the file as it may be by now
                    fmt = member.artifact.kind
                    content = member.artifact.content if fmt == "onnx" else \
                        write_artifact(member.artifact, Path(scratch) / str(index))
                    sha = reg.store_artifact(session, league.home, content, fmt).sha256
                kind = "scripted" if member.artifact is None else "base"
                agent = reg.create_agent(session, entry["name"], game_id, kind, owner=manifest.get("name"),
                                         artifact_sha256=sha, status="active",
                                         metadata=entry.get("agent_metadata") or {})
            reg.add_population_member(session, population, agent, entry.get("metadata") or {})
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


def queue_import(league: League, game_id: str, population: str | None = None, *, who: Identity | None = None) -> int:
    """Queue the import of a population shipped with arena-league for ``game_id`` (default: the
    newest shipped; its members are validated: agent code, run by a worker, never by the caller);
    returns the job id: that of the import of the same population already queued or running, if any.
    ``who`` is recorded as the job's owner (None: the league's own)."""
    shipped = shipped_populations(game_id)
    if population is None:
        population = shipped[-1] if shipped else "base-v1"
    name, version = _parse_label(population)
    if version is not None or name not in shipped:
        raise ValueError(f"no population {population!r} is shipped for {game_id}.{did_you_mean(name, shipped)} "
                         f"Shipped for {game_id}: {', '.join(shipped) or 'none'}")
    if locate_population(game_id, name) is None:
        raise ValueError(f"the population {name} shipped for {game_id} is not on this machine; fetch it with "
                         f"`arena-league population pull {game_id} {name}`")
    register_game(league, game_id)
    payload = {"game_id": game_id, "population": name}
    limit = live_job_limit(league) if who is not None else None
    with league.transaction() as session:
        for job in live_jobs(session, "import"):
            if job.payload == payload:
                return job.id
        return enqueue_owned(session, who, "import", payload, priority=80, limit=limit).id


def base_import(league: League, game_id: str) -> dict[str, Any] | None:
    """For a view that needs the base population of ``game_id`` while the league lacks the shipped
    one (:func:`base_to_import`): its import, queued now unless one is queued, running or has
    failed (a failed one is shown, not retried on every view), as ``game_id``, ``population``,
    ``job`` and its ``state`` and ``error``. None when there is nothing to import."""
    name = base_to_import(league, game_id)
    if name is None:
        return None
    if locate_population(game_id, name) is None:  # shipped, but its files are not on this machine
        return {"game_id": game_id, "population": name, "job": None, "state": "missing",
                "error": f"the population {name} shipped for {game_id} is not on this machine; fetch it with "
                         f"`arena-league population pull {game_id} {name}`"}
    payload = {"game_id": game_id, "population": name}
    with league.reading() as session:
        last = next((job for job in reg.list_jobs(session, kind="import") if job.payload == payload), None)
        seen = None if last is None else (last.id, last.status, (last.error or "").strip().splitlines())
    if seen is None or seen[1] == "cancelled":
        job_id = queue_import(league, game_id, name)
        seen = (job_id, "queued", [])
    return {"game_id": game_id, "population": name, "job": seen[0], "state": seen[1],
            "error": seen[2][-1] if seen[2] else None}


def handle_import(ctx: reg.JobContext, progress: Any = None) -> dict[str, Any]:
    """Job handler: import a shipped population (see :func:`queue_import`)."""
    payload = ctx.job.payload
    label, imported = ensure_population(ctx.league, payload["game_id"], payload["population"])
    return {"game_id": payload["game_id"], "population": label, "imported": imported}
