"""Playing in a browser, below the page: LivePlay's messages, and the WebSocket that carries them.

GoBang against the shipped base population (imported on first use): moves refused with the
reason, a match played to its end by cells, stored, placed as a finished placement and listed
on the leaderboard; a paced game stepping on its own with the newest key holding; the same moves
giving the same frames; and the socket refusing bad input, full servers and bad guest names.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from arena_league import registry as reg
from arena_league.envs import make
from arena_league.league import LivePlay, leaderboard, open_home, player_of, set_setting

GAME = "GoBang-2T1P-v1"
SIZE = 15


@pytest.fixture(scope="module")
def home(tmp_path_factory):
    return tmp_path_factory.mktemp("live") / "home"


def cell_point(row: int, col: int) -> list[float]:
    return [col + 0.5, SIZE - row - 0.5]


def stones(frame: dict) -> set[tuple[int, int]]:
    return {(SIZE - 1 - int(s["y"]), int(s["x"])) for s in frame["shapes"] if s["kind"] == "circle" and s["r"] > 0.3}


def play_out(live: LivePlay, order: list[tuple[int, int]]) -> tuple[list[dict], dict]:
    """Click ``order``'s cells (skipping taken ones) until the match ends; every frame, and the end."""
    frames: list[dict] = []
    taken: set[tuple[int, int]] = set()
    for row, col in order:
        if (row, col) in taken:
            continue
        out = live.act({"type": "act", "point": cell_point(row, col)})
        assert out and out[0]["type"] != "refused", out
        frames += [m for m in out if m["type"] == "frame"]
        taken = stones(frames[-1])
        ends = [m for m in out if m["type"] == "end"]
        if ends:
            return frames, ends[0]
    raise AssertionError("the match did not end")


ORDER = [(r, c) for r in range(SIZE) for c in range(SIZE)]


def test_moves_are_refused_with_the_reason_and_a_match_ends_stored_and_placed(home):
    with open_home(home) as league:
        live = LivePlay(league, GAME, player="ada", owner="ada")
        hello = live.hello()
        assert hello["agent"] == "ada@GoBang-2T1P-v1" and hello["base_size"] == 100
        opening, first = live.start()[:2]
        assert opening["type"] == "match" and opening["team"] == 0 and opening["controls"]["input"] == "cells"
        assert [s["role"] for s in opening["seats"]] == ["you", "opponent"]
        assert first["type"] == "frame" and first["waiting"] and first["step"] == 0
        refusals = [live.act({"type": "act", "point": p})[0]
                    for p in ([15.3, 3.0], [1.0], ["a", "b"], [float("nan"), 1], [1e308, -1e308])]
        assert [r["type"] for r in refusals] == ["refused"] * 5
        assert "off the board" in refusals[0]["reason"] and "point: [x, y]" in refusals[1]["reason"]
        assert refusals[4]["reason"] == "that click is outside the view; click on the board"
        assert "occupied" not in refusals[0]["reason"]
        out = live.act({"type": "act", "point": cell_point(7, 7)})
        assert [m["type"] for m in out] == ["frame", "frame"] and out[-1]["waiting"]
        assert live.act({"type": "act", "point": cell_point(7, 7)})[0]["reason"].startswith("H8 is occupied")
        assert live.act({"type": "act", "text": "x" * 65})[0]["type"] == "refused"
        frames, end = play_out(live, ORDER)
        assert frames[-1]["step"] == end["steps"] and not frames[-1]["waiting"]
        assert end["outcome"] in ("win", "loss", "draw") and end["reason"]
        assert end["placement"]["total_matches"] == 1 and end["placement"]["lower"] <= end["placement"]["rating"]
        assert not live.playing and live.resign() == []
        with league.reading() as session:
            match = reg.get_match_by_id(session, end["match_id"])
            seats = {s.agent.name: s.outcome for s in match.seats}
            placed = [j for j in reg.list_jobs(session, status="done", kind="rank")
                      if (j.payload or {}).get("agent") == "ada@GoBang-2T1P-v1"]
        assert seats["ada@GoBang-2T1P-v1"] == end["outcome"] and len(placed) == 1
        board = leaderboard(league, GAME, save=False, import_shipped=False)
        row = next(r for r in board.rows if r.agent == "ada@GoBang-2T1P-v1")
        assert row.kind == "human" and row.lower <= row.rating <= row.upper


def test_resigning_is_a_loss_and_the_next_match_changes_sides(home):
    with open_home(home) as league:
        live = LivePlay(league, GAME, player="bo", owner="bo")
        live.start()
        live.act({"type": "act", "point": cell_point(0, 0)})
        [end] = live.resign()
        assert end["outcome"] == "loss" and end["resigned"] and end["reason"] == "you resigned (a loss)"
        messages = live.start()
        assert messages[0]["team"] == 1
        # the opponent (black) moves first: the page gets its frame and then waits for the person
        assert messages[-1]["waiting"] and messages[-1]["step"] == 1
        with pytest.raises(ValueError, match="in progress"):
            live.start()


def test_matches_a_minute_are_bounded_by_the_clock(home):
    now = [1000.0]
    with open_home(home) as league:
        live = LivePlay(league, GAME, player="cy", owner="cy", matches_per_minute=2, clock=lambda: now[0])
        for _ in range(2):
            live.start()
            now[0] += 1.0
            assert live.resign()[0]["type"] == "end"
        with pytest.raises(ValueError, match=r"^at most 2 match\(es\) a minute .*web.live_matches_per_minute\); "
                           r"the next can start in 58 s$"):
            live.start()
        assert not live.playing
        now[0] = 1060.0  # a minute after the first started
        assert live.start()[0]["type"] == "match"


def test_the_same_moves_give_the_same_frames(home):
    def session(player: str) -> list[list[dict]]:
        with open_home(home) as league:
            live = LivePlay(league, GAME, player=player, owner=player)
            live.start()
            return [m["shapes"] for m in live.act({"type": "act", "point": cell_point(3, 4)})
                    + live.act({"type": "act", "point": cell_point(5, 5)}) if m["type"] == "frame"]

    assert session("twin-a") == session("twin-b")


def test_a_paced_game_steps_on_its_own_and_the_newest_key_holds(home):
    with open_home(home) as league:
        live = LivePlay(league, "Snake-2T2P-v1", player="cy", owner="cy")
        opening, first = live.start()[:2]
        assert live.pace == 6.0 and opening["controls"]["input"] == "keys" and not first["waiting"]
        assert [s["role"] for s in opening["seats"]] == ["you", "teammate", "opponent", "opponent"]
        assert {s["text"] for s in first["shapes"] if s["kind"] == "text"} >= {"you", "#1", "#2", "#3"}

        def head(frame: dict) -> np.ndarray:
            return np.asarray(next((s["x"], s["y"]) for s in frame["shapes"] if s.get("text") == "you"))

        a, b = head(live.tick()[0]), head(live.tick()[0])
        assert np.abs(b - a).sum() == pytest.approx(1.0)
        assert live.act({"type": "act", "text": "up?"})[0]["type"] == "refused"
        turn = "d" if (b - a)[1] != 0 else "w"
        assert live.act({"type": "act", "text": turn}) == []  # held for the next tick
        c = head(live.tick()[0])
        assert tuple(np.round(c - b)) == ((1.0, 0.0) if turn == "d" else (0.0, 1.0))
        assert live.act({"type": "act", "point": [1.0, 1.0]})[0]["reason"].startswith("this game is not played by")
        live.resign()


def test_guests_and_players_are_named_safely():
    assert player_of("alice", "ignored") == ("alice", "alice")
    assert player_of(None, "bob") == ("guest-bob", "guest-bob")
    for bad in (None, "", "two words", "x" * 40, "../etc"):
        with pytest.raises(ValueError, match="guest name"):
            player_of(None, bad)


def test_every_two_team_game_declares_how_a_browser_plays_it():
    from arena_league.envs import list_games

    for game in list_games():
        env = make(game)
        if env.rules.n_teams != 2:
            continue
        env.reset(seed=0)
        web = env.rules.human_controls(0).web()
        assert web["input"] in ("keys", "cells", "text") and web["hint"], game
        json.dumps(web)
        if web["input"] == "keys":
            assert web["pace"] and web["keys"] and all(isinstance(v, str) for v in web["keys"].values()), game


# --- the socket ---------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def client(home):
    from fastapi.testclient import TestClient

    from arena_league.web.app import create_app

    with TestClient(create_app(home)) as test_client:
        yield test_client


def test_the_socket_answers_bad_messages_with_one_line_and_plays_on(client):
    with client.websocket_connect(f"/ws/play/{GAME}?guest=sockets") as socket:
        assert socket.receive_json()["type"] == "hello"
        socket.send_json({"type": "next"})
        assert socket.receive_json()["type"] == "match"
        assert socket.receive_json()["waiting"]
        socket.send_text("not json")
        assert "one JSON object" in socket.receive_json()["detail"]
        socket.send_json({"type": "dance"})
        assert "unknown message type 'dance'" in socket.receive_json()["detail"]
        socket.send_json({"type": "next"})
        assert "in progress" in socket.receive_json()["detail"]
        socket.send_bytes(b"\x00\x01")  # no JSON text: answered, and the game goes on
        assert "one JSON object" in socket.receive_json()["detail"]
        socket.send_json({"type": "act", "point": cell_point(7, 7)})
        assert socket.receive_json()["type"] == "frame"


def test_the_socket_refuses_bad_guests_unknown_games_and_a_full_server(client, home):
    for path, words in ((f"/ws/play/{GAME}?guest=a%20b", "guest name"), (f"/ws/play/{GAME}", "guest name"),
                        ("/ws/play/Nope-v1?guest=x", "unknown game id"),
                        ("/ws/play/Snake-4T1P-v1?guest=x", "two-team matches")):
        with client.websocket_connect(path) as socket:
            message = socket.receive_json()
            assert message["type"] == "error" and words in message["detail"], (path, message)
    with open_home(home) as league:
        set_setting(league, "web.live_games", 0)
    try:
        with client.websocket_connect(f"/ws/play/{GAME}?guest=late") as socket:
            assert "web.live_games" in socket.receive_json()["detail"]
    finally:
        with open_home(home) as league:
            set_setting(league, "web.live_games", 8)
