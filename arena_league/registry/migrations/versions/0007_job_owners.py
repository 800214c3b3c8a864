"""Who queued each job, for per-owner quotas and a fair claim.

Revision ID: 0007
Revises: 0006
Create Date: 2026-11-28 17:00:00

A job queued by a request records its owner (``jobs.owner``), so that the league can bound the
jobs one owner holds and workers can take jobs fairly across owners. Jobs queued before, and the
league's own (schedules, the command line), have none. Two indexes serve those lookups: an owner's
jobs by status, and by when they started.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0007"
down_revision: str | Sequence[str] | None = "0006"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("owner", sa.String(length=128), nullable=True))
    op.create_index(op.f("ix_jobs_owner_status"), "jobs", ["owner", "status"])
    op.create_index(op.f("ix_jobs_owner_started_at"), "jobs", ["owner", "started_at"])


def downgrade() -> None:
    op.drop_index(op.f("ix_jobs_owner_started_at"), table_name="jobs")
    op.drop_index(op.f("ix_jobs_owner_status"), table_name="jobs")
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("owner")
