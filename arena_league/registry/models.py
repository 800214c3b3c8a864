"""SQL models of the league registry (SQLAlchemy 2, typed declarative mapping).

After Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for
Multi-Agent Intelligence", AAAI 2020): a league holds games, agents (base-population members,
community submissions, trained snapshots, scripted and human players), the artifacts that carry
their weights, named and versioned populations, every match ever played with its per-seat
outcome, rating snapshots derived from those matches, and the job queue that plays them.

Conventions:
- timestamps are stored as naive UTC and read back as timezone-aware UTC (`UTCDateTime`);
- closed vocabularies (agent kind, status, outcome, job status) are `StrEnum`s stored as short
  strings guarded by CHECK constraints, so both SQLite and PostgreSQL refuse a stray value;
- constraint names follow one naming convention, so migrations name them the same everywhere.

This module holds no game logic and no rating maths: it is the shape of what is stored.
"""

from __future__ import annotations

import enum
from datetime import UTC, datetime
from typing import Any, ClassVar

from sqlalchemy import (
    JSON,
    BigInteger,
    Boolean,
    CheckConstraint,
    DateTime,
    Dialect,
    Float,
    ForeignKey,
    Index,
    Integer,
    MetaData,
    String,
    Text,
    TypeDecorator,
    UniqueConstraint,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


def utcnow() -> datetime:
    """The current time, timezone-aware UTC."""
    return datetime.now(UTC)


class UTCDateTime(TypeDecorator[datetime]):
    """A timestamp stored as naive UTC and returned as aware UTC.

    SQLite has no time zones and compares timestamps as text, so every stored value is brought to
    UTC first; a naive datetime handed in is taken to be UTC already.
    """

    impl = DateTime
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is None or value.tzinfo is None:
            return value
        return value.astimezone(UTC).replace(tzinfo=None)

    def process_result_value(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is None:
            return None
        return value.replace(tzinfo=UTC) if value.tzinfo is None else value.astimezone(UTC)


class AgentKind(enum.StrEnum):
    """Where an agent comes from."""

    BASE = "base"  # a member of a game's shipped base population
    SUBMISSION = "submission"  # uploaded by a user
    TRAINED = "trained"  # a snapshot written by arena_league.training
    SCRIPTED = "scripted"  # a built-in scripted policy (random, heuristic)
    HUMAN = "human"  # a person at the keyboard


class AgentStatus(enum.StrEnum):
    """Where an agent stands in the league."""

    PENDING = "pending"  # submitted, not yet validated
    ACTIVE = "active"  # validated, plays ranked matches
    REJECTED = "rejected"  # failed validation; reject_reason says why
    RETIRED = "retired"  # kept for history, no longer scheduled
    SUSPENDED = "suspended"  # forfeited too many matches; reject_reason says why, no longer scheduled


class ArtifactFormat(enum.StrEnum):
    """How an artifact's bytes are to be read (ONNX file, arena-policy folder or scripted description)."""

    ONNX = "onnx"
    ARENA_POLICY = "arena-policy"  # a folder: manifest.json + weights.safetensors
    SCRIPTED = "scripted"  # a JSON description of a built-in scripted policy


class Outcome(enum.StrEnum):
    """A seat's outcome in one match."""

    WIN = "win"
    LOSS = "loss"
    DRAW = "draw"


class JobStatus(enum.StrEnum):
    """Life cycle of a queued job: queued -> running -> done | failed (running -> queued on retry);
    queued or running -> cancelled when someone cancels it (a running job's worker stops at its
    next lease renewal)."""

    QUEUED = "queued"
    RUNNING = "running"
    DONE = "done"
    FAILED = "failed"
    CANCELLED = "cancelled"


def _one_of(column: str, values: type[enum.StrEnum]) -> str:
    """A CHECK constraint body restricting `column` to the values of an enum."""
    return f"{column} IN ({', '.join(repr(v.value) for v in values)})"


NAMING_CONVENTION = {
    "ix": "ix_%(table_name)s_%(column_0_N_name)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


class Base(DeclarativeBase):
    """Declarative base of every registry table."""

    metadata = MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map: ClassVar[dict[Any, Any]] = {datetime: UTCDateTime(), dict[str, Any]: JSON()}


class Game(Base):
    """A game known to the league, by its Arena id such as "Crossroads-2T2P-v1"."""

    __tablename__ = "games"

    id: Mapped[str] = mapped_column(String(128), primary_key=True)
    n_teams: Mapped[int] = mapped_column(Integer)
    players_per_team: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    __table_args__ = (CheckConstraint("n_teams >= 1 AND players_per_team >= 1", name="team_sizes"),)


class Artifact(Base):
    """A content-addressed artifact: bytes (or a folder) stored under the league home."""

    __tablename__ = "artifacts"

    sha256: Mapped[str] = mapped_column(String(64), primary_key=True)
    format: Mapped[str] = mapped_column(String(16))
    size_bytes: Mapped[int] = mapped_column(BigInteger)
    path: Mapped[str] = mapped_column(String(512))  # relative to the league home
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    __table_args__ = (CheckConstraint(_one_of("format", ArtifactFormat), name="format"),)


class Agent(Base):
    """A player of one game: its kind, owner, status and the artifact holding its policy.

    One agent per (game, artifact): the same bytes are one player of a game, whatever names they
    are submitted under (a unique index; agents without an artifact, such as scripted ones, are
    exempt, since SQLite and PostgreSQL both count NULLs as distinct in a unique index).
    """

    __tablename__ = "agents"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(128), unique=True)
    game_id: Mapped[str] = mapped_column(ForeignKey("games.id"))
    kind: Mapped[str] = mapped_column(String(16))
    owner: Mapped[str | None] = mapped_column(String(128))
    status: Mapped[str] = mapped_column(String(16), default=AgentStatus.PENDING.value)
    reject_reason: Mapped[str | None] = mapped_column(Text)
    validation_log: Mapped[str | None] = mapped_column(Text)
    artifact_sha256: Mapped[str | None] = mapped_column(ForeignKey("artifacts.sha256"))
    meta: Mapped[dict[str, Any]] = mapped_column("metadata", default=dict)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    game: Mapped[Game] = relationship()
    artifact: Mapped[Artifact | None] = relationship()

    __table_args__ = (
        CheckConstraint(_one_of("kind", AgentKind), name="kind"),
        CheckConstraint(_one_of("status", AgentStatus), name="status"),
        Index(None, "game_id", "status"),
        Index(None, "artifact_sha256"),
        Index(None, "game_id", "artifact_sha256", unique=True),
    )


class Population(Base):
    """A named set of agents of one game, versioned per game and name; frozen once published."""

    __tablename__ = "populations"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(128))
    version: Mapped[int] = mapped_column(Integer)
    game_id: Mapped[str] = mapped_column(ForeignKey("games.id"))
    frozen: Mapped[bool] = mapped_column(Boolean, default=False)
    provenance: Mapped[dict[str, Any]] = mapped_column(default=dict)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    frozen_at: Mapped[datetime | None]

    game: Mapped[Game] = relationship()
    members: Mapped[list[PopulationMember]] = relationship(
        back_populates="population", order_by="PopulationMember.id", cascade="all, delete-orphan"
    )

    __table_args__ = (UniqueConstraint("game_id", "name", "version"), CheckConstraint("version >= 1", name="version"))


class PopulationMember(Base):
    """One agent's place in a population, with how it got there (scheme, steps, seed, rating)."""

    __tablename__ = "population_members"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    population_id: Mapped[int] = mapped_column(ForeignKey("populations.id", ondelete="CASCADE"))
    agent_id: Mapped[int] = mapped_column(ForeignKey("agents.id"))
    meta: Mapped[dict[str, Any]] = mapped_column("metadata", default=dict)

    population: Mapped[Population] = relationship(back_populates="members")
    agent: Mapped[Agent] = relationship()

    __table_args__ = (UniqueConstraint("population_id", "agent_id"), Index(None, "agent_id"))


class Schedule(Base):
    """A job enqueued again and again, every `interval_seconds` or on a cron expression (UTC)."""

    __tablename__ = "schedules"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(128), unique=True)
    kind: Mapped[str] = mapped_column(String(64))
    payload: Mapped[dict[str, Any]] = mapped_column(default=dict)
    interval_seconds: Mapped[int | None] = mapped_column(Integer)
    cron: Mapped[str | None] = mapped_column(String(128))
    priority: Mapped[int] = mapped_column(Integer, default=0)
    max_attempts: Mapped[int] = mapped_column(Integer, default=3)
    next_run_at: Mapped[datetime]
    last_run_at: Mapped[datetime | None]
    enabled: Mapped[bool] = mapped_column(Boolean, default=True)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    __table_args__ = (
        CheckConstraint("(interval_seconds IS NULL) <> (cron IS NULL)", name="interval_xor_cron"),
        CheckConstraint("interval_seconds IS NULL OR interval_seconds > 0", name="interval_positive"),
        Index(None, "enabled", "next_run_at"),
    )


class Job(Base):
    """A unit of work with a lease: claimed by one worker at a time, retried up to max_attempts."""

    __tablename__ = "jobs"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    kind: Mapped[str] = mapped_column(String(64))
    payload: Mapped[dict[str, Any]] = mapped_column(default=dict)
    status: Mapped[str] = mapped_column(String(16), default=JobStatus.QUEUED.value)
    priority: Mapped[int] = mapped_column(Integer, default=0)  # higher runs first
    attempts: Mapped[int] = mapped_column(Integer, default=0)  # claims so far; fences old workers
    max_attempts: Mapped[int] = mapped_column(Integer, default=3)
    lease_owner: Mapped[str | None] = mapped_column(String(128))
    lease_expires_at: Mapped[datetime | None]
    run_after: Mapped[datetime] = mapped_column(default=utcnow)  # not claimed before this time
    result: Mapped[Any | None] = mapped_column(JSON(none_as_null=True))
    error: Mapped[str | None] = mapped_column(Text)
    #: What a running job has done so far (``{"done": n, "total": m, ...}``), for live progress.
    progress: Mapped[Any | None] = mapped_column(JSON(none_as_null=True))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    started_at: Mapped[datetime | None]
    finished_at: Mapped[datetime | None]
    schedule_id: Mapped[int | None] = mapped_column(ForeignKey("schedules.id", ondelete="SET NULL"))
    #: Who queued it (a token's owner); None for the league's own jobs (schedules, the command line).
    owner: Mapped[str | None] = mapped_column(String(128))

    __table_args__ = (
        CheckConstraint(_one_of("status", JobStatus), name="status"),
        CheckConstraint("max_attempts >= 1", name="max_attempts"),
        Index(None, "status", "priority", "id"),
        Index(None, "schedule_id"),
        Index(None, "owner", "status"),  # an owner's live jobs: quotas, and the fair claim's running count
        Index(None, "owner", "started_at"),  # when an owner was last served: the fair claim's tie-break
    )


class Match(Base):
    """One played match. `match_key` is unique so a retried job records the same match once."""

    __tablename__ = "matches"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    game_id: Mapped[str] = mapped_column(ForeignKey("games.id"))
    match_key: Mapped[str] = mapped_column(String(255), unique=True)
    seed: Mapped[int] = mapped_column(BigInteger)
    job_id: Mapped[int | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"))
    replay_path: Mapped[str | None] = mapped_column(String(512))
    # a pair's two matches (seats, scores, pair points, steps, replay), for games played in pairs
    halves: Mapped[Any | None] = mapped_column(JSON(none_as_null=True))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    game: Mapped[Game] = relationship()
    seats: Mapped[list[MatchSeat]] = relationship(
        back_populates="match", order_by="MatchSeat.seat", cascade="all, delete-orphan"
    )

    __table_args__ = (
        CheckConstraint("seed >= 0", name="seed"),
        Index(None, "game_id", "id"),
        Index(None, "job_id"),
    )


class MatchSeat(Base):
    """One seat of a match: which agent sat there, its team, score, outcome and finishing place."""

    __tablename__ = "match_seats"

    match_id: Mapped[int] = mapped_column(ForeignKey("matches.id", ondelete="CASCADE"), primary_key=True)
    seat: Mapped[int] = mapped_column(Integer, primary_key=True)
    agent_id: Mapped[int] = mapped_column(ForeignKey("agents.id"))
    team: Mapped[int] = mapped_column(Integer)
    score: Mapped[float] = mapped_column(Float)
    outcome: Mapped[str] = mapped_column(String(8))
    position: Mapped[int | None] = mapped_column(Integer)  # 1 = first place, for > 2 teams
    #: Why the seat's agent forfeited the match (its call failed in the inference sandbox); NULL
    #: for a seat played out.
    forfeit: Mapped[str | None] = mapped_column(Text)

    match: Mapped[Match] = relationship(back_populates="seats")
    agent: Mapped[Agent] = relationship()

    __table_args__ = (
        CheckConstraint(_one_of("outcome", Outcome), name="outcome"),
        CheckConstraint("seat >= 0 AND team >= 0", name="indices"),
        Index(None, "agent_id"),
    )


class Token(Base):
    """A bearer token of the web service: only its SHA-256 hash is kept, with its first characters
    (to tell tokens apart), its owner and whether it is an administrator's."""

    __tablename__ = "tokens"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    owner: Mapped[str] = mapped_column(String(128))
    token_hash: Mapped[str] = mapped_column(String(64), unique=True)
    prefix: Mapped[str] = mapped_column(String(16))
    admin: Mapped[bool] = mapped_column(Boolean, default=False)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    last_used_at: Mapped[datetime | None] = mapped_column()
    revoked_at: Mapped[datetime | None] = mapped_column()

    __table_args__ = (Index(None, "owner"),)


class Tree(Base):
    """A social tree saved by its owner: the spec ``arena_league.envs.make(game, tree=spec)`` takes."""

    __tablename__ = "trees"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(128))
    game_id: Mapped[str] = mapped_column(ForeignKey("games.id"))
    owner: Mapped[str] = mapped_column(String(128))
    spec: Mapped[dict[str, Any]] = mapped_column()
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    __table_args__ = (Index(None, "game_id"),)


class Setting(Base):
    """A league setting changed from its default: its key and JSON value (the league layer knows
    the keys, their types and defaults)."""

    __tablename__ = "settings"

    key: Mapped[str] = mapped_column(String(64), primary_key=True)
    value: Mapped[Any] = mapped_column(JSON)
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, onupdate=utcnow)


class RatingSnapshot(Base):
    """Ratings computed by one method over one scope (a population, or a named scope) at one time."""

    __tablename__ = "rating_snapshots"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    game_id: Mapped[str] = mapped_column(ForeignKey("games.id"))
    method: Mapped[str] = mapped_column(String(32))
    population_id: Mapped[int | None] = mapped_column(ForeignKey("populations.id", ondelete="SET NULL"))
    scope: Mapped[str | None] = mapped_column(String(128))
    params: Mapped[dict[str, Any]] = mapped_column(default=dict)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    entries: Mapped[list[RatingEntry]] = relationship(
        back_populates="snapshot",
        order_by=lambda: [RatingEntry.rating.desc(), RatingEntry.agent_id],
        cascade="all, delete-orphan",
    )

    __table_args__ = (Index(None, "game_id", "method", "created_at"),)


class RatingEntry(Base):
    """One agent's rating in a snapshot, with its interval, rank interval and match count."""

    __tablename__ = "rating_entries"

    snapshot_id: Mapped[int] = mapped_column(
        ForeignKey("rating_snapshots.id", ondelete="CASCADE"), primary_key=True
    )
    agent_id: Mapped[int] = mapped_column(ForeignKey("agents.id"), primary_key=True)
    rating: Mapped[float] = mapped_column(Float)
    ci_low: Mapped[float | None] = mapped_column(Float)
    ci_high: Mapped[float | None] = mapped_column(Float)
    rank_low: Mapped[int | None] = mapped_column(Integer)
    rank_high: Mapped[int | None] = mapped_column(Integer)
    n_matches: Mapped[int] = mapped_column(Integer, default=0)
    extra: Mapped[dict[str, Any]] = mapped_column(default=dict)

    snapshot: Mapped[RatingSnapshot] = relationship(back_populates="entries")
    agent: Mapped[Agent] = relationship()

    __table_args__ = (Index(None, "agent_id"),)
