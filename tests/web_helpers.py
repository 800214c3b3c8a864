"""A real web service for the tests: ``arena-league serve`` in a subprocess on a free loopback
port, over a league of its own, with one job worker; stopped (with its worker) by its pid.
PYTEST_DONT_REWRITE
"""

from __future__ import annotations

import os
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


@contextmanager
def running_server(home: Path, db: str | None = None, workers: int = 1) -> Iterator[Server]:
    port = free_port()
    env = dict(os.environ)
    env.pop("ARENA_LEAGUE_DB", None)
    command = [sys.executable, "-m", "arena_league.cli", "serve", "--port", str(port), "--home", str(home),
               "--workers", str(workers), *(["--db", db] if db else [])]
    log = open(home.parent / f"serve-{port}.log", "w")  # noqa: SIM115 - closed with the server below
    process = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT)
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
                raise RuntimeError(f"the server did not start: {(home.parent / f'serve-{port}.log').read_text()}")
            time.sleep(0.2)
        yield Server(url, home, db, process)
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)  # uvicorn stops gracefully and stops its workers
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        log.close()
