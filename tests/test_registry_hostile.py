"""The registry under hostile conditions: a league that cannot be written, a full disk, a damaged
file, a worker facing a broken database, the same bytes submitted twice at once, overlapping
evaluations, and a schema migration over duplicates. Each failure is one named error with its fix
(never a traceback, never a hang), and concurrent work agrees on what is stored."""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import shutil
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from registry_fixtures import GAME_ID, REPO_ROOT, add_players
from sqlalchemy import create_engine, text
from sqlalchemy.exc import OperationalError
from sqlalchemy.orm import Session

import arena_league.registry.jobs as jobs_module
from arena_league.cli import main
from arena_league.registry import (
    Agent,
    League,
    MatchRecord,
    SeatResult,
    alembic_config,
    create_agent,
    ensure_game,
    find_agents_by_artifact,
    list_agents,
    match_seat_rows,
    open_league,
    record_matches,
    run_worker,
    store_artifact,
)
from arena_league.registry.errors import (
    ArtifactTakenError,
    CorruptDatabaseError,
    DatabaseFullError,
    ReadOnlyDatabaseError,
    WorkerGaveUpError,
)

pytest_plugins = ["registry_fixtures"]

IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


@contextmanager
def read_only(path: Path) -> Iterator[None]:
    """Make `path` unwritable for this process: `chattr +i` as root (root ignores permission bits,
    as SQLite would), else chmod; undone afterwards."""
    if IS_ROOT:
        if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(path)],
                                                            check=False, capture_output=True).returncode != 0:
            pytest.skip("running as root and `chattr +i` is not available here to make a file read-only")
        try:
            yield
        finally:
            subprocess.run(["chattr", "-i", str(path)], check=True)
        return
    mode = path.stat().st_mode
    path.chmod(0o555 if path.is_dir() else 0o444)
    try:
        yield
    finally:
        path.chmod(mode)


def _new_home(tmp_path: Path) -> Path:
    home = tmp_path / "home"
    league = open_league(home=home)
    add_players(league)
    league.close()  # checkpoints the WAL now, not at some later garbage collection
    return home


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, dict | None, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.strip().startswith("{") else None, err


# --- a league that cannot be written --------------------------------------------------------------

@pytest.mark.parametrize("target", ["file", "folder"])
def test_a_read_only_league_is_one_named_error(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                               target: str) -> None:
    home = _new_home(tmp_path)
    database = home / "league.db"
    before = _digest(database)
    with read_only(database if target == "file" else home):
        code, doc, err = _cli(capsys, "agents", "--home", str(home), "--json")
        with pytest.raises(ReadOnlyDatabaseError, match="read-only"):
            open_league(home=home)
    assert code == 2
    assert doc is not None and doc["kind"] == "ReadOnlyDatabaseError"
    assert "read-only" in doc["error"] and "server is running" not in doc["error"]
    assert "chmod u+w" in doc["error"] and "Traceback" not in err
    assert _digest(database) == before


def test_a_write_refused_later_names_the_read_only_cause(league: League) -> None:
    """A write the database refuses after opening (a PostgreSQL read-only transaction; an SQLite
    connection switched to query_only) comes out of `transaction()` as the named error."""
    add_players(league)
    refuse = "SET TRANSACTION READ ONLY" if league.dialect == "postgresql" else "PRAGMA query_only = ON"
    with pytest.raises(ReadOnlyDatabaseError, match="cannot be written|accepts no writes"), \
            league.transaction() as session:
        session.execute(text(refuse))
        session.add(Agent(name="ghost", game_id=GAME_ID, kind="scripted", status="active", meta={}))
    league.close()  # drop the connection left query_only
    with league.reading() as session:
        assert [a.name for a in list_agents(session)] == ["red", "blue"]


def test_worker_until_idle_on_a_read_only_league_exits_at_once(tmp_path: Path) -> None:
    home = _new_home(tmp_path)
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT)}
    env.pop("ARENA_LEAGUE_DB", None)
    with read_only(home / "league.db"):
        start = time.monotonic()
        done = subprocess.run([sys.executable, "-m", "arena_league.cli", "worker", "--until-idle", "--home",
                               str(home), "--json"], check=False, capture_output=True, text=True, timeout=120, env=env)
        seconds = time.monotonic() - start
    assert done.returncode == 2, done.stderr
    assert json.loads(done.stdout)["kind"] == "ReadOnlyDatabaseError"
    assert "Traceback" not in done.stderr
    assert seconds < 30


# --- a full disk ----------------------------------------------------------------------------------

def test_a_full_disk_is_one_named_error_and_nothing_half_written(sqlite_league: League) -> None:
    add_players(sqlite_league)
    with pytest.raises(DatabaseFullError, match="free some space"), sqlite_league.transaction() as session:
        pages = session.execute(text("PRAGMA page_count")).scalar_one()
        session.execute(text(f"PRAGMA max_page_count = {pages + 2}"))
        for index in range(200):
            create_agent(session, f"big-{index}", GAME_ID, "scripted", metadata={"pad": "x" * 4000})
    sqlite_league.close()  # drop the connection that carries the page limit
    with sqlite_league.reading() as session:
        assert [a.name for a in list_agents(session)] == ["red", "blue"]


# --- a damaged file -------------------------------------------------------------------------------

def _league_with_matches(home: Path, n_matches: int) -> Path:
    with open_league(home=home) as league:
        first, second = add_players(league)
        seats = [SeatResult(first, 0, 1.0, "win"), SeatResult(first, 0, 1.0, "win"),
                 SeatResult(second, 1, 0.0, "loss"), SeatResult(second, 1, 0.0, "loss")]
        for start in range(0, n_matches, 500):
            with league.transaction() as session:
                record_matches(session, GAME_ID, [MatchRecord(f"m{k}", k, seats)
                                                  for k in range(start, min(n_matches, start + 500))])
    return home / "league.db"


def test_a_damaged_page_is_refused_with_the_fix_and_the_file_left_alone(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    database = _league_with_matches(tmp_path / "home", 300)
    page_size = int.from_bytes(database.read_bytes()[16:18], "big")
    engine = create_engine(f"sqlite:///{database}")
    with engine.connect() as connection:
        root = connection.exec_driver_sql("SELECT rootpage FROM sqlite_master WHERE name = 'match_seats'").scalar()
    engine.dispose()
    with database.open("r+b") as handle:  # garbage over the match_seats table's root page
        handle.seek((root - 1) * page_size)
        handle.write(bytes((i * 7 + 3) % 256 for i in range(page_size)))
    before = _digest(database)

    with pytest.raises(CorruptDatabaseError, match=r"\.recover"):
        open_league(home=tmp_path / "home")
    code, doc, err = _cli(capsys, "agents", "--home", str(tmp_path / "home"), "--json")

    assert code == 2 and doc is not None and doc["kind"] == "CorruptDatabaseError"
    assert "restore it from a backup" in doc["error"].lower() and "Traceback" not in err
    assert _digest(database) == before


def test_an_intact_league_passes_its_integrity_check(tmp_path: Path) -> None:
    database = _league_with_matches(tmp_path / "home", 50)
    with open_league(home=tmp_path / "home") as league, league.reading() as session:
        assert len({r["match_id"] for r in match_seat_rows(session, GAME_ID)}) == 50
    assert database.exists()


# --- a worker facing a broken database -----------------------------------------------------------

def _failing_claims(monkeypatch: pytest.MonkeyPatch, error: Exception) -> list[float]:
    calls: list[float] = []

    def claim(*args: object, **kwargs: object) -> None:
        calls.append(time.monotonic())
        raise error

    monkeypatch.setattr(jobs_module, "claim_job", claim)
    return calls


@pytest.mark.parametrize("until_idle, attempts", [(True, jobs_module.DB_FAILURES_UNTIL_IDLE),
                                                  (False, jobs_module.DB_FAILURES_LONG_RUNNING)])
def test_a_worker_backs_off_then_gives_up_on_a_failing_database(
        sqlite_league: League, monkeypatch: pytest.MonkeyPatch, until_idle: bool, attempts: int) -> None:
    locked = OperationalError("UPDATE jobs ...", {}, Exception("database is locked"))
    calls = _failing_claims(monkeypatch, locked)
    with pytest.raises(WorkerGaveUpError, match=f"after {attempts} failed attempts.*database is locked"):
        run_worker(sqlite_league, {}, poll_seconds=0.002, until_idle=until_idle)
    assert len(calls) == attempts
    gaps = [b - a for a, b in itertools.pairwise(calls)]
    assert gaps[-1] > gaps[0]  # each pause longer than the one before


def test_a_worker_stops_at_once_on_a_read_only_database(sqlite_league: League,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    calls = _failing_claims(monkeypatch, ReadOnlyDatabaseError("the league database x is read-only; chmod u+w"))
    with pytest.raises(ReadOnlyDatabaseError):
        run_worker(sqlite_league, {}, poll_seconds=0.01)
    assert len(calls) == 1


# --- one agent per (game, bytes) ------------------------------------------------------------------

def test_the_same_bytes_registered_twice_at_once_make_one_agent(league: League) -> None:
    """The first writer inserts and holds its transaction open; the second, started meanwhile,
    is told the bytes are the first's once that commits (PostgreSQL: by the unique index, the
    check before its insert having seen nothing; SQLite: by that check, after the write lock)."""
    with league.transaction() as session:
        ensure_game(session, GAME_ID)
        digest = store_artifact(session, league.home, b"twin weights", "onnx").sha256
    inserted, outcome = threading.Event(), {}

    def first() -> None:
        with league.transaction() as session:
            create_agent(session, "castor", GAME_ID, "submission", artifact_sha256=digest)
            inserted.set()
            time.sleep(0.5)  # the second writer reaches its insert meanwhile

    def second() -> None:
        inserted.wait(10)
        try:
            with league.transaction() as session:
                create_agent(session, "pollux", GAME_ID, "submission", artifact_sha256=digest)
            outcome["created"] = True
        except ArtifactTakenError as error:
            outcome["error"] = error

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(30)

    assert "created" not in outcome
    assert outcome["error"].agent == "castor" and outcome["error"].requested == "pollux"
    assert "already agent 'castor'" in str(outcome["error"])
    with league.reading() as session:
        assert [a.name for a in find_agents_by_artifact(session, digest)] == ["castor"]


def test_agents_without_artifact_may_share_a_game(league: League) -> None:
    add_players(league, names=("red", "blue", "green"))
    with league.reading() as session:
        assert len(list_agents(session, game_id=GAME_ID)) == 3


def _upgrade_over_duplicates(url: str, home: Path) -> None:
    """A league at schema 0002 whose agents table holds the same bytes three times in one game."""
    from alembic import command

    command.upgrade(alembic_config(url=url), "0002")
    engine = create_engine(url)
    with Session(engine) as session, session.begin():
        ensure_game(session, GAME_ID)
        ensure_game(session, "GoBang-2T1P-v1")
        digest = store_artifact(session, home, b"copied weights", "onnx").sha256
        for name, game in (("original", GAME_ID), ("copy-1", GAME_ID), ("other-game", "GoBang-2T1P-v1"),
                           ("copy-2", GAME_ID)):
            session.add(Agent(name=name, game_id=game, kind="submission", status="active",
                              artifact_sha256=digest, meta={"note": name}))
            session.flush()
    engine.dispose()


@pytest.mark.parametrize("backend", ["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def test_migration_keeps_the_oldest_duplicate_and_retires_the_others(
        request: pytest.FixtureRequest, tmp_path: Path, backend: str) -> None:
    home = tmp_path / "home"
    home.mkdir()
    url = request.getfixturevalue("pg_url") if backend == "postgresql" else f"sqlite:///{home / 'league.db'}"
    _upgrade_over_duplicates(url, home)

    with open_league(url, home=home) as league, league.reading() as session:
        agents = {a.name: a for a in list_agents(session)}
        digest = agents["original"].artifact_sha256
        assert agents["original"].status == "active" and digest is not None
        assert agents["other-game"].artifact_sha256 == digest  # another game: not a duplicate
        for name in ("copy-1", "copy-2"):
            assert agents[name].status == "retired" and agents[name].artifact_sha256 is None
            assert agents[name].meta == {"note": name, "duplicate_of": "original", "artifact_sha256": digest}
        with pytest.raises(ArtifactTakenError, match="already agent 'original'"):
            create_agent(session, "copy-3", GAME_ID, "submission", artifact_sha256=digest)


# --- overlapping evaluations ----------------------------------------------------------------------

def _pair_counts(league: League, game_id: str) -> Counter[frozenset[str]]:
    with league.reading() as session:
        rows = match_seat_rows(session, game_id)
    seats: dict[int, set[str]] = {}
    for row in rows:
        seats.setdefault(row["match_id"], set()).add(row["agent"])
    return Counter(frozenset(agents) for agents in seats.values())


def test_overlapping_evaluations_give_each_pair_exactly_what_was_asked(league: League) -> None:
    from arena_league.league.service import ensure_scripted_agents, job_handlers, queue_evaluation

    game = "GoBang-2T1P-v1"
    first, second = ensure_scripted_agents(league, game)
    with league.transaction() as session:
        create_agent(session, "third", game, "scripted", status="active", metadata={"scripted": "random"})
    trio = [first, second, "third"]
    # two jobs over one shared pair, run at once by two workers
    queue_evaluation(league, game, trio, matches_per_pair=3, seed=1)
    queue_evaluation(league, game, [first, second], matches_per_pair=3, seed=2)
    urls = league.engine.url.render_as_string(hide_password=False)
    errors: list[BaseException] = []

    def work() -> None:
        try:
            with open_league(urls, home=league.home) as own:
                run_worker(own, job_handlers(), poll_seconds=0.02, until_idle=True, max_jobs=1)
        except BaseException as error:
            errors.append(error)

    workers = [threading.Thread(target=work) for _ in range(2)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(300)
    assert errors == []
    assert _pair_counts(league, game) == {frozenset(p): 3 for p in
                                          ((first, second), (first, "third"), (second, "third"))}

    # then back to back: a higher target topped up once, not twice
    queue_evaluation(league, game, [first, second], matches_per_pair=5, seed=3)
    queue_evaluation(league, game, trio, matches_per_pair=5, seed=4)
    report = run_worker(league, job_handlers(), poll_seconds=0.02, until_idle=True)
    assert report.completed == 2
    assert _pair_counts(league, game) == {frozenset(p): 5 for p in
                                          ((first, second), (first, "third"), (second, "third"))}
