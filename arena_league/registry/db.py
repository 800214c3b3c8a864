"""Opening a league: the league home, the database engine, sessions and schema migrations.

A league (after Arena, Song et al. AAAI 2020: a shared population against which new agents are
ranked) lives in a *league home*, `ARENA_LEAGUE_HOME` (default `~/.arena-league`), holding the
SQLite database `league.db` and the content-addressed artifact store `artifacts/`.
`ARENA_LEAGUE_DB` replaces the database with any SQLAlchemy URL, e.g.
`postgresql+psycopg://user@host/league` for a league shared by several machines.

SQLite is set up for several worker processes on one machine: write-ahead logging (readers never
block the writer), a busy timeout (a writer waits for the lock instead of failing), foreign keys
enforced, and every write transaction opened with `BEGIN IMMEDIATE`, so it takes the write lock
up front and never fails half-way on a lock upgrade. Python's sqlite3 module issues its own
BEGIN; as SQLAlchemy's SQLite dialect documentation describes, the driver's transaction control
is switched off (`isolation_level = None`) and SQLAlchemy's "begin" event emits ours.

`open_league` migrates the schema to this code's head with Alembic (programmatically; no
alembic.ini). It first checks what it is opening, and refuses, without writing a byte, a file
that is not an SQLite database (an empty file included: only a missing file is a new league), a
database holding some other application's tables, and a database migrated by a newer arena-league.

Every command of a league may write (a game registered, a job claimed, a rating snapshot kept),
so an SQLite league that cannot be written is refused when it is opened
(`ReadOnlyDatabaseError`): a read-only or immutable file, a folder where SQLite cannot create its
`-wal` and `-shm` files, or a read-only mount. An existing SQLite file is also checked with
`PRAGMA quick_check` (every page read once: about 10 ms per MB, 15 ms for a league of 3,000
matches) and a damaged one is refused
(`CorruptDatabaseError`) before anything is written to it. Errors the database raises later,
inside `League.transaction()` or `League.reading()`, are translated where their cause is known:
read-only, disk full, corrupt, server unreachable (see `database_error`); any other SQL error
goes on as SQLAlchemy raised it.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self

from sqlalchemy import Connection, Engine, create_engine, event, inspect
from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import DatabaseError, DBAPIError, OperationalError
from sqlalchemy.orm import Session, sessionmaker

from arena_league.registry.errors import (
    CorruptDatabaseError,
    DatabaseFullError,
    DatabaseStateError,
    DatabaseUnreachableError,
    ForeignDatabaseError,
    InvalidRecordError,
    NotADatabaseError,
    ReadOnlyDatabaseError,
    SchemaOutOfDateError,
    SchemaTooNewError,
)

HOME_ENV = "ARENA_LEAGUE_HOME"
DB_ENV = "ARENA_LEAGUE_DB"
DEFAULT_HOME = "~/.arena-league"
DB_FILENAME = "league.db"
ARTIFACTS_DIRNAME = "artifacts"
MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"

_SQLITE_HEADER = b"SQLite format 3\x00"
#: An empty database file this recent may be a league another process is creating right now ...
_CREATION_WINDOW_S = 10.0
#: ... and is given this long to receive its first page before it is refused as empty.
_CREATION_GRACE_S = 5.0
_READ_ONLY_OPTION = "arena_league_read_only"
# Any constant: serialises concurrent migrations of one PostgreSQL database.
_PG_MIGRATION_LOCK = 0x4172656E61  # "Arena"


def league_home(home: str | os.PathLike[str] | None = None) -> Path:
    """The league home: `home` if given, else `$ARENA_LEAGUE_HOME`, else `~/.arena-league`."""
    chosen = home if home is not None else os.environ.get(HOME_ENV) or DEFAULT_HOME
    return Path(chosen).expanduser().resolve()


def league_url(url: str | None = None, home: str | os.PathLike[str] | None = None) -> URL:
    """The database URL: `url` if given, else `$ARENA_LEAGUE_DB`, else SQLite in the league home.

    A bare `postgresql://` URL is given the psycopg 3 driver, the one arena-league installs.
    """
    chosen = url if url is not None else os.environ.get(DB_ENV)
    if not chosen:
        return URL.create("sqlite", database=str(league_home(home) / DB_FILENAME))
    parsed = make_url(chosen)
    if parsed.drivername in ("postgresql", "postgres"):
        parsed = parsed.set(drivername="postgresql+psycopg")
    return parsed


#: The newest revision under ``migrations/versions``. A database already at it is opened without
#: loading Alembic (a fifth of a second of every command); a test checks it is Alembic's head.
SCHEMA_HEAD = "0008"


def alembic_config(connection: Connection | None = None, url: str | None = None) -> Any:
    """An Alembic configuration for the registry's migrations, without an alembic.ini.

    Developers adding a revision can run
    `alembic.command.revision(alembic_config(url=...), message=..., autogenerate=True)`.
    """
    from alembic.config import Config

    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS_DIR))
    if url is not None:
        config.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    if connection is not None:
        config.attributes["connection"] = connection
    return config


@dataclass(eq=False)
class League:
    """An open league: its home folder and database engine, and sessions over it.

    Use `transaction()` for writes (one transaction, committed on success, rolled back on error;
    on SQLite it starts with BEGIN IMMEDIATE), `reading()` for reads that take no write lock, or
    `session()` to manage a Session yourself. Sessions keep loaded objects usable after commit.
    """

    engine: Engine
    home: Path
    _write_sessions: sessionmaker[Session] = field(init=False, repr=False)
    _read_sessions: sessionmaker[Session] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._write_sessions = sessionmaker(bind=self.engine, expire_on_commit=False)
        read_engine = self.engine.execution_options(**{_READ_ONLY_OPTION: True})
        self._read_sessions = sessionmaker(bind=read_engine, expire_on_commit=False)

    @property
    def url(self) -> str:
        """The database URL with any password hidden, for display."""
        return self.engine.url.render_as_string(hide_password=True)

    @property
    def dialect(self) -> str:
        """The database family: "sqlite" or "postgresql" (others work but are not tested)."""
        return self.engine.dialect.name

    @property
    def artifacts_dir(self) -> Path:
        """The root of the content-addressed artifact store."""
        return self.home / ARTIFACTS_DIRNAME

    def session(self) -> Session:
        """A new Session for writes; the caller commits and closes it."""
        return self._write_sessions()

    @contextmanager
    def transaction(self) -> Iterator[Session]:
        """One write transaction: committed when the block ends, rolled back if it raises.

        A database error of known cause (read-only, disk full, corrupt, unreachable) comes out as
        the `DatabaseStateError` that names it (see `database_error`); any other goes on as is.
        """
        with self._translated_errors(), self._write_sessions() as session, session.begin():
            yield session

    @contextmanager
    def reading(self) -> Iterator[Session]:
        """A Session for reading; on SQLite its transaction takes no write lock. Database errors
        are translated as in `transaction()`."""
        with self._translated_errors(), self._read_sessions() as session:
            yield session

    @contextmanager
    def _translated_errors(self) -> Iterator[None]:
        """Raise a database error of known cause as the `DatabaseStateError` that names it."""
        try:
            yield
        except DBAPIError as error:
            translated = database_error(error, self.engine)
            if translated is None:
                raise
            raise translated from error

    def close(self) -> None:
        """Close every pooled connection."""
        self.engine.dispose()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def open_league(
    url: str | None = None,
    home: str | os.PathLike[str] | None = None,
    *,
    migrate: bool = True,
    busy_timeout_s: float = 30.0,
    echo: bool = False,
    check_integrity: bool = True,
) -> League:
    """Open (creating if needed) a league and bring its schema to this code's head.

    Args:
        url: any SQLAlchemy URL; default `$ARENA_LEAGUE_DB`, else `<home>/league.db`.
        home: the league home; default `$ARENA_LEAGUE_HOME`, else `~/.arena-league`. Created.
        migrate: when False, a database behind this code's schema raises
            `SchemaOutOfDateError` instead of being migrated.
        busy_timeout_s: SQLite only: how long a writer waits for the database lock.
        echo: log every SQL statement (SQLAlchemy's echo).
        check_integrity: SQLite only: run `PRAGMA quick_check` on an existing file first (about
            10 ms per MB of database: 15 ms for 3,000 matches, 0.1 s for 30,000). Turn it off for
            a very large league opened often, once it has been checked.

    Raises:
        NotADatabaseError: the SQLite path holds something that is not an SQLite database.
        ForeignDatabaseError: the database holds tables arena-league did not create.
        SchemaTooNewError: the database was migrated by a newer arena-league.
        DatabaseUnreachableError: the server could not be reached.
        ReadOnlyDatabaseError: the SQLite file or its folder cannot be written.
        CorruptDatabaseError: the SQLite file fails `PRAGMA quick_check`.
        DatabaseFullError: the disk is full (the schema could not be migrated).
    In each case the database is left exactly as it was.
    """
    home_path = league_home(home)
    db_url = league_url(url, home_path)
    if db_url.get_backend_name() == "sqlite":
        engine = _sqlite_engine(db_url, busy_timeout_s, echo)
    else:
        engine = create_engine(db_url, pool_pre_ping=True, echo=echo)
    try:
        _prepare_schema(engine, migrate, check_integrity)
    except BaseException:
        engine.dispose()
        raise
    home_path.mkdir(parents=True, exist_ok=True)
    (home_path / ARTIFACTS_DIRNAME).mkdir(exist_ok=True)
    return League(engine=engine, home=home_path)


def _sqlite_engine(db_url: URL, busy_timeout_s: float, echo: bool) -> Engine:
    """An engine for an SQLite file, refusing a path that holds something else."""
    database = db_url.database or ""
    if database in ("", ":memory:") or database.startswith("file::memory:"):
        raise InvalidRecordError(
            "an in-memory SQLite database cannot be shared by workers and schedulers; "
            "use a file, e.g. sqlite:///path/to/league.db"
        )
    path = Path(database).expanduser()
    _refuse_non_sqlite_file(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ReadOnlyDatabaseError(
            f"cannot create the folder {path.parent} for the league database ({error.strerror}); "
            "create it with write permission, or set ARENA_LEAGUE_HOME or ARENA_LEAGUE_DB elsewhere"
        ) from error
    _refuse_read_only_file(path)
    engine = create_engine(
        db_url.set(database=str(path)), connect_args={"timeout": busy_timeout_s}, echo=echo
    )
    busy_ms = int(busy_timeout_s * 1000)

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection: Any, connection_record: Any) -> None:
        # Take BEGIN away from the sqlite3 driver; the "begin" listener below emits it.
        dbapi_connection.isolation_level = None
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA foreign_keys = ON")
        cursor.execute(f"PRAGMA busy_timeout = {busy_ms}")
        # WAL + NORMAL survives process crashes; only a power cut may lose the latest commits.
        cursor.execute("PRAGMA synchronous = NORMAL")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _on_begin(connection: Connection) -> None:
        read_only = connection.get_execution_options().get(_READ_ONLY_OPTION, False)
        connection.exec_driver_sql("BEGIN" if read_only else "BEGIN IMMEDIATE")

    return engine


def _refuse_non_sqlite_file(path: Path) -> None:
    """Raise NotADatabaseError if `path` exists and is not an SQLite database; never writes."""
    if not path.exists():
        return
    fix = (
        "move it aside, or set ARENA_LEAGUE_HOME to another folder or ARENA_LEAGUE_DB to another "
        "database URL; the file was not changed"
    )
    if not path.is_file():
        raise NotADatabaseError(f"league database path {path} is not a file; {fix}")
    if _stays_empty(path):
        raise NotADatabaseError(
            f"the league database {path} is an empty file (0 bytes), not a league: a new league is made "
            "only where no database file exists. If it should hold your league, restore it from a backup; "
            f"to start a new league here, delete the empty file (rm {path}); the file was not changed"
        )
    with path.open("rb") as handle:
        header = handle.read(len(_SQLITE_HEADER))
    if header and header != _SQLITE_HEADER:
        raise NotADatabaseError(
            f"{path} is not an SQLite database (it starts with {header!r}, not the SQLite header); {fix}"
        )


def _stays_empty(path: Path) -> bool:
    """Whether ``path`` is an empty file that no one is creating the league in: a file made in the
    last seconds is given a moment to receive its first page from the process that made it."""
    size, modified = path.stat().st_size, path.stat().st_mtime
    deadline = time.monotonic() + _CREATION_GRACE_S
    while size == 0 and time.time() - modified < _CREATION_WINDOW_S and time.monotonic() < deadline:
        time.sleep(0.05)
        size = path.stat().st_size
    return size == 0


def _refuse_read_only_file(path: Path) -> None:
    """Raise ReadOnlyDatabaseError if SQLite could not write `path` or create files beside it.

    `os.access` answers for the real user, immutable files (`chattr +i`) and read-only mounts
    included; root passes plain permission bits, as SQLite itself does.
    """
    fix = (
        "make it writable (chmod u+w; chattr -i for an immutable file; remount a read-only disk), "
        "or copy the league home to a writable place and point ARENA_LEAGUE_HOME at the copy; "
        "nothing was changed"
    )
    for companion in (path, path.with_name(path.name + "-wal"), path.with_name(path.name + "-shm")):
        if companion.exists() and not os.access(companion, os.R_OK | os.W_OK):
            raise ReadOnlyDatabaseError(f"the league database file {companion} is read-only; {fix}")
    folder = path.parent
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ReadOnlyDatabaseError(
            f"the folder {folder} holding the league database is read-only, and SQLite must create "
            f"its -wal and -shm files there; {fix}"
        )


def _check_integrity(engine: Engine) -> None:
    """Raise CorruptDatabaseError if an existing SQLite file fails `PRAGMA quick_check` (reads
    every page once; writes nothing)."""
    path = Path(engine.url.database or "")
    if not path.is_file() or path.stat().st_size == 0:
        return
    try:
        raw = engine.raw_connection()
        try:
            cursor = raw.cursor()
            cursor.execute("PRAGMA quick_check(5)")
            problems = [row[0] for row in cursor.fetchall()]
            cursor.close()
        finally:
            raw.close()
    except DBAPIError as error:
        translated = database_error(error, engine)
        if translated is not None:
            raise translated from error
        raise
    except Exception as error:  # the driver's own error, raised while connecting
        message = str(error)
        if "malformed" in message:
            raise _corrupt(engine, message) from error
        if "not a database" in message:
            raise NotADatabaseError(
                f"{engine.url.database} is not a readable SQLite database ({message}); move it aside, "
                "or set ARENA_LEAGUE_HOME or ARENA_LEAGUE_DB elsewhere; the file was not changed"
            ) from error
        raise
    if problems != ["ok"]:
        raise _corrupt(engine, "; ".join(problems))


def _corrupt(engine: Engine, detail: str) -> CorruptDatabaseError:
    database = engine.url.database
    return CorruptDatabaseError(
        f"the league database {database} is damaged ({detail}); it was not changed and nothing will "
        f"be written to it. Restore it from a backup, or recover what can be read: "
        f"`sqlite3 {database} .recover | sqlite3 recovered.db`, then move recovered.db in its place"
    )


def database_error(error: DBAPIError, engine: Engine) -> DatabaseStateError | None:
    """The `DatabaseStateError` naming the cause of a database error, or None when the cause is
    not one of: read-only, disk full, corrupt, unreachable (a lock timeout, a constraint or an SQL
    mistake stay as SQLAlchemy raised them)."""
    seen = error.__context__
    for _ in range(3):  # a rollback that failed after the real error (a lost savepoint) hides it
        if not isinstance(seen, DBAPIError):
            break
        earlier = database_error(seen, engine)
        if earlier is not None:
            return earlier
        seen = seen.__context__
    url = engine.url.render_as_string(hide_password=True)
    cause = error.orig
    message = str(cause)
    if engine.dialect.name == "sqlite":
        if "readonly database" in message:
            return ReadOnlyDatabaseError(
                f"the league database {engine.url.database} cannot be written ({message}): the file, "
                "its -wal/-shm files or its folder is read-only or immutable, or the disk is mounted "
                "read-only; make them writable (chmod u+w, chattr -i) or copy the league home to a "
                "writable place and point ARENA_LEAGUE_HOME at it"
            )
        if "database or disk is full" in message:
            return DatabaseFullError(
                f"the disk holding the league database {engine.url.database} is full ({message}); "
                "free some space (old replays under the league home's replays/ folder are safe to "
                "delete) and run the command again; the last transaction was rolled back"
            )
        if "malformed" in message:
            return _corrupt(engine, message)
        if "unable to open database file" in message:
            return ReadOnlyDatabaseError(
                f"SQLite cannot open the league database {engine.url.database} ({message}); check "
                "that the file and its folder exist and are readable and writable"
            )
        return None
    sqlstate = getattr(cause, "sqlstate", None) or ""
    if sqlstate == "25006":
        return ReadOnlyDatabaseError(
            f"the database {url} accepts no writes ({message.strip()}); it is a read-only replica or "
            "the user's transactions are read-only: point ARENA_LEAGUE_DB at the primary server"
        )
    if sqlstate in ("53100", "53200"):
        return DatabaseFullError(
            f"the database server of {url} is out of disk or memory ({message.strip()}); free space "
            "on the server and run the command again; the last transaction was rolled back"
        )
    if sqlstate in ("XX001", "XX002"):
        return CorruptDatabaseError(
            f"the database {url} reports damaged data ({message.strip()}); restore it from a backup "
            "(or REINDEX a damaged index) before writing to it again"
        )
    if isinstance(error, OperationalError) and (error.connection_invalidated or sqlstate.startswith("08")
                                                or not sqlstate):
        return DatabaseUnreachableError(
            f"lost the connection to the league database {url} ({message.strip()}); check that the "
            "server is running and that ARENA_LEAGUE_DB is right"
        )
    return None


def _prepare_schema(engine: Engine, migrate: bool, check_integrity: bool = True) -> None:
    """Check what the database holds, then migrate it to head (or refuse)."""
    if check_integrity and engine.dialect.name == "sqlite":
        _check_integrity(engine)
    if _at_head(engine):
        return
    from alembic import command
    from alembic.script import ScriptDirectory

    script = ScriptDirectory.from_config(alembic_config())
    head = script.get_current_head()
    is_sqlite = engine.dialect.name == "sqlite"
    try:
        if is_sqlite:
            # Look before switching to WAL: the journal mode is written into the file header.
            read_engine = engine.execution_options(**{_READ_ONLY_OPTION: True})
            with read_engine.connect() as connection:
                current = _current_revision(connection, script)
            if current == head:
                return
            if not migrate:
                raise _out_of_date(engine, current, head)
            _enable_wal(engine)
        with engine.begin() as connection:
            if engine.dialect.name == "postgresql":
                connection.exec_driver_sql(f"SELECT pg_advisory_xact_lock({_PG_MIGRATION_LOCK})")
            current = _current_revision(connection, script)
            if current == head:
                return
            if not migrate:
                raise _out_of_date(engine, current, head)
            command.upgrade(alembic_config(connection), "head")
    except OperationalError as error:
        if is_sqlite and "not a database" in str(error.orig):
            raise _not_a_database(engine, error) from error
        translated = database_error(error, engine)
        if is_sqlite or (translated is not None and not isinstance(translated, DatabaseUnreachableError)):
            if translated is None:
                raise DatabaseStateError(
                    f"cannot open the league database {engine.url.database}: {error.orig}; check that "
                    "the file and its folder are readable and writable"
                ) from error
            raise translated from error
        raise DatabaseUnreachableError(
            f"cannot open the league database {engine.url.render_as_string(hide_password=True)}: "
            f"{error.orig}; check that the server is running and that ARENA_LEAGUE_DB is right"
        ) from error
    except DatabaseError as error:
        translated = database_error(error, engine)
        if translated is not None:
            raise translated from error
        if is_sqlite:
            raise _not_a_database(engine, error) from error
        raise


def _at_head(engine: Engine) -> bool:
    """Whether the database already records :data:`SCHEMA_HEAD` (read only; any doubt says no, and
    the full check decides)."""
    try:
        with engine.execution_options(**{_READ_ONLY_OPTION: True}).connect() as connection:
            if "alembic_version" not in inspect(connection).get_table_names():
                return False
            versions = connection.exec_driver_sql("SELECT version_num FROM alembic_version").scalars().all()
    except DatabaseError:
        return False
    return versions == [SCHEMA_HEAD]


def _current_revision(connection: Connection, script: Any) -> str | None:
    """The database's schema revision, after checking it is ours and not newer than this code."""
    tables = set(inspect(connection).get_table_names())
    url = connection.engine.url.render_as_string(hide_password=True)
    if "alembic_version" not in tables:
        if tables:
            shown = ", ".join(sorted(tables)[:5])
            raise ForeignDatabaseError(
                f"the database {url} holds tables that arena-league did not create ({shown}); "
                "point ARENA_LEAGUE_DB or ARENA_LEAGUE_HOME at an empty or arena-league database; "
                "nothing was changed"
            )
        return None
    from alembic.runtime.migration import MigrationContext

    current = MigrationContext.configure(connection).get_current_revision()
    if current is not None and current not in {rev.revision for rev in script.walk_revisions()}:
        raise SchemaTooNewError(
            f"the database {url} is at schema revision {current!r}, which this arena-league "
            "does not know: it was migrated by a newer arena-league. Upgrade arena-league "
            "(pip install -U arena-league) to open it; nothing was changed"
        )
    return current


def _enable_wal(engine: Engine) -> None:
    """Switch an SQLite database to write-ahead logging (outside any transaction, as SQLite needs)."""
    raw = engine.raw_connection()
    try:
        cursor = raw.cursor()
        cursor.execute("PRAGMA journal_mode = WAL")
        cursor.close()
    finally:
        raw.close()


def _out_of_date(engine: Engine, current: str | None, head: str | None) -> SchemaOutOfDateError:
    url = engine.url.render_as_string(hide_password=True)
    return SchemaOutOfDateError(
        f"the database {url} is at schema revision {current!r}, behind this arena-league's "
        f"{head!r}; open it with migrate=True to upgrade it"
    )


def _not_a_database(engine: Engine, error: DatabaseError) -> NotADatabaseError:
    return NotADatabaseError(
        f"{engine.url.database} is not a readable SQLite database ({error.orig}); move it aside, "
        "or set ARENA_LEAGUE_HOME or ARENA_LEAGUE_DB elsewhere; the file was not changed"
    )
