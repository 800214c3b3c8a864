"""Alembic environment of the league registry, run programmatically by `open_league`.

`open_league` hands Alembic an open connection (already inside its write transaction) through
`config.attributes["connection"]`; a developer may instead give `sqlalchemy.url` (see
`arena_league.registry.db.alembic_config`), or run offline to print the SQL for a DBA.
SQLite cannot ALTER most things in place, so migrations render as batch operations.
"""

from __future__ import annotations

from alembic import context
from sqlalchemy import create_engine

from arena_league.registry.models import Base

config = context.config
target_metadata = Base.metadata


def run_migrations_offline() -> None:
    """Emit the migration SQL for `sqlalchemy.url` without connecting."""
    context.configure(
        url=config.get_main_option("sqlalchemy.url"),
        target_metadata=target_metadata,
        literal_binds=True,
        render_as_batch=True,
    )
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    """Migrate through the connection `open_league` passed, or one made from `sqlalchemy.url`."""
    connection = config.attributes.get("connection")
    if connection is not None:
        context.configure(connection=connection, target_metadata=target_metadata, render_as_batch=True)
        with context.begin_transaction():
            context.run_migrations()
        return
    engine = create_engine(config.get_main_option("sqlalchemy.url") or "")
    with engine.connect() as own_connection:
        context.configure(connection=own_connection, target_metadata=target_metadata, render_as_batch=True)
        with context.begin_transaction():
            context.run_migrations()
    engine.dispose()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
