"""Cross-site request forgery: what a write the sign-in cookie authenticates must show, and the
security headers of every response.

A browser sends the sign-in cookie with every request to this site, also the ones a page of another
origin makes: a form posted from another port of the same host is "same-site", which the cookie's
SameSite=Strict does not stop. So a write (POST, PUT, PATCH, DELETE) that uses the cookie must

* come from this league's own pages: its ``Origin``, where the browser sends one, is this server's
  own, and its ``Sec-Fetch-Site`` is ``same-origin`` or ``none``;
* carry the session's CSRF token (:func:`session_token`, an HMAC of the sign-in token, so only a
  page the server rendered for that session knows it): the ``X-CSRF-Token`` header (the pages'
  scripts read it from the ``csrf-token`` meta tag), or a form's first field ``csrf_token`` (read
  before the rest of the body, so an upload is refused before it streams in).

Signing in has no session yet: ``GET /signin`` sets a random pre-session cookie and puts the same
value in its form, and ``POST /signin`` must carry both (besides the Origin check), so another
site's form cannot sign a browser in as someone else. A request with ``Authorization: Bearer``
does not use the cookie: a page of another origin cannot send that header without a CORS preflight
this server never answers, so it needs none of this (the CLI, scripts). The play socket
(:mod:`.play`) checks the same with :func:`socket_problem`, its token in the ``csrf`` query
parameter.

:class:`Guard`, an ASGI middleware, refuses such a write with 403 before any route reads it;
:class:`SecurityHeaders` adds :data:`SECURITY_HEADERS` to every HTTP response.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets
from typing import Any
from urllib.parse import unquote_plus

from python_multipart.exceptions import MultipartParseError
from python_multipart.multipart import MultipartParser, parse_options_header
from starlette.datastructures import MutableHeaders
from starlette.requests import HTTPConnection, Request
from starlette.responses import JSONResponse

from arena_league.web.auth import COOKIE

__all__ = ["FIELD", "SECURITY_HEADERS", "SIGNIN_COOKIE", "Guard", "SecurityHeaders", "add_security_headers", "new_signin_token", "page_token",
           "session_token", "socket_problem"]

#: The form field (first in the form) and the header that carry the CSRF token.
FIELD = "csrf_token"
HEADER = "x-csrf-token"
#: The pre-session cookie of the sign-in form (double submit: the form carries the same value).
SIGNIN_COOKIE = "arena_league_signin"
_KEY = b"arena-league csrf token"
_WRITES = frozenset({"POST", "PUT", "PATCH", "DELETE"})
#: The most of a form's body read to find its first field.
_FIRST_FIELD_BYTES = 8192
_CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; style-src-attr 'unsafe-inline'; "
        "img-src 'self' data:; connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; "
        "frame-ancestors 'none'")
# FastAPI's API explorer (/docs, /redoc) is an inline script loading its bundle from a CDN; it shows
# only this server's own OpenAPI document
_DOCS_CSP = ("default-src 'self'; script-src 'self' 'unsafe-inline' https://cdn.jsdelivr.net; "
             "style-src 'self' 'unsafe-inline' https://cdn.jsdelivr.net; img-src 'self' data: https:; "
             "worker-src 'self' blob:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'")
# the guide is the docs site built by mkdocs-material, served from this server: its pages carry
# small inline scripts and styles of their own (theme and search set-up), and load nothing else
_GUIDE_CSP = ("default-src 'self'; script-src 'self' 'unsafe-inline'; style-src 'self' 'unsafe-inline'; "
              "img-src 'self' data:; font-src 'self' data:; connect-src 'self'; worker-src 'self' blob:; "
              "object-src 'none'; base-uri 'self'; form-action 'self'; frame-ancestors 'none'")
#: Sent with every HTTP response (the CSP's ``style-src-attr`` lets the heatmap's and the team
#: swatches' computed colours stay attributes; no script runs but the site's own files).
SECURITY_HEADERS: dict[str, str] = {"Content-Security-Policy": _CSP, "X-Content-Type-Options": "nosniff",
                                    "X-Frame-Options": "DENY", "Referrer-Policy": "same-origin"}


def session_token(token: str) -> str:
    """The CSRF token of the session signed in with ``token`` (a token has 256 random bits, so its
    keyed digest can be neither guessed nor turned back into it, and every server of a league
    derives the same one)."""
    return hmac.new(_KEY, token.encode(), hashlib.sha256).hexdigest()


def page_token(request: Request) -> str:
    """The CSRF token a page rendered for ``request`` carries ("" without a sign-in cookie)."""
    cookie = request.cookies.get(COOKIE)
    return session_token(cookie) if cookie else ""


def new_signin_token() -> str:
    """A fresh pre-session token for the sign-in form."""
    return secrets.token_urlsafe(32)


def _same(presented: str | None, expected: str | None) -> bool:
    return bool(presented and expected) and hmac.compare_digest(presented.encode(), expected.encode())  # type: ignore[union-attr]


def _bearer(connection: HTTPConnection) -> bool:
    scheme, _, value = connection.headers.get("authorization", "").partition(" ")
    return scheme.lower() == "bearer" and bool(value.strip())


def _origin_problem(connection: HTTPConnection) -> str | None:
    """Why ``connection`` does not come from this league's own pages, or None."""
    site = connection.headers.get("sec-fetch-site")
    if site in ("cross-site", "same-site"):
        where = "another site" if site == "cross-site" else "another origin of this site (a port, a subdomain)"
        return (f"this request comes from a page of {where} (Sec-Fetch-Site: {site}), not from this league's own "
                "pages; use the league's pages, or send `Authorization: Bearer <token>`")
    origin = connection.headers.get("origin")
    if origin is None:
        return None
    scheme = {"ws": "http", "wss": "https"}.get(connection.url.scheme, connection.url.scheme)
    own = f"{scheme}://{connection.headers.get('host', '')}"
    if origin.lower() != own.lower():
        return (f"this request comes from a page of {origin[:80]}, not of this league ({own[:80]}); use the "
                "league's own pages, or send `Authorization: Bearer <token>`")
    return None


def socket_problem(connection: HTTPConnection) -> str | None:
    """Why a WebSocket handshake may not go on (its origin, or a cookie without the session's token
    in the ``csrf`` query parameter), or None."""
    problem = _origin_problem(connection)
    if problem is not None or _bearer(connection):
        return problem
    cookie = connection.cookies.get(COOKIE)
    if cookie is not None and not _same(connection.query_params.get("csrf"), session_token(cookie)):
        return ("this socket carries no valid CSRF token for the signed-in browser; reload the play page (it "
                "adds one), or sign out to play as a guest")
    return None


async def _first_field(scope: dict, headers: Any, receive: Any) -> tuple[str | None, list[dict]]:
    """The form's first field if it is ``csrf_token``, and the body messages read to find it."""
    kind, options = parse_options_header(headers.get("content-type"))
    messages: list[dict] = []
    if kind not in (b"application/x-www-form-urlencoded", b"multipart/form-data"):
        return None, messages
    seen = bytearray()
    first: dict[str, Any] = {"headers": [], "field": b"", "value": bytearray(), "done": False, "parts": 0}

    def header_field(data: bytes, start: int, end: int) -> None:
        if first["parts"] == 1:
            first["field"] += data[start:end]

    def header_value(data: bytes, start: int, end: int) -> None:
        if first["parts"] == 1 and first["field"].lower() == b"content-disposition":
            first["headers"].append(data[start:end])

    def header_end() -> None:
        first["field"] = b""

    def part_begin() -> None:
        first["parts"] += 1

    def part_data(data: bytes, start: int, end: int) -> None:
        if first["parts"] == 1:
            first["value"] += data[start:end]

    def part_end() -> None:
        first["done"] = True

    parser = None
    if kind == b"multipart/form-data" and options.get(b"boundary"):
        parser = MultipartParser(options[b"boundary"], {
            "on_part_begin": part_begin, "on_header_field": header_field, "on_header_value": header_value,
            "on_header_end": header_end, "on_part_data": part_data, "on_part_end": part_end})
    more = True
    while more and len(seen) <= _FIRST_FIELD_BYTES:
        message = await receive()
        messages.append(message)
        if message["type"] != "http.request":
            break
        chunk = message.get("body", b"")
        more = message.get("more_body", False)
        seen += chunk
        if parser is not None:
            try:
                parser.write(chunk)
            except MultipartParseError:  # a malformed body has no token; the route says what else is wrong
                break
            if first["done"]:
                break
        elif b"&" in seen:
            break
    if parser is not None:
        if not first["done"] or not first["headers"]:
            return None, messages
        _, disposition = parse_options_header(b"".join(first["headers"]))
        if disposition.get(b"name") != FIELD.encode():
            return None, messages
        return bytes(first["value"]).decode("ascii", "replace"), messages
    pair = bytes(seen).split(b"&", 1)[0] if (b"&" in seen or not more) else b""
    name, _, value = pair.partition(b"=")
    return (unquote_plus(value.decode("ascii", "replace")) if name == FIELD.encode() else None), messages


async def _write_problem(scope: dict, receive: Any) -> tuple[str | None, list[dict]]:
    """Why a write may not go on, or None; and the body messages read to decide."""
    connection = HTTPConnection(scope)
    if _bearer(connection):
        return None, []
    if scope["path"] == "/signin":
        expected, what = connection.cookies.get(SIGNIN_COOKIE), "sign-in form"
    elif COOKIE in connection.cookies:
        expected, what = session_token(connection.cookies[COOKIE]), "signed-in browser"
    else:
        return None, []  # no credentials: the route answers 401, or sends the browser to sign in
    problem = _origin_problem(connection)
    if problem is not None:
        return problem, []
    presented = connection.headers.get(HEADER)
    messages: list[dict] = []
    if presented is None:
        presented, messages = await _first_field(scope, connection.headers, receive)
    if not _same(presented, expected):
        return (f"this request carries no valid CSRF token for this {what} (the page is older than the sign-in, "
                "or another site made it); reload the page and try again, or send `Authorization: Bearer "
                "<token>`"), messages
    return None, messages


class Guard:
    """ASGI middleware: refuse a cookie-authenticated write that lacks its origin or CSRF token
    (403, one line)."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] == "http" and scope["method"] in _WRITES:
            problem, messages = await _write_problem(scope, receive)
            if problem is not None:
                await _refuse(scope, problem)(scope, _gone, send)
                return
            if messages:
                receive = _replaying(messages, receive)
        await self.app(scope, receive, send)


class SecurityHeaders:
    """ASGI middleware: add :data:`SECURITY_HEADERS` to every HTTP response (outermost, so that the
    refusals of the middleware inside it carry them too)."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        docs = scope["path"].startswith(("/docs", "/redoc"))
        guide = scope["path"] == "/guide" or scope["path"].startswith("/guide/")

        async def with_headers(message: dict) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                if guide:
                    headers.setdefault("Content-Security-Policy", _GUIDE_CSP)
                add_security_headers(headers, docs=docs)
            await send(message)

        await self.app(scope, receive, with_headers)


def add_security_headers(headers: MutableHeaders, *, docs: bool = False) -> None:
    """Set each of :data:`SECURITY_HEADERS` a response does not set itself (the API's interactive
    docs get the looser policy FastAPI's page needs)."""
    for name, value in SECURITY_HEADERS.items():
        headers.setdefault(name, _DOCS_CSP if docs and name == "Content-Security-Policy" else value)


def _replaying(messages: list[dict], receive: Any) -> Any:
    async def replayed() -> dict:
        return messages.pop(0) if messages else await receive()
    return replayed


async def _gone() -> dict:
    return {"type": "http.disconnect"}


def _refuse(scope: dict, problem: str) -> Any:
    """The 403 answer: the error page to a browser asking for one, else ``{"detail": ...}``."""
    request = Request(scope)
    path = scope["path"]
    if not path.startswith("/api/") and not path.endswith(".json") and "text/html" in request.headers.get("accept", ""):
        from arena_league.web.pages import templates  # the pages register this module's helpers: import late

        return templates.TemplateResponse(request, "error.html", {"status": 403, "message": problem, "viewer": None,
                                                                  "json_url": "/api/games"}, status_code=403)
    return JSONResponse({"detail": problem}, status_code=403)
