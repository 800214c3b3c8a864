"""Social trees as a resource of the league.

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-26 03:00:00

A researcher builds a social tree in the web service's editor and saves it: the ``trees`` table
keeps its name, game, owner and spec (the JSON that ``arena_league.envs.make(game, tree=...)``
takes). Existing rows are unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0006"
down_revision: str | Sequence[str] | None = "0005"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "trees",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(length=128), nullable=False),
        sa.Column("game_id", sa.String(length=128), nullable=False),
        sa.Column("owner", sa.String(length=128), nullable=False),
        sa.Column("spec", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(["game_id"], ["games.id"], name=op.f("fk_trees_game_id_games")),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_trees")),
    )
    op.create_index(op.f("ix_trees_game_id"), "trees", ["game_id"])


def downgrade() -> None:
    op.drop_index(op.f("ix_trees_game_id"), table_name="trees")
    op.drop_table("trees")
