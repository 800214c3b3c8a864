"""Per-owner quotas: the jobs one owner may hold (``jobs.live_per_owner``) and the uploads one owner
may make in an hour (``web.uploads_per_hour``), each checked and queued in one step under the
owner's lock, so concurrent requests (threads here, each with a league of its own as separate
servers have, and real HTTP to a real ``serve``) cannot together pass the limit; on SQLite and
on PostgreSQL."""

from __future__ import annotations

import io
import threading
from collections import Counter
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from datetime import datetime
from pathlib import Path

import httpx
import pytest
from web_helpers import running_server

from arena_league import registry as reg
from arena_league.envs.games.crossroads import CASE_STUDY_TREES
from arena_league.league import (
    Identity,
    RateLimitedError,
    cancel_job,
    open_home,
    queue_preview,
    queue_verify,
    set_setting,
    upload_agent,
)

pytest_plugins = ["registry_fixtures"]  # pg_url

GAME = "Crossroads-2T2P-v1"
TREE = CASE_STUDY_TREES["CL_under_CP"]
ALICE, BOB = Identity("alice"), Identity("bob")
ROOT = Identity("root", admin=True)
CONCURRENT = 20


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def where(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[tuple[Path, str | None]]:
    """(home, database URL) of a new league: its home's SQLite file, or a PostgreSQL schema of its own."""
    url = request.getfixturevalue("pg_url") if request.param == "postgresql" else None
    home = tmp_path / "home"
    open_home(home, url).close()
    yield home, url


def at_once(where: tuple[Path, str | None], attempt: Callable[[reg.League, int], object]) -> Counter[str]:
    """Run ``attempt`` in CONCURRENT threads released together, each on a league of its own (as
    separate servers are); how many succeeded and how many were refused for their rate."""
    gate = threading.Barrier(CONCURRENT)

    def one(index: int) -> str:
        with open_home(*where) as league:
            gate.wait()
            try:
                attempt(league, index)
            except RateLimitedError:
                return "refused"
            return "accepted"

    with ThreadPoolExecutor(CONCURRENT) as pool:
        return Counter(pool.map(one, range(CONCURRENT)))


def live_jobs_of(where: tuple[Path, str | None], owner: str) -> int:
    with open_home(*where) as league, league.reading() as session:
        return reg.count_live_jobs(session, owner)


def test_an_owner_past_the_quota_is_refused_until_their_jobs_end(tmp_path: Path) -> None:
    with open_home(tmp_path / "home") as league:
        set_setting(league, "jobs.live_per_owner", 3)
        jobs = [queue_verify(league, GAME, TREE, samples=4, who=ALICE) for _ in range(2)]
        jobs.append(queue_preview(league, GAME, TREE, who=ALICE))  # every kind counts
        with pytest.raises(RateLimitedError, match=r"alice already has 3 jobs .*jobs\.live_per_owner.*jobs cancel"):
            queue_verify(league, GAME, TREE, samples=4, who=ALICE)
        queue_verify(league, GAME, TREE, samples=4, who=BOB)  # another owner's quota is their own
        for _ in range(4):  # the league's operator is not limited
            queue_verify(league, GAME, TREE, samples=4, who=ROOT)
        cancel_job(league, jobs[0])
        queue_verify(league, GAME, TREE, samples=4, who=ALICE)
        with league.reading() as session:
            owners = Counter(job.owner for job in reg.list_jobs(session, status="queued"))
    assert owners == {"alice": 3, "bob": 1, "root": 4}


def test_concurrent_requests_cannot_pass_the_job_quota(where: tuple[Path, str | None]) -> None:
    with open_home(*where) as league:
        set_setting(league, "jobs.live_per_owner", 5)
    outcome = at_once(where, lambda league, i: queue_verify(league, GAME, TREE, samples=4, seed=i, who=ALICE))
    assert outcome == {"accepted": 5, "refused": CONCURRENT - 5}
    assert live_jobs_of(where, "alice") == 5


def test_concurrent_uploads_cannot_pass_the_hourly_limit(where: tuple[Path, str | None]) -> None:
    with open_home(*where) as league:
        set_setting(league, "web.uploads_per_hour", 5)  # below jobs.live_per_owner: the hourly limit is under test

    def upload(league: reg.League, index: int) -> object:
        return upload_agent(league, ALICE, GAME, f"hasty{index}", [("model.onnx", io.BytesIO(b"not yet validated"))])

    outcome = at_once(where, upload)
    assert outcome == {"accepted": 5, "refused": CONCURRENT - 5}
    with open_home(*where) as league, league.reading() as session:
        assert reg.count_agents_since(session, "alice", datetime(2000, 1, 1)) == 5  # noqa: DTZ001 - stored naive UTC
    assert len(list((where[0] / "uploads").iterdir())) == 5  # the refused uploads kept no files


@pytest.mark.slow
def test_concurrent_http_uploads_and_verifications_keep_to_the_limits(tmp_path: Path) -> None:
    with running_server(tmp_path / "home", workers=0) as server:
        server.command("settings", "set", "web.uploads_per_hour", "5")
        # the uploads in flight have limits of their own (the front door's): here all 20 may stream at once
        server.command("settings", "set", "web.uploads_in_flight_per_owner", str(CONCURRENT))
        server.command("settings", "set", "web.uploads_in_flight", str(CONCURRENT))
        headers = {"Authorization": f"Bearer {server.token('alice')}"}
        gate = threading.Barrier(CONCURRENT)

        def post(index: int) -> int:
            with httpx.Client(base_url=server.url, headers=headers, timeout=60) as client:
                gate.wait()
                return client.post("/api/agents", data={"game": GAME, "name": f"hasty{index}"},
                                   files=[("file", ("model.onnx", b"not yet validated"))]).status_code

        with ThreadPoolExecutor(CONCURRENT) as pool:
            assert Counter(pool.map(post, range(CONCURRENT))) == {202: 5, 429: CONCURRENT - 5}
        # no worker runs: the 5 validations stay queued, and count against the default quota of 10 jobs
        with httpx.Client(base_url=server.url, headers=headers, timeout=60) as client:
            verify = {"game": GAME, "spec": TREE, "samples": 4}
            assert [client.post("/api/trees/verify", json=verify).status_code for _ in range(5)] == [202] * 5
            refused = client.post("/api/trees/verify", json=verify)
        assert refused.status_code == 429 and "jobs.live_per_owner" in refused.json()["detail"]
