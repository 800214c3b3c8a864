"""What the routers share: who asks (:data:`Viewer`, :data:`Writer`), the league a request is
served from, and the parameters several routes take (a row id, a rating method)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import Depends, Path, Query, Request

from arena_league import league as ops
from arena_league.league import Identity
from arena_league.league.errors import DatabaseFullError, DiskFullError
from arena_league.web.auth import optional_identity, required_identity

__all__ = ["STATUS_OF", "Method", "RowId", "Viewer", "Writer", "league_of", "status_of"]

#: The HTTP status of the league's errors that say more than "bad input" (400).
STATUS_OF: dict[type[Exception], int] = {ops.NotFoundError: 404, ops.ForbiddenError: 403, ops.RateLimitedError: 429,
                                         DiskFullError: 507, DatabaseFullError: 507}

#: The requester's identity, or None (reads are open).
Viewer = Annotated[Identity | None, Depends(optional_identity)]
#: The requester's identity; 401 without a valid token.
Writer = Annotated[Identity, Depends(required_identity)]
#: A row id: the database's 64-bit integers.
RowId = Annotated[int, Path(ge=1, le=2**63 - 1, description="a row id")]
#: A rating method, one of the league's.
Method = Annotated[str, Query(pattern=f"^({'|'.join(ops.METHODS)})$")]


def league_of(request: Request) -> Any:
    """The league the application serves."""
    return request.app.state.league


def status_of(error: Exception) -> int:
    """The HTTP status a user error answers with (see :data:`STATUS_OF`; anything else is 400)."""
    return next((status for kind, status in STATUS_OF.items() if isinstance(error, kind)), 400)
