"""The pages: server-rendered HTML, each with a ``.json`` twin that returns the document the page
shows (:mod:`arena_league.league.views`). Reading needs no token; the forms that write (sign in,
submit, rank, record a replay) use the sign-in cookie and answer with a redirect to the page that
shows what happened (``303 See Other``). The social-tree editor (``/trees/new``, ``/trees/{id}``)
is a script that talks to ``/api/trees`` with the same cookie. Every form that writes carries the
session's CSRF token as its first field, and every page has it in a ``csrf-token`` meta tag for
its scripts (:mod:`.csrf` checks them)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any
from urllib.parse import urlparse

from fastapi import APIRouter, File, Form, Request, UploadFile
from fastapi.responses import HTMLResponse, RedirectResponse
from fastapi.templating import Jinja2Templates

from arena_league import league as ops
from arena_league.league import Identity
from arena_league.web.auth import COOKIE
from arena_league.web.csrf import SIGNIN_COOKIE, new_signin_token, page_token
from arena_league.web.deps import Method, RowId, Viewer, league_of, status_of

__all__ = ["router", "templates"]

router = APIRouter(include_in_schema=False)
templates = Jinja2Templates(directory=str(Path(__file__).parent / "templates"))

def _page(request: Request, template: str, view: Any, viewer: Identity | None, json_url: str, **extra: Any
          ) -> HTMLResponse:
    return templates.TemplateResponse(request, template, {"view": view, "viewer": viewer, "json_url": json_url,
                                                          **extra})


def _local(target: str) -> str:
    """A redirect target on this site only (no scheme, no host: no open redirect)."""
    parsed = urlparse(target or "/")
    if parsed.scheme or parsed.netloc or not parsed.path.startswith("/") or parsed.path[1:2] in ("/", "\\"):
        return "/"
    return parsed.path + (f"?{parsed.query}" if parsed.query else "")


def _here(request: Request) -> str:
    """The page asked for, query included: where signing in comes back to."""
    return request.url.path + (f"?{request.url.query}" if request.url.query else "")


templates.env.globals["here"] = _here
templates.env.globals["csrf_token"] = page_token


def _seen(request: Request, query: dict[str, Any]) -> str:
    pairs = "&".join(f"{k}={v}" for k, v in query.items() if v)
    return f"{request.url.path}.json" + (f"?{pairs}" if pairs else "")


def _signed_in(viewer: Identity | None, path: str) -> Identity | RedirectResponse:
    return viewer if viewer is not None else RedirectResponse(f"/signin?next={path}", status_code=303)


# --- home ---------------------------------------------------------------------------------------

@router.get("/index.json")
def home_json(request: Request) -> dict[str, Any]:
    return ops.home_view(league_of(request))


@router.get("/", response_class=HTMLResponse)
def home(request: Request, viewer: Viewer) -> HTMLResponse:
    return _page(request, "index.html", ops.home_view(league_of(request)), viewer, "/index.json")


# --- games --------------------------------------------------------------------------------------

def _game(request: Request, game: str, method: str, kind: str | None, owner: str | None, sort: str | None,
          viewer: Identity | None) -> dict[str, Any]:
    return ops.game_view(league_of(request), request.app.state.boards, game, method=method, kind=kind or None,
                         owner=owner or None, sort=sort or None, viewer=viewer)


@router.get("/games/{game}.json")
def game_json(request: Request, game: str, viewer: Viewer, method: Method = "bt", kind: str | None = None,
              owner: str | None = None, sort: str | None = None) -> dict[str, Any]:
    return _game(request, game, method, kind, owner, sort, viewer)


@router.get("/games/{game}", response_class=HTMLResponse)
def game_page(request: Request, game: str, viewer: Viewer, method: Method = "bt", kind: str | None = None,
              owner: str | None = None, sort: str | None = None) -> HTMLResponse:
    view = _game(request, game, method, kind, owner, sort, viewer)
    return _page(request, "game.html", view, viewer,
                 _seen(request, {"method": method, "kind": kind, "owner": owner, "sort": sort}),
                 manual=ops.game_manual(game), guide=request.app.state.guide)


# --- agents -------------------------------------------------------------------------------------

@router.get("/agents/{name}.json")
def agent_json(request: Request, name: str, viewer: Viewer) -> dict[str, Any]:
    return ops.agent_view(league_of(request), name, viewer=viewer, boards=request.app.state.boards)


@router.get("/agents/{name}", response_class=HTMLResponse)
def agent_page(request: Request, name: str, viewer: Viewer) -> HTMLResponse:
    view = ops.agent_view(league_of(request), name, viewer=viewer, boards=request.app.state.boards)
    return _page(request, "agent.html", view, viewer,
                 f"/agents/{name}.json")


@router.post("/agents/{name}/rank")
def rank(request: Request, name: str, viewer: Viewer) -> RedirectResponse:
    who = _signed_in(viewer, f"/agents/{name}")
    if isinstance(who, RedirectResponse):
        return who
    league = league_of(request)
    return RedirectResponse(f"/jobs/{ops.queue_rank(league, ops.resolve_agent(league, name), who=who)}",
                            status_code=303)


# --- matches ------------------------------------------------------------------------------------

@router.get("/matches/{match_id}.json")
def match_json(request: Request, match_id: RowId) -> dict[str, Any]:
    return ops.match_view(league_of(request), match_id)


@router.get("/matches/{match_id}", response_class=HTMLResponse)
def match_page(request: Request, match_id: RowId, viewer: Viewer) -> HTMLResponse:
    return _page(request, "match.html", ops.match_view(league_of(request), match_id), viewer,
                 f"/matches/{match_id}.json")


@router.post("/matches/{match_id}/replay")
def record_replay(request: Request, match_id: RowId, viewer: Viewer) -> RedirectResponse:
    who = _signed_in(viewer, f"/matches/{match_id}")
    if isinstance(who, RedirectResponse):
        return who
    return RedirectResponse(f"/jobs/{ops.queue_replay(league_of(request), match_id, who=who)}", status_code=303)


# --- jobs ---------------------------------------------------------------------------------------

@router.get("/jobs/{job_id}.json")
def job_json(request: Request, job_id: RowId) -> dict[str, Any]:
    return ops.job_view(league_of(request), job_id)


@router.get("/jobs/{job_id}", response_class=HTMLResponse)
def job_page(request: Request, job_id: RowId, viewer: Viewer) -> HTMLResponse:
    return _page(request, "job.html", ops.job_view(league_of(request), job_id), viewer, f"/jobs/{job_id}.json")


# --- social trees -------------------------------------------------------------------------------

def _trees(request: Request, game: str | None, owner: str | None, limit: int) -> dict[str, Any]:
    league = league_of(request)
    return {"trees": ops.list_tree_views(league, game_id=game or None, owner=owner or None, limit=limit),
            "games": ops.game_ids(), "filters": {"game": game, "owner": owner}}


@router.get("/trees.json")
def trees_json(request: Request, game: str | None = None, owner: str | None = None, limit: int = 100
               ) -> dict[str, Any]:
    return _trees(request, game, owner, limit)


@router.get("/trees", response_class=HTMLResponse)
def trees_page(request: Request, viewer: Viewer, game: str | None = None, owner: str | None = None,
               limit: int = 100) -> HTMLResponse:
    return _page(request, "trees.html", _trees(request, game, owner, limit), viewer,
                 _seen(request, {"game": game, "owner": owner, "limit": limit if limit != 100 else None}))


@router.get("/trees/new", response_class=HTMLResponse)
def tree_new(request: Request, viewer: Viewer, game: str = "Crossroads-2T2P-v1") -> HTMLResponse:
    ops.check_game(game)  # an unknown game is a 400 naming the valid ones
    return _page(request, "tree.html", {"game_id": game, "tree": None}, viewer,
                 f"/api/games/{game}/tree-catalog")


@router.get("/trees/{tree_id}.json")
def tree_json(request: Request, tree_id: RowId) -> dict[str, Any]:
    return ops.tree_view(league_of(request), tree_id)


@router.get("/trees/{tree_id}", response_class=HTMLResponse)
def tree_page(request: Request, tree_id: RowId, viewer: Viewer) -> HTMLResponse:
    view = ops.tree_view(league_of(request), tree_id)
    return _page(request, "tree.html", {"game_id": view["game_id"], "tree": view}, viewer, f"/trees/{tree_id}.json")


# --- submitting, signing in ---------------------------------------------------------------------

def _submit_page(request: Request, viewer: Identity | None, **extra: Any) -> HTMLResponse:
    games = ops.game_ids()
    return _page(request, "submit.html", None, viewer, "/api/games", games=games, **extra)


@router.get("/submit", response_class=HTMLResponse)
def submit_form(request: Request, viewer: Viewer) -> HTMLResponse:
    return _submit_page(request, viewer)


@router.post("/submit", response_model=None)
def submit(request: Request, viewer: Viewer, game: Annotated[str, Form()], name: Annotated[str, Form()],
           file: Annotated[list[UploadFile], File()]) -> RedirectResponse | HTMLResponse:
    who = _signed_in(viewer, "/submit")
    if isinstance(who, RedirectResponse):
        return who
    try:
        queued = ops.upload_agent(league_of(request), who, game, name, [(f.filename or "", f.file) for f in file])
    except ops.USER_ERRORS as error:
        response = _submit_page(request, viewer, error=str(error), game=game, name=name)
        response.status_code = status_of(error)
        return response
    return RedirectResponse(f"/jobs/{queued['job']}", status_code=303)


def _signin_page(request: Request, viewer: Identity | None, next: str, **extra: Any) -> HTMLResponse:
    # the form and a cookie carry the same pre-session token: a page of another site cannot read it
    known = request.cookies.get(SIGNIN_COOKIE)
    token = known or new_signin_token()
    response = _page(request, "signin.html", None, viewer, "/api/games", next=_local(next), signin_token=token,
                     **extra)
    if known is None:
        response.set_cookie(SIGNIN_COOKIE, token, path="/signin", httponly=True, samesite="strict",
                            secure=request.url.scheme == "https")
    return response


@router.get("/signin", response_class=HTMLResponse)
def signin_form(request: Request, viewer: Viewer, next: str = "/") -> HTMLResponse:
    return _signin_page(request, viewer, next)


@router.post("/signin", response_model=None)
def signin(request: Request, token: Annotated[str, Form()], next: Annotated[str, Form()] = "/"
           ) -> RedirectResponse | HTMLResponse:
    identity = ops.authenticate(league_of(request), token.strip())
    if identity is None:
        response = _signin_page(request, None, next, error="this token is not valid (unknown or revoked)")
        response.status_code = 401
        return response
    response = RedirectResponse(_local(next), status_code=303)
    response.set_cookie(COOKIE, token.strip(), httponly=True, samesite="strict", secure=request.url.scheme == "https",
                        max_age=30 * 24 * 3600)
    return response


@router.post("/signout")
def signout() -> RedirectResponse:
    response = RedirectResponse("/", status_code=303)
    response.delete_cookie(COOKIE)
    return response
