"""The application: :func:`create_app` builds one for a league (a home folder or a database URL).

Besides the routes (:mod:`.api`, :mod:`.pages`) it sets up

* the league, opened once, and a :class:`~arena_league.league.LeaderboardCache` shared by the
  requests of this process;
* job workers: with ``workers=N`` (the ``serve`` default is 1), N ``arena-league worker``
  processes run beside the server, on the same league, restarted if one dies and stopped with it
  (:mod:`.workers`); with 0, jobs wait for workers started elsewhere (several, on PostgreSQL,
  across machines);
* a limit on request bodies (the league's ``web.upload_mib`` setting plus room for the form), so an
  upload over it is refused with 413 while it streams, before it fills a disk;
* one log line per request on stderr (method, path, status, milliseconds, owner);
* errors as ``{"detail": ...}`` (the API and the ``.json`` twins) or as a page: 400 for bad input,
  401, 403, 404 and 429 as their names say, 500 for a bug (logged with its traceback, answered
  with one line).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import HTTPException, RequestValidationError
from fastapi.responses import JSONResponse, Response
from fastapi.staticfiles import StaticFiles

from arena_league import league as ops
from arena_league.web import api, pages, play
from arena_league.web.auth import token_of
from arena_league.web.deps import STATUS_OF, status_of
from arena_league.web.workers import WorkerPool, worker_command

__all__ = ["create_app"]

logger = logging.getLogger("arena_league.web")
#: Room a multipart form needs beyond the files it carries.
FORM_SLACK_BYTES = 1 << 20
_UPLOAD_PATHS = ("/api/agents", "/submit")
#: The most any other request body (a JSON document, a form) may hold.
JSON_BODY_BYTES = 1 << 20


class _BodyTooLarge(Exception):
    pass


class BodyLimit:
    """ASGI middleware: refuse an upload whose body is over the league's upload limit (any other
    body over :data:`JSON_BODY_BYTES`), by its Content-Length at once, or, without one, as soon as
    that much has streamed in."""

    def __init__(self, app: Any, limit: Any) -> None:
        self.app = app
        self.limit = limit  # a callable: the limit in bytes now

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope["method"] not in ("POST", "PUT", "PATCH"):
            await self.app(scope, receive, send)
            return
        limit = self.limit() if scope["path"] in _UPLOAD_PATHS else JSON_BODY_BYTES
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None and declared.isdigit() and int(declared) > limit:
            await _refuse(scope, send, limit)
            return
        received = 0
        started = False

        async def counted() -> dict:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise _BodyTooLarge
            return message

        async def watched(message: dict) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await send(message)

        try:
            await self.app(scope, counted, watched)
        except _BodyTooLarge:
            if not started:
                await _refuse(scope, send, limit)


async def _refuse(scope: dict, send: Any, limit: int) -> None:
    if scope["path"] in _UPLOAD_PATHS:
        detail = (f"the upload is over {(limit - FORM_SLACK_BYTES) >> 20} MiB, the most this league takes (the "
                  "setting web.upload_mib)")
    else:
        detail = f"the request body is over {limit >> 20} MiB, the most a request other than an upload may carry"
    response = JSONResponse({"detail": detail}, status_code=413)
    await response(scope, _no_body, send)


async def _no_body() -> dict:
    return {"type": "http.disconnect"}


def _openapi(app: FastAPI) -> dict[str, Any]:
    """The OpenAPI document, with FastAPI's validation error (a list) replaced by this API's one-line
    ``{"detail": ...}``, which every error answers with."""
    if app.openapi_schema is None:
        from fastapi.openapi.utils import get_openapi

        document = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
        schemas = document.get("components", {}).get("schemas", {})
        schemas["HTTPValidationError"] = {"title": "HTTPValidationError", "type": "object", "required": ["detail"],
                                          "properties": {"detail": {"type": "string", "title": "Detail"}}}
        schemas.pop("ValidationError", None)
        app.openapi_schema = document
    return app.openapi_schema


def create_app(home: str | Path | None = None, url: str | None = None, *, workers: int = 0) -> FastAPI:
    """The web service of the league at ``home`` / ``url`` (``ARENA_LEAGUE_HOME``,
    ``ARENA_LEAGUE_DB``, default ``~/.arena-league``), with ``workers`` job workers beside it."""
    if workers < 0:
        raise ValueError(f"workers must be 0 or more, not {workers}")
    league = ops.open_home(home, url)
    pool = WorkerPool(worker_command(league.home, url), workers)  # the workers open this same league

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        await asyncio.to_thread(pool.start)
        try:
            yield
        finally:
            await asyncio.to_thread(pool.stop)
            league.close()

    app = FastAPI(title="arena-league", lifespan=lifespan,
                  description="A league for multi-agent RL agents: upload an agent with a token, follow its "
                              "validation, rank it against its game's base population, read leaderboards with "
                              "intervals, watch replays. Every write queues a job.")
    app.state.league = league
    app.state.workers = pool
    app.state.boards = ops.LeaderboardCache()
    app.state.live_games = 0  # people playing in a browser now (see .play)
    app.include_router(api.router)
    app.include_router(pages.router)
    app.include_router(play.router)
    app.openapi = lambda: _openapi(app)
    app.mount("/static", StaticFiles(directory=str(Path(__file__).parent / "static")), name="static")

    def upload_limit() -> int:
        return ops.upload_limits(league)[0] + FORM_SLACK_BYTES

    app.add_middleware(BodyLimit, limit=upload_limit)

    @app.middleware("http")
    async def log_requests(request: Request, call_next: Any) -> Response:
        started = time.perf_counter()
        response = await call_next(request)
        owner = "-" if token_of(request) is None else "token"
        logger.info("%s %s %d %.1f ms %s", request.method, request.url.path, response.status_code,
                    1e3 * (time.perf_counter() - started), owner)
        return response

    def respond(request: Request, status: int, message: str, headers: dict[str, str] | None = None) -> Response:
        wants_page = (not request.url.path.startswith("/api/") and not request.url.path.endswith(".json")
                      and "text/html" in request.headers.get("accept", ""))
        if wants_page:
            page = pages.templates.TemplateResponse(request, "error.html", {
                "status": status, "message": message, "viewer": None, "json_url": "/api/games"}, status_code=status)
            return page
        return JSONResponse({"detail": message}, status_code=status, headers=headers)

    for kind in STATUS_OF:
        @app.exception_handler(kind)
        async def refused(request: Request, error: Exception) -> Response:
            status = status_of(error)
            return respond(request, status, str(error), {"Retry-After": "3600"} if status == 429 else None)

    @app.exception_handler(HTTPException)
    async def http_error(request: Request, error: HTTPException) -> Response:
        return respond(request, error.status_code, str(error.detail), dict(error.headers or {}))

    @app.exception_handler(RequestValidationError)
    async def invalid(request: Request, error: RequestValidationError) -> Response:
        problems = "; ".join(f"{'.'.join(str(p) for p in e.get('loc', ()))}: {e.get('msg')}" for e in error.errors())
        return respond(request, 422, f"the request is not valid: {problems}")

    for kind in ops.USER_ERRORS:
        @app.exception_handler(kind)
        async def bad_input(request: Request, error: Exception) -> Response:
            return respond(request, 400, str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__)

    @app.exception_handler(Exception)
    async def bug(request: Request, error: Exception) -> Response:
        logger.error("%s %s failed", request.method, request.url.path, exc_info=error)
        return respond(request, 500, f"internal error ({type(error).__name__}); the server's log has the traceback")

    return app
