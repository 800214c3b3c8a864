"""Reading and writing league records: games, agents, populations, matches and rating snapshots.

The league of Arena (Song et al., AAAI 2020) ranks new agents against a fixed base population
from the outcomes of matches played against it. This module is the one way the layers above
(the `arena-league` command, the match engine, population building) store and find those
records. Every function works inside the caller's Session and transaction (see
`League.transaction()`); a function that refuses raises before it writes, so the caller's
rollback leaves the league exactly as it was.

It holds no game rules and no rating maths: outcomes are stored as given, ratings as computed
elsewhere (`arena_league.rating`).
"""

from __future__ import annotations

import difflib
import math
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from sqlalchemy import func, or_, select
from sqlalchemy.dialects.postgresql import insert as postgresql_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, selectinload

from arena_league.registry.errors import (
    ArtifactTakenError,
    GameMismatchError,
    InvalidRecordError,
    MatchKeyConflictError,
    NameTakenError,
    PopulationFrozenError,
    UnknownAgentError,
    UnknownGameError,
)
from arena_league.registry.models import (
    Agent,
    AgentKind,
    AgentStatus,
    Artifact,
    Base,
    Game,
    Match,
    MatchSeat,
    Outcome,
    Population,
    PopulationMember,
    RatingEntry,
    RatingSnapshot,
    utcnow,
)

GAME_ID_PATTERN = re.compile(
    r"^(?P<name>[A-Za-z][A-Za-z0-9]*)-(?P<teams>\d+)T(?P<players>\d+)P-v(?P<version>\d+)\Z"
)
#: Letters and digits of any script first; ends at ``\Z``, since ``$`` also matches before a final newline.
AGENT_NAME_PATTERN = re.compile(r"^[^\W_][\w.:@+-]{0,127}\Z")


def plain_name(name: str) -> bool:
    """Whether ``name`` is an agent name without ``:`` (a series' or an owner's name: ``:`` marks
    versions)."""
    return bool(AGENT_NAME_PATTERN.match(name)) and ":" not in name


MAX_SEED = 2**63 - 1  # seeds are stored as signed 64-bit integers
_BATCH_ROWS = 500  # rows per INSERT or IN (...) list: far below SQLite's and PostgreSQL's bind limits
# Agents of these kinds are code shipped with arena-league or a person; the others need weights.
_KINDS_WITHOUT_ARTIFACT = {AgentKind.SCRIPTED, AgentKind.HUMAN}


@dataclass(frozen=True)
class SeatResult:
    """One seat's result, as the match engine hands it to `record_match` (seat = list index)."""

    agent_id: int
    team: int
    score: float
    outcome: Outcome | str
    position: int | None = None  # finishing place, 1 = first, for games of more than two teams
    forfeit: str | None = None  # why the seat's agent forfeited the match (None: played out)


@dataclass(frozen=True)
class MatchRecord:
    """A played match, as the match engine hands it to `record_matches`."""

    match_key: str  # unique in the league; derive it from what defines the match (job, pairing, index)
    seed: int
    seats: Sequence[SeatResult]
    replay_path: str | None = None
    halves: Sequence[Mapping[str, Any]] | None = None  # a pair's two matches (see `Match.halves`)


@dataclass(frozen=True)
class RecordedMatch:
    """Where `record_matches` put a match, and whether this call stored it (False: already there)."""

    match_id: int
    match_key: str
    created: bool


@dataclass(frozen=True)
class RatingRow:
    """One agent's rating, as a rating method hands it to `write_rating_snapshot`."""

    agent_id: int
    rating: float
    ci_low: float | None = None
    ci_high: float | None = None
    rank_low: int | None = None
    rank_high: int | None = None
    n_matches: int = 0
    extra: dict[str, Any] = field(default_factory=dict)


def insert_ignoring_conflict(
    session: Session,
    model: type[Base],
    rows: Sequence[Mapping[str, Any]],
    conflict_columns: Sequence[str],
    returning: Sequence[str] | None = None,
) -> list[tuple[Any, ...]]:
    """INSERT rows, skipping those whose `conflict_columns` match a stored row.

    Returns the `returning` columns (default: the primary key) of the rows actually inserted.
    SQLite and PostgreSQL use one `INSERT ... ON CONFLICT DO NOTHING`, so concurrent writers of
    the same key never fail; other databases fall back to one savepoint per row. Every row must
    name the same columns.
    """
    if not rows:
        return []
    table = model.__table__
    columns = [table.c[name] for name in returning] if returning else list(table.primary_key.columns)
    dialect = session.get_bind().dialect.name
    if dialect in ("sqlite", "postgresql"):
        insert = sqlite_insert if dialect == "sqlite" else postgresql_insert
        statement = (
            insert(table).on_conflict_do_nothing(index_elements=list(conflict_columns)).returning(*columns)
        )
        # Executemany: SQLAlchemy batches the rows into multi-row INSERTs ("insertmanyvalues").
        return [tuple(row) for row in session.execute(statement, [dict(row) for row in rows])]
    inserted = []
    for row in rows:
        try:
            with session.begin_nested():
                inserted.append(
                    tuple(session.execute(table.insert().values(**row).returning(*columns)).one())
                )
        except IntegrityError:
            continue
    return inserted


# ----------------------------------------------------------------------------------------- games


def ensure_game(
    session: Session, game_id: str, n_teams: int | None = None, players_per_team: int | None = None
) -> Game:
    """The game with this id, registering it if new.

    Team sizes default to those in an Arena id `<Game>-<x>T<y>P-v<N>` (x teams of y players).

    Raises:
        InvalidRecordError: the sizes are missing and the id does not say them, or disagree with it.
        GameMismatchError: the game is registered with other team sizes.
    """
    parsed = GAME_ID_PATTERN.match(game_id)
    if parsed is not None:
        id_sizes = (int(parsed["teams"]), int(parsed["players"]))
        given = (
            n_teams if n_teams is not None else id_sizes[0],
            players_per_team if players_per_team is not None else id_sizes[1],
        )
        if given != id_sizes:
            raise InvalidRecordError(
                f"game id {game_id!r} says {id_sizes[0]} teams of {id_sizes[1]}, but "
                f"{given[0]} teams of {given[1]} were given; leave the sizes out or fix the id"
            )
        n_teams, players_per_team = id_sizes
    elif n_teams is None or players_per_team is None:
        raise InvalidRecordError(
            f"game id {game_id!r} does not follow Arena's <Game>-<x>T<y>P-v<N> convention, so pass "
            "n_teams and players_per_team"
        )
    if n_teams < 1 or players_per_team < 1:
        raise InvalidRecordError(f"game {game_id!r} needs at least one team of one player")
    game = session.get(Game, game_id)
    if game is None:
        insert_ignoring_conflict(
            session,
            Game,
            [
                {
                    "id": game_id,
                    "n_teams": n_teams,
                    "players_per_team": players_per_team,
                    "created_at": utcnow(),
                }
            ],
            ["id"],
        )
        game = session.get(Game, game_id)
        assert game is not None
    if (game.n_teams, game.players_per_team) != (n_teams, players_per_team):
        raise GameMismatchError(
            f"game {game_id!r} is registered with {game.n_teams} teams of {game.players_per_team}, "
            f"not {n_teams} of {players_per_team}; use a new version in the game id"
        )
    return game


def get_game(session: Session, game_id: str) -> Game | None:
    """The game with this id, or None."""
    return session.get(Game, game_id)


def require_game(session: Session, game_id: str) -> Game:
    """The game with this id; raises UnknownGameError naming the registered games closest to it."""
    game = session.get(Game, game_id)
    if game is None:
        known = list(session.scalars(select(Game.id).order_by(Game.id)))
        close = difflib.get_close_matches(game_id, known, n=3)
        hint = f"did you mean {', '.join(map(repr, close))}? " if close else ""
        raise UnknownGameError(
            f"game {game_id!r} is not registered in this league; {hint}registered games: "
            f"{', '.join(known) or 'none'}"
        )
    return game


def list_games(session: Session) -> list[Game]:
    """Every registered game, by id."""
    return list(session.scalars(select(Game).order_by(Game.id)))


# ---------------------------------------------------------------------------------------- agents


def create_agent(
    session: Session,
    name: str,
    game_id: str,
    kind: AgentKind | str,
    *,
    owner: str | None = None,
    artifact_sha256: str | None = None,
    status: AgentStatus | str = AgentStatus.PENDING,
    metadata: Mapping[str, Any] | None = None,
    reserved: bool = False,
) -> Agent:
    """Register a new agent of a registered game. With ``reserved``, a pending agent without an
    artifact yet: a name held for an upload that a job validates and then gives its artifact
    (`attach_artifact`).

    Raises:
        NameTakenError: another agent has this name (the error names it and suggests a free name).
        ArtifactTakenError: another agent of the game holds this artifact (one agent per game and
            bytes; a unique index enforces it, so of two concurrent registrations of the same
            bytes the second gets this error, naming the first).
        UnknownGameError: the game is not registered.
        InvalidRecordError: a malformed name, an unknown kind or status, a base / submission /
            trained agent without an artifact (unless ``reserved``), or a reserved one not pending.
    Nothing is stored when it raises.
    """
    if not AGENT_NAME_PATTERN.match(name):
        raise InvalidRecordError(
            f"agent name {name!r} is not allowed: use 1 to 128 letters, digits and . _ : @ + -, "
            "starting with a letter or digit"
        )
    agent_kind = _parse(AgentKind, kind, "agent kind")
    agent_status = _parse(AgentStatus, status, "agent status")
    if reserved and (agent_status is not AgentStatus.PENDING or artifact_sha256 is not None):
        raise InvalidRecordError("a reserved agent is pending and has no artifact yet")
    if artifact_sha256 is None and agent_kind not in _KINDS_WITHOUT_ARTIFACT and not reserved:
        raise InvalidRecordError(
            f"a {agent_kind.value} agent needs an artifact; store it with store_artifact first"
        )
    refuse_taken_name(session, name)
    require_game(session, game_id)
    if artifact_sha256 is not None and session.get(Artifact, artifact_sha256) is None:
        raise InvalidRecordError(
            f"artifact {artifact_sha256[:12]} is not in the store; store it with store_artifact first"
        )
    _refuse_taken_artifact(session, name, game_id, artifact_sha256)
    agent = Agent(
        name=name,
        game_id=game_id,
        kind=agent_kind.value,
        owner=owner,
        status=agent_status.value,
        artifact_sha256=artifact_sha256,
        meta=dict(metadata or {}),
    )
    try:
        with session.begin_nested():
            session.add(agent)
    except IntegrityError:
        refuse_taken_name(session, name)  # another writer took the name meanwhile
        _refuse_taken_artifact(session, name, game_id, artifact_sha256)  # or the bytes
        raise
    return agent


def _refuse_taken_artifact(session: Session, name: str, game_id: str, artifact_sha256: str | None) -> None:
    """Raise `ArtifactTakenError` if an agent of `game_id` already holds `artifact_sha256`."""
    if artifact_sha256 is None:
        return
    holder = session.scalars(
        select(Agent.name)
        .where(Agent.game_id == game_id, Agent.artifact_sha256 == artifact_sha256)
        .order_by(Agent.id)
        .limit(1)
    ).first()
    if holder is not None:
        raise ArtifactTakenError(holder, name, game_id, artifact_sha256)


def get_agent(session: Session, name: str) -> Agent | None:
    """The agent with this name, or None."""
    return session.scalars(select(Agent).where(Agent.name == name)).one_or_none()


def require_agent(session: Session, name: str) -> Agent:
    """The agent with this name; raises UnknownAgentError naming the closest registered names."""
    agent = get_agent(session, name)
    if agent is None:
        close = difflib.get_close_matches(name, list(session.scalars(select(Agent.name))), n=3)
        hint = f"; did you mean {', '.join(map(repr, close))}?" if close else ""
        raise UnknownAgentError(f"no agent named {name!r} in this league{hint}")
    return agent


def list_agents(
    session: Session,
    *,
    game_id: str | None = None,
    status: AgentStatus | str | None = None,
    kind: AgentKind | str | None = None,
) -> list[Agent]:
    """Agents, oldest first, optionally only those of one game, status or kind."""
    query = select(Agent).order_by(Agent.id)
    if game_id is not None:
        query = query.where(Agent.game_id == game_id)
    if status is not None:
        query = query.where(Agent.status == _parse(AgentStatus, status, "agent status").value)
    if kind is not None:
        query = query.where(Agent.kind == _parse(AgentKind, kind, "agent kind").value)
    return list(session.scalars(query))


def attach_artifact(session: Session, agent: Agent, sha256: str) -> Agent:
    """Give a pending agent (a reserved name) the artifact it was validated with.

    Raises ArtifactTakenError when another agent of the game holds these bytes, InvalidRecordError
    when the artifact is not stored or the agent already has one."""
    if agent.artifact_sha256 is not None:
        raise InvalidRecordError(f"agent {agent.name} already holds artifact {agent.artifact_sha256[:12]}")
    if session.get(Artifact, sha256) is None:
        raise InvalidRecordError(f"artifact {sha256[:12]} is not in the store; store it with store_artifact first")
    _refuse_taken_artifact(session, agent.name, agent.game_id, sha256)
    agent.artifact_sha256 = sha256
    session.flush()
    return agent


def series_agents(session: Session, series: str) -> list[Agent]:
    """The versions of a name: the agent ``series`` itself (version 1) and ``series:v2``,
    ``series:v3``, ..., in version order."""
    pattern = re.compile(rf"^{re.escape(series)}:v([0-9]+)\Z")
    found = session.scalars(select(Agent).where(or_(Agent.name == series, Agent.name.like(f"{series}:v%")))).all()
    versions = [(1, a) for a in found if a.name == series]
    versions += [(int(m.group(1)), a) for a in found if (m := pattern.match(a.name))]
    return [a for _, a in sorted(versions, key=lambda pair: pair[0])]


def agent_names(session: Session, game_id: str, *, after_id: int = 0) -> list[tuple[int, str]]:
    """(id, name) of the agents of ``game_id`` with an id above ``after_id``, by id (names only: a
    league may hold thousands)."""
    query = select(Agent.id, Agent.name).where(Agent.game_id == game_id, Agent.id > after_id).order_by(Agent.id)
    return [(int(row.id), row.name) for row in session.execute(query)]


def agent_span(session: Session, game_id: str) -> tuple[int, int]:
    """(how many agents ``game_id`` has, the newest one's id): whether a copy of its names is current."""
    count, newest = session.execute(select(func.count(Agent.id), func.max(Agent.id))
                                    .where(Agent.game_id == game_id)).one()
    return int(count), int(newest or 0)


def count_agents_since(session: Session, owner: str, since: Any) -> int:
    """Agents ``owner`` registered at or after ``since`` (a UTC datetime): uploads, for rate limits."""
    return int(session.scalar(select(func.count(Agent.id)).where(Agent.owner == owner, Agent.created_at >= since)))


def find_agents_by_artifact(session: Session, sha256: str, *, game_id: str | None = None) -> list[Agent]:
    """Agents whose artifact is this content: how a re-submission of the same bytes is recognised."""
    query = select(Agent).where(Agent.artifact_sha256 == sha256.lower()).order_by(Agent.id)
    if game_id is not None:
        query = query.where(Agent.game_id == game_id)
    return list(session.scalars(query))


def set_agent_status(
    session: Session,
    agent: Agent | str,
    status: AgentStatus | str,
    *,
    reason: str | None = None,
    log: str | None = None,
) -> Agent:
    """Move an agent to pending / active / rejected / retired / suspended.

    `reason` is required for "rejected" and "suspended" (and cleared otherwise); `log`, when given,
    replaces the stored validation log, so a rejected agent keeps the log that explains why.
    """
    target = require_agent(session, agent) if isinstance(agent, str) else agent
    new_status = _parse(AgentStatus, status, "agent status")
    explained = (AgentStatus.REJECTED, AgentStatus.SUSPENDED)
    if new_status in explained and not (reason and reason.strip()):
        raise InvalidRecordError(f"a {new_status.value} agent ({target.name!r}) needs a reason the owner can act on")
    target.status = new_status.value
    target.reject_reason = reason if new_status in explained else None
    if log is not None:
        target.validation_log = log
    session.flush()
    return target


def refuse_taken_name(session: Session, name: str) -> None:
    """Raise `NameTakenError` (naming the holder and a free name) if an agent has `name`."""
    existing = get_agent(session, name)
    if existing is None:
        return
    owner = f" owned by {existing.owner}" if existing.owner else ""
    raise NameTakenError(
        "agent",
        name,
        f"{existing.kind} agent #{existing.id}{owner} for {existing.game_id} ({existing.status})",
        _free_name(session, name),
    )


def _free_name(session: Session, name: str) -> str:
    """A free agent name next to `name`: its trailing number counted up, or `-2`, `-3`, ... added."""
    numbered = re.match(r"^(.*?)(\d+)$", name)
    stem, start = (numbered[1], int(numbered[2]) + 1) if numbered else (f"{name}-", 2)
    taken = set(session.scalars(select(Agent.name).where(Agent.name.startswith(stem, autoescape=True))))
    number = start
    while f"{stem}{number}" in taken:
        number += 1
    return f"{stem}{number}"


# ----------------------------------------------------------------------------------- populations


def create_population(
    session: Session,
    name: str,
    game_id: str,
    *,
    version: int | None = None,
    provenance: Mapping[str, Any] | None = None,
) -> Population:
    """Create a population of a game: version `version`, or one past the latest of that name in
    that game (versions count per game: every game's first ``base-v1`` is version 1).

    Raises NameTakenError if that name and version exist for the game, UnknownGameError for an
    unknown game.
    """
    require_game(session, game_id)
    same = (Population.game_id == game_id, Population.name == name)
    latest = session.scalar(select(func.max(Population.version)).where(*same)) or 0
    chosen = latest + 1 if version is None else version
    if chosen < 1:
        raise InvalidRecordError(f"population versions start at 1, not {chosen}")
    if session.scalar(select(Population.id).where(*same, Population.version == chosen)):
        raise NameTakenError(
            "population", f"{name} v{chosen}", f"population {name} v{chosen} of {game_id}", f"{name} v{latest + 1}"
        )
    population = Population(name=name, version=chosen, game_id=game_id, provenance=dict(provenance or {}))
    session.add(population)
    session.flush()
    return population


def get_population(
    session: Session, name: str, version: int | None = None, *, game_id: str | None = None
) -> Population | None:
    """A population by name and version (the latest version when None), members loaded; of
    `game_id`, or of any game (the newest such population) when None."""
    query = select(Population).where(Population.name == name).options(selectinload(Population.members))
    if game_id is not None:
        query = query.where(Population.game_id == game_id)
    if version is None:
        query = query.order_by(Population.version.desc(), Population.id.desc()).limit(1)
    else:
        query = query.where(Population.version == version).order_by(Population.id.desc())
    return session.scalars(query).first()


def list_populations(session: Session, *, game_id: str | None = None) -> list[Population]:
    """Every population (optionally of one game), by name then version, members and their agents
    loaded (listings read them all)."""
    query = (
        select(Population)
        .order_by(Population.name, Population.version)
        .options(selectinload(Population.members).selectinload(PopulationMember.agent))
    )
    if game_id is not None:
        query = query.where(Population.game_id == game_id)
    return list(session.scalars(query))


def add_population_member(
    session: Session, population: Population, agent: Agent, metadata: Mapping[str, Any] | None = None
) -> PopulationMember:
    """Add an agent to an unfrozen population of its game; adding it again returns the same member.

    Raises PopulationFrozenError for a frozen population, InvalidRecordError for an agent of
    another game or a second add with different metadata.
    """
    if population.frozen:
        raise PopulationFrozenError(
            f"population {population.name} v{population.version} is frozen; create version "
            f"{population.version + 1} to change its members"
        )
    if agent.game_id != population.game_id:
        raise InvalidRecordError(
            f"agent {agent.name!r} plays {agent.game_id}, but population {population.name} plays "
            f"{population.game_id}"
        )
    new_meta = dict(metadata or {})
    member = session.scalars(
        select(PopulationMember).where(
            PopulationMember.population_id == population.id, PopulationMember.agent_id == agent.id
        )
    ).one_or_none()
    if member is not None:
        if member.meta != new_meta:
            raise InvalidRecordError(
                f"agent {agent.name!r} is already a member of {population.name} v{population.version} "
                "with other metadata"
            )
        return member
    member = PopulationMember(population=population, agent=agent, meta=new_meta)
    session.add(member)
    session.flush()
    return member


def freeze_population(session: Session, population: Population) -> Population:
    """Freeze a population: its members can no longer change. Freezing twice is harmless."""
    if not population.frozen:
        population.frozen = True
        population.frozen_at = utcnow()
        session.flush()
    return population


# --------------------------------------------------------------------------------------- matches


def record_matches(
    session: Session, game_id: str, matches: Sequence[MatchRecord], *, job_id: int | None = None
) -> list[RecordedMatch]:
    """Store played matches and their seats, once per match key; returns one entry per match, in order.

    A match whose key is already stored (a retried job replaying it) is left as it is and comes
    back with `created=False`; concurrent writers of one key store it once. A seat's index is its
    position in `MatchRecord.seats`. Matches are written in batches, a few statements per batch,
    so the match engine can hand over thousands at once.

    Raises:
        MatchKeyConflictError: a key is stored for another game, seed or seating.
        InvalidRecordError: a key twice in `matches`, no seats, a team out of range, an unknown
            outcome, a score that is not finite, a seed outside [0, 2**63), or an agent that is not
            registered for this game.
        UnknownGameError: the game is not registered.
    Every check but the key conflict runs before anything is written; a conflict is found after
    the batch's inserts, so, as with any error, roll the transaction back (`League.transaction()`
    does) and nothing of the batch is stored.
    """
    game = require_game(session, game_id)
    keys = [match.match_key for match in matches]
    if len(set(keys)) != len(keys):
        twice = sorted(key for key, count in Counter(keys).items() if count > 1)
        raise InvalidRecordError(f"match keys {twice[:3]} appear more than once in one batch")
    seat_rows = {match.match_key: _seat_rows(game, match) for match in matches}
    _refuse_foreign_agents(session, game_id, seat_rows)

    now = utcnow()
    inserted: dict[str, int] = {}
    for start in range(0, len(matches), _BATCH_ROWS):
        batch = matches[start : start + _BATCH_ROWS]
        match_rows = [
            {
                "game_id": game_id,
                "match_key": match.match_key,
                "seed": match.seed,
                "job_id": job_id,
                "replay_path": match.replay_path,
                "halves": None if match.halves is None else [dict(half) for half in match.halves],
                "created_at": now,
            }
            for match in batch
        ]
        for match_id, match_key in insert_ignoring_conflict(
            session, Match, match_rows, ["match_key"], returning=["id", "match_key"]
        ):
            inserted[match_key] = match_id
        new_seats = [
            {"match_id": inserted[match.match_key], **row}
            for match in batch
            if match.match_key in inserted
            for row in seat_rows[match.match_key]
        ]
        if new_seats:
            # RETURNING makes SQLAlchemy send multi-row INSERTs, not one INSERT per seat.
            session.execute(MatchSeat.__table__.insert().returning(MatchSeat.match_id), new_seats)

    existing = _stored_seatings(session, [key for key in keys if key not in inserted])
    for match in matches:
        if match.match_key in inserted:
            continue
        stored_game, stored_seed, _, stored_seating = existing[match.match_key]
        seating = [(row["agent_id"], row["team"]) for row in seat_rows[match.match_key]]
        if (stored_game, stored_seed, stored_seating) != (game_id, match.seed, seating):
            raise MatchKeyConflictError(
                f"match key {match.match_key!r} is already stored for a different match (game "
                f"{stored_game}, seed {stored_seed}); derive match keys from everything that "
                "defines a match (job, pairing, index)"
            )
    return [
        RecordedMatch(match_id=inserted[key], match_key=key, created=True)
        if key in inserted
        else RecordedMatch(match_id=existing[key][2], match_key=key, created=False)
        for key in keys
    ]


def record_match(
    session: Session,
    game_id: str,
    match_key: str,
    seed: int,
    seats: Sequence[SeatResult],
    *,
    job_id: int | None = None,
    replay_path: str | None = None,
) -> tuple[Match, bool]:
    """Store one played match (see `record_matches`); returns (match with its seats, created)."""
    recorded = record_matches(
        session, game_id, [MatchRecord(match_key, seed, seats, replay_path)], job_id=job_id
    )[0]
    match = session.scalars(
        select(Match)
        .where(Match.id == recorded.match_id)
        .options(selectinload(Match.seats))
        .execution_options(populate_existing=True)
    ).one()
    return match, recorded.created


def get_match(session: Session, match_key: str) -> Match | None:
    """The match with this key, seats loaded, or None."""
    return session.scalars(
        select(Match).where(Match.match_key == match_key).options(selectinload(Match.seats))
    ).one_or_none()


def get_match_by_id(session: Session, match_id: int) -> Match | None:
    """The match with this row id, seats and their agents loaded, or None."""
    return session.scalars(
        select(Match).where(Match.id == match_id)
        .options(selectinload(Match.seats).selectinload(MatchSeat.agent))
    ).one_or_none()


def set_replay_path(session: Session, match: Match, path: str,
                    halves: Sequence[Mapping[str, Any]] | None = None) -> Match:
    """Note the replay recorded for a stored match (and, for a pair, its halves with theirs)."""
    match.replay_path = path
    if halves is not None:
        match.halves = [dict(half) for half in halves]
    session.flush()
    return match


def list_matches(
    session: Session,
    game_id: str,
    *,
    agent_id: int | None = None,
    after_id: int | None = None,
    limit: int | None = None,
) -> list[Match]:
    """Matches of a game in the order they were stored, seats loaded.

    `agent_id` keeps those where that agent sat; `after_id` and `limit` page through the table.
    """
    query = (
        select(Match).where(Match.game_id == game_id).options(selectinload(Match.seats)).order_by(Match.id)
    )
    if agent_id is not None:
        query = query.where(Match.id.in_(select(MatchSeat.match_id).where(MatchSeat.agent_id == agent_id)))
    if after_id is not None:
        query = query.where(Match.id > after_id)
    if limit is not None:
        query = query.limit(limit)
    return list(session.scalars(query))


def match_seat_rows(
    session: Session,
    game_id: str,
    *,
    agents: Sequence[str] | None = None,
    exclude_job_id: int | None = None,
) -> list[dict[str, Any]]:
    """Every seat of a game's matches as plain rows, in match order: ``match_id``, ``match_key``,
    ``job_id``, ``seat``, ``agent`` (name), ``team``, ``score``, ``outcome``, ``position``.

    `agents` keeps the matches in which every seat is one of those agents; `exclude_job_id` drops
    the matches a job recorded (a retried job recounts what others played).
    """
    query = (
        select(Match.id, Match.match_key, Match.job_id, MatchSeat.seat, Agent.name, MatchSeat.team,
               MatchSeat.score, MatchSeat.outcome, MatchSeat.position)
        .join(MatchSeat, MatchSeat.match_id == Match.id)
        .join(Agent, Agent.id == MatchSeat.agent_id)
        .where(Match.game_id == game_id)
        .order_by(Match.id, MatchSeat.seat)
    )
    if exclude_job_id is not None:
        query = query.where(or_(Match.job_id.is_(None), Match.job_id != exclude_job_id))
    keys = ("match_id", "match_key", "job_id", "seat", "agent", "team", "score", "outcome", "position")
    rows = [dict(zip(keys, row)) for row in session.execute(query)]
    if agents is None:
        return rows
    wanted = set(agents)
    outside = {row["match_id"] for row in rows if row["agent"] not in wanted}
    return [row for row in rows if row["match_id"] not in outside]


def match_keys_of_job(session: Session, job_id: int) -> set[str]:
    """The keys of the matches a job has recorded so far."""
    return set(session.scalars(select(Match.match_key).where(Match.job_id == job_id)))


def count_matches(session: Session, game_id: str | None = None, *, agent_id: int | None = None) -> int:
    """How many matches are stored (of one game, or of all; those `agent_id` sat in, when given)."""
    query = select(func.count(func.distinct(Match.id)))
    if agent_id is not None:
        query = query.join(MatchSeat, MatchSeat.match_id == Match.id).where(MatchSeat.agent_id == agent_id)
    if game_id is not None:
        query = query.where(Match.game_id == game_id)
    return int(session.scalar(query) or 0)


def _seat_rows(game: Game, match: MatchRecord) -> list[dict[str, Any]]:
    """The seat rows of one match, checked against the game."""
    where = f"match {match.match_key!r}"
    if not 0 <= match.seed <= MAX_SEED:
        raise InvalidRecordError(f"{where} has seed {match.seed}, outside [0, 2**63); reduce it modulo 2**63")
    if not match.seats:
        raise InvalidRecordError(f"{where} has no seats")
    rows = []
    for index, seat in enumerate(match.seats):
        outcome = _parse(Outcome, seat.outcome, f"outcome of seat {index} in {where}")
        if not 0 <= seat.team < game.n_teams:
            raise InvalidRecordError(
                f"seat {index} of {where} is on team {seat.team}, but {game.id} has teams "
                f"0..{game.n_teams - 1}"
            )
        if not math.isfinite(seat.score):
            raise InvalidRecordError(f"seat {index} of {where} has score {seat.score}; scores must be finite")
        if seat.position is not None and seat.position < 1:
            raise InvalidRecordError(
                f"seat {index} of {where} finished in position {seat.position}; positions start at 1"
            )
        rows.append(
            {
                "seat": index,
                "agent_id": seat.agent_id,
                "team": seat.team,
                "score": float(seat.score),
                "outcome": outcome.value,
                "position": seat.position,
                "forfeit": seat.forfeit,
            }
        )
    return rows


def _refuse_foreign_agents(
    session: Session, game_id: str, seat_rows: Mapping[str, list[dict[str, Any]]]
) -> None:
    """Raise InvalidRecordError if a seat holds an agent that is not registered for this game."""
    seated = {row["agent_id"]: key for key, rows in seat_rows.items() for row in rows}
    agent_games: dict[int, str] = {}
    ids = sorted(seated)
    for start in range(0, len(ids), _BATCH_ROWS):
        query = select(Agent.id, Agent.game_id).where(Agent.id.in_(ids[start : start + _BATCH_ROWS]))
        agent_games.update(dict(session.execute(query).all()))
    for agent_id in ids:
        if agent_games.get(agent_id) != game_id:
            plays = (
                f"which plays {agent_games[agent_id]}"
                if agent_id in agent_games
                else "which is not registered"
            )
            raise InvalidRecordError(
                f"match {seated[agent_id]!r} of {game_id} seats agent #{agent_id}, {plays}"
            )


def _stored_seatings(
    session: Session, keys: Sequence[str]
) -> dict[str, tuple[str, int, int, list[tuple[int, int]]]]:
    """match key -> (game id, seed, match id, [(agent id, team) by seat]) for stored matches."""
    stored: dict[str, tuple[str, int, int, list[tuple[int, int]]]] = {}
    for start in range(0, len(keys), _BATCH_ROWS):
        query = (
            select(Match.match_key, Match.game_id, Match.seed, Match.id, MatchSeat.agent_id, MatchSeat.team)
            .join(MatchSeat, MatchSeat.match_id == Match.id)
            .where(Match.match_key.in_(keys[start : start + _BATCH_ROWS]))
            .order_by(Match.id, MatchSeat.seat)
        )
        for match_key, game_id, seed, match_id, agent_id, team in session.execute(query):
            stored.setdefault(match_key, (game_id, seed, match_id, []))[3].append((agent_id, team))
    return stored


# --------------------------------------------------------------------------------------- ratings


def write_rating_snapshot(
    session: Session,
    game_id: str,
    method: str,
    rows: Sequence[RatingRow],
    *,
    population: Population | None = None,
    scope: str | None = None,
    params: Mapping[str, Any] | None = None,
) -> RatingSnapshot:
    """Store the ratings one method computed over a population or a named scope, as of now."""
    require_game(session, game_id)
    seen: set[int] = set()
    for row in rows:
        if row.agent_id in seen:
            raise InvalidRecordError(f"rating snapshot lists agent #{row.agent_id} twice")
        seen.add(row.agent_id)
        if not math.isfinite(row.rating):
            raise InvalidRecordError(f"agent #{row.agent_id} has rating {row.rating}; ratings must be finite")
    snapshot = RatingSnapshot(
        game_id=game_id,
        method=method,
        population_id=population.id if population is not None else None,
        scope=scope,
        params=dict(params or {}),
        entries=[
            RatingEntry(
                agent_id=row.agent_id,
                rating=float(row.rating),
                ci_low=row.ci_low,
                ci_high=row.ci_high,
                rank_low=row.rank_low,
                rank_high=row.rank_high,
                n_matches=row.n_matches,
                extra=dict(row.extra),
            )
            for row in rows
        ],
    )
    session.add(snapshot)
    session.flush()
    return snapshot


def latest_rating_snapshot(
    session: Session,
    game_id: str,
    method: str,
    *,
    population: Population | None = None,
    scope: str | None = None,
) -> RatingSnapshot | None:
    """The most recent snapshot of exactly this game, method, population and scope (None = none).

    Entries come loaded, best rating first.
    """
    query = (
        select(RatingSnapshot)
        .where(RatingSnapshot.game_id == game_id, RatingSnapshot.method == method)
        .where(
            RatingSnapshot.population_id.is_(None)
            if population is None
            else RatingSnapshot.population_id == population.id
        )
        .where(RatingSnapshot.scope.is_(None) if scope is None else RatingSnapshot.scope == scope)
        .options(selectinload(RatingSnapshot.entries))
        .order_by(RatingSnapshot.id.desc())
        .limit(1)
    )
    return session.scalars(query).first()


def _parse(enum_type: Any, value: Any, what: str) -> Any:
    """`value` as a member of `enum_type`, or InvalidRecordError listing the allowed values."""
    try:
        return enum_type(value)
    except ValueError:
        allowed = ", ".join(repr(member.value) for member in enum_type)
        raise InvalidRecordError(f"unknown {what} {value!r}; use one of {allowed}") from None


def forfeit_counts(session: Session, agent_ids: Sequence[int]) -> dict[int, int]:
    """Agent id -> matches it forfeited (seats with a forfeit reason), for the given agents."""
    counts: dict[int, int] = {}
    ids = list(dict.fromkeys(int(i) for i in agent_ids))
    for start in range(0, len(ids), _BATCH_ROWS):
        query = (
            select(MatchSeat.agent_id, func.count(func.distinct(MatchSeat.match_id)))
            .where(MatchSeat.agent_id.in_(ids[start: start + _BATCH_ROWS]), MatchSeat.forfeit.is_not(None))
            .group_by(MatchSeat.agent_id)
        )
        counts.update({int(agent_id): int(n) for agent_id, n in session.execute(query)})
    return counts


def agent_forfeits(session: Session, agent: Agent, *, limit: int = 20) -> list[dict[str, Any]]:
    """The agent's most recent forfeits, newest first: ``match`` (its id), ``match_key``, ``job_id``,
    ``reason``, ``at``."""
    query = (
        select(Match.id, Match.match_key, Match.job_id, MatchSeat.forfeit, Match.created_at)
        .join(MatchSeat, MatchSeat.match_id == Match.id)
        .where(MatchSeat.agent_id == agent.id, MatchSeat.forfeit.is_not(None))
        .group_by(Match.id, Match.match_key, Match.job_id, MatchSeat.forfeit, Match.created_at)
        .order_by(Match.id.desc())
        .limit(limit)
    )
    return [{"match": match_id, "match_key": key, "job_id": job_id, "reason": reason, "at": at}
            for match_id, key, job_id, reason, at in session.execute(query)]
