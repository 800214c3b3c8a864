"""Fixtures and job handlers shared by the registry tests (tests/test_registry_*.py).

Leagues are real: an SQLite file in a temporary folder, or PostgreSQL on the local server
(127.0.0.1:5432, database `test`, trust auth, user `postgres` or `root`). Each test run gets a
schema of its own, named at random and dropped at the end, so runs never meet; `pg_league`
empties its tables before each test, and `pg_url` / `fresh_league` give a test a brand-new schema.
PostgreSQL tests are skipped, with the reason, where that server cannot be reached.

The handlers write real rows through the registry; `worker_main` is what the killed-worker test
runs in a subprocess. The test modules load this file as a pytest plugin (`pytest_plugins`)
and also import its helpers; it holds no asserts, so it opts out of assertion rewriting:
PYTEST_DONT_REWRITE
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import psycopg
import pytest
from sqlalchemy import Integer

from arena_league.registry import (
    JobContext,
    League,
    SeatResult,
    create_agent,
    ensure_game,
    open_league,
    record_match,
    run_worker,
)
from arena_league.registry.models import Base

GAME_ID = "Crossroads-2T2P-v1"
PG_HOST = "127.0.0.1"
PG_PORT = 5432
PG_DATABASE = "test"
PG_USERS = ("postgres", "root")
TESTS_DIR = Path(__file__).resolve().parent
REPO_ROOT = TESTS_DIR.parent


@functools.cache
def postgres_user() -> str | None:
    """The first user the local PostgreSQL server lets in, or None if it cannot be reached."""
    for user in PG_USERS:
        try:
            with psycopg.connect(
                host=PG_HOST, port=PG_PORT, dbname=PG_DATABASE, user=user, connect_timeout=3
            ):
                return user
        except psycopg.OperationalError:
            continue
    return None


def _admin_execute(sql: str) -> None:
    with psycopg.connect(
        host=PG_HOST, port=PG_PORT, dbname=PG_DATABASE, user=postgres_user(), autocommit=True
    ) as connection:
        connection.execute(sql)


def _require_postgres() -> str:
    user = postgres_user()
    if user is None:
        pytest.skip(
            f"PostgreSQL is not reachable at {PG_HOST}:{PG_PORT} (database {PG_DATABASE!r}, "
            f"users {', '.join(PG_USERS)}); start it to run the PostgreSQL tests"
        )
    return user


@contextmanager
def _own_schema() -> Iterator[str]:
    """A new PostgreSQL schema named for this run, as a URL whose search_path points at it."""
    user = _require_postgres()
    schema = f"registry_test_{uuid.uuid4().hex[:12]}"
    _admin_execute(f"CREATE SCHEMA {schema}")
    try:
        yield (
            f"postgresql+psycopg://{user}@{PG_HOST}:{PG_PORT}/{PG_DATABASE}?options=-csearch_path%3D{schema}"
        )
    finally:
        _admin_execute(f"DROP SCHEMA {schema} CASCADE")


@pytest.fixture
def pg_url() -> Iterator[str]:
    """The URL of a fresh, empty PostgreSQL schema of this test's own (dropped afterwards)."""
    with _own_schema() as url:
        yield url


@pytest.fixture(scope="session")
def pg_shared_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A PostgreSQL schema of this test run's own, migrated once; `pg_league` empties it per test."""
    with _own_schema() as url:
        open_league(url, home=tmp_path_factory.mktemp("pg-home")).close()
        yield url


@pytest.fixture
def sqlite_league(tmp_path: Path) -> Iterator[League]:
    """A new league in a temporary home, on SQLite."""
    league = open_league(home=tmp_path / "home")
    yield league
    league.close()


@pytest.fixture
def pg_league(pg_shared_url: str, tmp_path: Path) -> Iterator[League]:
    """A league on PostgreSQL with every table emptied first, its artifacts in a temporary home."""
    league = open_league(pg_shared_url, home=tmp_path / "home")
    with league.engine.begin() as connection:  # DELETE: far cheaper than TRUNCATE on tiny tables
        for table in reversed(Base.metadata.sorted_tables):
            connection.execute(table.delete())
            if "id" in table.c and isinstance(table.c.id.type, Integer):
                connection.exec_driver_sql(
                    f"SELECT setval(pg_get_serial_sequence('{table.name}', 'id'), 1, false)"
                )
    yield league
    league.close()


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def league(request: pytest.FixtureRequest) -> League:
    """An empty league, once on SQLite and once on PostgreSQL."""
    return request.getfixturevalue(f"{request.param.replace('postgresql', 'pg')}_league")


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def fresh_league(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[League]:
    """A league migrated from nothing for this test alone (SQLite, then a PostgreSQL schema of its own)."""
    url = request.getfixturevalue("pg_url") if request.param == "postgresql" else None
    league = open_league(url, home=tmp_path / "fresh-home")
    yield league
    league.close()


def add_players(
    league: League, game_id: str = GAME_ID, names: tuple[str, ...] = ("red", "blue")
) -> list[int]:
    """Register the game and scripted agents named `names`; returns their ids."""
    with league.transaction() as session:
        ensure_game(session, game_id)
        return [create_agent(session, name, game_id, "scripted").id for name in names]


def two_team_seats(first: int, second: int, first_wins: bool = True) -> list[SeatResult]:
    """Seats of a 2 teams x 2 players match: `first` holds team 0, `second` team 1."""
    top, bottom = ("win", "loss") if first_wins else ("loss", "win")
    return [
        SeatResult(first, 0, 1.0 if first_wins else 0.0, top),
        SeatResult(first, 0, 1.0 if first_wins else 0.0, top),
        SeatResult(second, 1, 0.0 if first_wins else 1.0, bottom),
        SeatResult(second, 1, 0.0 if first_wins else 1.0, bottom),
    ]


def play_matches(context: JobContext) -> dict[str, int]:
    """Job handler: record `n_matches` matches one by one, each in its own transaction.

    Match keys derive from the job and the match index, so a retried job records each match once.
    Payload: game_id, agents [first, second], n_matches, delay_s (pause after each match).
    """
    payload = context.job.payload
    first, second = payload["agents"]
    created = 0
    for index in range(payload["n_matches"]):
        context.raise_if_lease_lost()
        with context.league.transaction() as session:
            _, is_new = record_match(
                session,
                payload["game_id"],
                f"job-{context.job.id}/match-{index}",
                seed=index,
                seats=two_team_seats(first, second, first_wins=index % 2 == 0),
                job_id=context.job.id,
            )
        created += int(is_new)
        time.sleep(payload.get("delay_s", 0.0))
    return {"created": created, "existing": payload["n_matches"] - created}


def play_one_fresh_match(context: JobContext) -> dict[str, Any]:
    """Job handler: record one match under a key unique to this execution.

    Were a job run twice, it would leave two matches with its job id: this is how the
    concurrent-claim tests count executions in the database itself.
    """
    payload = context.job.payload
    first, second = payload["agents"]
    with context.league.transaction() as session:
        match, _ = record_match(
            session,
            payload["game_id"],
            f"job-{context.job.id}/run-{uuid.uuid4().hex}",
            seed=context.job.id,
            seats=two_team_seats(first, second),
            job_id=context.job.id,
        )
    time.sleep(payload.get("delay_s", 0.0))
    return {"match_id": match.id, "worker": context.job.worker_id}


HANDLERS = {"play": play_matches, "play-fresh": play_one_fresh_match}


def worker_main(argv: list[str]) -> None:
    """Subprocess entry: `url home worker_id lease_seconds max_jobs` -> run_worker over HANDLERS."""
    url, home, worker_id, lease_seconds, max_jobs = argv
    with open_league(url, home=home) as league:
        run_worker(
            league,
            HANDLERS,
            worker_id=worker_id,
            lease_seconds=float(lease_seconds),
            poll_seconds=0.05,
            max_jobs=int(max_jobs) if max_jobs != "none" else None,
            until_idle=max_jobs == "none",
        )


def start_worker_process(
    league: League, worker_id: str, lease_seconds: float, max_jobs: int | None = 1
) -> subprocess.Popen[bytes]:
    """Start `worker_main` in a new Python process on the same league."""
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); import registry_fixtures; "
        "registry_fixtures.worker_main(sys.argv[2:])"
    )
    url = league.engine.url.render_as_string(hide_password=False)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO_ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.Popen(
        [
            sys.executable,
            "-c",
            code,
            str(TESTS_DIR),
            url,
            str(league.home),
            worker_id,
            str(lease_seconds),
            "none" if max_jobs is None else str(max_jobs),
        ],
        env=env,
        stderr=subprocess.PIPE,
    )


def wait_until(condition: Any, timeout_s: float = 20.0, interval_s: float = 0.02) -> None:
    """Poll `condition()` until it is true; fail the test after `timeout_s`."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"condition not met within {timeout_s} s")
        time.sleep(interval_s)
