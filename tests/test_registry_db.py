"""Opening a league: home and URL resolution, SQLite settings, refusals, and migrations."""

from __future__ import annotations

import sqlite3
import threading
from pathlib import Path

import psycopg
import pytest
from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.runtime.migration import MigrationContext
from registry_fixtures import GAME_ID, add_players, postgres_user
from sqlalchemy import Column, Integer, MetaData, Table, text

from arena_league.registry import (
    DatabaseUnreachableError,
    ForeignDatabaseError,
    InvalidRecordError,
    League,
    NotADatabaseError,
    SchemaOutOfDateError,
    SchemaTooNewError,
    alembic_config,
    count_matches,
    get_agent,
    open_league,
)
from arena_league.registry.models import Base

pytest_plugins = ["registry_fixtures"]  # the league, pg_url, ... fixtures


def _file_state(path: Path) -> tuple[bytes, int]:
    return path.read_bytes(), path.stat().st_mtime_ns


def test_open_creates_home_database_and_artifact_store(tmp_path: Path) -> None:
    home = tmp_path / "new-home"
    with open_league(home=home) as league:
        assert league.dialect == "sqlite"
        assert (home / "league.db").is_file()
        assert (home / "artifacts").is_dir()
        with league.engine.connect() as connection:
            assert connection.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
            assert connection.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1
            assert connection.exec_driver_sql("PRAGMA busy_timeout").scalar() == 30000


def test_home_and_database_come_from_the_environment(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ARENA_LEAGUE_HOME", str(tmp_path / "env-home"))
    monkeypatch.delenv("ARENA_LEAGUE_DB", raising=False)
    with open_league() as league:
        assert league.home == (tmp_path / "env-home").resolve()
        assert league.engine.url.database == str((tmp_path / "env-home" / "league.db").resolve())
    monkeypatch.setenv("ARENA_LEAGUE_DB", f"sqlite:///{tmp_path / 'elsewhere.db'}")
    with open_league() as league:
        assert league.engine.url.database == str(tmp_path / "elsewhere.db")
        assert league.home == (tmp_path / "env-home").resolve()  # artifacts stay in the home
    assert (tmp_path / "elsewhere.db").is_file()


def test_reopening_keeps_what_was_stored(tmp_path: Path) -> None:
    with open_league(home=tmp_path) as league:
        add_players(league)
    with open_league(home=tmp_path) as league, league.reading() as session:
        assert get_agent(session, "red") is not None


def test_leagues_opened_at_once_migrate_once(fresh_league: League) -> None:
    url = fresh_league.engine.url.render_as_string(hide_password=False)
    fresh_league.close()
    if fresh_league.dialect == "sqlite":  # start from nothing: no file at all
        Path(fresh_league.engine.url.database).unlink()
        for suffix in ("-wal", "-shm"):
            Path(fresh_league.engine.url.database + suffix).unlink(missing_ok=True)
    else:
        with fresh_league.engine.begin() as connection:
            command.downgrade(alembic_config(connection), "base")
    barrier = threading.Barrier(4)
    opened: list[League] = []

    def open_at_once() -> None:
        barrier.wait()
        opened.append(open_league(url, home=fresh_league.home))

    threads = [threading.Thread(target=open_at_once) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(opened) == 4
    add_players(opened[0])
    with opened[3].reading() as session:
        assert get_agent(session, "blue") is not None
    for league in opened:
        league.close()


def test_readers_do_not_block_writers_on_sqlite(sqlite_league: League) -> None:
    red, _ = add_players(sqlite_league)
    with sqlite_league.reading() as reader:
        assert get_agent(reader, "red").id == red  # the read transaction is open from here on
        writer = threading.Thread(target=add_players, args=(sqlite_league, GAME_ID, ("green",)))
        writer.start()
        writer.join(timeout=5)
        assert not writer.is_alive()  # the write committed while the reader held its snapshot
        assert get_agent(reader, "green") is None  # ... which still shows the league before it
    with sqlite_league.reading() as session:
        assert get_agent(session, "green") is not None


def test_a_file_that_is_not_a_database_is_refused_and_left_unchanged(tmp_path: Path) -> None:
    home = tmp_path / "home"
    home.mkdir()
    thesis = home / "league.db"
    thesis.write_text("Chapter 1. Multi-agent intelligence\n" * 200)
    before = _file_state(thesis)

    with pytest.raises(NotADatabaseError) as refusal:
        open_league(home=home)

    message = str(refusal.value)
    assert str(thesis) in message and "not an SQLite database" in message
    assert "ARENA_LEAGUE_HOME" in message  # the fix
    assert _file_state(thesis) == before
    assert sorted(p.name for p in home.iterdir()) == ["league.db"]  # no -wal, -shm or artifacts/


def test_a_damaged_sqlite_file_is_refused_and_left_unchanged(tmp_path: Path) -> None:
    damaged = tmp_path / "league.db"
    damaged.write_bytes(b"SQLite format 3\x00" + bytes(range(256)) * 40)
    before = _file_state(damaged)

    with pytest.raises(NotADatabaseError, match="not a readable SQLite database"):
        open_league(home=tmp_path)

    assert _file_state(damaged) == before


def test_another_applications_database_is_refused_and_left_unchanged(tmp_path: Path) -> None:
    other = tmp_path / "league.db"
    with sqlite3.connect(other) as connection:
        connection.execute("CREATE TABLE invoices (id INTEGER PRIMARY KEY, total REAL)")
        connection.execute("INSERT INTO invoices (total) VALUES (12.5)")
    connection.close()
    before = _file_state(other)

    with pytest.raises(ForeignDatabaseError, match="invoices"):
        open_league(home=tmp_path)

    assert _file_state(other) == before
    with sqlite3.connect(other) as connection:
        assert connection.execute("PRAGMA journal_mode").fetchone()[0] == "delete"  # not switched to WAL
    connection.close()


def test_a_database_from_a_newer_arena_league_is_refused_and_left_unchanged(tmp_path: Path) -> None:
    with open_league(home=tmp_path) as league:
        add_players(league)
        with league.engine.begin() as connection:
            connection.execute(text("UPDATE alembic_version SET version_num = 'f00dfeed9999'"))
    database = tmp_path / "league.db"
    before = _file_state(database)

    with pytest.raises(SchemaTooNewError) as refusal:
        open_league(home=tmp_path)

    assert "f00dfeed9999" in str(refusal.value) and "pip install -U arena-league" in str(refusal.value)
    assert _file_state(database) == before


@pytest.mark.postgres
def test_a_newer_postgresql_schema_is_refused_untouched(pg_url: str, tmp_path: Path) -> None:
    with open_league(pg_url, home=tmp_path) as league:
        add_players(league)
        with league.engine.begin() as connection:
            connection.execute(text("UPDATE alembic_version SET version_num = 'f00dfeed9999'"))

        with pytest.raises(SchemaTooNewError, match="f00dfeed9999"):
            open_league(pg_url, home=tmp_path)

        with league.engine.connect() as connection:
            assert (
                connection.execute(text("SELECT version_num FROM alembic_version")).scalar() == "f00dfeed9999"
            )
            assert connection.execute(text("SELECT count(*) FROM agents")).scalar() == 2


def test_migrate_false_refuses_an_unmigrated_database(tmp_path: Path) -> None:
    with pytest.raises(SchemaOutOfDateError, match="migrate=True"):
        open_league(home=tmp_path, migrate=False)


def test_in_memory_sqlite_is_refused_with_the_fix(tmp_path: Path) -> None:
    with pytest.raises(InvalidRecordError, match="use a file"):
        open_league("sqlite://", home=tmp_path)


def test_an_unreachable_server_gets_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(DatabaseUnreachableError, match="ARENA_LEAGUE_DB") as refusal:
        open_league("postgresql://nobody:secret@127.0.0.1:1/league", home=tmp_path)
    assert "secret" not in str(refusal.value)


def _schema_differences(league: League, metadata: MetaData = Base.metadata) -> list[object]:
    with league.engine.connect() as connection:
        context = MigrationContext.configure(connection, opts={"compare_type": True})
        return compare_metadata(context, metadata)


def test_migrated_schema_matches_the_models(fresh_league: League) -> None:
    assert _schema_differences(fresh_league) == []

    # The comparison is not blind: a table the migrations lack is reported.
    extended = MetaData()
    for table in Base.metadata.tables.values():
        table.to_metadata(extended)
    Table("leaderboard_cache", extended, Column("id", Integer, primary_key=True))
    differences = _schema_differences(fresh_league, extended)
    assert [difference[0] for difference in differences] == ["add_table"]


def test_migrations_go_down_to_empty_and_up_again(fresh_league: League) -> None:
    add_players(fresh_league)
    with fresh_league.engine.begin() as connection:
        command.downgrade(alembic_config(connection), "base")
    with fresh_league.engine.connect() as connection:
        assert MigrationContext.configure(connection).get_current_revision() is None
    reopened = open_league(
        fresh_league.engine.url.render_as_string(hide_password=False), home=fresh_league.home
    )
    with reopened.reading() as session:
        assert count_matches(session, GAME_ID) == 0 and get_agent(session, "red") is None
    assert _schema_differences(reopened) == []
    reopened.close()


@pytest.mark.postgres
def test_postgresql_leagues_use_psycopg_3(pg_league: League) -> None:
    assert pg_league.engine.dialect.driver == "psycopg"
    assert postgres_user() is not None and psycopg.__version__.startswith("3")


def test_schema_head_is_alembics_head() -> None:
    from alembic.script import ScriptDirectory

    from arena_league.registry.db import SCHEMA_HEAD

    assert ScriptDirectory.from_config(alembic_config()).get_current_head() == SCHEMA_HEAD


def test_a_league_of_the_first_schema_upgrades_keeping_its_populations(fresh_league: League) -> None:
    """Before 0002 population versions counted across games; upgrading keeps every row and
    version, then counts new versions per game, and jobs can be cancelled."""
    from arena_league.registry import JobStatus, cancel_job, create_population, enqueue, ensure_game, get_job

    with fresh_league.transaction() as session:
        ensure_game(session, GAME_ID)
        ensure_game(session, "Snake-2T2P-v1")
    with fresh_league.engine.begin() as connection:
        command.downgrade(alembic_config(connection), "0001")
        connection.execute(text(
            "INSERT INTO populations (name, version, game_id, frozen, provenance, created_at) VALUES "
            f"('base-v1', 1, '{GAME_ID}', TRUE, '{{}}', '2026-11-01'), "
            "('base-v1', 2, 'Snake-2T2P-v1', TRUE, '{}', '2026-11-02')"))
    url = fresh_league.engine.url.render_as_string(hide_password=False)
    reopened = open_league(url, home=fresh_league.home)
    with reopened.transaction() as session:
        rows = session.execute(text("SELECT game_id, version FROM populations ORDER BY id")).all()
        assert [tuple(r) for r in rows] == [(GAME_ID, 1), ("Snake-2T2P-v1", 2)]
        assert create_population(session, "base-v1", "Snake-2T2P-v1").version == 3
        assert create_population(session, "base-v1", GAME_ID).version == 2
        assert create_population(session, "other", GAME_ID).version == 1
        job = enqueue(session, "evaluate", {"game_id": GAME_ID})
        job_id = job.id
    cancel_job(reopened, job_id)
    with reopened.reading() as session:
        assert get_job(session, job_id).status == JobStatus.CANCELLED.value
    assert _schema_differences(reopened) == []
    reopened.close()
