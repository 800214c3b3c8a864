"""Forfeits, suspended agents and league settings.

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-26 01:00:00

Submitted agents now play inside a bounded inference sandbox; an agent whose call fails there
(over its time or memory budget, a crash, an error) forfeits the matches it has in flight. A
seat records why its agent forfeited (``match_seats.forfeit``, NULL for a seat played out), an
agent that forfeits too often is ``suspended`` (a new agent status), and the budgets are league
settings kept in the registry (the ``settings`` table: a key and its JSON value). Existing rows
are unchanged: no seat forfeited, no agent is suspended, no setting departs from its default.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0004"
down_revision: str | Sequence[str] | None = "0003"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

_AGENT_STATUSES = ("pending", "active", "rejected", "retired")


def _statuses(values: Sequence[str]) -> str:
    return f"status IN ({', '.join(repr(v) for v in values)})"


def upgrade() -> None:
    with op.batch_alter_table("agents") as batch:
        batch.drop_constraint(op.f("ck_agents_status"), type_="check")
        batch.create_check_constraint(op.f("ck_agents_status"), _statuses((*_AGENT_STATUSES, "suspended")))
    with op.batch_alter_table("match_seats") as batch:
        batch.add_column(sa.Column("forfeit", sa.Text(), nullable=True))
    op.create_table(
        "settings",
        sa.Column("key", sa.String(length=64), nullable=False),
        sa.Column("value", sa.JSON(), nullable=False),
        sa.Column("updated_at", sa.DateTime(), nullable=False),
        sa.PrimaryKeyConstraint("key", name=op.f("pk_settings")),
    )


def downgrade() -> None:
    op.drop_table("settings")
    with op.batch_alter_table("match_seats") as batch:
        batch.drop_column("forfeit")
    op.execute("UPDATE agents SET status = 'retired' WHERE status = 'suspended'")
    with op.batch_alter_table("agents") as batch:
        batch.drop_constraint(op.f("ck_agents_status"), type_="check")
        batch.create_check_constraint(op.f("ck_agents_status"), _statuses(_AGENT_STATUSES))
