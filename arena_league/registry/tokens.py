"""Bearer tokens of the web service: the registry keeps a token's SHA-256 hash, never the token.

A token is made once (:func:`create_token` gets the hash of a fresh random token the league layer
drew and shows once); a request's token is found by its hash (:func:`find_token`), which also
notes when it was last used; a revoked token is found no more.
"""

from __future__ import annotations

from sqlalchemy import select, update
from sqlalchemy.orm import Session

from arena_league.registry.errors import InvalidRecordError
from arena_league.registry.models import Token, utcnow

__all__ = ["create_token", "find_token", "list_tokens", "revoke_tokens"]


def create_token(session: Session, owner: str, token_hash: str, prefix: str, *, admin: bool = False) -> Token:
    """Keep a new token's hash (64 hex digits) for ``owner``."""
    if len(token_hash) != 64 or any(c not in "0123456789abcdef" for c in token_hash):
        raise InvalidRecordError("a token is kept as its SHA-256 hash: 64 lowercase hex digits")
    token = Token(owner=owner, token_hash=token_hash, prefix=prefix, admin=admin, created_at=utcnow())
    session.add(token)
    session.flush()
    return token


def find_token(session: Session, token_hash: str, *, touch: bool = True) -> Token | None:
    """The live (not revoked) token with this hash, or None; ``touch`` notes its use now."""
    token = session.scalars(select(Token).where(Token.token_hash == token_hash, Token.revoked_at.is_(None))
                            ).one_or_none()
    if token is not None and touch:
        token.last_used_at = utcnow()
        session.flush()
    return token


def list_tokens(session: Session, *, owner: str | None = None) -> list[Token]:
    """Every token (revoked ones too), oldest first, optionally one owner's."""
    query = select(Token).order_by(Token.id)
    if owner is not None:
        query = query.where(Token.owner == owner)
    return list(session.scalars(query))


def revoke_tokens(session: Session, *, token_id: int | None = None, owner: str | None = None) -> int:
    """Revoke one token (by id) or every live token of ``owner``; returns how many were revoked."""
    if (token_id is None) == (owner is None):
        raise InvalidRecordError("revoke one token by its id, or every token of one owner")
    query = update(Token).where(Token.revoked_at.is_(None))
    query = query.where(Token.id == token_id) if token_id is not None else query.where(Token.owner == owner)
    return int(session.execute(query.values(revoked_at=utcnow())).rowcount)
