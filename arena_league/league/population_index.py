"""The base populations shipped with arena-league, as data: their index, where they are found, and pulling one.

The package carries an index (``population_index.json``): for each shipped population (game, name)
its content address (:func:`population_folder_address`), its member names, and every file with its
relative path, size and SHA-256, plus the base URL the files are fetched from. Under that URL (or a
mirror) the files lie as in a checkout's ``checkpoints/``: ``<game>/<name>/<relative path>``, so any
static copy of ``checkpoints/`` is a mirror. The index is written from ``checkpoints/`` by
``arena-league population index --write`` (:func:`write_index`), and a test fails when they disagree.

A shipped population is found, in this order, in the checkout's ``checkpoints/`` (when the package
runs from one), in the user cache (``ARENA_LEAGUE_POPULATIONS``, default
``~/.cache/arena-league/populations``, the same ``<game>/<name>/`` layout) and among the populations
the wheel itself carries (the quickstart's). A folder found is checked against its content address
before it is imported (:func:`verified_population`). :func:`pull_population` fetches one into the
cache, every file checked against its size and SHA-256 while it streams, into a temporary folder
renamed into place only when whole.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import http.client
import json
import os
import re
import shutil
import tempfile
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from arena_league.league.catalog import check_game
from arena_league.league.home import did_you_mean
from arena_league.policies.address import file_address, folder_address

__all__ = [
    "CACHE_ENV",
    "CHECKOUT_POPULATIONS",
    "INDEX_PATH",
    "MIRROR_ENV",
    "PACKAGED_POPULATIONS",
    "Located",
    "PullReport",
    "build_index",
    "cache_root",
    "index_differences",
    "index_entry",
    "indexed_member_names",
    "indexed_populations",
    "load_index",
    "locate_population",
    "population_folder_address",
    "population_source",
    "pull_population",
    "shipped_rows",
    "verified_population",
    "write_index",
]

#: The index the package carries.
INDEX_PATH = Path(__file__).with_name("population_index.json")
#: A checkout's populations: ``checkpoints/<game>/<name>/`` (absent in an installed package).
CHECKOUT_POPULATIONS = Path(__file__).resolve().parents[2] / "checkpoints"
#: The populations a built wheel carries (setup.py copies them there; absent in a checkout).
PACKAGED_POPULATIONS = Path(__file__).resolve().parent / "packaged" / "populations"
#: The user cache of pulled populations (default ``~/.cache/arena-league/populations``).
CACHE_ENV = "ARENA_LEAGUE_POPULATIONS"
#: A mirror to pull from instead of the index's URL.
MIRROR_ENV = "ARENA_LEAGUE_POPULATION_MIRROR"
MANIFEST = "population.json"
INDEX_FORMAT = 1
#: Bytes read from the network per step while a file streams.
CHUNK = 1 << 20
#: Seconds a mirror may stay silent before a pull gives up.
TIMEOUT_S = 60


def population_folder_address(folder: str | Path) -> str:
    """The content address of a population folder: every file's address under its relative path."""
    return folder_address((rel, digest) for rel, _, digest in _folder_files(Path(folder)))


def _folder_files(root: Path) -> list[tuple[str, int, str]]:
    files = sorted(p for p in root.rglob("*") if p.is_file() and not p.is_symlink())
    listing = []
    for path in files:
        content = path.read_bytes()
        listing.append((path.relative_to(root).as_posix(), len(content), file_address(content)))
    return sorted(listing)


def _version_key(name: str) -> tuple[int, str]:
    digits = re.findall(r"\d+", name)
    return (int(digits[-1]) if digits else 0, name)


# --- the index -------------------------------------------------------------------------------------

def build_index(root: str | Path | None = None, url: str | None = None) -> dict[str, Any]:
    """The index of every population under ``root`` (default: the checkout's ``checkpoints/``,
    ``<game>/<name>/population.json``), with ``url`` as the base URL its files are fetched from."""
    root = Path(root) if root is not None else CHECKOUT_POPULATIONS
    if not root.is_dir():
        raise ValueError(f"{root} is not a folder; the index is written from a checkout's checkpoints/ (run this "
                         f"from a git checkout of arena-league)")
    populations = []
    for manifest_path in sorted(root.glob(f"*/*/{MANIFEST}"), key=lambda p: (p.parent.parent.name,
                                                                             _version_key(p.parent.name))):
        folder = manifest_path.parent
        manifest = json.loads(manifest_path.read_text())
        files = _folder_files(folder)
        populations.append({
            "game_id": folder.parent.name, "name": folder.name,
            "address": folder_address((rel, digest) for rel, _, digest in files),
            "bytes": sum(size for _, size, _ in files),
            "members": [m["name"] for m in manifest.get("members") or []],
            "files": [list(f) for f in files]})
    return {"format": INDEX_FORMAT, "url": url, "populations": populations}


def _index_text(index: dict[str, Any]) -> str:
    """The index as JSON with one line per file, so a changed population reads as a short diff."""
    head = {k: v for k, v in index.items() if k != "populations"}
    lines = [json.dumps(head)[:-1] + ', "populations": [']
    for i, population in enumerate(index["populations"]):
        fields = {k: v for k, v in population.items() if k != "files"}
        lines.append(" " + json.dumps(fields)[:-1] + ', "files": [')
        lines += ["  " + json.dumps(f) + ("," if j < len(population["files"]) - 1 else "")
                  for j, f in enumerate(population["files"])]
        lines.append(" ]}" + ("," if i < len(index["populations"]) - 1 else ""))
    return "\n".join([*lines, "]}"]) + "\n"


def write_index(root: str | Path | None = None, path: str | Path | None = None,
                url: str | None = None) -> dict[str, Any]:
    """Write the index of ``root`` to ``path`` (default: the package's); ``url`` None keeps the base
    URL the index at ``path`` names."""
    path = Path(path) if path is not None else INDEX_PATH
    if url is None and path.is_file():
        url = json.loads(path.read_text()).get("url")
    index = build_index(root, url)
    path.write_text(_index_text(index))
    return index


def index_differences(root: str | Path | None = None, index: dict[str, Any] | None = None) -> list[str]:
    """What differs between the index (default: the package's) and the populations under ``root``,
    one line each; empty when they agree."""
    index = load_index() if index is None else index
    fresh = build_index(root, index.get("url"))
    root = root if root is not None else CHECKOUT_POPULATIONS
    have = {(p["game_id"], p["name"]): p for p in index["populations"]}
    want = {(p["game_id"], p["name"]): p for p in fresh["populations"]}
    lines = [f"{g}/{n}: in {root} but not in the index" for g, n in sorted(want.keys() - have.keys())]
    lines += [f"{g}/{n}: in the index but not in {root}" for g, n in sorted(have.keys() - want.keys())]
    for key in sorted(want.keys() & have.keys()):
        if have[key] != want[key]:
            changed = sorted(k for k in want[key] if have[key].get(k) != want[key][k])
            lines.append(f"{key[0]}/{key[1]}: {', '.join(changed)} differ")
    return lines


@functools.lru_cache(maxsize=4)
def _read_index(path: str, stamp: tuple[int, int]) -> dict[str, Any]:
    index = json.loads(Path(path).read_text())
    index["by_key"] = {(p["game_id"], p["name"]): p for p in index["populations"]}
    index["member_names"] = frozenset(n for p in index["populations"] for n in p["members"])
    return index


def load_index(path: str | Path | None = None) -> dict[str, Any]:
    """The index at ``path`` (default: the package's), read once per version of the file."""
    path = Path(path) if path is not None else INDEX_PATH
    stat = path.stat()
    return _read_index(str(path), (stat.st_mtime_ns, stat.st_size))


def indexed_populations(game_id: str) -> list[str]:
    """The names of the populations shipped for ``game_id``, oldest first (``base-v1``, ``base-v2``, ...)."""
    return sorted((n for g, n in load_index()["by_key"] if g == game_id), key=_version_key)


def index_entry(game_id: str, name: str) -> dict[str, Any] | None:
    """The index's entry of the population ``name`` shipped for ``game_id``, or None."""
    return load_index()["by_key"].get((game_id, name))


def indexed_member_names() -> frozenset[str]:
    """The member names of every shipped population, whether or not its files are here."""
    return load_index()["member_names"]


# --- where a shipped population is -----------------------------------------------------------------

def cache_root() -> Path:
    """The user cache of pulled populations: ``ARENA_LEAGUE_POPULATIONS``, default
    ``~/.cache/arena-league/populations``."""
    configured = os.environ.get(CACHE_ENV)
    return Path(configured).expanduser() if configured else Path.home() / ".cache" / "arena-league" / "populations"


def _roots() -> list[tuple[str, Path]]:
    return [("checkout", CHECKOUT_POPULATIONS), ("cache", cache_root()), ("package", PACKAGED_POPULATIONS)]


@dataclass(frozen=True)
class Located:
    """A shipped population's folder on disk, and where it was found (checkout, cache or package)."""

    game_id: str
    name: str
    folder: Path
    source: str


def locate_population(game_id: str, name: str) -> Located | None:
    """The first folder holding the shipped population ``name`` of ``game_id`` (checkout, cache,
    package), unchecked; None when the index does not name it or no folder holds it."""
    if index_entry(game_id, name) is None:
        return None
    for source, root in _roots():
        folder = root / game_id / name
        if (folder / MANIFEST).is_file():
            return Located(game_id, name, folder, source)
    return None


def population_source(path: str | Path) -> str:
    """Where a population folder lies, for a person: ``the package``, ``the cache DIR``, ``the
    checkout DIR`` or the folder itself."""
    folder = Path(path).resolve()
    for source, root in _roots():
        if folder.is_relative_to(root.resolve()):
            return "the package" if source == "package" else f"the {source} {root}"
    return str(path)


def _pull_hint(game_id: str, name: str) -> str:
    return f"`arena-league population pull {game_id} {name}`"


def verified_population(game_id: str, name: str) -> Located:
    """:func:`locate_population`, its folder checked against the index's content address; raises
    naming the fix when it is not here (pull it) or holds other files (pull it again)."""
    entry = index_entry(game_id, name)
    if entry is None:
        names = indexed_populations(game_id)
        raise ValueError(f"no population {name!r} is shipped for {game_id}.{did_you_mean(name, names)} Shipped for "
                         f"{game_id}: {', '.join(names) or 'none'}")
    found = locate_population(game_id, name)
    if found is None:
        raise ValueError(f"the population {name} of {game_id} ({len(entry['members'])} agents) is not on this "
                         f"machine; fetch it with {_pull_hint(game_id, name)} (into {cache_root()})")
    if population_folder_address(found.folder) != entry["address"]:
        fix = f"pull it again with {_pull_hint(game_id, name)}"
        if found.source == "checkout":
            fix = "restore it (`git checkout checkpoints/`) or, changed on purpose, rewrite the index with " \
                "`arena-league population index --write`"
        raise ValueError(f"{found.folder} does not hold the files the index names for {game_id} {name} (changed or "
                         f"partly written); {fix}")
    return found


def shipped_rows(game_id: str | None = None) -> list[dict[str, Any]]:
    """One row per shipped population (of ``game_id``): name, members, size and where it is
    (``checkout``, ``cache``, ``package`` or ``not downloaded``) with its folder."""
    rows = []
    for population in load_index()["populations"]:
        if game_id is not None and population["game_id"] != game_id:
            continue
        found = locate_population(population["game_id"], population["name"])
        rows.append({"game_id": population["game_id"], "name": population["name"],
                     "members": len(population["members"]), "bytes": population["bytes"],
                     "where": found.source if found else "not downloaded",
                     "path": str(found.folder) if found else None})
    return rows


# --- pulling ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class PullReport:
    """A population pulled (or found already whole) in the cache."""

    game_id: str
    name: str
    path: str
    files: int
    bytes: int
    fetched: bool
    #: The mirror (or the index's URL) the files were fetched from.
    url: str

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _base_url(mirror: str | None) -> str:
    base = mirror or os.environ.get(MIRROR_ENV) or load_index().get("url")
    if not base:
        raise ValueError(f"the package's population index names no URL to fetch from; give a copy of checkpoints/ "
                         f"with --mirror URL or {MIRROR_ENV} (http://, https:// or file://)")
    if "://" not in base:  # a plain folder
        base = Path(base).expanduser().resolve().as_uri()
    return base.rstrip("/") + "/"


def _pull_targets(game_id: str | None, name: str | None, every: bool) -> list[tuple[str, str]]:
    index = load_index()
    if game_id is None:
        if not every:
            raise ValueError("name the game to pull for, e.g. `arena-league population pull Snake-2T2P-v1`, or "
                             "pull every shipped population with --all")
        return list(index["by_key"])
    check_game(game_id)
    names = indexed_populations(game_id)
    shipped_games = sorted({g for g, _ in index["by_key"]})
    if not names:
        raise ValueError(f"{game_id} ships no base population; the games that do: {', '.join(shipped_games)}")
    if name is None:
        return [(game_id, n) for n in names] if every else [(game_id, names[-1])]
    if name not in names:
        raise ValueError(f"no population {name!r} is shipped for {game_id}.{did_you_mean(name, names)} Shipped for "
                         f"{game_id}: {', '.join(names)}")
    return [(game_id, name)]


def _fetch(url: str, size: int, sha256: str, target: Path, shown: str) -> None:
    """Stream ``url`` into ``target``, reading at most ``size`` + 1 bytes, checked as it goes."""
    digest, got = hashlib.sha256(), 0
    with urllib.request.urlopen(url, timeout=TIMEOUT_S) as response, target.open("wb") as out:
        while got <= size:
            chunk = response.read(min(CHUNK, size + 1 - got))
            if not chunk:
                break
            got += len(chunk)
            digest.update(chunk)
            out.write(chunk)
    if got != size:
        what = "more than" if got > size else f"{got} bytes, not"
        raise ValueError(f"{shown}: the mirror sent {what} the {size} bytes the index names; nothing was kept. Pull "
                         f"again, or from another mirror (--mirror URL)")
    if digest.hexdigest() != sha256:
        raise ValueError(f"{shown}: its SHA-256 is not the one the index names (the mirror holds other bytes); "
                         f"nothing was kept. Pull from another mirror (--mirror URL) or the index's URL")


def _pull_one(game_id: str, name: str, base: str, root: Path) -> PullReport:
    entry = index_entry(game_id, name)
    dest = root / game_id / name
    files, total = len(entry["files"]), entry["bytes"]
    if dest.is_dir() and population_folder_address(dest) == entry["address"]:
        return PullReport(game_id, name, str(dest), files, total, False, base)
    dest.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=f".{name}.pull-", dir=dest.parent))
    try:
        scratch.chmod(0o755)  # mkdtemp's 0700 would hide a shared cache from its other users
        for rel, size, sha256 in entry["files"]:
            url = base + urllib.parse.quote(f"{game_id}/{name}/{rel}")
            target = scratch / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            try:
                _fetch(url, size, sha256, target, url)
            except urllib.error.HTTPError as error:
                raise ValueError(f"{url}: HTTP {error.code} {error.reason}; the mirror lacks {game_id}/{name} "
                                 f"(a mirror holds a copy of checkpoints/: <game>/<name>/<file>); use another "
                                 f"with --mirror URL") from None
            except urllib.error.URLError as error:
                raise ValueError(f"cannot reach {base} ({error.reason}); check the URL, or use another mirror "
                                 f"with --mirror URL or {MIRROR_ENV}") from None
            except (http.client.HTTPException, OSError) as error:
                raise ValueError(f"{url}: the transfer broke off ({type(error).__name__}: {error}); nothing was "
                                 f"kept, pull again") from None
        if dest.exists():  # a folder holding other files: replaced whole
            stale = Path(tempfile.mkdtemp(prefix=f".{name}.stale-", dir=dest.parent))
            dest.rename(stale / name)
            scratch.rename(dest)
            shutil.rmtree(stale)
        else:
            scratch.rename(dest)
    except BaseException:
        shutil.rmtree(scratch, ignore_errors=True)
        with contextlib.suppress(OSError):  # the game's folder, when this pull made it and it stayed empty
            dest.parent.rmdir()
        raise
    return PullReport(game_id, name, str(dest), files, total, True, base)


def pull_population(game_id: str | None, name: str | None = None, *, every: bool = False,
                    mirror: str | None = None) -> list[PullReport]:
    """Fetch the shipped population ``name`` of ``game_id`` (default: the newest shipped; ``every``:
    all of the game's, or all shipped when ``game_id`` is None) into the cache (:func:`cache_root`),
    from ``mirror``, ``ARENA_LEAGUE_POPULATION_MIRROR`` or the index's URL. A population already
    whole in the cache is not fetched again; one holding other files is replaced."""
    targets = _pull_targets(game_id, name, every)
    base = _base_url(mirror)
    return [_pull_one(g, n, base, cache_root()) for g, n in targets]
