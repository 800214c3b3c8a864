"""The job workers ``serve`` runs beside itself, supervised: a worker killed with ``kill -9`` is
logged and started again, and the queue goes on; the workers end when ``serve`` does, even when it
is killed with ``kill -9``, handing a running job back to the queue. A real ``serve`` on loopback
(under the helpers' memory limit), real processes and signals, a SQLite league under tmp_path."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

import hostile_agents as hostile
import pytest
from web_helpers import Server, running_server

from arena_league import registry as reg
from arena_league.league import open_home
from arena_league.web.workers import RESTARTS_PER_MINUTE, SLOW_RESTART_SECONDS, WorkerPool

GAME = "GoBang-2T1P-v1"
linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads processes from /proc")


def running(pid: int) -> bool:
    """Whether ``pid`` is a live process (a zombie, ended but not yet reaped, is not)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "\nState:\tZ" not in status


def workers_of(server: Server) -> set[int]:
    """The pids of the ``arena-league worker`` processes ``serve`` started."""
    found: set[int] = set()
    for task in Path(f"/proc/{server.process.pid}/task").glob("*"):
        with contextlib.suppress(OSError):
            for child in (task / "children").read_text().split():
                with contextlib.suppress(OSError):
                    if b"worker" in Path(f"/proc/{child}/cmdline").read_bytes().split(b"\0") and running(int(child)):
                        found.add(int(child))
    return found


def until(what: str, check: Callable[[], object], seconds: float = 60) -> object:
    """``check()``'s first true answer, looked for until a generous deadline."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        answer = check()
        if answer:
            return answer
        time.sleep(0.1)
    raise AssertionError(f"{what}: not within {seconds} s")


def upload(server: Server, token: str, name: str, tmp_path: Path, seed: int) -> int:
    path = hostile.save(hostile.plain(GAME, seed=seed), tmp_path / f"{name}.onnx")
    with server.client(token) as client:
        answer = client.post("/api/agents", data={"game": GAME, "name": name},
                             files=[("file", ("model.onnx", path.read_bytes()))])
    assert answer.status_code == 202, answer.text
    return answer.json()["job"]


def job_row(server: Server, job_id: int) -> reg.Job:
    with open_home(server.home) as league, league.reading() as session:
        job = reg.get_job(session, job_id)
        session.expunge(job)
        return job


@contextlib.contextmanager
def ending(pids: set[int]):
    """Kill whatever of ``pids`` (processes this test started) is still running at the end."""
    try:
        yield
    finally:
        for pid in pids:
            if running(pid):
                with contextlib.suppress(OSError):
                    os.kill(pid, signal.SIGKILL)


@pytest.mark.slow
@linux_only
def test_a_killed_worker_is_logged_restarted_and_the_queue_goes_on(tmp_path):
    with running_server(tmp_path / "home", workers=1) as server:
        (first,) = until("serve's worker", lambda: workers_of(server))
        os.kill(first, signal.SIGKILL)
        until("a log line naming the dead worker", lambda: f"job worker pid {first} was killed by signal SIGKILL"
              in server.log.read_text())
        (second,) = until("a new worker", lambda: workers_of(server) - {first})
        with server.client() as client:
            health = client.get("/api/health").json()
        assert health["ok"] and health["workers"]["restarts"] == 1 and health["workers"]["alive"] == 1
        job = upload(server, server.token("alice"), "after-the-kill", tmp_path, seed=1)
        assert server.wait_job(job)["result"]["status"] == "active"
        assert workers_of(server) == {second}


@pytest.mark.slow
@linux_only
def test_health_names_the_queue_and_a_server_without_workers(tmp_path):
    with running_server(tmp_path / "home", workers=0) as server:
        upload(server, server.token("alice"), "waits", tmp_path, seed=2)
        with server.client() as client:
            health = client.get("/api/health").json()
    assert health["jobs"] == {"queued": 1, "running": 0}
    assert health["workers"]["started_here"] == 0 and health["workers"]["alive"] == 0
    assert "jobs wait for `arena-league worker` processes started elsewhere" in health["workers"]["note"]
    assert "this server runs no job worker" in server.log.read_text()


@pytest.mark.slow
@linux_only
def test_killing_serve_ends_its_workers_and_hands_their_job_back(tmp_path):
    with running_server(tmp_path / "home", workers=2) as server:
        workers = until("serve's two workers", lambda: len(workers_of(server)) == 2 and workers_of(server))
        with ending(workers):
            job = upload(server, server.token("alice"), "in-flight", tmp_path, seed=3)
            with server.client() as client:
                until("the validation running", lambda: client.get(f"/api/jobs/{job}").json()["state"] == "running")
            server.process.kill()
            server.process.wait()
            until("the orphaned workers ending", lambda: not any(running(pid) for pid in workers), seconds=30)
            row = job_row(server, job)
            assert (row.status, row.lease_owner, row.attempts) == ("queued", None, 0)


@pytest.mark.slow
@linux_only
def test_stopping_serve_stops_its_workers_and_hands_their_job_back(tmp_path):
    with running_server(tmp_path / "home", workers=1) as server:
        workers = until("serve's worker", lambda: workers_of(server))
        with ending(workers):
            job = upload(server, server.token("alice"), "in-flight", tmp_path, seed=4)
            with server.client() as client:
                until("the validation running", lambda: client.get(f"/api/jobs/{job}").json()["state"] == "running")
            server.process.send_signal(signal.SIGINT)
            server.process.wait(timeout=60)
            assert not any(running(pid) for pid in workers)
            row = job_row(server, job)
            assert (row.status, row.lease_owner, row.attempts) == ("queued", None, 0)


def test_restarts_slow_down_past_the_bound_and_go_on(caplog):
    """A worker that dies at once, on an injected clock that stands still: restarted at once
    RESTARTS_PER_MINUTE times, then only once SLOW_RESTART_SECONDS have passed."""
    moment = [0.0]
    pool = WorkerPool([sys.executable, "-c", "raise SystemExit(3)"], 1, clock=lambda: moment[0])
    caplog.set_level(logging.WARNING, logger="arena_league.web.workers")
    try:
        pool.check()  # the first start; a process just started is still running
        assert len(pool.pids()) == 1
        for restart in range(1, RESTARTS_PER_MINUTE + 2):
            until("the worker ending", lambda: pool.alive() == 0, seconds=30)
            pool.check()
            assert pool.restarts == restart
            assert len(pool.pids()) == (1 if restart <= RESTARTS_PER_MINUTE else 0)
        assert "exited with code 3; starting another" in caplog.text
        assert (f"after {RESTARTS_PER_MINUTE} restarts in the last minute; starting another in "
                f"{SLOW_RESTART_SECONDS:.0f} s") in caplog.text
        moment[0] += SLOW_RESTART_SECONDS - 1
        pool.check()
        assert pool.pids() == []
        moment[0] += 1
        pool.check()  # the slow restart is due
        assert len(pool.pids()) == 1
    finally:
        pool.stop()


def test_an_orphaned_worker_hands_its_job_back_at_the_next_lease_renewal(tmp_path, monkeypatch):
    """The portable check (no signal): the worker's parent pid changes while a job runs."""
    league = reg.open_league(None, home=tmp_path / "home")
    with league.transaction() as session:
        job_id = reg.enqueue(session, "wait").id
    parent = [os.getppid()]
    monkeypatch.setattr(os, "getppid", lambda: parent[0])

    def wait(context: reg.JobContext) -> None:
        parent[0] = 1  # serve ended: the worker now belongs to init
        while True:
            context.heartbeat()
            context.raise_if_lease_lost()
            time.sleep(0.01)

    try:
        report = reg.run_worker(league, {"wait": wait}, lease_seconds=0.3, poll_seconds=0.05,
                                parent_pid=os.getppid())
        with league.reading() as session:
            job = reg.get_job(session, job_id)
            assert (job.status, job.lease_owner, job.attempts) == ("queued", None, 0)
        assert report.job_ids == [job_id] and report.completed == 0
        parent[0] = 2
        assert reg.run_worker(league, {"wait": wait}, poll_seconds=0.05, parent_pid=1).job_ids == []
    finally:
        league.close()


# A worker that claims the queued job and then neither stops on SIGTERM nor hands the job back.
_STUCK_WORKER = """
import signal, sys, time
from arena_league import registry as reg
signal.signal(signal.SIGTERM, signal.SIG_IGN)
league = reg.open_league(None, home=sys.argv[1])
job = reg.claim_job(league, reg.default_worker_id(), lease_seconds=3600)
print("claimed", job.id, flush=True)
time.sleep(600)
"""


@linux_only
def test_a_worker_killed_on_the_stop_has_its_job_handed_back_by_its_supervisor(tmp_path, monkeypatch):
    home = tmp_path / "home"
    league = reg.open_league(None, home=home)
    with league.transaction() as session:
        other_id = reg.enqueue(session, "wait").id
    assert reg.claim_job(league, "elsewhere:1:abcdef", lease_seconds=3600).id == other_id  # another worker's
    with league.transaction() as session:
        job_id = reg.enqueue(session, "wait").id
    monkeypatch.setattr("arena_league.web.workers.STOP_SECONDS", 1.0)
    pool = WorkerPool([sys.executable, "-c", _STUCK_WORKER, str(home)], 1)
    pool.start()
    until("the job claimed", lambda: job_row_of(league, job_id).status == "running", seconds=60)
    (pid,) = pool.pids()
    assert pool.stop() == [pid] and not running(pid)  # killed: it ignored SIGTERM
    assert job_row_of(league, job_id).lease_owner.split(":")[1] == str(pid)
    assert reg.release_jobs_of_process(league, pid) == [job_id]
    row = job_row_of(league, job_id)
    assert (row.status, row.lease_owner, row.attempts) == ("queued", None, 0)
    assert job_row_of(league, other_id).status == "running"  # another owner's job stays where it is
    assert reg.release_jobs_of_process(league, pid) == []


def job_row_of(league: reg.League, job_id: int) -> reg.Job:
    with league.reading() as session:
        job = reg.get_job(session, job_id)
        session.expunge(job)
        return job
