"""The front door of a real ``arena-league serve``: a write's token, size and uploads in flight are
checked before a byte of its body is read; an oversized chunked upload is a 413; a full disk, an
empty database file and a rejected upload are named without the server's paths.

Whether the server read a body is seen on the wire: a request sent with ``Expect: 100-continue``
and no body gets ``100 Continue`` only once the application asks for the body (uvicorn sends it
then), so a final answer in its place is one given before the body was read.
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from unittest import mock
from urllib.parse import urlparse

import pytest
from web_helpers import Server, running_server

from arena_league.league import (
    authenticate,
    create_token,
    open_home,
    reset_setting,
    set_setting,
    upload_agent,
)
from arena_league.registry.errors import DiskFullError, NotADatabaseError

GAME = "GoBang-2T1P-v1"
MIB = 1 << 20


def _head(server: Server, method: str, path: str, length: int, headers: dict[str, str] | None = None,
          keep: list[socket.socket] | None = None) -> tuple[int, dict[str, str]]:
    """Send a request's headers (``Expect: 100-continue``, ``Content-Length: length``) and no body;
    the status and headers of the first answer. With ``keep``, the socket stays open there."""
    address = urlparse(server.url)
    sock = socket.create_connection((address.hostname, address.port), timeout=30)
    lines = [f"{method} {path} HTTP/1.1", f"Host: {address.netloc}", "Expect: 100-continue",
             f"Content-Length: {length}", "Content-Type: multipart/form-data; boundary=front-door",
             *(f"{k}: {v}" for k, v in (headers or {}).items())]
    sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
    answer = b""
    while b"\r\n\r\n" not in answer:
        chunk = sock.recv(65536)
        if not chunk:
            break
        answer += chunk
    if keep is None:
        sock.close()
    else:
        keep.append(sock)
    status_line, *header_lines = answer.split(b"\r\n\r\n")[0].decode("latin-1").split("\r\n")
    fields = dict(line.split(": ", 1) for line in header_lines if ": " in line)
    return int(status_line.split()[1]), {k.lower(): v for k, v in fields.items()}


def _bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


@contextlib.contextmanager
def _tmpfs(folder: Path, size: str) -> Iterator[None]:
    """A small tmpfs mounted at ``folder`` (root only; the test is skipped elsewhere)."""
    folder.mkdir(parents=True, exist_ok=True)
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)],
                             check=False, capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({mounted.stderr.strip()})")
    try:
        yield
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)


@dataclass
class Door:
    """The module's server, and its tmpfs mounts (None where this machine lets no test mount one)."""

    server: Server
    uploads: Path | None
    spool: Path | None


def _mount(folder: Path, size: str) -> Path | None:
    folder.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)], check=False,
                          capture_output=True)
    return folder if done.returncode == 0 else None


@pytest.fixture(scope="module")
def door(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Door]:
    """A server whose uploads are at most 2 MiB, 2 in flight per owner and 3 in all, with its
    uploads folder on a 256 KiB tmpfs and its temporary folder (where a form's files spool) on an
    8 MiB one, when this machine lets tests mount them."""
    root = tmp_path_factory.mktemp("door")
    home = root / "home"
    with open_home(home) as league:
        set_setting(league, "web.upload_mib", 2)
        set_setting(league, "web.uploads_in_flight_per_owner", 2)
        set_setting(league, "web.uploads_in_flight", 3)
    uploads, spool = _mount(home / "uploads", "256k"), _mount(root / "spool", "8m")
    try:
        with contextlib.ExitStack() as stack:
            with mock.patch.dict(os.environ, {"TMPDIR": str(spool)} if spool else {}):
                server = stack.enter_context(running_server(home, workers=0))
            yield Door(server, uploads, spool)
    finally:
        for folder in (uploads, spool):
            if folder is not None:
                subprocess.run(["umount", "-l", str(folder)], check=False)


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_a_write_is_refused_before_its_body_is_read(door: Door) -> None:
    server = door.server
    alice = server.token("alice")
    big = 250 * MIB
    # anonymous, a bad token, an anonymous page form: answered before the first byte of the body
    status, headers = _head(server, "POST", "/api/agents", big)
    assert status == 401 and headers.get("www-authenticate") == "Bearer"
    assert _head(server, "POST", "/api/agents", big, _bearer("al_not-a-token"))[0] == 401
    status, headers = _head(server, "POST", "/submit", big, {"Cookie": "arena_league_token=al_nope"})
    assert status == 303 and headers["location"] == "/signin?next=/submit"
    assert _head(server, "POST", "/api/trees", 4096)[0] == 401
    assert _head(server, "POST", "/agents/x/rank", 4096)[0] == 303
    # a valid token with a body over the league's limit: 413 by its declared length, nothing read
    status, _ = _head(server, "POST", "/api/agents", big, _bearer(alice))
    assert status == 413
    # the sign-in form and tree checks stay open: their bodies are read (100 Continue)
    assert _head(server, "POST", "/signin", 100)[0] == 100
    assert _head(server, "POST", "/api/trees/check", 100)[0] == 100
    # and a write with a valid token, within the limits, is read as before
    assert _head(server, "POST", "/api/trees", 100, _bearer(alice))[0] == 100
    with server.client() as client:
        refused = client.post("/api/agents", data={"game": GAME, "name": "x"},
                              files={"file": ("model.onnx", b"onnx")})
        assert refused.status_code == 401 and "Bearer" in refused.json()["detail"]
        assert client.get("/api/games").status_code == 200


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_uploads_in_flight_are_bounded_per_owner_and_in_all(door: Door) -> None:
    server = door.server
    alice, bob, carol = (server.token(owner) for owner in ("alice", "bob", "carol"))
    held: list[socket.socket] = []
    try:
        # alice's two uploads are being read (each got 100 Continue) and hold her slots ...
        assert _head(server, "POST", "/api/agents", MIB, _bearer(alice), held)[0] == 100
        assert _head(server, "POST", "/api/agents", MIB, _bearer(alice), held)[0] == 100
        status, headers = _head(server, "POST", "/api/agents", MIB, _bearer(alice))
        assert status == 429 and int(headers["retry-after"]) > 0  # ... her third waits, unread
        # bob takes the server's third slot; carol finds the server full
        assert _head(server, "POST", "/api/agents", MIB, _bearer(bob), held)[0] == 100
        status, headers = _head(server, "POST", "/api/agents", MIB, _bearer(carol))
        assert status == 429 and int(headers["retry-after"]) > 0
    finally:
        for sock in held:
            sock.close()
    # the slots come back when their uploads end (here: their clients went away)
    for _ in range(100):
        if _head(server, "POST", "/api/agents", 10, _bearer(alice))[0] != 429:
            break
        time.sleep(0.1)
    else:
        pytest.fail("alice's slots were not given back after her uploads ended")


def _next_answer(sock: socket.socket) -> tuple[int, str]:
    """The status and the rest of the next answer on ``sock`` after its ``100 Continue``, read until
    the server closes it (or the socket's timeout, a generous deadline, passes)."""
    answer = b""
    with contextlib.suppress(TimeoutError):
        while chunk := sock.recv(65536):
            answer += chunk
    answer = answer.split(b"HTTP/1.1 100 Continue\r\n\r\n", 1)[-1]
    if not answer.startswith(b"HTTP/1.1 "):
        return 0, ""
    return int(answer.split()[1]), answer.decode("latin-1")


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_a_stalled_upload_is_abandoned_and_its_slot_given_back(door: Door) -> None:
    server = door.server
    dora = server.token("dora")
    with open_home(server.home, server.db) as league:
        set_setting(league, "web.body_idle_seconds", 1)
    held: list[socket.socket] = []
    try:
        # dora's two uploads send their headers, get 100 Continue, and then nothing: both her slots held
        for _ in range(2):
            assert _head(server, "POST", "/api/agents", MIB, _bearer(dora), held)[0] == 100
        for sock in held:
            sock.settimeout(20)
        answers = [_next_answer(sock) for sock in held]
        assert [status for status, _ in answers] == [408, 408]
        assert all("web.body_idle_seconds" in text for _, text in answers)
        # their slots are back: a third upload is read (100 Continue), not refused (429)
        assert _head(server, "POST", "/api/agents", MIB, _bearer(dora))[0] == 100
    finally:
        for sock in held:
            sock.close()
        with open_home(server.home, server.db) as league:
            reset_setting(league, "web.body_idle_seconds")


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_a_trickled_upload_is_abandoned_and_its_slot_given_back(door: Door) -> None:
    server = door.server
    erin = server.token("erin")
    with open_home(server.home, server.db) as league:
        set_setting(league, "web.body_idle_seconds", 1)
        set_setting(league, "web.body_min_kib_per_second", 64)
    held: list[socket.socket] = []
    try:
        # erin's two uploads each send 100 bytes every 0.2 s: never idle for a second, far under 64 KiB/s
        for _ in range(2):
            assert _head(server, "POST", "/api/agents", MIB, _bearer(erin), held)[0] == 100
            held[-1].sendall(b"--front-door\r\nContent-Disposition: form-data; name=\"file\"; "
                             b"filename=\"model.onnx\"\r\nContent-Type: application/octet-stream\r\n\r\n")
        for _ in range(100):
            waiting = [sock for sock in held if not select.select([sock], [], [], 0)[0]]
            if not waiting:
                break
            for sock in waiting:
                sock.sendall(b"\0" * 100)
            time.sleep(0.2)
        for sock in held:
            sock.settimeout(20)
        answers = [_next_answer(sock) for sock in held]
        assert [status for status, _ in answers] == [408, 408]
        assert all("web.body_min_kib_per_second" in text for _, text in answers)
        # their slots are back: a third upload is read (100 Continue), not refused (429)
        assert _head(server, "POST", "/api/agents", MIB, _bearer(erin))[0] == 100
    finally:
        for sock in held:
            sock.close()
        with open_home(server.home, server.db) as league:
            reset_setting(league, "web.body_idle_seconds")
            reset_setting(league, "web.body_min_kib_per_second")


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_an_oversized_chunked_upload_answers_413(door: Door) -> None:
    server = door.server
    alice = server.token("alice")
    boundary = "front-door"

    def body() -> Iterator[bytes]:  # no Content-Length: the body streams chunked
        yield (f"--{boundary}\r\nContent-Disposition: form-data; name=\"game\"\r\n\r\n{GAME}\r\n"
               f"--{boundary}\r\nContent-Disposition: form-data; name=\"name\"\r\n\r\nbig\r\n"
               f"--{boundary}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"model.onnx\"\r\n"
               "Content-Type: application/octet-stream\r\n\r\n").encode()
        for _ in range(5):
            yield b"\0" * MIB
        yield f"\r\n--{boundary}--\r\n".encode()

    with server.client(alice) as client:
        answer = client.post("/api/agents", content=body(),
                             headers={"Content-Type": f"multipart/form-data; boundary={boundary}"})
    assert answer.status_code == 413
    assert "web.upload_mib" in answer.json()["detail"]


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_a_full_uploads_disk_is_named_without_paths(door: Door) -> None:
    server, uploads = door.server, door.uploads
    if uploads is None:
        pytest.skip("cannot mount a tmpfs here")
    with server.client(server.token("alice")) as client:
        answer = client.post("/api/agents", data={"game": GAME, "name": "fills-the-disk"},
                             files={"file": ("model.onnx", b"\1" * (MIB - 4096))})
    assert answer.status_code == 507, answer.text
    detail = answer.json()["detail"]
    assert "the league home's uploads/ folder is full" in detail and "free space" in detail
    assert str(server.home) not in detail and "internal error" not in detail
    assert list(uploads.iterdir()) == []  # the staged part was removed


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_a_full_temporary_folder_is_named(door: Door) -> None:
    server, spool = door.server, door.spool
    if spool is None:
        pytest.skip("cannot mount a tmpfs here")
    filler = spool / "filler"
    try:
        with contextlib.suppress(OSError), open(filler, "wb") as out:
            while True:
                out.write(b"\0" * 65536)
                out.flush()
        with server.client(server.token("alice")) as client:  # over 1 MiB: the form spools it to disk
            answer = client.post("/api/agents", data={"game": GAME, "name": "spooled"},
                                 files={"file": ("model.onnx", b"\1" * (MIB + MIB // 2))})
    finally:
        filler.unlink()
    assert answer.status_code == 507, answer.text
    detail = answer.json()["detail"]
    assert "the web server's temporary folder (TMPDIR) is full" in detail and str(spool) not in detail


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_a_full_database_disk_is_named_without_paths(tmp_path: Path) -> None:
    home = tmp_path / "home"
    with _tmpfs(home, "4m"), running_server(home, workers=0) as server:
        alice = server.token("alice")
        with server.client(alice) as client:
            assert client.get("/api/me").status_code == 200  # the token's first use is noted while there is room
            spec = client.get("/api/games/Crossroads-2T2P-v1/tree-catalog").json()["default"]
            with contextlib.suppress(OSError), open(home / "filler", "wb") as filler:
                while True:
                    filler.write(b"\0" * 65536)
                    filler.flush()
            answer = client.post("/api/trees", json={"game": "Crossroads-2T2P-v1", "spec": spec, "name": "full"})
            (home / "filler").unlink()
    assert answer.status_code == 507, answer.text
    detail = answer.json()["detail"]
    assert "the disk holding the league's database is full" in detail and str(home) not in detail


def test_a_full_artifact_store_is_named(tmp_path: Path) -> None:
    from arena_league.registry import store_artifact

    home = tmp_path / "home"
    with open_home(home) as league, _tmpfs(home / "artifacts", "256k"):
        with (pytest.raises(DiskFullError, match=r"the disk holding the league home's artifacts/ folder is full"),
              league.transaction() as session):
            store_artifact(session, league.home, b"\1" * MIB, "onnx")
        assert [p for p in (home / "artifacts").rglob("*") if p.is_file()] == []


@pytest.mark.slow  # the leaderboard imports the game's shipped base population first (about 100 s)
def test_a_full_disk_in_the_cli_is_one_line_and_an_exit_code(tmp_path: Path) -> None:
    home, full = tmp_path / "home", tmp_path / "full"
    with _tmpfs(full, "64k"):
        with contextlib.suppress(OSError), open(full / "filler", "wb") as filler:
            while True:
                filler.write(b"\0" * 4096)
                filler.flush()
        done = subprocess.run([sys.executable, "-m", "arena_league.cli", "leaderboard", GAME, "--html",
                               str(full / "board.html"), "--home", str(home)], check=False, capture_output=True,
                              text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    message = " ".join(done.stderr.split())
    assert "is full (No space left on device)" in message and "free space" in message
    assert "Traceback" not in done.stderr and "internal error" not in message


def test_an_empty_database_file_is_not_a_new_league(tmp_path: Path) -> None:
    home = tmp_path / "home"
    home.mkdir()
    empty = home / "league.db"
    empty.touch()
    os.utime(empty, (time.time() - 3600, time.time() - 3600))  # not a league being created this moment
    with pytest.raises(NotADatabaseError, match="is an empty file") as refused:
        open_home(home)
    assert "restore it from a backup" in str(refused.value) and "delete the empty file" in str(refused.value)
    assert empty.stat().st_size == 0
    done = subprocess.run([sys.executable, "-m", "arena_league.cli", "settings", "list", "--home", str(home)],
                          check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "is an empty file" in done.stderr and "Traceback" not in done.stderr
    assert empty.stat().st_size == 0
    empty.unlink()  # a missing file is a new league
    open_home(home).close()


@pytest.mark.slow  # a real server (its start is most of it) or a validation job
def test_a_rejection_reason_carries_no_server_path(tmp_path: Path) -> None:
    from arena_league.league import run_worker

    home = tmp_path / "home"
    with open_home(home) as league:
        who = authenticate(league, create_token(league, "alice")["token"])
        assert who is not None
        queued = upload_agent(league, who, GAME, "garbage", [("model.onnx", _Bytes(b"not an onnx model at all"))])
        run_worker(league, until_idle=True, poll_seconds=0.1)
        with league.reading() as session:
            from arena_league.registry import get_agent

            agent = get_agent(session, queued["name"])
            reason, log = agent.reject_reason, agent.validation_log
    assert agent.status == "rejected" and reason
    for text in (reason, log):
        assert str(home) not in text and "uploads/" not in text
    assert "model.onnx" in reason


class _Bytes:
    """A file-like of ``data`` for :func:`upload_agent`."""

    def __init__(self, data: bytes) -> None:
        self.data = data

    def read(self, size: int = -1) -> bytes:
        chunk, self.data = (self.data, b"") if size < 0 else (self.data[:size], self.data[size:])
        return chunk
