"""The content-addressed artifact store under the league home.

Arena (Song et al., AAAI 2020) ranks agents submitted as weights; the league keeps each agent's
artifact for good, addressed by the SHA-256 of its content, so the same bytes are stored once and
re-submitting them finds the agent already there.

Layout: `<home>/artifacts/<first two hex digits>/<sha256><suffix>`, where the suffix is `.onnx`
for ONNX files, `.json` for scripted-policy descriptions and nothing for `arena-policy` folders.
Addresses follow `arena_league.policies.address` (a file's: the SHA-256 of its bytes; a folder's:
the SHA-256 of its `sha256sum` listing); folders may hold only regular files and folders (no
links), since a link could reach outside the store.

Writes are atomic: content is copied (and hashed on the way) into `artifacts/.incoming/`, flushed
to disk, then renamed into place, so a crash leaves either nothing or a complete artifact. A write
that fails removes what it staged, and a file a session moved into place is removed again when that
session's transaction does not commit (unless a committed row of another writer now names it), so a
refused submission leaves no file behind. What a crash can still leave (a `.part` file, a file whose
row was never committed) is removed by :func:`collect_artifact_garbage`. This module stores and
finds bytes; what they mean (ONNX graphs, manifests) is `arena_league.policies`'s business.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import time
import uuid
from pathlib import Path
from typing import Any

from sqlalchemy import delete, event, select
from sqlalchemy.orm import Session, SessionTransaction

from arena_league.policies.address import folder_address
from arena_league.registry.db import ARTIFACTS_DIRNAME
from arena_league.registry.errors import (
    ArtifactError,
    ArtifactTooLargeError,
    InvalidRecordError,
    disk_full_error,
)
from arena_league.registry.models import Agent, Artifact, ArtifactFormat
from arena_league.registry.repository import insert_ignoring_conflict

_INCOMING_DIRNAME = ".incoming"
_CHUNK_BYTES = 1 << 20
_SUFFIXES = {ArtifactFormat.ONNX: ".onnx", ArtifactFormat.SCRIPTED: ".json", ArtifactFormat.ARENA_POLICY: ""}
#: `Session.info` key: (sha256, path) of the files this session's open transaction moved into place.
_PLACED_KEY = "arena_league.placed_artifacts"


def store_artifact(
    session: Session,
    home: str | os.PathLike[str],
    source: bytes | str | os.PathLike[str],
    format: ArtifactFormat | str,
    *,
    max_bytes: int | None = None,
) -> Artifact:
    """Store an artifact (bytes, a file, or a folder) and return its row; idempotent by content.

    Args:
        session: the caller's session; the row is added to its transaction.
        home: the league home (`League.home`); the file goes under `<home>/artifacts/`.
        source: the content itself, or the path of a file or an `arena-policy` folder.
        format: "onnx", "arena-policy" or "scripted".
        max_bytes: refuse, before reading anything, content larger than this.

    Raises:
        ArtifactTooLargeError: the content is over `max_bytes` (nothing was read or written).
        ArtifactError: the path is missing, or a folder holds a link or a special file.
        InvalidRecordError: unknown format, or the same content is already stored as another format.
        DiskFullError: the store's disk is full (nothing was added to it).
    """
    try:
        return _store_artifact(session, home, source, format, max_bytes)
    except OSError as error:
        full = disk_full_error(error, f"the league home's {ARTIFACTS_DIRNAME}/ folder")
        if full is None:
            raise
        raise full from error


def _store_artifact(session: Session, home: str | os.PathLike[str], source: bytes | str | os.PathLike[str],
                    format: ArtifactFormat | str, max_bytes: int | None) -> Artifact:
    artifact_format = _parse_format(format)
    home_path = Path(home)
    incoming = home_path / ARTIFACTS_DIRNAME / _INCOMING_DIRNAME
    incoming.mkdir(parents=True, exist_ok=True)
    if isinstance(source, bytes | bytearray | memoryview):
        content = bytes(source)
        _check_size(len(content), max_bytes, "the artifact")
        sha256 = hashlib.sha256(content).hexdigest()
        size = len(content)
        staged = incoming / f"{uuid.uuid4().hex}.part"
        try:
            with staged.open("wb") as handle:
                handle.write(content)
                handle.flush()
                os.fsync(handle.fileno())
        except BaseException:
            staged.unlink(missing_ok=True)
            raise
    else:
        source_path = Path(source).expanduser()
        if source_path.is_dir():
            staged, sha256, size = _stage_folder(source_path, incoming, max_bytes)
        elif source_path.is_file():
            _check_size(source_path.stat().st_size, max_bytes, str(source_path))
            staged = incoming / f"{uuid.uuid4().hex}.part"
            sha256, size = _copy_hashing(source_path, staged, max_bytes)
        else:
            raise ArtifactError(f"artifact path {source_path} does not exist or is not a file or folder")

    relative = Path(ARTIFACTS_DIRNAME) / sha256[:2] / f"{sha256}{_SUFFIXES[artifact_format]}"
    try:
        existing = session.get(Artifact, sha256)
        if existing is not None and existing.format != artifact_format.value:
            raise InvalidRecordError(
                f"artifact {sha256[:12]} is already stored as format {existing.format!r}, not "
                f"{artifact_format.value!r}; submit it with format {existing.format!r}"
            )
        placed = _move_into_place(staged, home_path / relative)
    except BaseException:
        _remove(staged)
        raise
    if placed:
        _track_placed(session, sha256, home_path / relative)

    if existing is None:
        row = {
            "sha256": sha256,
            "format": artifact_format.value,
            "size_bytes": size,
            "path": relative.as_posix(),
        }
        insert_ignoring_conflict(session, Artifact, [row], conflict_columns=["sha256"])
        existing = session.get(Artifact, sha256)
        assert existing is not None
    if existing.format != artifact_format.value:  # a concurrent writer stored it as another format
        raise InvalidRecordError(
            f"artifact {sha256[:12]} is already stored as format {existing.format!r}, not "
            f"{artifact_format.value!r}; submit it with format {existing.format!r}"
        )
    return existing


def get_artifact(session: Session, sha256: str) -> Artifact | None:
    """The artifact with this SHA-256 (lowercase hex), or None."""
    return session.get(Artifact, sha256.lower())


def list_artifacts(session: Session) -> list[Artifact]:
    """Every stored artifact, oldest first."""
    return list(session.scalars(select(Artifact).order_by(Artifact.created_at, Artifact.sha256)))


def artifact_path(home: str | os.PathLike[str], artifact: Artifact) -> Path:
    """Where an artifact's file (or folder) lies under the league home."""
    return Path(home) / artifact.path


def verify_artifact(home: str | os.PathLike[str], artifact: Artifact) -> None:
    """Re-hash a stored artifact; raise ArtifactError if it is missing or its content changed."""
    path = artifact_path(home, artifact)
    if not path.exists():
        raise ArtifactError(
            f"artifact {artifact.sha256[:12]} is missing from the store ({path}); store the same "
            "file again to restore it"
        )
    actual = _folder_digest(path)[0] if path.is_dir() else _hash_file(path)
    if actual != artifact.sha256:
        raise ArtifactError(
            f"artifact {artifact.sha256[:12]} at {path} no longer matches its hash (now "
            f"{actual[:12]}); the store was modified outside arena-league; store the original again"
        )


def _parse_format(format: ArtifactFormat | str) -> ArtifactFormat:
    try:
        return ArtifactFormat(format)
    except ValueError:
        known = ", ".join(repr(f.value) for f in ArtifactFormat)
        raise InvalidRecordError(f"unknown artifact format {format!r}; use one of {known}") from None


def _check_size(size: int, max_bytes: int | None, what: str) -> None:
    if max_bytes is not None and size > max_bytes:
        raise ArtifactTooLargeError(
            f"{what} is {size} bytes, over the limit of {max_bytes} bytes; it was not read. "
            "Shrink the artifact (e.g. export in float16) or raise the limit"
        )


def _hash_file(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        while chunk := handle.read(_CHUNK_BYTES):
            digest.update(chunk)
    return digest.hexdigest()


def _copy_hashing(source: Path, target: Path, max_bytes: int | None) -> tuple[str, int]:
    """Copy `source` to `target` in chunks, hashing on the way; returns (sha256, size)."""
    digest = hashlib.sha256()
    size = 0
    try:
        with source.open("rb") as reader, target.open("wb") as writer:
            while chunk := reader.read(_CHUNK_BYTES):
                size += len(chunk)
                _check_size(size, max_bytes, str(source))  # the file may grow while read
                digest.update(chunk)
                writer.write(chunk)
            writer.flush()
            os.fsync(writer.fileno())
    except BaseException:
        target.unlink(missing_ok=True)
        raise
    return digest.hexdigest(), size


def _folder_files(folder: Path) -> list[tuple[str, Path]]:
    """(relative POSIX path, path) of every file under `folder`, sorted; refuses links."""
    files = []
    for path in sorted(folder.rglob("*")):
        relative = path.relative_to(folder).as_posix()
        if path.is_symlink():
            raise ArtifactError(
                f"artifact folder {folder} holds a link ({relative}); copy the real file in its place"
            )
        if path.is_file():
            files.append((relative, path))
        elif not path.is_dir():
            raise ArtifactError(f"artifact folder {folder} holds {relative}, which is not a regular file")
    if not files:
        raise ArtifactError(f"artifact folder {folder} holds no files")
    return sorted(files)


def _folder_digest(folder: Path) -> tuple[str, int]:
    """The folder's address and total size, without copying it."""
    files = _folder_files(folder)
    address = folder_address((relative, _hash_file(path)) for relative, path in files)
    return address, sum(path.stat().st_size for _, path in files)


def _stage_folder(folder: Path, incoming: Path, max_bytes: int | None) -> tuple[Path, str, int]:
    """Copy a folder into the incoming area, hashing each file; returns (staged, sha256, size)."""
    files = _folder_files(folder)
    _check_size(sum(path.stat().st_size for _, path in files), max_bytes, str(folder))
    staged = incoming / uuid.uuid4().hex
    listing = []
    total = 0
    try:
        for relative, path in files:
            target = staged / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            file_sha, file_size = _copy_hashing(path, target, None)
            total += file_size
            _check_size(total, max_bytes, str(folder))
            listing.append((relative, file_sha))
    except BaseException:
        shutil.rmtree(staged, ignore_errors=True)
        raise
    return staged, folder_address(listing), total


def _move_into_place(staged: Path, final: Path) -> bool:
    """Rename a staged file or folder to its address; if the address is taken, keep what is there.
    Returns whether this call put the content there."""
    final.parent.mkdir(parents=True, exist_ok=True)
    if staged.is_dir():
        if final.exists():
            shutil.rmtree(staged)
            return False
        try:
            staged.rename(final)
        except OSError:
            if not final.is_dir():  # a concurrent store of the same folder won the rename
                raise
            shutil.rmtree(staged)
            return False
        return True
    if final.exists():
        staged.unlink()
        return False
    os.replace(staged, final)
    return True


def _remove(path: Path) -> None:
    """Remove a file or folder if it is there."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def _track_placed(session: Session, sha256: str, path: Path) -> None:
    """Remember a file this session's transaction put in the store, to remove it if it does not commit."""
    placed = session.info.get(_PLACED_KEY)
    if placed is None:
        placed = session.info[_PLACED_KEY] = []
        event.listen(session, "after_commit", _forget_placed)
        event.listen(session, "after_transaction_end", _remove_uncommitted)
    placed.append((sha256, path))


def _forget_placed(session: Session) -> None:
    session.info.get(_PLACED_KEY, []).clear()


def _remove_uncommitted(session: Session, transaction: SessionTransaction) -> None:
    """After the outermost transaction ends without a commit, remove the files it placed, keeping
    any whose row another writer has committed meanwhile (it now owns the file)."""
    if transaction.parent is not None:
        return
    placed = session.info.get(_PLACED_KEY) or []
    if not placed:
        return
    pending, placed[:] = list(placed), []
    shas = sorted({sha for sha, _ in pending})
    try:
        with session.get_bind().connect() as connection:
            kept = set(connection.scalars(select(Artifact.sha256).where(Artifact.sha256.in_(shas))))
    except Exception:  # cannot tell: keep the files; `arena-league gc` removes them later
        return
    for sha, path in pending:
        if sha not in kept:
            _remove(path)


def collect_artifact_garbage(
    session: Session,
    home: str | os.PathLike[str],
    *,
    dry_run: bool = False,
    min_age_s: float = 3600.0,
) -> dict[str, list[dict[str, Any]]]:
    """Remove what no agent needs from the artifact store; returns what was (or would be) removed.

    Removed: stored files and folders whose content no agent references (with their artifact rows),
    and leftovers of interrupted writes in `artifacts/.incoming/`. Only entries last modified at
    least `min_age_s` seconds ago are touched, so a write under way in another process (its file
    placed, its row not yet committed) is left alone; pass 0 to collect everything now. Run it
    inside a write transaction so no writer commits a new reference meanwhile.

    Returns:
        {"artifacts": [{"sha256", "path", "bytes", "row"}...], "incoming": [{"path", "bytes"}...]},
        paths relative to the league home; `row` says whether an artifact row was deleted too.
    """
    home_path = Path(home)
    store = home_path / ARTIFACTS_DIRNAME
    cutoff = time.time() - min_age_s
    referenced = set(session.scalars(select(Agent.artifact_sha256).where(Agent.artifact_sha256.is_not(None))))
    rows = {row.sha256: row for row in session.scalars(select(Artifact))}
    removed: dict[str, list[dict[str, Any]]] = {"artifacts": [], "incoming": []}
    incoming = store / _INCOMING_DIRNAME
    if incoming.is_dir():
        for entry in sorted(incoming.iterdir()):
            if _modified(entry) <= cutoff:
                removed["incoming"].append({"path": entry.relative_to(home_path).as_posix(), "bytes": _size(entry)})
                if not dry_run:
                    _remove(entry)
    unreferenced_rows = []
    if store.is_dir():
        for prefix in sorted(store.iterdir()):
            if prefix.name == _INCOMING_DIRNAME or not prefix.is_dir() or prefix.is_symlink():
                continue
            for entry in sorted(prefix.iterdir()):
                sha = entry.name.split(".", 1)[0]
                if sha in referenced or _modified(entry) > cutoff:
                    continue
                row = rows.get(sha)
                if row is not None and Path(row.path) != entry.relative_to(home_path):
                    row = None  # the same bytes stored under another format's name: that file stays
                removed["artifacts"].append({"sha256": sha, "path": entry.relative_to(home_path).as_posix(),
                                             "bytes": _size(entry), "row": row is not None})
                if row is not None:
                    unreferenced_rows.append(sha)
                if not dry_run:
                    _remove(entry)
    listed = {entry["sha256"] for entry in removed["artifacts"]}
    for sha, row in rows.items():  # rows whose file is gone already and no agent needs
        if sha not in referenced and sha not in listed and not (home_path / row.path).exists():
            removed["artifacts"].append({"sha256": sha, "path": row.path, "bytes": 0, "row": True})
            unreferenced_rows.append(sha)
    if unreferenced_rows and not dry_run:
        session.execute(delete(Artifact).where(Artifact.sha256.in_(unreferenced_rows)))
        session.flush()
    return removed


def _modified(path: Path) -> float:
    try:
        return path.lstat().st_mtime
    except FileNotFoundError:
        return time.time()


def _size(path: Path) -> int:
    if path.is_dir() and not path.is_symlink():
        return sum(p.lstat().st_size for p in path.rglob("*") if p.is_file() and not p.is_symlink())
    try:
        return path.lstat().st_size
    except FileNotFoundError:
        return 0
