"""Schedules: intervals and cron expressions, one job per due time, and concurrent ticks."""

from __future__ import annotations

import threading
from datetime import UTC, datetime, timedelta

import pytest

from arena_league.registry import (
    InvalidScheduleError,
    League,
    NameTakenError,
    Schedule,
    add_schedule,
    get_schedule,
    list_jobs,
    list_schedules,
    remove_schedule,
    run_scheduler,
    set_schedule_enabled,
    tick,
)

pytest_plugins = ["registry_fixtures"]  # the league, pg_url, ... fixtures

T0 = datetime(2025, 3, 1, 12, 3, tzinfo=UTC)


def _add(league: League, name: str, **options: object) -> Schedule:
    with league.transaction() as session:
        return add_schedule(session, name, "evaluate", {"game_id": "Crossroads-2T2P-v1"}, now=T0, **options)


def _next_run(league: League, name: str) -> datetime:
    with league.reading() as session:
        return get_schedule(session, name).next_run_at


def test_an_interval_schedule_enqueues_once_per_due_time(league: League) -> None:
    schedule = _add(league, "hourly-ish", interval_seconds=60, priority=3)
    assert schedule.next_run_at == T0  # an interval schedule first runs at once

    assert len(tick(league, T0)) == 1
    assert tick(league, T0) == []  # the same due time is not enqueued twice
    assert tick(league, T0 + timedelta(seconds=59)) == []
    assert len(tick(league, T0 + timedelta(seconds=60))) == 1
    assert _next_run(league, "hourly-ish") == T0 + timedelta(seconds=120)

    # Ten missed runs coalesce into one job, and the schedule keeps its phase.
    assert len(tick(league, T0 + timedelta(seconds=725))) == 1
    assert _next_run(league, "hourly-ish") == T0 + timedelta(seconds=780)

    with league.reading() as session:
        jobs = list_jobs(session)
        assert [(j.kind, j.payload, j.priority, j.schedule_id) for j in jobs] == [
            ("evaluate", {"game_id": "Crossroads-2T2P-v1"}, 3, schedule.id)
        ] * 3
        assert get_schedule(session, "hourly-ish").last_run_at == T0 + timedelta(seconds=725)


def test_a_cron_schedule_enqueues_at_its_times(league: League) -> None:
    _add(league, "every-5-min", cron="*/5  *  * * *")
    assert _next_run(league, "every-5-min") == datetime(2025, 3, 1, 12, 5, tzinfo=UTC)

    moments = [(12, 4, 0), (12, 5, 0), (12, 5, 0), (12, 7, 0), (12, 10, 30)]
    fired = [len(tick(league, datetime(2025, 3, 1, h, m, s, tzinfo=UTC))) for h, m, s in moments]
    assert fired == [0, 1, 0, 0, 1]
    assert _next_run(league, "every-5-min") == datetime(2025, 3, 1, 12, 15, tzinfo=UTC)
    with league.reading() as session:
        assert len(list_jobs(session)) == 2  # 12:05 and 12:10
        assert get_schedule(session, "every-5-min").cron == "*/5 * * * *"


def test_a_nightly_cron_schedule_runs_once_a_day(league: League) -> None:
    _add(league, "nightly", cron="0 3 * * *")
    assert _next_run(league, "nightly") == datetime(2025, 3, 2, 3, 0, tzinfo=UTC)
    counts = [len(tick(league, datetime(2025, 3, 2, hour, 0, tzinfo=UTC))) for hour in (2, 3, 3, 4)]
    assert counts == [0, 1, 0, 0]
    assert _next_run(league, "nightly") == datetime(2025, 3, 3, 3, 0, tzinfo=UTC)


def test_bad_schedules_are_refused_with_the_expected_form(league: League) -> None:
    refusals = {
        "is not valid": {"cron": "61 * * * *"},
        "has 6 fields": {"cron": "0 0 3 * * *"},
        "'0 3 \\* \\* \\*' for 03:00": {"cron": "every night"},
        "not both": {"cron": "0 3 * * *", "interval_seconds": 60},
        "not neither": {},
        "above 0": {"interval_seconds": 0},
    }
    for reason, options in refusals.items():
        with pytest.raises(InvalidScheduleError, match=reason):
            _add(league, "bad", **options)
    _add(league, "nightly", cron="0 3 * * *")
    with pytest.raises(NameTakenError, match="'nightly-2'"):
        _add(league, "nightly", interval_seconds=60)
    with league.reading() as session:
        assert [s.name for s in list_schedules(session)] == ["nightly"]


def test_paused_and_removed_schedules_enqueue_nothing(league: League) -> None:
    _add(league, "paused", interval_seconds=60)
    _add(league, "removed", interval_seconds=60)
    with league.transaction() as session:
        set_schedule_enabled(session, "paused", False)
        remove_schedule(session, "removed")
    assert tick(league, T0 + timedelta(hours=1)) == []
    with league.transaction() as session:
        set_schedule_enabled(session, "paused", True)
    assert len(tick(league, T0 + timedelta(hours=1))) == 1


def test_ticks_at_the_same_moment_enqueue_each_due_run_once(league: League) -> None:
    for index in range(3):
        _add(league, f"schedule-{index}", interval_seconds=300)
    barrier = threading.Barrier(6)
    enqueued: list[int] = []

    def race() -> None:
        barrier.wait()
        enqueued.extend(tick(league, T0 + timedelta(seconds=1)))

    threads = [threading.Thread(target=race) for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    with league.reading() as session:
        jobs = list_jobs(session)
    assert len(jobs) == 3 and sorted(enqueued) == sorted(job.id for job in jobs)
    with league.reading() as session:
        assert sorted(job.schedule_id for job in jobs) == sorted(s.id for s in list_schedules(session))


def test_the_scheduler_loop_ticks_until_stopped(league: League) -> None:
    _add(league, "often", interval_seconds=3600, start_at=datetime.now(UTC) - timedelta(seconds=1))
    assert run_scheduler(league, poll_seconds=0.01, max_ticks=3) == 1
    stop = threading.Event()
    stop.set()
    assert run_scheduler(league, stop_event=stop) == 0
