"""Names that cannot impersonate or block: one Unicode form, no hidden characters, no look-alike of
another name of the game (UTS #39 skeletons), and the names of the agents people play as
(``<owner>@<game>``, ``guest-<name>@<game>``) kept from uploads and owners.

Below the web: the league's ``submit``, ``create_token`` and ``player_of`` on a real SQLite league,
and ``arena-league submit`` as a process. Over the web: a real ``arena-league serve`` on loopback,
uploads by httpx and the play socket by ``websockets``.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time

import pytest
from cli_helpers import gobang_agent
from web_helpers import running_server
from websockets.sync.client import connect

from arena_league import registry as reg
from arena_league.league import ForbiddenError, create_token, open_home, player_of, submit
from arena_league.league.versions import version_name

GAME = "GoBang-2T1P-v1"
OTHER_GAME = "Crossroads-2T2P-v1"


@pytest.fixture
def league(tmp_path):
    with open_home(tmp_path / "home") as opened:
        yield opened


def holder(league, name: str, game_id: str = GAME, owner: str = "alice") -> None:
    """``owner``'s agent ``name`` (reserved: a name held without bytes, as an upload in flight holds it)."""
    from arena_league.league.home import register_game

    register_game(league, game_id)
    with league.transaction() as session:
        reg.create_agent(session, name, game_id, "submission", owner=owner, reserved=True)


@pytest.mark.parametrize(("name", "shown"), [
    ("alice-a1\n", "U+000A"),           # shows as a second alice-a1
    ("alice\ta1", "U+0009"),
    ("ali\u200bce-a1", "U+200B zero width space"),
    ("ali\u202ece-a1", "U+202E right-to-left override"),
    ("\uff41lice-a1", "'alice-a1'"),     # fullwidth a: its NFKC form is named
])
def test_hidden_characters_and_other_forms_are_refused_with_one_line(league, tmp_path, name, shown):
    with pytest.raises(ValueError) as refused:
        submit(league, tmp_path / "never-read.onnx", GAME, name, owner="mallory")
    message = str(refused.value)
    assert "\n" not in message.replace(repr(name), "") and shown in message
    with league.reading() as session:
        assert reg.agent_names(session, GAME) == []


@pytest.mark.parametrize("twin", ["\u0430lice-a1", "a1ice-a1", "aIice-a1"])  # Cyrillic a, digit one, capital I
def test_a_look_alike_of_an_agent_of_the_game_is_refused_and_free_in_another_game(league, tmp_path, twin):
    holder(league, "alice-a1")
    with pytest.raises(ForbiddenError, match="can be mistaken for 'alice-a1'"):
        submit(league, tmp_path / "never-read.onnx", GAME, twin, owner="mallory")
    holder(league, "someone-else", OTHER_GAME, owner="bob")
    with league.reading() as session:
        assert version_name(session, twin, OTHER_GAME, "mallory") == (twin, 1)
        assert version_name(session, "alice-a1", GAME, "alice") == ("alice-a1:v2", 2)  # her own name: a version


@pytest.mark.parametrize("name", [f"alice@{GAME}", f"guest-carol@{GAME}", "guest-carol", "Guest-x", "x@G\u043eBang-2T1P-v1",
                                  "alice@gobang-2t1p-v1", "alice@GOBANG-2T1P-V1", "base-v9.top", "BASE-V1.sp-s0-sp-5120",
                                  "b\u0430se-v2.top"])
def test_the_names_people_play_as_cannot_be_submitted(league, tmp_path, name):
    with pytest.raises(ForbiddenError, match="reserved for the league") as refused:
        submit(league, tmp_path / "never-read.onnx", GAME, name, owner="mallory")
    suggestion = str(refused.value).rpartition("--name ")[2]
    assert "@" not in suggestion and not suggestion.lower().startswith("guest-")
    with league.reading() as session:
        assert reg.agent_names(session, GAME) == []
    assert player_of("alice", None) == ("alice", "alice")
    assert player_of(None, "carol") == ("guest-carol", "guest-carol")


@pytest.mark.parametrize(("name", "end"), [
    (f"alice@{GAME}.", "."), ("alice@GoBang-2T1P-v1-", "-"), ("base-v1.dppo-s0-seat3-20480@Crossroads-2T2P-v1.", "."),
    ("alice_", "_"), ("alice+", "+"), ("alice@", "@"),
])
def test_an_agent_name_must_end_in_a_letter_or_digit(league, tmp_path, name, end):
    with pytest.raises(ValueError, match="must end in a letter or digit") as refused:
        submit(league, tmp_path / "never-read.onnx", GAME, name, owner="mallory")
    assert f"ends in {end!r}" in str(refused.value) and "\n" not in str(refused.value)
    with league.reading() as session:
        assert reg.agent_names(session, GAME) == []


def test_names_like_a_member_only_in_part_stay_free():
    from arena_league.league.names import member_name_reason

    assert member_name_reason("base-v9.top") is not None
    assert all(member_name_reason(name) is None for name in ("base-vx.top", "base-v9", "my-base-v9.top", "base-v.x"))


@pytest.mark.parametrize(("owner", "words"), [
    ("guest-carol", "keeps for guests"), ("gu\u0435st-carol", "keeps for guests"),  # with a Cyrillic e too
    ("carol@example.org", "holds '@'"), ("alice\n", "U+000A"), ("\uff41lice", "'alice'"),
    ("a1ice", "can be mistaken for 'alice'"), ("ALICE", "can be mistaken for 'alice'"),
    ("A1ICE", "can be mistaken for 'alice'"), ("carol.", "must end in a letter or digit"),
    ("carol-", "must end in a letter or digit"), ("carol_", "must end in a letter or digit"),
])
def test_owner_names_stay_out_of_the_guests_and_look_like_no_other_owner(league, owner, words):
    create_token(league, "alice")
    with pytest.raises(ValueError, match=re.escape(words)):
        create_token(league, owner)
    assert create_token(league, "alice")["owner"] == "alice"  # a second token of the same owner


def test_an_owner_named_like_a_guest_before_this_rule_cannot_play_as_the_guest(league):
    with league.transaction() as session:
        reg.create_token(session, "guest-dave", "0" * 64, "al_old")
    with pytest.raises(ValueError, match="named like a guest"):
        player_of("guest-dave", None)
    with pytest.raises(ValueError, match="guest name"):
        player_of(None, "dave\n")


def test_the_command_refuses_a_name_with_a_newline_in_one_line(tmp_path):
    agent = gobang_agent(tmp_path / "agent", 3)
    done = subprocess.run([sys.executable, "-m", "arena_league.cli", "submit", str(agent), "--game", GAME,
                           "--name", "alice\n", "--home", str(tmp_path / "home")],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "U+000A" in done.stderr, done.stderr


# --- over the web -------------------------------------------------------------------------------

def play_hello(url: str, query: str = "", token: str | None = None, seconds: float = 240) -> dict:
    """The play socket's first message once the game's base population is imported (a worker's job)."""
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    deadline = time.monotonic() + seconds
    while True:
        with connect(f"ws://{url.removeprefix('http://')}/ws/play/{GAME}{query}", additional_headers=headers,
                     origin=url, open_timeout=60) as socket:
            message = json.loads(socket.recv(timeout=120))
        if message.get("type") == "hello" or "being imported" not in message.get("detail", "") \
                or time.monotonic() > deadline:
            return message
        time.sleep(1)


@pytest.mark.slow
def test_uploads_cannot_take_or_imitate_the_names_people_play_as(tmp_path):
    with running_server(tmp_path / "home") as server:
        mallory, alice = server.token("mallory"), server.token("alice")
        onnx = [("file", ("model.onnx", b"never stored"))]
        with server.client(mallory) as client:
            for name in (f"alice@{GAME}", f"guest-carol@{GAME}"):
                taken = client.post("/api/agents", data={"game": GAME, "name": name}, files=onnx)
                assert taken.status_code == 403 and "reserved for the league" in taken.json()["detail"], taken.text
            hidden = client.post("/api/agents", data={"game": GAME, "name": "alice-a1\n"}, files=onnx)
            assert hidden.status_code == 400 and "U+000A" in hidden.json()["detail"]
        signed_in, guest = play_hello(server.url, token=alice), play_hello(server.url, "?guest=carol")
        assert signed_in.get("agent") == f"alice@{GAME}", signed_in
        assert guest.get("agent") == f"guest-carol@{GAME}", guest
