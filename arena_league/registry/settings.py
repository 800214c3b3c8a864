"""League settings kept in the registry: the values an operator changed from their defaults.

The registry stores a key and its JSON value and nothing else; which keys exist, their types,
defaults and meaning belong to the league layer, which checks a value before it is written.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import delete, select
from sqlalchemy.orm import Session

from arena_league.registry.models import Setting, utcnow

__all__ = ["delete_setting", "read_settings", "write_setting"]


def read_settings(session: Session) -> dict[str, Any]:
    """Every stored setting, key -> value."""
    return {row.key: row.value for row in session.scalars(select(Setting))}


def write_setting(session: Session, key: str, value: Any) -> None:
    """Store ``value`` (JSON) under ``key``, replacing what was there."""
    row = session.get(Setting, key)
    if row is None:
        session.add(Setting(key=key, value=value, updated_at=utcnow()))
    else:
        row.value = value
        row.updated_at = utcnow()
    session.flush()


def delete_setting(session: Session, key: str) -> bool:
    """Forget ``key`` (its default applies again); whether it was stored."""
    return bool(session.execute(delete(Setting).where(Setting.key == key)).rowcount)
