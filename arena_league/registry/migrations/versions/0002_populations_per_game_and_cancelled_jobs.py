"""Population versions count per game; jobs may be cancelled.

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-24 06:40:00

A population was unique by (name, version) across games, so every game's import of ``base-v1``
took the next version of one shared count. Now (game_id, name, version) is unique and versions
count per game and name; existing rows keep their versions (they were unique already). Jobs gain
the status ``cancelled``.
"""

from __future__ import annotations

from collections.abc import Sequence

from alembic import op

revision: str = "0002"
down_revision: str | Sequence[str] | None = "0001"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

_JOB_STATUSES = ("queued", "running", "done", "failed")


def _statuses(values: Sequence[str]) -> str:
    return f"status IN ({', '.join(repr(v) for v in values)})"


def upgrade() -> None:
    with op.batch_alter_table("populations") as batch:
        batch.drop_constraint(op.f("uq_populations_name_version"), type_="unique")
        batch.create_unique_constraint(op.f("uq_populations_game_id_name_version"), ["game_id", "name", "version"])
    with op.batch_alter_table("jobs") as batch:
        batch.drop_constraint(op.f("ck_jobs_status"), type_="check")
        batch.create_check_constraint(op.f("ck_jobs_status"), _statuses((*_JOB_STATUSES, "cancelled")))


def downgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.drop_constraint(op.f("ck_jobs_status"), type_="check")
        batch.create_check_constraint(op.f("ck_jobs_status"), _statuses(_JOB_STATUSES))
    with op.batch_alter_table("populations") as batch:
        batch.drop_constraint(op.f("uq_populations_game_id_name_version"), type_="unique")
        batch.create_unique_constraint(op.f("uq_populations_name_version"), ["name", "version"])
