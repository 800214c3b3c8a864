"""Who is asking: bearer tokens of the web service, and what a token's owner may do.

``arena-league token create OWNER [--admin]`` draws a random token, shows it once and keeps only
its SHA-256 hash (a token has 256 random bits, so a hash without salt cannot be reversed by
guessing). A request presents it as ``Authorization: Bearer <token>`` (or, on the web pages, in
the cookie set by signing in); :func:`authenticate` turns it into an :class:`Identity`.
Submitters own the agents they upload; administrators may also manage populations, schedules and
suspended agents, and read every agent's log. An owner's name follows the league's name policy
(:func:`~arena_league.league.names.check_owner_name`): never ``guest-...`` nor with ``@`` (the
names of the agents people play as), nor a look-alike of another owner.
"""

from __future__ import annotations

import hashlib
import secrets
from dataclasses import dataclass
from datetime import timedelta
from typing import Any

from arena_league import registry as reg
from arena_league.league.names import check_owner_name
from arena_league.registry import League
from arena_league.registry.models import utcnow

__all__ = ["TOKEN_PREFIX", "Identity", "authenticate", "create_token", "list_tokens", "revoke_token"]

#: Every token starts so, which makes a leaked one easy to recognise (in logs, in a repository).
TOKEN_PREFIX = "al_"
#: How stale a token's "last used" may get before a request notes it again.
_TOUCH_EVERY = timedelta(minutes=5)


@dataclass(frozen=True)
class Identity:
    """The owner a request acts for."""

    owner: str
    admin: bool = False
    token_id: int = 0

    def may_manage(self, owner: str | None) -> bool:
        """Whether this identity may act on what ``owner`` owns (its own, or anything as admin)."""
        return self.admin or (owner is not None and owner == self.owner)


def _hash(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()


def create_token(league: League, owner: str, *, admin: bool = False) -> dict[str, Any]:
    """A new token for ``owner``; the returned ``token`` is the only time it is shown. Raises
    ``ValueError`` for a malformed owner name, :class:`~arena_league.league.errors.ForbiddenError` for one the league keeps
    for people who play or one that looks like another owner's."""
    check_owner_name(owner)
    token = TOKEN_PREFIX + secrets.token_urlsafe(32)
    with league.transaction() as session:
        check_owner_name(owner, {row.owner for row in reg.list_tokens(session)})
        row = reg.create_token(session, owner, _hash(token), token[: len(TOKEN_PREFIX) + 6], admin=admin)
        return {"id": row.id, "owner": owner, "admin": admin, "prefix": row.prefix, "token": token}


def list_tokens(league: League) -> list[dict[str, Any]]:
    """Every token's id, owner, role, prefix and dates (never the token)."""
    with league.reading() as session:
        return [{"id": t.id, "owner": t.owner, "admin": t.admin, "prefix": t.prefix,
                 "created_at": t.created_at.isoformat(timespec="seconds"),
                 "last_used_at": t.last_used_at.isoformat(timespec="seconds") if t.last_used_at else None,
                 "revoked_at": t.revoked_at.isoformat(timespec="seconds") if t.revoked_at else None}
                for t in reg.list_tokens(session)]


def revoke_token(league: League, which: str) -> dict[str, Any]:
    """Revoke the token with id ``which`` (digits), or every live token of the owner ``which``."""
    with league.transaction() as session:
        if which.isdigit():
            count = reg.revoke_tokens(session, token_id=int(which))
        else:
            count = reg.revoke_tokens(session, owner=which)
    if count == 0:
        raise ValueError(f"no live token {'with id ' + which if which.isdigit() else 'of ' + which}; see "
                         "`arena-league token list`")
    return {"revoked": count, "which": which}


def authenticate(league: League, token: str | None) -> Identity | None:
    """The identity of a presented token, or None for no token, an unknown or a revoked one. The
    token's last use is noted at most every few minutes (a read needs no write lock)."""
    if not token or not token.startswith(TOKEN_PREFIX) or len(token) > 200:
        return None
    digest = _hash(token)
    with league.reading() as session:
        row = reg.find_token(session, digest, touch=False)
        if row is None:
            return None
        identity = Identity(row.owner, bool(row.admin), row.id)
        stale = row.last_used_at is None or utcnow() - row.last_used_at > _TOUCH_EVERY
    if stale:
        with league.transaction() as session:
            reg.find_token(session, digest)
    return identity
