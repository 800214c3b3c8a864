"""Who a request comes from: a bearer token in the ``Authorization`` header (the API) or in the
cookie that signing in on the pages sets (HttpOnly, SameSite=Strict, so another site's form cannot
use it)."""

from __future__ import annotations

from fastapi import HTTPException, Request

from arena_league.league import Identity, authenticate

__all__ = ["COOKIE", "optional_identity", "required_identity", "token_of"]

#: The cookie that keeps a signed-in browser's token.
COOKIE = "arena_league_token"


def token_of(request: Request) -> str | None:
    """The token a request presents: ``Authorization: Bearer <token>``, else the sign-in cookie."""
    header = request.headers.get("authorization", "")
    scheme, _, value = header.partition(" ")
    if scheme.lower() == "bearer" and value.strip():
        return value.strip()
    return request.cookies.get(COOKIE)


def optional_identity(request: Request) -> Identity | None:
    """The requester's identity, or None (anonymous reads)."""
    return authenticate(request.app.state.league, token_of(request))


def required_identity(request: Request) -> Identity:
    """The requester's identity; 401 without a valid token."""
    identity = optional_identity(request)
    if identity is None:
        presented = token_of(request) is not None
        raise HTTPException(401, "this token is not valid (unknown or revoked); ask the league's operator for one"
                            if presented else "writing needs a token: send `Authorization: Bearer <token>` "
                            "(`arena-league token create OWNER` makes one)",
                            headers={"WWW-Authenticate": "Bearer"})
    return identity
