"""Play sockets that cannot hold a server: a real ``arena-league serve`` on loopback, GoBang's base
population imported beforehand, real WebSocket clients.

Only moves keep a game open (a socket sending invalid text, binary frames, unknown types and pings,
or starting and resigning matches, is closed for idleness while a socket that moves plays on); a
socket starts at most its setting of matches a minute, past it answered with the wait; one owner (a guest name, or a token's
owner) and one address hold at most their settings' number of sockets, refused with 1013 naming
the setting; a message nested 60,000 deep is answered with one line and the game goes on. Each
test connects from an address of its own (127.0.0.x) so the per-address counts stay apart.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from contextlib import ExitStack

import httpx
import pytest
from web_helpers import Server, running_server
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect

from arena_league.league import base_to_import, ensure_population, open_home, set_setting

GAME = "GoBang-2T1P-v1"
SIZE = 15


@pytest.fixture(scope="module")
def server(tmp_path_factory) -> Iterator[Server]:
    home = tmp_path_factory.mktemp("limits") / "home"
    with open_home(home) as league:
        ensure_population(league, GAME, base_to_import(league, GAME))  # here, not by a worker
        set_setting(league, "web.live_games", 100)  # the per-owner and per-address limits are the ones tested
    with running_server(home, workers=0) as running:
        yield running


def setting(server: Server, key: str, value: int) -> None:
    with open_home(server.home) as league:
        set_setting(league, key, value)


def play(server: Server, address: str, guest: str | None = None, token: str | None = None) -> ClientConnection:
    query = f"?guest={guest}" if guest else ""
    headers = {"Authorization": f"Bearer {token}"} if token else None
    return connect(f"{server.url.replace('http', 'ws')}/ws/play/{GAME}{query}", additional_headers=headers,
                   source_address=(address, 0), open_timeout=30)


def receive(socket: ClientConnection) -> dict:
    return json.loads(socket.recv(timeout=60))


def refusal(socket: ClientConnection) -> tuple[dict, int, str]:
    """The error message of a refused socket, its close code and reason."""
    message = receive(socket)
    with pytest.raises(ConnectionClosed) as closed:
        socket.recv(timeout=60)
    return message, closed.value.rcvd.code, closed.value.rcvd.reason


def test_one_address_holds_at_most_its_setting_of_sockets(server):
    setting(server, "web.live_games_per_address", 4)
    with ExitStack() as stack:
        sockets = [stack.enter_context(play(server, "127.0.0.2", guest=f"ann{k}")) for k in range(4)]
        assert [receive(s)["type"] for s in sockets] == ["hello"] * 4
        with play(server, "127.0.0.2", guest="ann4") as fifth:
            message, code, reason = refusal(fifth)
        assert code == 1013 and "web.live_games_per_address" in reason
        assert message["detail"] == ("4 game(s) already open from your address (the league's "
                                     "web.live_games_per_address); close one to play here")
        with play(server, "127.0.0.3", guest="ann4") as elsewhere:  # another address is not held back
            assert receive(elsewhere)["type"] == "hello"
        sockets[0].close()
        for _ in range(100):  # the server counts the closed socket out once it has seen it go
            with play(server, "127.0.0.2", guest="ann5") as again:
                if receive(again)["type"] == "hello":
                    break
            time.sleep(0.1)
        else:
            raise AssertionError("a closed socket's slot was never given back")


def test_one_owner_holds_at_most_its_setting_of_sockets_guest_or_signed_in(server):
    setting(server, "web.live_games_per_owner", 2)
    setting(server, "web.live_games_per_address", 100)  # sockets of the first round may still be closing
    token = server.token("bea")
    for who in ({"guest": "carol"}, {"token": token}):
        with play(server, "127.0.0.4", **who) as first, play(server, "127.0.0.4", **who) as second:
            assert receive(first)["type"] == receive(second)["type"] == "hello"
            with play(server, "127.0.0.4", **who) as third:
                message, code, reason = refusal(third)
            assert code == 1013 and "web.live_games_per_owner" in reason, (who, reason)
            owner = "guest-carol" if "guest" in who else "bea"
            assert message["detail"] == (f"2 game(s) already open as {owner} (the league's web.live_games_per_owner); "
                                         "close one to play here")
            with play(server, "127.0.0.4", guest="dora") as other:  # another owner on the same address plays
                assert receive(other)["type"] == "hello"


def test_a_deeply_nested_message_is_answered_and_the_game_goes_on(server):
    with play(server, "127.0.0.5", guest="deep") as socket:
        assert receive(socket)["type"] == "hello"
        socket.send("[" * 60_000)  # 60,000 deep: as deep as a frame of the server's 64 KiB limit holds
        assert receive(socket) == {"type": "error", "detail": "a play message is 60000 bytes, over the limit of "
                                   "4096; send a smaller document"}
        socket.send("[" * 4000)
        assert receive(socket)["detail"] == ("a play message nests arrays and objects 4000 deep, deeper than the "
                                             "limit of 8; write it with less nesting")
        socket.send(json.dumps({"type": "next"}))
        assert receive(socket)["type"] == "match"
    assert httpx.get(f"{server.url}/api/games").status_code == 200


def cell(row: int, col: int) -> str:
    return json.dumps({"type": "act", "point": [col + 0.5, SIZE - row - 0.5]})


def move(socket: ClientConnection, cells: Iterator[tuple[int, int]]) -> None:
    """Play the next free cell (a refused one is skipped), and a next match once one ends."""
    for row, col in cells:
        socket.send(cell(row, col))
        while True:
            message = receive(socket)
            if message["type"] == "refused":
                break  # the cell is taken: the next one
            if message["type"] == "end":
                socket.send(json.dumps({"type": "next"}))
                continue
            if message["type"] == "frame" and message["waiting"]:
                return
    raise AssertionError("no free cell left")


def closed_for_idleness(server, address: str, poke, rounds: int) -> tuple[int, str, int]:
    """Two guests on ``address``: one pokes its socket with ``poke(socket, round)`` (which returns
    the answer it reads) once a second, the other moves; returns the poker's close code, reason and
    how many pokes were answered before it was closed. The mover must still play afterwards."""
    with play(server, address, guest="poker") as poker, play(server, address, guest="mover") as mover:
        assert receive(poker)["type"] == receive(mover)["type"] == "hello"
        mover.send(json.dumps({"type": "next"}))
        while receive(mover).get("waiting") is not True:
            pass
        cells = iter([(r, c) for r in range(SIZE) for c in range(SIZE)])
        for round_ in range(rounds):
            try:
                message = poke(poker, round_)
            except ConnectionClosed as closed:
                return closed.rcvd.code, closed.rcvd.reason, round_
            if message["type"] == "error" and message["detail"].startswith("no move for"):
                with pytest.raises(ConnectionClosed) as closed:
                    poker.recv(timeout=60)
                move(mover, cells)  # the mover, who sent as many messages, plays on
                return closed.value.rcvd.code, closed.value.rcvd.reason, round_
            move(mover, cells)
            time.sleep(1.0)
        raise AssertionError(f"the poking socket was still open after {rounds} answers")


@pytest.mark.slow
def test_only_moves_keep_a_game_open(server):
    junk = [lambda s: s.send("not json"), lambda s: s.send(b"\x00\x01"),
            lambda s: s.send(json.dumps({"type": "dance"})), lambda s: s.send(json.dumps({"type": "act", "text": "w"}))]

    def send_junk(socket: ClientConnection, round_: int) -> dict:
        junk[round_ % len(junk)](socket)
        socket.ping()
        message = receive(socket)
        assert message["type"] == "error", message  # answered, junk or the idle notice
        return message

    setting(server, "web.live_idle_seconds", 10)  # the least the setting takes
    try:
        code, reason, answered = closed_for_idleness(server, "127.0.0.6", send_junk, 60)
        assert code == 1008 and reason.startswith("no move for 10 s"), (code, reason)
        assert answered >= 4  # it was answered (and not closed) while it sent junk
    finally:
        setting(server, "web.live_idle_seconds", 600)


def start_and_resign(socket: ClientConnection) -> dict:
    """Start a match and resign it at once; the last message (``end``, or an error)."""
    socket.send(json.dumps({"type": "next"}))
    while (message := receive(socket))["type"] in ("match", "frame") and message.get("waiting") is not True:
        pass
    if message["type"] == "error":
        return message
    socket.send(json.dumps({"type": "resign"}))
    return receive(socket)


@pytest.mark.slow
def test_starting_and_resigning_matches_does_not_keep_a_game_open(server):
    def loop_a_match(socket: ClientConnection, round_: int) -> dict:
        message = start_and_resign(socket)
        assert (message["type"] == "end" and message["resigned"]) or message["detail"].startswith("no move for"), \
            message
        return message

    setting(server, "web.live_idle_seconds", 10)  # the least the setting takes
    setting(server, "web.live_matches_per_minute", 600)  # the idle time is what closes it, not the rate
    try:
        code, reason, looped = closed_for_idleness(server, "127.0.0.7", loop_a_match, 40)
        assert code == 1008 and reason.startswith("no move for 10 s"), (code, reason)
        assert looped >= 4  # its matches were played (and it was not closed) until the idle time
    finally:
        setting(server, "web.live_idle_seconds", 600)
        setting(server, "web.live_matches_per_minute", 6)


def test_a_socket_starts_at_most_its_setting_of_matches_a_minute(server):
    setting(server, "web.live_matches_per_minute", 2)
    try:
        with play(server, "127.0.0.8", guest="hasty") as socket:
            assert receive(socket)["type"] == "hello"
            assert start_and_resign(socket)["type"] == start_and_resign(socket)["type"] == "end"
            socket.send(json.dumps({"type": "next"}))
            message = receive(socket)
            assert message["type"] == "error", message
            head, wait = message["detail"].rsplit(" in ", 1)
            assert head == ("at most 2 match(es) a minute start on one play page (the league's "
                            "web.live_matches_per_minute); the next can start")
            assert wait.endswith(" s") and 0 < int(wait.removesuffix(" s")) <= 60, wait
            socket.send(json.dumps({"type": "resign"}))  # no match was started: nothing to resign
            socket.send(json.dumps({"type": "dance"}))
            assert "unknown message type" in receive(socket)["detail"]
    finally:
        setting(server, "web.live_matches_per_minute", 6)
