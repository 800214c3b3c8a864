"""One agent per (game, artifact).

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-24 07:30:00

The same bytes submitted under two names at the same instant could register two agents, since
the check for an agent holding the bytes and the insert were separate statements. A unique index
on agents (game_id, artifact_sha256) now makes the second insert fail. Agents without an artifact
(scripted, human) keep NULL there, and NULLs are distinct in a unique index on SQLite and
PostgreSQL alike.

A league that already holds such duplicates keeps, for each (game, artifact), its oldest agent
(lowest id) as it is. Every younger one is retired and unlinked from the artifact (its
``artifact_sha256`` set to NULL) so the index can hold; its metadata keeps the digest under
``artifact_sha256`` and the agent it duplicates under ``duplicate_of``. Its matches, ratings and
population memberships stay. Downgrading drops the index and leaves those agents as they are.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import context, op

revision: str = "0003"
down_revision: str | Sequence[str] | None = "0002"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

_AGENTS = sa.table(
    "agents",
    sa.column("id", sa.Integer),
    sa.column("name", sa.String),
    sa.column("game_id", sa.String),
    sa.column("artifact_sha256", sa.String),
    sa.column("status", sa.String),
    sa.column("metadata", sa.JSON),
)

# Every agent that shares its game and artifact with an older agent (portable SQL, so that
# offline mode prints it too).
_RETIRE_YOUNGER_DUPLICATES = """
UPDATE agents SET status = 'retired', artifact_sha256 = NULL
WHERE artifact_sha256 IS NOT NULL AND EXISTS (
    SELECT 1 FROM agents AS older
    WHERE older.game_id = agents.game_id
      AND older.artifact_sha256 = agents.artifact_sha256
      AND older.id < agents.id
)
"""


def _note_duplicates() -> None:
    """Write into each younger duplicate's metadata which agent it duplicates, and its digest."""
    agents = _AGENTS.c
    bind = op.get_bind()
    shared = (
        sa.select(agents.game_id, agents.artifact_sha256)
        .where(agents.artifact_sha256.is_not(None))
        .group_by(agents.game_id, agents.artifact_sha256)
        .having(sa.func.count(agents.id) > 1)
    )
    for game_id, digest in bind.execute(shared).all():
        rows = bind.execute(
            sa.select(agents.id, agents.name, agents["metadata"])
            .where(agents.game_id == game_id, agents.artifact_sha256 == digest)
            .order_by(agents.id)
        ).all()
        keeper = rows[0].name
        for row in rows[1:]:
            meta = {**(row.metadata or {}), "duplicate_of": keeper, "artifact_sha256": digest}
            bind.execute(sa.update(_AGENTS).where(agents.id == row.id).values({"metadata": meta}))


def upgrade() -> None:
    if not context.is_offline_mode():
        _note_duplicates()
    op.execute(_RETIRE_YOUNGER_DUPLICATES)
    with op.batch_alter_table("agents") as batch:
        batch.create_index(op.f("ix_agents_game_id_artifact_sha256"), ["game_id", "artifact_sha256"], unique=True)


def downgrade() -> None:
    with op.batch_alter_table("agents") as batch:
        batch.drop_index(op.f("ix_agents_game_id_artifact_sha256"))
