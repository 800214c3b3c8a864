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
to disk, then renamed into place, so a crash leaves either nothing or a complete artifact. This
module stores and finds bytes; what they mean (ONNX graphs, manifests) is
`arena_league.policies`'s business.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import uuid
from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import Session

from arena_league.policies.address import folder_address
from arena_league.registry.db import ARTIFACTS_DIRNAME
from arena_league.registry.errors import ArtifactError, ArtifactTooLargeError, InvalidRecordError
from arena_league.registry.models import Artifact, ArtifactFormat
from arena_league.registry.repository import insert_ignoring_conflict

_INCOMING_DIRNAME = ".incoming"
_CHUNK_BYTES = 1 << 20
_SUFFIXES = {ArtifactFormat.ONNX: ".onnx", ArtifactFormat.SCRIPTED: ".json", ArtifactFormat.ARENA_POLICY: ""}


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
    """
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
        with staged.open("wb") as handle:
            handle.write(content)
            handle.flush()
            os.fsync(handle.fileno())
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
    _move_into_place(staged, home_path / relative)

    existing = session.get(Artifact, sha256)
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
    if existing.format != artifact_format.value:
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


def _move_into_place(staged: Path, final: Path) -> None:
    """Rename a staged file or folder to its address; if the address is taken, keep what is there."""
    final.parent.mkdir(parents=True, exist_ok=True)
    if staged.is_dir():
        if final.exists():
            shutil.rmtree(staged)
            return
        try:
            staged.rename(final)
        except OSError:
            if not final.is_dir():  # a concurrent store of the same folder won the rename
                raise
            shutil.rmtree(staged)
    elif final.exists():
        staged.unlink()
    else:
        os.replace(staged, final)
