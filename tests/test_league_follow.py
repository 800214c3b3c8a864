"""A command that queues a job follows it wherever it runs: here when it can claim it, else in the
worker that took it (the server's), with that worker's progress; a failed or cancelled job says so in
one line; Ctrl-C cancels the job either way, and a worker running a cancelled job stops."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time

import pytest
from placement_helpers import scripted_base_with_entrant
from web_helpers import running_server

from arena_league.league import (
    EvaluationReport,
    JobCancelledError,
    JobFailedError,
    JobInterrupted,
    ensure_scripted_agents,
    evaluation_payload,
    follow_job,
    job_handlers,
    open_home,
    queue_evaluation,
    queue_rank,
)
from arena_league.registry import (
    cancel_job,
    claim_job,
    count_matches,
    enqueue,
    fail_job,
    get_job,
    run_claimed_job,
    run_worker,
    set_job_progress,
)

GAME = "GoBang-2T1P-v1"
CROSSROADS = "Crossroads-2T2P-v1"


def _status(league, job_id: int) -> str:
    with league.reading() as session:
        return get_job(session, job_id).status


def _wait_until(condition, what: str, seconds: float = 60.0) -> None:
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what} did not happen within {seconds} s")
        time.sleep(0.01)


def test_a_job_another_worker_runs_is_followed_with_its_progress_to_its_result(tmp_path):
    with open_home(tmp_path / "league") as league:
        names = ensure_scripted_agents(league, GAME)
        job_id = queue_evaluation(league, GAME, names, matches_per_pair=4)
        other = claim_job(league, "server-worker", job_id=job_id)  # the server's worker took it first
        seen, said = [], []

        def other_worker_runs(seconds: float) -> None:  # the follower's pause: the other worker gets on
            if not seen:
                set_job_progress(league, other, {"done": 1, "total": 4})
            else:
                run_claimed_job(league, other, job_handlers())

        result = follow_job(league, job_id, job_handlers(), progress=lambda done, total: seen.append((done, total)),
                            log=said.append, sleep=other_worker_runs)
        report = EvaluationReport(**result)
        assert report.played == report.stored == 4 and report.job_id == job_id
        assert seen == [(1, 4), (4, 4)]
        assert said == [f"job {job_id} is run by worker server-worker; following it here (Ctrl-C cancels it)"]
        with league.reading() as session:
            assert count_matches(session, GAME) == 4  # played once, by the other worker


def test_a_failed_or_cancelled_job_says_so_in_one_line(tmp_path):
    with open_home(tmp_path / "league") as league:
        names = ensure_scripted_agents(league, GAME)
        with league.transaction() as session:
            failing = enqueue(session, "evaluate", evaluation_payload(GAME, names, matches_per_pair=2),
                              max_attempts=1).id
        held = claim_job(league, "server-worker", job_id=failing)
        with pytest.raises(JobFailedError) as failed:
            follow_job(league, failing, job_handlers(), sleep=lambda s: fail_job(
                league, held, "Traceback (most recent call last):\n  ...\nValueError: the base is gone\n"))
        assert str(failed.value) == (f"job {failing} failed: ValueError: the base is gone; see "
                                     f"`arena-league jobs show {failing}`")
        cancelled = queue_evaluation(league, GAME, names, matches_per_pair=2)
        claim_job(league, "server-worker", job_id=cancelled)
        with pytest.raises(JobCancelledError, match=f"job {cancelled} was cancelled"):
            follow_job(league, cancelled, job_handlers(), sleep=lambda s: cancel_job(league, cancelled))


def test_ctrl_c_cancels_a_job_run_here(tmp_path):
    with open_home(tmp_path / "league") as league:
        names = ensure_scripted_agents(league, GAME)
        job_id = queue_evaluation(league, GAME, names, matches_per_pair=200)

        def interrupt(done: int, total: int) -> None:
            raise KeyboardInterrupt

        with pytest.raises(JobInterrupted, match=rf"job {job_id} was cancelled \(Ctrl-C\); the matches"):
            follow_job(league, job_id, job_handlers(interrupt), sleep=pytest.fail)
        assert _status(league, job_id) == "cancelled"


def test_ctrl_c_cancels_a_job_another_worker_runs_and_that_worker_stops(tmp_path):
    with open_home(tmp_path / "league") as league:
        names = ensure_scripted_agents(league, GAME)
        job_id = queue_evaluation(league, GAME, names, matches_per_pair=5000)
        reports = []
        worker = threading.Thread(target=lambda: reports.append(run_worker(
            league, job_handlers(), "server-worker", lease_seconds=30, poll_seconds=0.01, max_jobs=1)))
        worker.start()
        try:
            def progressed() -> bool:
                with league.reading() as session:
                    return bool((get_job(session, job_id).progress or {}).get("done"))

            _wait_until(progressed, "the worker's first progress report")

            def ctrl_c(seconds: float) -> None:
                raise KeyboardInterrupt

            with pytest.raises(JobInterrupted, match="in worker server-worker, which stops at its next progress"):
                follow_job(league, job_id, job_handlers(), sleep=ctrl_c)
        finally:
            worker.join(timeout=120)
        assert not worker.is_alive() and reports[0].lost == 1 and reports[0].completed == 0
        assert _status(league, job_id) == "cancelled"
        with league.reading() as session:  # it stopped at its next progress report, far from the end
            assert count_matches(session, GAME) < 5000 and get_job(session, job_id).progress["done"] < 5000


@pytest.mark.slow
def test_ctrl_c_in_the_terminal_cancels_its_job_and_says_so_in_one_line(tmp_path):
    home = tmp_path / "league"
    with open_home(home) as league:
        ensure_scripted_agents(league, GAME)
    command = subprocess.Popen([sys.executable, "-m", "arena_league.cli", "evaluate", GAME, "--matches-per-pair",
                                "5000", "--home", str(home)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        with open_home(home) as league:
            def progressed() -> bool:
                with league.reading() as session:
                    job = get_job(session, 1)
                    return job is not None and bool((job.progress or {}).get("done"))

            _wait_until(progressed, "the evaluation's first progress report", seconds=120)
        command.send_signal(signal.SIGINT)
        _, err = command.communicate(timeout=60)
    finally:
        if command.poll() is None:
            command.kill()
            command.wait()
    assert command.returncode == 130
    assert err.splitlines()[-1] == ("interrupted: job 1 was cancelled (Ctrl-C); the matches it already played stay "
                                    "stored. See `arena-league jobs show 1`")
    with open_home(home) as league:
        assert _status(league, 1) == "cancelled"


@pytest.mark.slow
def test_rank_from_a_terminal_beside_the_server_prints_the_placement(tmp_path):
    home = tmp_path / "league"
    scripted_base_with_entrant(home, CROSSROADS)
    with running_server(home) as server:
        # the race made certain: the server's worker has the placement when the terminal asks for it
        with open_home(home) as league:
            job_id = queue_rank(league, "alice", budget=30, seed=0)

            def base_resolved() -> bool:  # then it starts the sandbox, writing nothing for a while
                with league.reading() as session:
                    return "base" in get_job(session, job_id).payload

            _wait_until(base_resolved, "the server's worker claiming the job")
            with league.reading() as session:
                owner = get_job(session, job_id).lease_owner
        worker_pid = int(owner.split(":")[1])
        os.kill(worker_pid, signal.SIGSTOP)  # held mid-job (holding no lock) until the terminal follows it
        try:
            log = tmp_path / "rank.err"
            with open(log, "w") as err:
                command = subprocess.Popen([sys.executable, "-m", "arena_league.cli", "rank", "alice", "--budget", "30",
                                            "--home", str(home)], stdout=subprocess.PIPE, stderr=err, text=True)
                _wait_until(lambda: "following it here" in log.read_text(), "the terminal following the job")
        finally:
            os.kill(worker_pid, signal.SIGCONT)
        out, _ = command.communicate(timeout=300)
        assert command.returncode == 0, log.read_text()
        assert f"job {job_id} already places alice against scripted:1 with seed 0" in log.read_text()
        assert f"job {job_id} is run by worker {owner}; following it here" in log.read_text()
        assert "alice on Crossroads-2T2P-v1 against scripted:1 of Crossroads-2T2P-v1 (2 agents," in out
        assert "rank        " in out
        assert server.wait_job(job_id)["state"] == "done"
        again = server.command("rank", "alice", "--budget", "30")  # asked again: the stored placement
        assert f"from the stored placement (job {job_id}, seed 0)" in again.stdout
