"""The application: :func:`create_app` builds one for a league (a home folder or a database URL).

Besides the routes (:mod:`.api`, :mod:`.pages`) it sets up

* the league, opened once, and a :class:`~arena_league.league.LeaderboardCache` shared by the
  requests of this process;
* job workers: with ``workers=N`` (the ``serve`` default is 1), N ``arena-league worker``
  processes run beside the server, on the same league, restarted if one dies and stopped with it
  (:mod:`.workers`); with 0, jobs wait for workers started elsewhere (several, on PostgreSQL,
  across machines);
* the front door (:mod:`.guard`): a write's token, its size and the uploads in flight are checked
  before its body is read (401, 413, 429), and a body is counted as it streams (413 past its limit);
* the guide (the docs site, once built with ``mkdocs build``) under ``/guide``: the folder named by
  ``ARENA_LEAGUE_GUIDE``, else a checkout's ``site/``; where none is built, ``/guide`` answers 404
  with how to build it;
* one log line per request on stderr (method, path, status, milliseconds, owner);
* errors as ``{"detail": ...}`` (the API and the ``.json`` twins) or as a page: 400 for bad input,
  401, 403, 404 and 429 as their names say, 507 for a full disk (naming which, without the
  server's paths), 500 for a bug (logged with its traceback, answered with one line).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import HTTPException, RequestValidationError
from fastapi.responses import JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException

from arena_league import league as ops
from arena_league.league.errors import DatabaseFullError, DiskFullError, disk_full_error
from arena_league.web import api, pages, play
from arena_league.web.auth import token_of
from arena_league.web.bodies import JsonNesting
from arena_league.web.csrf import Guard, SecurityHeaders, add_security_headers
from arena_league.web.deps import STATUS_OF, status_of
from arena_league.web.guard import DATABASE_FULL, FULL_RETRY_SECONDS, FrontDoor
from arena_league.web.workers import WorkerPool, worker_command

__all__ = ["GUIDE_ENV", "create_app", "guide_folder"]

#: Names a built docs site to serve under ``/guide`` (default: a checkout's ``site/``).
GUIDE_ENV = "ARENA_LEAGUE_GUIDE"
#: What ``/guide`` answers where no site is built.
GUIDE_MISSING = ("the guide is not built here: in a checkout, `pip install -e \".[dev]\"` then `mkdocs build` "
                 f"writes it into site/ (or set {GUIDE_ENV} to a built site's folder)")


def guide_folder() -> Path | None:
    """The built docs site to serve: ``$ARENA_LEAGUE_GUIDE``, else the ``site/`` beside the package
    in a checkout; None where neither holds an ``index.html``."""
    named = os.environ.get(GUIDE_ENV)
    folder = Path(named) if named else Path(__file__).resolve().parents[2] / "site"
    return folder if (folder / "index.html").is_file() else None

logger = logging.getLogger("arena_league.web")


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
            for pid in await asyncio.to_thread(pool.stop):
                # a worker killed on the stop could not hand its job back: done here for it
                released = await asyncio.to_thread(ops.release_jobs_of_process, league, pid)
                if released:
                    logger.warning("job(s) %s of the stopped worker %d went back to the queue",
                                   ", ".join(map(str, released)), pid)
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
    guide = guide_folder()
    app.state.guide = guide is not None
    if guide is not None:
        app.mount("/guide", StaticFiles(directory=str(guide), html=True), name="guide")
    else:
        @app.get("/guide", include_in_schema=False)
        @app.get("/guide/{rest:path}", include_in_schema=False)
        async def no_guide(rest: str = "") -> Response:
            raise HTTPException(404, GUIDE_MISSING)

    def respond(request: Request, status: int, message: str, headers: dict[str, str] | None = None) -> Response:
        wants_page = (not request.url.path.startswith("/api/") and not request.url.path.endswith(".json")
                      and "text/html" in request.headers.get("accept", ""))
        if wants_page:
            page = pages.templates.TemplateResponse(request, "error.html", {
                "status": status, "message": message, "viewer": None, "json_url": "/api/games"}, status_code=status, headers=headers)
            return page
        return JSONResponse({"detail": message}, status_code=status, headers=headers)

    # outermost last: the request log, the security headers, then the front door (a token and the limits, before any byte of
    # body), then the CSRF guard (it reads at most a form's first field), then the JSON nesting bound
    app.add_middleware(JsonNesting)
    app.add_middleware(Guard)
    app.add_middleware(FrontDoor, league=league, answer=respond)
    app.add_middleware(SecurityHeaders)

    @app.middleware("http")
    async def log_requests(request: Request, call_next: Any) -> Response:
        started = time.perf_counter()
        response = await call_next(request)
        owner = "-" if token_of(request) is None else "token"
        logger.info("%s %s %d %.1f ms %s", request.method, request.url.path, response.status_code,
                    1e3 * (time.perf_counter() - started), owner)
        return response

    for kind in STATUS_OF:
        @app.exception_handler(kind)
        async def refused(request: Request, error: Exception) -> Response:
            status = status_of(error)
            return respond(request, status, str(error), {"Retry-After": "3600"} if status == 429 else None)

    @app.exception_handler(DatabaseFullError)
    async def database_full(request: Request, error: DatabaseFullError) -> Response:
        logger.error("%s %s: %s", request.method, request.url.path, error)  # the operator's line names the file
        return respond(request, 507, DATABASE_FULL, {"Retry-After": str(FULL_RETRY_SECONDS)})

    @app.exception_handler(HTTPException)
    async def http_error(request: Request, error: HTTPException) -> Response:
        return respond(request, error.status_code, str(error.detail), dict(error.headers or {}))

    @app.exception_handler(StarletteHTTPException)
    async def body_error(request: Request, error: StarletteHTTPException) -> Response:
        # a body the server could not spool (its temporary folder full) is the server's fault: named
        full = disk_full_error(error.__cause__, "the web server's temporary folder (TMPDIR)") if error.__cause__ else None
        if full is not None:
            return disk_full(request, full)
        return await http_exception_handler(request, error)

    def disk_full(request: Request, error: Exception) -> Response:
        logger.error("%s %s: %s", request.method, request.url.path, error)
        return respond(request, 507, str(error), {"Retry-After": str(FULL_RETRY_SECONDS)})

    @app.exception_handler(RequestValidationError)
    async def invalid(request: Request, error: RequestValidationError) -> Response:
        problems = "; ".join(f"{'.'.join(str(p) for p in e.get('loc', ()))}: {e.get('msg')}" for e in error.errors())
        return respond(request, 422, f"the request is not valid: {problems}")

    for kind in ops.USER_ERRORS:
        @app.exception_handler(kind)
        async def bad_input(request: Request, error: Exception) -> Response:
            return respond(request, 400, str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__)

    @app.exception_handler(DiskFullError)
    async def storage_full(request: Request, error: DiskFullError) -> Response:
        return disk_full(request, error)

    @app.exception_handler(Exception)
    async def bug(request: Request, error: Exception) -> Response:
        full = disk_full_error(error, "the league home")  # a write the league did not name itself
        if full is not None:
            return disk_full(request, full)
        logger.error("%s %s failed", request.method, request.url.path, exc_info=error)
        response = respond(request, 500, f"internal error ({type(error).__name__}); the server's log has the traceback")
        # a bug's answer comes from outside every middleware: it takes the security headers here
        add_security_headers(response.headers, docs=False)
        return response

    return app
