"""The two halves of a paired match.

Revision ID: 0008
Revises: 0007
Create Date: 2026-11-29 02:00:00

A game whose teams play different roles is played in pairs: two matches from one seed with the
roles swapped, stored as one match whose seats and outcomes are the pair's. ``matches.halves``
keeps the two matches inside it (each one's seats, scores, pair points, steps and replay file);
it is null for an unpaired match.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0008"
down_revision: str | Sequence[str] | None = "0007"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("matches") as batch:
        batch.add_column(sa.Column("halves", sa.JSON(none_as_null=True), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("matches") as batch:
        batch.drop_column("halves")
