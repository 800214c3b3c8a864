"""A real web service for the tests: ``arena-league serve`` in a subprocess on a free loopback
port, over a league of its own, with one job worker, under an address-space limit (RLIMIT_AS,
which its workers and their sandboxes inherit); stopped (with its worker) by its pid.
PYTEST_DONT_REWRITE
"""

from __future__ import annotations

import os
import resource
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import httpx

from arena_league.league import create_token, open_home

#: The address space (MiB) a test's serve, and each of its workers, may map: about three times a
#: worker's peak (VmPeak ~1.4 GiB after validating and ranking an ONNX agent, torch and onnxruntime
#: loaded; serve ~0.7 GiB), leaving the worker's inference sandbox room for the settings' default.
SERVE_MEMORY_MIB = 4096


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@dataclass
class Server:
    url: str
    home: Path
    db: str | None
    process: subprocess.Popen
    log: Path | None = None

    def token(self, owner: str, admin: bool = False) -> str:
        with open_home(self.home, self.db) as league:
            return create_token(league, owner, admin=admin)["token"]

    def client(self, token: str | None = None) -> httpx.Client:
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        return httpx.Client(base_url=self.url, headers=headers, timeout=60)

    def command(self, *argv: str) -> subprocess.CompletedProcess:
        """``arena-league ARGV`` on the server's league."""
        return subprocess.run([sys.executable, "-m", "arena_league.cli", *argv, "--home", str(self.home),
                               *(["--db", self.db] if self.db else [])], capture_output=True, text=True,
                              timeout=120, check=True)

    def wait_job(self, job: int, seconds: float = 120) -> dict:
        """The job's state once it finished (the server's worker runs it)."""
        deadline = time.monotonic() + seconds
        with self.client() as client:
            while time.monotonic() < deadline:
                state = client.get(f"/api/jobs/{job}").json()
                if state["finished"]:
                    return state
                time.sleep(0.2)
        raise TimeoutError(f"job {job} did not finish in {seconds} s")


def _limit_memory(mib: int) -> None:
    resource.setrlimit(resource.RLIMIT_AS, (mib << 20, mib << 20))


@contextmanager
def running_server(home: Path, db: str | None = None, workers: int = 1,
                   memory_mib: int | None = SERVE_MEMORY_MIB) -> Iterator[Server]:
    """``serve`` on ``home`` (or ``db``) with ``workers``, each process under ``memory_mib`` MiB
    of address space (None: no limit)."""
    port = free_port()
    env = dict(os.environ)
    env.pop("ARENA_LEAGUE_DB", None)
    command = [sys.executable, "-m", "arena_league.cli", "serve", "--port", str(port), "--home", str(home),
               "--workers", str(workers), *(["--db", db] if db else [])]
    log_path = home.parent / f"serve-{port}.log"
    log = open(log_path, "w")  # noqa: SIM115 - closed with the server below
    limit = None if memory_mib is None else (lambda: _limit_memory(memory_mib))
    # the child only calls setrlimit between fork and exec: no lock another thread could hold
    process = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT,
                               preexec_fn=limit)  # noqa: PLW1509
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 90
        while True:
            try:
                if httpx.get(f"{url}/api/games", timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if process.poll() is not None or time.monotonic() > deadline:
                log.flush()
                raise RuntimeError(f"the server did not start: {log_path.read_text()}")
            time.sleep(0.2)
        yield Server(url, home, db, process, log_path)
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)  # uvicorn stops gracefully and stops its workers
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        log.close()
