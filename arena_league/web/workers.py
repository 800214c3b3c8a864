"""The job workers ``serve`` runs beside itself: a :class:`WorkerPool` of ``arena-league worker``
processes on the server's league, supervised.

* A worker that dies is started again, with one log line on stderr naming how it ended (exit code
  or signal). A job it was running waits for its lease to run out (the worker's ``--lease``, 60 s
  by default) and is then claimed again; queued jobs go to the new worker at once.
* Restarts are bounded: at most :data:`RESTARTS_PER_MINUTE` in any minute; past that, each dead
  worker is logged as an error and started again only every :data:`SLOW_RESTART_SECONDS`, so a
  worker that cannot start (a broken database, a missing module) does not spin.
* Workers end with the server: it stops them (SIGTERM: each hands its job back) when it stops, and
  each is started with ``--parent`` naming the server's pid, so that even after ``kill -9`` of the
  server a worker stops (on Linux at once, by a parent-death signal; elsewhere before its next
  claim or lease renewal), handing its job back.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["RESTARTS_PER_MINUTE", "SLOW_RESTART_SECONDS", "WorkerPool", "worker_command"]

logger = logging.getLogger("arena_league.web.workers")

#: Restarts allowed in any 60 s before the pool slows down.
RESTARTS_PER_MINUTE = 5
#: Once restarts are over that rate, how long a dead worker waits before it is started again.
SLOW_RESTART_SECONDS = 60.0
#: How long a stopping worker has to hand its job back before it is killed.
STOP_SECONDS = 15.0


def worker_command(home: str | Path, url: str | None = None) -> list[str]:
    """``arena-league worker`` on the league at ``home`` (and the database ``url``, if given)."""
    return [sys.executable, "-m", "arena_league.cli", "worker", "--home", str(home), *(["--db", url] if url else [])]


def _how_it_ended(code: int) -> str:
    if code < 0:
        try:
            return f"was killed by signal {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with code {code}"


class WorkerPool:
    """``size`` worker processes running ``command`` (plus ``--parent`` with this process's pid),
    started by :meth:`start`, restarted by a supervising thread that looks every ``check_seconds``,
    stopped by :meth:`stop`. ``clock`` (monotonic seconds) is injectable for the restart bound."""

    def __init__(self, command: Sequence[str], size: int, *, check_seconds: float = 0.5,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if size < 0:
            raise ValueError(f"workers must be 0 or more, not {size}")
        self.size = size
        self._command = [*command, "--parent", str(os.getpid())]
        self._check_seconds = check_seconds
        self._clock = clock
        self._processes: list[subprocess.Popen | None] = [None] * size
        self._due = [0.0] * size  # when an empty slot may be started (again)
        self._restarts: deque[float] = deque()  # when each restart of the last minute happened
        self.restarts = 0
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._first_pass = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the workers and their supervisor; returns once the workers were started."""
        if self.size == 0:
            logger.info("this server runs no job worker: jobs wait for `arena-league worker` processes started "
                        "elsewhere")
            return
        if self._thread is not None:
            return
        # the supervising thread starts every worker: Linux sends a parent-death signal when the
        # thread that started a process ends, and this one lives as long as the pool
        self._thread = threading.Thread(target=self._supervise, name="worker-supervisor", daemon=True)
        self._thread.start()
        self._first_pass.wait()

    def _supervise(self) -> None:
        while not self._stopping.is_set():
            try:
                self.check()
            except Exception:  # a bug here must not end supervision
                logger.exception("supervising the job workers failed; trying again")
            self._first_pass.set()
            self._stopping.wait(self._check_seconds)

    def check(self) -> None:
        """One look: note each worker that ended, and start each one whose slot is due."""
        with self._lock:
            if self._stopping.is_set():
                return
            now = self._clock()
            while self._restarts and self._restarts[0] <= now - 60:
                self._restarts.popleft()
            for slot, process in enumerate(self._processes):
                if process is not None:
                    code = process.poll()
                    if code is None:
                        continue
                    self._processes[slot] = None
                    if len(self._restarts) < RESTARTS_PER_MINUTE:
                        self._due[slot] = now
                        logger.warning("job worker pid %d %s; starting another", process.pid, _how_it_ended(code))
                    else:
                        self._due[slot] = now + SLOW_RESTART_SECONDS
                        logger.error("job worker pid %d %s, after %d restarts in the last minute; starting another "
                                     "in %.0f s (its own log lines above say why it ended)", process.pid,
                                     _how_it_ended(code), len(self._restarts), SLOW_RESTART_SECONDS)
                    self._restarts.append(now)
                    self.restarts += 1
                if self._due[slot] <= now:
                    self._spawn(slot, now)

    def _spawn(self, slot: int, now: float) -> None:
        try:
            # a group of its own: Ctrl-C at a terminal reaches serve alone, which stops its workers
            # itself, rather than the workers too, which the supervisor would then start again
            process = subprocess.Popen(self._command, stdin=subprocess.DEVNULL, process_group=0)
        except OSError as error:
            self._due[slot] = now + SLOW_RESTART_SECONDS
            logger.error("cannot start a job worker (%s); trying again in %.0f s", error, SLOW_RESTART_SECONDS)
            return
        self._processes[slot] = process

    def alive(self) -> int:
        """How many of the pool's workers are running now."""
        with self._lock:
            return sum(1 for process in self._processes if process is not None and process.poll() is None)

    def pids(self) -> list[int]:
        """The running workers' process ids."""
        with self._lock:
            return [p.pid for p in self._processes if p is not None and p.poll() is None]

    def health(self) -> dict[str, Any]:
        """The pool as the health document shows it."""
        alive = self.alive()
        document: dict[str, Any] = {"started_here": self.size, "alive": alive, "restarts": self.restarts}
        if self.size == 0:
            document["note"] = ("this server runs no job worker: jobs wait for `arena-league worker` processes "
                                "started elsewhere")
        elif alive < self.size:
            document["note"] = f"{self.size - alive} job worker(s) ended and are being started again"
        return document

    def stop(self) -> list[int]:
        """Stop supervising, then stop the workers: each hands its job back to the queue (killed
        after :data:`STOP_SECONDS` if it has not). Returns the process ids of the workers it
        stopped: a job one of them still holds (killed before it handed it back) is the caller's to
        hand back (``release_jobs_of_process``)."""
        self._stopping.set()
        if self._thread is not None:
            self._thread.join()
        with self._lock:
            processes = [p for p in self._processes if p is not None]
        for process in processes:
            if process.poll() is None:
                process.terminate()
        for process in processes:
            try:
                process.wait(timeout=STOP_SECONDS)
            except subprocess.TimeoutExpired:
                logger.warning("job worker %d did not stop within %.0f s: killed", process.pid, STOP_SECONDS)
                process.kill()
                process.wait()
        return [process.pid for process in processes]
