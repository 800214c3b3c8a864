"""Registry records: games, artifacts, agents, populations, matches and rating snapshots."""

from __future__ import annotations

import hashlib
import math
import threading
import time
from pathlib import Path

import pytest
from registry_fixtures import GAME_ID, add_players, two_team_seats
from sqlalchemy import func, select

from arena_league.registry import (
    Agent,
    Artifact,
    ArtifactError,
    ArtifactTooLargeError,
    GameMismatchError,
    InvalidRecordError,
    League,
    Match,
    MatchKeyConflictError,
    MatchRecord,
    MatchSeat,
    NameTakenError,
    PopulationFrozenError,
    RatingRow,
    SeatResult,
    UnknownAgentError,
    UnknownGameError,
    add_population_member,
    artifact_path,
    count_matches,
    create_agent,
    create_population,
    ensure_game,
    find_agents_by_artifact,
    freeze_population,
    get_match,
    get_population,
    latest_rating_snapshot,
    list_agents,
    list_matches,
    record_match,
    record_matches,
    require_agent,
    require_game,
    set_agent_status,
    store_artifact,
    verify_artifact,
    write_rating_snapshot,
)

pytest_plugins = ["registry_fixtures"]  # the league, pg_url, ... fixtures


def _agent_rows(league: League) -> list[tuple[object, ...]]:
    with league.reading() as session:
        return [tuple(row) for row in session.execute(select(Agent.__table__).order_by(Agent.id))]


def _count(league: League, model: type) -> int:
    with league.reading() as session:
        return int(session.scalar(select(func.count()).select_from(model)) or 0)


# ----------------------------------------------------------------------------------------- games


def test_games_take_their_team_sizes_from_the_arena_id(league: League) -> None:
    with league.transaction() as session:
        game = ensure_game(session, "Soccer-2T2P-v1")
        assert (game.n_teams, game.players_per_team) == (2, 2)
        assert ensure_game(session, "Soccer-2T2P-v1").id == game.id  # idempotent
        assert ensure_game(session, "Tag", 4, 1).n_teams == 4
        with pytest.raises(InvalidRecordError, match="says 2 teams of 2"):
            ensure_game(session, "Soccer-2T2P-v2", 3, 2)
        with pytest.raises(InvalidRecordError, match="pass n_teams"):
            ensure_game(session, "Tennis")
        with pytest.raises(GameMismatchError, match="4 teams of 1"):
            ensure_game(session, "Tag", 2, 2)
        with pytest.raises(UnknownGameError, match="did you mean 'Soccer-2T2P-v1'"):
            require_game(session, "Socer-2T2P-v1")


# ------------------------------------------------------------------------------------- artifacts


def test_artifacts_are_stored_once_by_content(league: League) -> None:
    weights = b"\x08\x07onnx-bytes" * 1000
    with league.transaction() as session:
        artifact = store_artifact(session, league.home, weights, "onnx")
        again = store_artifact(session, league.home, weights, "onnx")
    sha = hashlib.sha256(weights).hexdigest()
    assert artifact.sha256 == again.sha256 == sha
    assert artifact.path == f"artifacts/{sha[:2]}/{sha}.onnx"
    assert artifact_path(league.home, artifact).read_bytes() == weights
    assert artifact.size_bytes == len(weights)
    assert _count(league, Artifact) == 1
    assert list((league.home / "artifacts" / ".incoming").iterdir()) == []  # no leftovers


def test_artifacts_from_a_file_and_from_an_arena_policy_folder(league: League, tmp_path: Path) -> None:
    model = tmp_path / "agent.onnx"
    model.write_bytes(b"model" * 4000)
    policy = tmp_path / "policy"
    (policy / "extra").mkdir(parents=True)
    (policy / "manifest.json").write_text('{"family": "MLP"}')
    (policy / "weights.safetensors").write_bytes(b"\x00" * 512)
    (policy / "extra" / "notes.txt").write_text("trained with PPO")
    with league.transaction() as session:
        from_file = store_artifact(session, league.home, model, "onnx")
        from_folder = store_artifact(session, league.home, policy, "arena-policy")
        assert store_artifact(session, league.home, model.read_bytes(), "onnx").sha256 == from_file.sha256

    assert from_file.sha256 == hashlib.sha256(model.read_bytes()).hexdigest()
    # The folder's address is the SHA-256 of its `sha256sum`-style listing, sorted by path.
    listing = "".join(
        f"{hashlib.sha256((policy / name).read_bytes()).hexdigest()}  {name}\n"
        for name in sorted(["manifest.json", "weights.safetensors", "extra/notes.txt"])
    )
    assert from_folder.sha256 == hashlib.sha256(listing.encode()).hexdigest()
    stored = artifact_path(league.home, from_folder)
    assert (stored / "extra" / "notes.txt").read_text() == "trained with PPO"
    assert from_folder.size_bytes == 512 + len('{"family": "MLP"}') + len("trained with PPO")
    verify_artifact(league.home, from_folder)
    verify_artifact(league.home, from_file)

    (stored / "manifest.json").write_text('{"family": "GRU"}')  # tampering is noticed
    with pytest.raises(ArtifactError, match="no longer matches"):
        verify_artifact(league.home, from_folder)


def test_a_folder_with_a_link_is_refused(sqlite_league: League, tmp_path: Path) -> None:
    policy = tmp_path / "policy"
    policy.mkdir()
    (policy / "manifest.json").write_text("{}")
    (policy / "weights.safetensors").symlink_to("/etc/passwd")
    with pytest.raises(ArtifactError, match="holds a link"), sqlite_league.transaction() as session:
        store_artifact(session, sqlite_league.home, policy, "arena-policy")
    assert _count(sqlite_league, Artifact) == 0


def test_a_2gb_artifact_is_refused_before_it_is_read(sqlite_league: League, tmp_path: Path) -> None:
    huge = tmp_path / "huge.onnx"
    with huge.open("wb") as handle:  # sparse: 2 GiB long, nothing on disk
        handle.truncate(2 * 1024**3)
    started = time.perf_counter()
    refused = pytest.raises(ArtifactTooLargeError, match="2147483648 bytes, over the limit")
    with refused, sqlite_league.transaction() as session:
        store_artifact(session, sqlite_league.home, huge, "onnx", max_bytes=64 * 1024**2)
    assert time.perf_counter() - started < 1.0  # reading 2 GiB would take far longer
    assert _count(sqlite_league, Artifact) == 0
    stored = [p for p in (sqlite_league.home / "artifacts").rglob("*") if p.is_file()]
    assert stored == []


def test_the_same_content_cannot_change_format(sqlite_league: League) -> None:
    with sqlite_league.transaction() as session:
        store_artifact(session, sqlite_league.home, b'{"script": "random"}', "scripted")
        with pytest.raises(InvalidRecordError, match="already stored as format 'scripted'"):
            store_artifact(session, sqlite_league.home, b'{"script": "random"}', "onnx")
        with pytest.raises(InvalidRecordError, match="unknown artifact format 'pickle'"):
            store_artifact(session, sqlite_league.home, b"\x80\x04", "pickle")


# ---------------------------------------------------------------------------------------- agents


def test_an_agent_name_already_taken_is_refused_and_nothing_changes(league: League) -> None:
    with league.transaction() as session:
        ensure_game(session, GAME_ID)
        first = store_artifact(session, league.home, b"alice weights v3", "onnx")
        create_agent(session, "alice-v3", GAME_ID, "submission", owner="alice", artifact_sha256=first.sha256)
        fourth = store_artifact(session, league.home, b"alice weights v4", "onnx")
        create_agent(session, "alice-v4", GAME_ID, "submission", owner="alice", artifact_sha256=fourth.sha256)
        second = store_artifact(session, league.home, b"mallory weights", "onnx")
    agents_before = _agent_rows(league)

    with pytest.raises(NameTakenError) as refusal, league.transaction() as session:
        create_agent(
            session, "alice-v3", GAME_ID, "submission", owner="mallory", artifact_sha256=second.sha256
        )

    error = refusal.value
    assert error.name == "alice-v3"
    assert "submission agent #1 owned by alice" in str(error)
    assert error.suggestion == "alice-v5"  # alice-v4 is taken too
    assert "choose another name, for example 'alice-v5'" in str(error)
    assert _agent_rows(league) == agents_before
    with league.reading() as session:
        assert require_agent(session, "alice-v3").owner == "alice"
        assert find_agents_by_artifact(session, second.sha256) == []


def test_agents_need_a_known_game_a_valid_name_and_weights(league: League) -> None:
    add_players(league)
    with league.transaction() as session:
        with pytest.raises(UnknownGameError, match="registered games: Crossroads-2T2P-v1"):
            create_agent(session, "bob", "GoBang-2T1P-v1", "scripted")
        with pytest.raises(InvalidRecordError, match="is not allowed"):
            create_agent(session, "bob smith", GAME_ID, "scripted")
        with pytest.raises(InvalidRecordError, match="needs an artifact"):
            create_agent(session, "bob", GAME_ID, "submission")
        with pytest.raises(InvalidRecordError, match="not in the store"):
            create_agent(session, "bob", GAME_ID, "submission", artifact_sha256="ab" * 32)
        with pytest.raises(InvalidRecordError, match="unknown agent kind 'wizard'"):
            create_agent(session, "bob", GAME_ID, "wizard")
        with pytest.raises(UnknownAgentError, match="did you mean 'red'"):
            require_agent(session, "redd")
    assert len(_agent_rows(league)) == 2


def test_agent_status_keeps_the_reason_and_log_of_a_rejection(league: League) -> None:
    add_players(league, names=("entrant",))
    log = "probe 3: logits contain NaN\nvalidation match: not played"
    with league.transaction() as session:
        with pytest.raises(InvalidRecordError, match="needs a reason"):
            set_agent_status(session, "entrant", "rejected")
        set_agent_status(session, "entrant", "rejected", reason="outputs NaN on probe observations", log=log)
    with league.reading() as session:
        agent = require_agent(session, "entrant")
        assert (agent.status, agent.reject_reason, agent.validation_log) == (
            "rejected",
            "outputs NaN on probe observations",
            log,
        )
        assert [a.name for a in list_agents(session, status="rejected")] == ["entrant"]
    with league.transaction() as session:
        set_agent_status(session, "entrant", "active")
    with league.reading() as session:
        agent = require_agent(session, "entrant")
        assert (agent.status, agent.reject_reason, agent.validation_log) == ("active", None, log)


# --------------------------------------------------------------------------------------- matches


def test_a_match_is_recorded_once_per_key(league: League) -> None:
    red, blue = add_players(league)
    with league.transaction() as session:
        match, created = record_match(
            session, GAME_ID, "eval-1/0", 41, two_team_seats(red, blue), job_id=None
        )
    with league.transaction() as session:
        again, created_again = record_match(session, GAME_ID, "eval-1/0", 41, two_team_seats(red, blue))
    assert (created, created_again) == (True, False)
    assert again.id == match.id
    assert [(s.seat, s.agent_id, s.team, s.outcome) for s in again.seats] == [
        (0, red, 0, "win"),
        (1, red, 0, "win"),
        (2, blue, 1, "loss"),
        (3, blue, 1, "loss"),
    ]
    assert (_count(league, Match), _count(league, MatchSeat)) == (1, 4)

    with pytest.raises(MatchKeyConflictError, match="eval-1/0"), league.transaction() as session:
        record_match(session, GAME_ID, "eval-1/0", 42, two_team_seats(red, blue))
    assert (_count(league, Match), _count(league, MatchSeat)) == (1, 4)


def test_matches_are_recorded_in_batches_once_per_key(league: League) -> None:
    red, blue = add_players(league)
    batch = [
        MatchRecord(f"rr/{index}", index, two_team_seats(red, blue, index % 3 == 0)) for index in range(1200)
    ]
    with league.transaction() as session:
        record_matches(session, GAME_ID, batch[100:300], job_id=None)  # an earlier, partial attempt
    with league.transaction() as session:
        recorded = record_matches(session, GAME_ID, batch)
    assert [r.match_key for r in recorded] == [m.match_key for m in batch]
    assert [r.created for r in recorded] == [not 100 <= index < 300 for index in range(1200)]
    assert len({r.match_id for r in recorded}) == 1200
    assert (_count(league, Match), _count(league, MatchSeat)) == (1200, 4800)
    with league.reading() as session:
        assert [s.outcome for s in get_match(session, "rr/3").seats] == ["win", "win", "loss", "loss"]
        assert [s.outcome for s in get_match(session, "rr/4").seats] == ["loss", "loss", "win", "win"]

    # One conflicting match refuses the whole batch: nothing of it is stored.
    clash = [
        MatchRecord("rr/new-1", 1, two_team_seats(red, blue)),
        MatchRecord("rr/7", 8, two_team_seats(red, blue)),
    ]
    with pytest.raises(MatchKeyConflictError, match="'rr/7'"), league.transaction() as session:
        record_matches(session, GAME_ID, clash)
    with pytest.raises(InvalidRecordError, match="more than once"), league.transaction() as session:
        record_matches(session, GAME_ID, [batch[0], batch[0]])
    assert (_count(league, Match), _count(league, MatchSeat)) == (1200, 4800)


def test_bad_match_results_are_refused_and_nothing_is_stored(league: League) -> None:
    red, blue = add_players(league)
    with league.transaction() as session:
        ensure_game(session, "GoBang-2T1P-v1")
        stranger = create_agent(session, "stranger", "GoBang-2T1P-v1", "scripted").id
    bad = {
        "on team 2": [SeatResult(red, 0, 1.0, "win"), SeatResult(blue, 2, 0.0, "loss")],
        "scores must be finite": [SeatResult(red, 0, math.nan, "win"), SeatResult(blue, 1, 0.0, "loss")],
        "unknown outcome": [SeatResult(red, 0, 1.0, "victory"), SeatResult(blue, 1, 0.0, "loss")],
        "which plays GoBang": [SeatResult(red, 0, 1.0, "win"), SeatResult(stranger, 1, 0.0, "loss")],
        "not registered": [SeatResult(red, 0, 1.0, "win"), SeatResult(9999, 1, 0.0, "loss")],
        "no seats": [],
    }
    for reason, seats in bad.items():
        with pytest.raises(InvalidRecordError, match=reason), league.transaction() as session:
            record_match(session, GAME_ID, f"bad/{reason}", 1, seats)
    with pytest.raises(InvalidRecordError, match="modulo 2"), league.transaction() as session:
        record_match(session, GAME_ID, "bad/seed", 2**64 - 1, two_team_seats(red, blue))
    assert (_count(league, Match), _count(league, MatchSeat)) == (0, 0)


def test_concurrent_recordings_of_one_match_store_it_once(league: League) -> None:
    red, blue = add_players(league)
    barrier = threading.Barrier(6)
    created: list[bool] = []

    def record() -> None:
        barrier.wait()
        with league.transaction() as session:
            created.append(record_match(session, GAME_ID, "race/0", 5, two_team_seats(red, blue))[1])

    threads = [threading.Thread(target=record) for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(created) == [False] * 5 + [True]
    assert (_count(league, Match), _count(league, MatchSeat)) == (1, 4)


def test_matches_are_listed_by_game_and_agent(league: League) -> None:
    red, blue, green = add_players(league, names=("red", "blue", "green"))
    with league.transaction() as session:
        for index, (first, second) in enumerate([(red, blue), (blue, green), (red, green)]):
            record_match(session, GAME_ID, f"rr/{index}", index, two_team_seats(first, second))
    with league.reading() as session:
        assert [m.match_key for m in list_matches(session, GAME_ID)] == ["rr/0", "rr/1", "rr/2"]
        assert [m.match_key for m in list_matches(session, GAME_ID, agent_id=green)] == ["rr/1", "rr/2"]
        first_page = list_matches(session, GAME_ID, limit=2)
        rest = list_matches(session, GAME_ID, after_id=first_page[-1].id)
        assert [m.match_key for m in rest] == ["rr/2"]
        assert count_matches(session, GAME_ID) == 3 and count_matches(session, "Other-2T1P-v1") == 0
        assert get_match(session, "rr/1").seats[2].agent_id == green


# ----------------------------------------------------------------------------------- populations


def test_populations_are_versioned_and_frozen(league: League) -> None:
    agents = add_players(league, names=("base-000", "base-001", "base-002"))
    with league.transaction() as session:
        population = create_population(session, "base", GAME_ID, provenance={"trainer": "PPO", "seed": 7})
        for index, agent_id in enumerate(agents[:2]):
            member = add_population_member(
                session, population, session.get(Agent, agent_id), {"scheme": "CP", "seed": index}
            )
        assert (
            add_population_member(
                session, population, session.get(Agent, agents[1]), {"scheme": "CP", "seed": 1}
            ).id
            == member.id
        )
        freeze_population(session, population)
    with pytest.raises(PopulationFrozenError, match="create version 2"), league.transaction() as session:
        add_population_member(session, get_population(session, "base"), session.get(Agent, agents[2]))

    with league.transaction() as session:
        second = create_population(session, "base", GAME_ID)
        with pytest.raises(NameTakenError, match="base v1"):
            create_population(session, "base", GAME_ID, version=1)
    assert second.version == 2
    with league.reading() as session:
        first = get_population(session, "base", 1)
        assert first.frozen and first.frozen_at is not None
        assert [(m.agent.name, m.meta["seed"]) for m in first.members] == [("base-000", 0), ("base-001", 1)]
        assert get_population(session, "base").version == 2


# --------------------------------------------------------------------------------------- ratings


def test_the_latest_rating_snapshot_is_read_back(league: League) -> None:
    red, blue = add_players(league)
    with league.transaction() as session:
        write_rating_snapshot(
            session, GAME_ID, "bt", [RatingRow(red, 10.0), RatingRow(blue, -10.0)], scope="all"
        )
        write_rating_snapshot(
            session,
            GAME_ID,
            "bt",
            [
                RatingRow(red, -35.0, -80.0, 10.0, 1, 2, 40),
                RatingRow(blue, 35.0, -10.0, 80.0, 1, 2, 40, {"win_rate": 0.6}),
            ],
            scope="all",
            params={"bootstrap": 200},
        )
        write_rating_snapshot(session, GAME_ID, "elo", [RatingRow(red, 1500.0)], scope="all")
        with pytest.raises(InvalidRecordError, match="twice"):
            write_rating_snapshot(session, GAME_ID, "bt", [RatingRow(red, 1.0), RatingRow(red, 2.0)])
    with league.reading() as session:
        latest = latest_rating_snapshot(session, GAME_ID, "bt", scope="all")
        assert latest.params == {"bootstrap": 200}
        assert [(e.agent_id, e.rating, e.n_matches) for e in latest.entries] == [
            (blue, 35.0, 40),
            (red, -35.0, 40),
        ]
        assert latest.entries[0].extra == {"win_rate": 0.6}
        assert latest_rating_snapshot(session, GAME_ID, "bt") is None  # no unscoped snapshot
        assert latest_rating_snapshot(session, GAME_ID, "nash", scope="all") is None
