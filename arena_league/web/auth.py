"""Who a request comes from: a bearer token in the ``Authorization`` header (the API) or in the
cookie that signing in on the pages sets (HttpOnly, SameSite=Strict, so another site's form cannot
use it). A write was authenticated already by the front door (:mod:`.guard`), before its body was
read; its identity is taken from there."""

from __future__ import annotations

from fastapi import HTTPException, Request
from starlette.requests import cookie_parser

from arena_league.league import Identity, authenticate

__all__ = ["COOKIE", "IDENTITY_KEY", "missing_token_message", "optional_identity", "required_identity",
           "token_in_headers", "token_of"]

#: The cookie that keeps a signed-in browser's token.
COOKIE = "arena_league_token"
#: Where the front door leaves the identity it found, in the request's state.
IDENTITY_KEY = "arena_league.identity"


def _bearer(header: str) -> str | None:
    scheme, _, value = header.partition(" ")
    return value.strip() if scheme.lower() == "bearer" and value.strip() else None


def token_of(request: Request) -> str | None:
    """The token a request presents: ``Authorization: Bearer <token>``, else the sign-in cookie."""
    return _bearer(request.headers.get("authorization", "")) or request.cookies.get(COOKIE)


def token_in_headers(headers: list[tuple[bytes, bytes]]) -> str | None:
    """:func:`token_of` from an ASGI scope's raw headers (before any request object exists)."""
    cookie: str | None = None
    for name, value in headers:
        if name == b"authorization":
            bearer = _bearer(value.decode("latin-1"))
            if bearer is not None:
                return bearer
        elif name == b"cookie" and cookie is None:  # parsed as the request's own cookies are
            cookie = cookie_parser(value.decode("latin-1")).get(COOKIE)
    return cookie


def missing_token_message(presented: bool) -> str:
    """The one line a write without a valid token is refused with."""
    if presented:
        return "this token is not valid (unknown or revoked); ask the league's operator for one"
    return "writing needs a token: send `Authorization: Bearer <token>` (`arena-league token create OWNER` makes one)"


def optional_identity(request: Request) -> Identity | None:
    """The requester's identity, or None (anonymous reads)."""
    known = request.scope.get("state", {}).get(IDENTITY_KEY)
    if known is not None:
        return known
    return authenticate(request.app.state.league, token_of(request))


def required_identity(request: Request) -> Identity:
    """The requester's identity; 401 without a valid token."""
    identity = optional_identity(request)
    if identity is None:
        raise HTTPException(401, missing_token_message(token_of(request) is not None),
                            headers={"WWW-Authenticate": "Bearer"})
    return identity
