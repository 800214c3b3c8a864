"""Agents uploaded through the web service: staged, named as versions, validated in a job.

An upload is a set of files: one ONNX file (with its ``.onnx.data`` beside it when torch wrote
one), or the files of an arena-policy folder (``manifest.json``, ``weights.safetensors``, and
optionally ``README.md``). :func:`upload_agent` checks the request (the game, the name, who owns
it, the uploader's rate), writes the files under the league home's ``uploads/`` (names checked,
sizes counted), reserves the agent's name as a *pending* agent and queues a ``validate`` job; it
answers at once. The job (:func:`handle_validate`) validates the files in the inference sandbox,
as ``arena-league submit`` does, stores the bytes and makes the agent active, or rejects it with
the reason and the log its owner can read. Agent code never runs in the request.

Names follow :mod:`arena_league.league.versions`, as ``arena-league submit`` does: a name is a
series of immutable versions owned by whoever submitted its first (:func:`series_versions`); new
bytes under it become its next version, the same bytes again are the agent already registered
for them (the job finds them, drops the version it reserved and answers with that agent), and
anyone else uploading under it is refused.
"""

from __future__ import annotations

import re
import shutil
import uuid
from collections.abc import Iterable
from datetime import timedelta
from pathlib import Path
from typing import Any, BinaryIO

from arena_league import registry as reg
from arena_league.league.errors import NotFoundError, RateLimitedError
from arena_league.league.home import register_game
from arena_league.league.quotas import enqueue_owned, live_job_limit
from arena_league.league.tokens import Identity
from arena_league.league.versions import (
    check_submitted_name,
    refuse_empty,
    series_of,
    version_name,
    version_rows,
)
from arena_league.registry import League
from arena_league.registry.errors import NameTakenError, disk_full_error
from arena_league.registry.jobs import set_job_payload
from arena_league.registry.models import utcnow

__all__ = ["UPLOADS", "handle_validate", "series_of", "series_versions", "upload_admission", "upload_agent",
           "upload_limits"]

#: Folder of the league home where uploads wait for their validation job.
UPLOADS = "uploads"
#: What an uploaded file may be called: no folders, no dot files.
_FILE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,127}$")
_POLICY_FILES = {"manifest.json", "weights.safetensors", "README.md"}
_CHUNK = 1 << 20
#: Where uploads are staged, as a refusal names it (a server's paths are not shown to uploaders).
_UPLOADS_WORDS = f"the league home's {UPLOADS}/ folder"


def series_versions(league: League, name: str) -> list[dict[str, Any]]:
    """Every version of the series ``name`` belongs to: name, version, status, reason, created."""
    with league.reading() as session:
        return version_rows(session, name)


def upload_limits(league: League) -> tuple[int, int]:
    """(bytes an upload may hold, uploads an owner may make per hour), from the league's settings."""
    from arena_league.league.settings import league_settings

    settings = league_settings(league)
    return int(settings["web.upload_mib"]["value"]) << 20, int(settings["web.uploads_per_hour"]["value"])


def upload_admission(league: League) -> tuple[int, int, int, tuple[int, int]]:
    """What a web server checks before it reads an upload, from one read of the league's settings:
    (bytes an upload may hold, uploads one owner may be sending to the server at once, uploads the
    server receives at once, (seconds it waits for the body's next bytes, the slowest average in
    bytes a second the body may arrive at once it has streamed that long)); past the last two, the
    upload is abandoned."""
    from arena_league.league.settings import league_settings

    settings = league_settings(league)

    def value(key: str) -> int:
        return int(settings[key]["value"])

    return (value("web.upload_mib") << 20, value("web.uploads_in_flight_per_owner"), value("web.uploads_in_flight"),
            (value("web.body_idle_seconds"), value("web.body_min_kib_per_second") << 10))


def upload_agent(league: League, who: Identity, game_id: str, name: str,
                 files: Iterable[tuple[str, BinaryIO]]) -> dict[str, Any]:
    """Stage an upload and queue its validation (see the module docstring); returns
    ``{"name", "version", "status": "pending", "job"}``.

    Raises ``ValueError`` for a bad game, name or file set (an empty file included; nothing is
    kept), :class:`ForbiddenError` when the name is reserved or belongs to another owner,
    :class:`RateLimitedError` past the hourly limit, :class:`~arena_league.registry.errors.DiskFullError`
    when the files do not fit on the league home's disk (nothing is kept)."""
    register_game(league, game_id)
    check_submitted_name(name)
    limit_bytes, per_hour = upload_limits(league)
    with league.reading() as session:
        recent = reg.count_agents_since(session, who.owner, utcnow() - timedelta(hours=1))
        version_name(session, name, game_id, who.owner)  # another owner's name is refused before staging
    _refuse_over_rate(who, recent, per_hour)  # early, before staging; _reserve counts again under the lock
    staged = _stage(league, files, limit_bytes)
    try:
        agent, job_id = _reserve(league, who, game_id, name, staged)
    except BaseException:
        _discard(staged)
        raise
    return {"name": agent, "version": series_of(agent)[1], "status": "pending", "job": job_id}


def _stage(league: League, files: Iterable[tuple[str, BinaryIO]], limit_bytes: int) -> Path:
    """Write the files under ``uploads/<random>/``; returns the artifact's path there (the ONNX file,
    or the folder of an arena-policy). Nothing stays when the files are refused."""
    folder = Path(league.home) / UPLOADS / uuid.uuid4().hex
    names: list[str] = []
    total = 0
    try:
        folder.mkdir(parents=True)
        for filename, stream in files:
            base = filename or ""
            if not _FILE_NAME.match(base) or base in names:  # no folder part, no dot file, once each
                raise ValueError(f"file name {filename!r} is not allowed (or given twice): upload model.onnx "
                                 "(with model.onnx.data) or manifest.json, weights.safetensors and README.md")
            names.append(base)
            with open(folder / base, "wb") as out:
                while chunk := stream.read(_CHUNK):
                    total += len(chunk)
                    if total > limit_bytes:
                        raise ValueError(f"the upload is over {limit_bytes >> 20} MiB, the most this league takes "
                                         "(the setting web.upload_mib)")
                    out.write(chunk)
        refuse_empty((n, (folder / n).stat().st_size) for n in names)
        onnx = [n for n in names if n.endswith(".onnx")]
        if len(onnx) == 1 and set(names) <= {onnx[0], onnx[0] + ".data"}:
            return folder / onnx[0]
        if {"manifest.json", "weights.safetensors"} <= set(names) <= _POLICY_FILES:
            return folder
        raise ValueError(f"an upload is one .onnx file (with its .onnx.data when torch wrote one) or an "
                         f"arena-policy folder's manifest.json and weights.safetensors (and README.md); got "
                         f"{', '.join(names) or 'no file'}")
    except BaseException as error:
        shutil.rmtree(folder, ignore_errors=True)
        full = disk_full_error(error, _UPLOADS_WORDS)
        if full is not None:
            raise full from error
        raise


def _reserve(league: League, who: Identity, game_id: str, series: str, staged: Path) -> tuple[str, int]:
    """Reserve the series' next version as a pending agent and queue its validation, in one
    transaction (a concurrent upload of the same series takes the version after). The owner's hourly
    uploads and live jobs are counted in that transaction, under the owner's lock, so concurrent
    uploads (on any server) cannot together pass ``web.uploads_per_hour`` or ``jobs.live_per_owner``."""
    relative = staged.relative_to(Path(league.home)).as_posix()
    per_hour, job_limit = upload_limits(league)[1], live_job_limit(league)
    for _ in range(5):
        try:
            with league.transaction() as session:
                reg.lock_owner(session, who.owner)
                _refuse_over_rate(who, reg.count_agents_since(session, who.owner, utcnow() - timedelta(hours=1)),
                                  per_hour)
                name, version = version_name(session, series, game_id, who.owner)
                reg.create_agent(session, name, game_id, "submission", owner=who.owner, status="pending",
                                 metadata={"series": series, "version": version, "upload": relative}, reserved=True)
                job = enqueue_owned(session, who, "validate", {"game_id": game_id, "agent": name, "upload": relative},
                                    priority=50, limit=job_limit)
                return name, job.id
        except NameTakenError:
            continue  # another upload took this version first
    raise ValueError(f"could not reserve a version of {series}: too many uploads of it at once; try again")


def _refuse_over_rate(who: Identity, recent: int, per_hour: int) -> None:
    """RateLimitedError once ``who`` (not an administrator) made ``per_hour`` uploads in the last hour."""
    if recent >= per_hour and not who.admin:
        raise RateLimitedError(f"{who.owner} has uploaded {recent} agents in the last hour, the most this league "
                               f"allows ({per_hour}, the setting web.uploads_per_hour); try again later")


def handle_validate(ctx: reg.JobContext, progress: Any = None) -> dict[str, Any]:
    """Job handler: validate an upload in the sandbox and make its pending agent active or rejected
    (the reason and the log kept); the staged files are removed either way."""
    from arena_league.league.service import agent_metadata, store_validated
    from arena_league.league.settings import sandbox_limits
    from arena_league.policies import ArtifactError, read_artifact, validate_submission

    payload = ctx.job.payload
    home = Path(ctx.league.home)
    staged = (home / payload["upload"]).resolve()
    if home.resolve() / UPLOADS not in staged.parents:
        raise ValueError(f"job {ctx.job.id}: upload path {payload['upload']!r} is outside the league's uploads")
    with ctx.league.reading() as session:
        agent = reg.get_agent(session, payload["agent"])
        if agent is None:
            raise NotFoundError(f"agent {payload['agent']} is gone")
        if agent.status != "pending":  # a retried job whose first attempt finished
            return {"agent": agent.name, "status": agent.status, "reason": agent.reject_reason}
    ctx.heartbeat()
    try:
        try:
            artifact = read_artifact(staged)
        except (ArtifactError, OSError) as error:
            reason = _without_paths(str(error), staged, home)
            return _settle(ctx.league, payload["agent"], "rejected", reason, f"[read] {reason}\n")
        with ctx.league.reading() as session:
            twin = next(iter(reg.find_agents_by_artifact(session, artifact.digest, game_id=payload["game_id"])), None)
        if twin is not None:
            return _drop_for_twin(ctx, twin, artifact.digest)
        if progress is not None:
            progress(0, 1)
        verdict = validate_submission(artifact, payload["game_id"], sandbox_limits=sandbox_limits(ctx.league))
        ctx.heartbeat()
        if progress is not None:
            progress(1, 1)
        status = "active" if verdict.ok else "rejected"
        with ctx.league.transaction() as session:
            row = reg.require_agent(session, payload["agent"])
            if verdict.error is None or verdict.ok:  # read and loaded: keep the bytes that were judged
                reg.attach_artifact(session, row, store_validated(session, ctx.league, artifact))
            kept = {k: v for k, v in (row.meta or {}).items() if k != "upload"}  # its files are removed below
            row.meta = {**agent_metadata(kept, artifact, verdict), "digest": artifact.digest}
            reason = None if verdict.reason is None else _without_paths(verdict.reason, staged, home)
            reg.set_agent_status(session, row, status, reason=reason, log=_without_paths(verdict.log, staged, home))
        return {"agent": payload["agent"], "status": status, "reason": reason,
                "seconds": round(verdict.seconds, 3), "size": verdict.size}
    finally:
        _discard(staged)


def _without_paths(text: str, staged: Path, home: Path) -> str:
    """``text`` with the server's paths of a staged upload replaced by the names its uploader gave
    (a file's name; "the uploaded folder" for an arena-policy's files), and any other mention of
    the league home by "the league home": a reason is shown to anyone, a log to the owner."""
    folder = staged if staged.is_dir() else staged.parent
    names = sorted((p.name for p in folder.iterdir()), key=len, reverse=True) if folder.is_dir() else [staged.name]
    for root in {folder, folder.resolve()}:
        for name in names:
            text = text.replace(f"{root}/{name}", name)
        text = text.replace(str(root), "the uploaded folder")
    for root in sorted({str(home), str(home.resolve())}, key=len, reverse=True):
        text = text.replace(root, "the league home")
    return text


def _discard(staged: Path) -> None:
    """Remove a staged upload (a file's folder, or the folder of a policy's files)."""
    shutil.rmtree(staged.parent if staged.is_file() else staged, ignore_errors=True)


def _drop_for_twin(ctx: reg.JobContext, twin: reg.Agent, digest: str) -> dict[str, Any]:
    """The upload's bytes are ``twin`` already: remove the version reserved for them (it never
    held an artifact), point the job at ``twin`` (its page links the agent it names) and answer
    with ``twin``, as ``arena-league submit`` does."""
    from arena_league.league.service import SubmitResult

    name = ctx.job.payload["agent"]
    with ctx.league.transaction() as session:
        row = reg.require_agent(session, name)
        if row.status == "pending" and row.artifact_sha256 is None:
            session.delete(row)
        set_job_payload(session, ctx.job, {**ctx.job.payload, "agent": twin.name})
    series, _ = series_of(name)
    return SubmitResult(twin.name, twin.game_id, twin.status, False, digest, twin.reject_reason,
                        requested=series).to_dict()


def _settle(league: League, name: str, status: str, reason: str, log: str) -> dict[str, Any]:
    with league.transaction() as session:
        reg.set_agent_status(session, reg.require_agent(session, name), status, reason=reason, log=log)
    return {"agent": name, "status": status, "reason": reason}
