"""Initial registry schema: games, artifacts, agents, populations, matches, ratings, jobs, schedules.

Revision ID: 0001
Revises:
Create Date: 2026-11-21 17:11:42

Written from `arena_league.registry.models` by Alembic's autogenerate, then tidied: timestamps are
plain DateTime columns here (the models' UTCDateTime only converts in Python).
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0001"
down_revision: str | Sequence[str] | None = None
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "artifacts",
        sa.Column("sha256", sa.String(length=64), nullable=False),
        sa.Column("format", sa.String(length=16), nullable=False),
        sa.Column("size_bytes", sa.BigInteger(), nullable=False),
        sa.Column("path", sa.String(length=512), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.CheckConstraint(
            "format IN ('onnx', 'arena-policy', 'scripted')", name=op.f("ck_artifacts_format")
        ),
        sa.PrimaryKeyConstraint("sha256", name=op.f("pk_artifacts")),
    )
    op.create_table(
        "games",
        sa.Column("id", sa.String(length=128), nullable=False),
        sa.Column("n_teams", sa.Integer(), nullable=False),
        sa.Column("players_per_team", sa.Integer(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.CheckConstraint("n_teams >= 1 AND players_per_team >= 1", name=op.f("ck_games_team_sizes")),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_games")),
    )
    op.create_table(
        "schedules",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(length=128), nullable=False),
        sa.Column("kind", sa.String(length=64), nullable=False),
        sa.Column("payload", sa.JSON(), nullable=False),
        sa.Column("interval_seconds", sa.Integer(), nullable=True),
        sa.Column("cron", sa.String(length=128), nullable=True),
        sa.Column("priority", sa.Integer(), nullable=False),
        sa.Column("max_attempts", sa.Integer(), nullable=False),
        sa.Column("next_run_at", sa.DateTime(), nullable=False),
        sa.Column("last_run_at", sa.DateTime(), nullable=True),
        sa.Column("enabled", sa.Boolean(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.CheckConstraint(
            "(interval_seconds IS NULL) <> (cron IS NULL)", name=op.f("ck_schedules_interval_xor_cron")
        ),
        sa.CheckConstraint(
            "interval_seconds IS NULL OR interval_seconds > 0", name=op.f("ck_schedules_interval_positive")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_schedules")),
        sa.UniqueConstraint("name", name=op.f("uq_schedules_name")),
    )
    op.create_index(op.f("ix_schedules_enabled_next_run_at"), "schedules", ["enabled", "next_run_at"])
    op.create_table(
        "agents",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(length=128), nullable=False),
        sa.Column("game_id", sa.String(length=128), nullable=False),
        sa.Column("kind", sa.String(length=16), nullable=False),
        sa.Column("owner", sa.String(length=128), nullable=True),
        sa.Column("status", sa.String(length=16), nullable=False),
        sa.Column("reject_reason", sa.Text(), nullable=True),
        sa.Column("validation_log", sa.Text(), nullable=True),
        sa.Column("artifact_sha256", sa.String(length=64), nullable=True),
        sa.Column("metadata", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.CheckConstraint(
            "kind IN ('base', 'submission', 'trained', 'scripted', 'human')", name=op.f("ck_agents_kind")
        ),
        sa.CheckConstraint(
            "status IN ('pending', 'active', 'rejected', 'retired')", name=op.f("ck_agents_status")
        ),
        sa.ForeignKeyConstraint(
            ["artifact_sha256"], ["artifacts.sha256"], name=op.f("fk_agents_artifact_sha256_artifacts")
        ),
        sa.ForeignKeyConstraint(["game_id"], ["games.id"], name=op.f("fk_agents_game_id_games")),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_agents")),
        sa.UniqueConstraint("name", name=op.f("uq_agents_name")),
    )
    op.create_index(op.f("ix_agents_artifact_sha256"), "agents", ["artifact_sha256"])
    op.create_index(op.f("ix_agents_game_id_status"), "agents", ["game_id", "status"])
    op.create_table(
        "jobs",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("kind", sa.String(length=64), nullable=False),
        sa.Column("payload", sa.JSON(), nullable=False),
        sa.Column("status", sa.String(length=16), nullable=False),
        sa.Column("priority", sa.Integer(), nullable=False),
        sa.Column("attempts", sa.Integer(), nullable=False),
        sa.Column("max_attempts", sa.Integer(), nullable=False),
        sa.Column("lease_owner", sa.String(length=128), nullable=True),
        sa.Column("lease_expires_at", sa.DateTime(), nullable=True),
        sa.Column("run_after", sa.DateTime(), nullable=False),
        sa.Column("result", sa.JSON(none_as_null=True), nullable=True),
        sa.Column("error", sa.Text(), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("started_at", sa.DateTime(), nullable=True),
        sa.Column("finished_at", sa.DateTime(), nullable=True),
        sa.Column("schedule_id", sa.Integer(), nullable=True),
        sa.CheckConstraint("status IN ('queued', 'running', 'done', 'failed')", name=op.f("ck_jobs_status")),
        sa.CheckConstraint("max_attempts >= 1", name=op.f("ck_jobs_max_attempts")),
        sa.ForeignKeyConstraint(
            ["schedule_id"], ["schedules.id"], name=op.f("fk_jobs_schedule_id_schedules"), ondelete="SET NULL"
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_jobs")),
    )
    op.create_index(op.f("ix_jobs_schedule_id"), "jobs", ["schedule_id"])
    op.create_index(op.f("ix_jobs_status_priority_id"), "jobs", ["status", "priority", "id"])
    op.create_table(
        "populations",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("name", sa.String(length=128), nullable=False),
        sa.Column("version", sa.Integer(), nullable=False),
        sa.Column("game_id", sa.String(length=128), nullable=False),
        sa.Column("frozen", sa.Boolean(), nullable=False),
        sa.Column("provenance", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("frozen_at", sa.DateTime(), nullable=True),
        sa.CheckConstraint("version >= 1", name=op.f("ck_populations_version")),
        sa.ForeignKeyConstraint(["game_id"], ["games.id"], name=op.f("fk_populations_game_id_games")),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_populations")),
        sa.UniqueConstraint("name", "version", name=op.f("uq_populations_name_version")),
    )
    op.create_table(
        "matches",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("game_id", sa.String(length=128), nullable=False),
        sa.Column("match_key", sa.String(length=255), nullable=False),
        sa.Column("seed", sa.BigInteger(), nullable=False),
        sa.Column("job_id", sa.Integer(), nullable=True),
        sa.Column("replay_path", sa.String(length=512), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.CheckConstraint("seed >= 0", name=op.f("ck_matches_seed")),
        sa.ForeignKeyConstraint(["game_id"], ["games.id"], name=op.f("fk_matches_game_id_games")),
        sa.ForeignKeyConstraint(
            ["job_id"], ["jobs.id"], name=op.f("fk_matches_job_id_jobs"), ondelete="SET NULL"
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_matches")),
        sa.UniqueConstraint("match_key", name=op.f("uq_matches_match_key")),
    )
    op.create_index(op.f("ix_matches_game_id_id"), "matches", ["game_id", "id"])
    op.create_index(op.f("ix_matches_job_id"), "matches", ["job_id"])
    op.create_table(
        "population_members",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("population_id", sa.Integer(), nullable=False),
        sa.Column("agent_id", sa.Integer(), nullable=False),
        sa.Column("metadata", sa.JSON(), nullable=False),
        sa.ForeignKeyConstraint(
            ["agent_id"], ["agents.id"], name=op.f("fk_population_members_agent_id_agents")
        ),
        sa.ForeignKeyConstraint(
            ["population_id"],
            ["populations.id"],
            name=op.f("fk_population_members_population_id_populations"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_population_members")),
        sa.UniqueConstraint(
            "population_id", "agent_id", name=op.f("uq_population_members_population_id_agent_id")
        ),
    )
    op.create_index(op.f("ix_population_members_agent_id"), "population_members", ["agent_id"])
    op.create_table(
        "rating_snapshots",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("game_id", sa.String(length=128), nullable=False),
        sa.Column("method", sa.String(length=32), nullable=False),
        sa.Column("population_id", sa.Integer(), nullable=True),
        sa.Column("scope", sa.String(length=128), nullable=True),
        sa.Column("params", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(["game_id"], ["games.id"], name=op.f("fk_rating_snapshots_game_id_games")),
        sa.ForeignKeyConstraint(
            ["population_id"],
            ["populations.id"],
            name=op.f("fk_rating_snapshots_population_id_populations"),
            ondelete="SET NULL",
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_rating_snapshots")),
    )
    op.create_index(
        op.f("ix_rating_snapshots_game_id_method_created_at"),
        "rating_snapshots",
        ["game_id", "method", "created_at"],
    )
    op.create_table(
        "match_seats",
        sa.Column("match_id", sa.Integer(), nullable=False),
        sa.Column("seat", sa.Integer(), nullable=False),
        sa.Column("agent_id", sa.Integer(), nullable=False),
        sa.Column("team", sa.Integer(), nullable=False),
        sa.Column("score", sa.Float(), nullable=False),
        sa.Column("outcome", sa.String(length=8), nullable=False),
        sa.Column("position", sa.Integer(), nullable=True),
        sa.CheckConstraint("outcome IN ('win', 'loss', 'draw')", name=op.f("ck_match_seats_outcome")),
        sa.CheckConstraint("seat >= 0 AND team >= 0", name=op.f("ck_match_seats_indices")),
        sa.ForeignKeyConstraint(["agent_id"], ["agents.id"], name=op.f("fk_match_seats_agent_id_agents")),
        sa.ForeignKeyConstraint(
            ["match_id"], ["matches.id"], name=op.f("fk_match_seats_match_id_matches"), ondelete="CASCADE"
        ),
        sa.PrimaryKeyConstraint("match_id", "seat", name=op.f("pk_match_seats")),
    )
    op.create_index(op.f("ix_match_seats_agent_id"), "match_seats", ["agent_id"])
    op.create_table(
        "rating_entries",
        sa.Column("snapshot_id", sa.Integer(), nullable=False),
        sa.Column("agent_id", sa.Integer(), nullable=False),
        sa.Column("rating", sa.Float(), nullable=False),
        sa.Column("ci_low", sa.Float(), nullable=True),
        sa.Column("ci_high", sa.Float(), nullable=True),
        sa.Column("rank_low", sa.Integer(), nullable=True),
        sa.Column("rank_high", sa.Integer(), nullable=True),
        sa.Column("n_matches", sa.Integer(), nullable=False),
        sa.Column("extra", sa.JSON(), nullable=False),
        sa.ForeignKeyConstraint(["agent_id"], ["agents.id"], name=op.f("fk_rating_entries_agent_id_agents")),
        sa.ForeignKeyConstraint(
            ["snapshot_id"],
            ["rating_snapshots.id"],
            name=op.f("fk_rating_entries_snapshot_id_rating_snapshots"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("snapshot_id", "agent_id", name=op.f("pk_rating_entries")),
    )
    op.create_index(op.f("ix_rating_entries_agent_id"), "rating_entries", ["agent_id"])


def downgrade() -> None:
    op.drop_index(op.f("ix_rating_entries_agent_id"), table_name="rating_entries")
    op.drop_table("rating_entries")
    op.drop_index(op.f("ix_match_seats_agent_id"), table_name="match_seats")
    op.drop_table("match_seats")
    op.drop_index(op.f("ix_rating_snapshots_game_id_method_created_at"), table_name="rating_snapshots")
    op.drop_table("rating_snapshots")
    op.drop_index(op.f("ix_population_members_agent_id"), table_name="population_members")
    op.drop_table("population_members")
    op.drop_index(op.f("ix_matches_job_id"), table_name="matches")
    op.drop_index(op.f("ix_matches_game_id_id"), table_name="matches")
    op.drop_table("matches")
    op.drop_table("populations")
    op.drop_index(op.f("ix_jobs_status_priority_id"), table_name="jobs")
    op.drop_index(op.f("ix_jobs_schedule_id"), table_name="jobs")
    op.drop_table("jobs")
    op.drop_index(op.f("ix_agents_game_id_status"), table_name="agents")
    op.drop_index(op.f("ix_agents_artifact_sha256"), table_name="agents")
    op.drop_table("agents")
    op.drop_index(op.f("ix_schedules_enabled_next_run_at"), table_name="schedules")
    op.drop_table("schedules")
    op.drop_table("games")
    op.drop_table("artifacts")
