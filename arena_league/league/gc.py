"""Collecting the artifact store's garbage: files no agent needs.

Agents keep their artifacts for good, so a file in the store that no agent references is left
over: by a write that crashed between placing the file and committing its row, or by an older
version that did not clean up after a refused submission. :func:`collect_garbage` removes those
files and folders (and their rows), and the leftovers of interrupted writes in
``artifacts/.incoming/``. It runs in one write transaction, so no submission commits a reference
to a file while it decides, and it leaves alone anything modified in the last ``min_age_s``
seconds, which another process may be storing right now. It also removes uploads of the web
service left under ``uploads/`` with no validation job waiting for them (a worker killed while it
validated one, for instance), and the replays of social-tree previews older than a day (their
jobs' results say so when asked again).
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import Any

from arena_league.league.trees import PREVIEWS
from arena_league.league.uploads import UPLOADS
from arena_league.registry import League
from arena_league.registry.artifacts import collect_artifact_garbage
from arena_league.registry.jobs import live_jobs

__all__ = ["collect_garbage"]

#: How long a social-tree preview's replay is kept (unless ``min_age_s`` is 0: everything goes).
PREVIEW_KEEP_S = 86400.0


def collect_garbage(league: League, dry_run: bool = False, *, min_age_s: float = 3600.0) -> dict[str, Any]:
    """Remove unreferenced artifacts and stale ``.incoming`` leftovers from the league's store.

    Args:
        league: the league whose home holds the store.
        dry_run: only list what would be removed.
        min_age_s: leave entries modified more recently than this (a write may be under way); 0
            collects everything.

    Returns:
        ``{"dry_run", "artifacts": [{"sha256", "path", "bytes", "row"}...], "incoming": [{"path",
        "bytes"}...], "uploads": [{"path", "bytes"}...], "previews": [{"path", "bytes"}...], "bytes"}``: what was (or, with ``dry_run``,
        would be) removed, paths relative to the league home, and the bytes freed.
    """
    if min_age_s < 0:
        raise ValueError(f"min_age_s must be 0 or more, not {min_age_s}")
    with league.transaction() as session:
        removed = collect_artifact_garbage(session, league.home, dry_run=dry_run, min_age_s=min_age_s)
        uploads = [(job.payload or {}).get("upload", "") for job in live_jobs(session, "validate")]
        waiting = {upload.split("/")[1] for upload in uploads if "/" in upload}
        removed["uploads"] = _stale_folders(Path(league.home), UPLOADS, waiting, dry_run, min_age_s)
    # previews belong to no row: swept outside the transaction
    removed["previews"] = _stale_folders(Path(league.home), PREVIEWS, set(), dry_run,
                                         0.0 if min_age_s == 0 else max(min_age_s, PREVIEW_KEEP_S))
    freed = sum(entry["bytes"] for entries in removed.values() for entry in entries)
    return {"dry_run": dry_run, **removed, "bytes": freed}


def _stale_folders(home: Path, under: str, keep: set[str], dry_run: bool, min_age_s: float) -> list[dict[str, Any]]:
    """Folders of ``home/under`` not named in ``keep``, older than ``min_age_s`` (removed unless
    ``dry_run``)."""
    root = home / under
    stale = []
    for folder in sorted(root.iterdir()) if root.is_dir() else []:
        if folder.name in keep or time.time() - folder.stat().st_mtime < min_age_s:
            continue
        size = sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())
        stale.append({"path": folder.relative_to(home).as_posix(), "bytes": size})
        if not dry_run:
            shutil.rmtree(folder, ignore_errors=True)
    return stale
