"""The web service over real HTTP: ``arena-league serve`` in a subprocess on a free loopback port,
httpx as the client, a temporary SQLite league (and one PostgreSQL test). Uploads are validated by
the server's worker; reads are open, writes need a token, private data is its owner's."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import hostile_agents as hostile
import httpx
import pytest
from cli_helpers import gobang_agent
from registry_fixtures import _own_schema
from web_helpers import Server, running_server

GAME = "GoBang-2T1P-v1"
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def server(tmp_path_factory) -> Server:
    with running_server(tmp_path_factory.mktemp("web") / "home") as running:
        yield running


@pytest.fixture(scope="module")
def alice(server) -> str:
    return server.token("alice")


def policy_files(folder: Path) -> list[tuple[str, tuple[str, bytes]]]:
    return [("file", (name, (folder / name).read_bytes())) for name in ("manifest.json", "weights.safetensors")]


def onnx_files(tmp_path: Path, seed: int) -> list[tuple[str, tuple[str, bytes]]]:
    path = hostile.save(hostile.plain(GAME, seed=seed), tmp_path / f"agent-{seed}.onnx")
    return [("file", ("model.onnx", path.read_bytes()))]


def upload(server: Server, token: str | None, name: str, files, game: str = GAME) -> httpx.Response:
    with server.client(token) as client:
        return client.post("/api/agents", data={"game": game, "name": name}, files=files)


def board_with(client: httpx.Client, agent: str) -> dict:
    """The game's board once it lists ``agent`` placed (a served board may be a second behind)."""
    deadline = time.monotonic() + 10
    while True:
        board = client.get(f"/api/games/{GAME}/leaderboard").json()
        if any(r["agent"] == agent and r["status"] == "placed" for r in board["rows"]) or time.monotonic() > deadline:
            return board
        time.sleep(0.2)


def test_pages_and_their_json_twins_are_served_to_anyone(server):
    with server.client() as client:
        games = client.get("/api/games").json()
        assert {g["game_id"] for g in games} >= {GAME, "Crossroads-2T2P-v1"}
        assert next(g for g in games if g["game_id"] == GAME)["base_shipped"] is True
        for page, twin in (("/", "/index.json"), (f"/games/{GAME}", f"/games/{GAME}.json")):
            html = client.get(page, headers={"accept": "text/html"})
            assert html.status_code == 200 and "text/html" in html.headers["content-type"]
            assert f'href="{twin}' in html.text  # the page names its JSON twin
            assert client.get(twin).headers["content-type"].startswith("application/json")
        assert client.get("/openapi.json").json()["paths"]["/api/agents"]["post"]
        missing = client.get("/agents/nobody", headers={"accept": "text/html"})
        assert missing.status_code == 404 and "there is no agent" in missing.text
        assert client.get("/api/agents/nobody").json()["detail"].startswith("there is no agent 'nobody'")
        assert client.get("/api/games/Gobang-2T1P-v1/leaderboard").status_code == 404


def test_writes_need_a_valid_token(server, tmp_path):
    refused = upload(server, None, "anon", onnx_files(tmp_path, 1))
    assert refused.status_code == 401 and refused.headers["www-authenticate"] == "Bearer"
    assert "writing needs a token" in refused.json()["detail"]
    forged = upload(server, "al_" + "x" * 43, "forged", onnx_files(tmp_path, 1))
    assert forged.status_code == 401 and "not valid" in forged.json()["detail"]
    with server.client() as client:
        assert client.post("/api/matches/1/replay").status_code == 401
        assert client.post("/api/agents/x/rank").status_code == 401


def test_an_upload_is_validated_by_a_job_and_a_name_is_a_series_of_versions(server, alice, tmp_path):
    first = upload(server, alice, "ann", onnx_files(tmp_path, 1))
    assert first.status_code == 202
    assert {k: first.json()[k] for k in ("name", "version", "status")} == {"name": "ann", "version": 1,
                                                                           "status": "pending"}
    assert server.wait_job(first.json()["job"])["result"]["status"] == "active"
    second = upload(server, alice, "ann", onnx_files(tmp_path, 2)).json()  # new bytes, same name
    assert (second["name"], second["version"]) == ("ann:v2", 2)
    assert server.wait_job(second["job"])["state"] == "done"
    again = upload(server, alice, "ann", onnx_files(tmp_path, 2)).json()  # the same bytes again
    job = server.wait_job(again["job"])
    result = job["result"]
    assert (result["agent"], result["status"], result["created"]) == ("ann:v2", "active", False)
    assert job["agent"] == "ann:v2"  # the job page links the agent the bytes belong to
    assert "already agent ann:v2" in result["note"] and "rename" not in result["note"]
    with server.client() as client:
        agent = client.get("/api/agents/ann").json()
        assert client.get(f"/api/agents/{again['name']}").status_code == 404  # the reserved version was dropped
    assert agent["owner"] == "alice" and agent["status"] == "active"
    assert [(v["name"], v["status"]) for v in agent["versions"]] == [("ann", "active"), ("ann:v2", "active")]
    squatter = upload(server, server.token("mallory"), "ann", onnx_files(tmp_path, 3))
    assert squatter.status_code == 403 and "belongs to another submitter" in squatter.json()["detail"]
    reserved = upload(server, alice, f"random@{GAME}", onnx_files(tmp_path, 4))
    assert reserved.status_code == 403 and "reserved" in reserved.json()["detail"]


def test_the_web_and_the_command_follow_one_rule_for_names_files_and_budgets(server, alice, tmp_path):
    """What the terminal answers (the command run on the server's league), the API answers too."""
    def refused_by_the_command(*argv: str) -> str:
        done = subprocess.run([sys.executable, "-m", "arena_league.cli", *argv, "--home", str(server.home)],
                              capture_output=True, text=True, timeout=120, check=False)
        assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
        return done.stderr.removeprefix("error: ").strip()

    empty = upload(server, alice, "hollow", [("file", ("model.onnx", b""))])
    (tmp_path / "model.onnx").write_bytes(b"")
    assert empty.status_code == 400
    assert empty.json()["detail"] == refused_by_the_command("submit", str(tmp_path / "model.onnx"), "--game", GAME,
                                                            "--name", "hollow")
    terminal = refused_by_the_command("submit", str(gobang_agent(tmp_path / "t", 31)), "--game", GAME, "--name",
                                      "ann", "--owner", "mallory")
    squatter = upload(server, server.token("mallory"), "ann", onnx_files(tmp_path, 32))
    assert squatter.status_code == 403 and squatter.json()["detail"] == terminal
    queued = upload(server, alice, "budgeted", policy_files(gobang_agent(tmp_path / "b", 33))).json()
    server.wait_job(queued["job"])
    with server.client(alice) as client:
        over = client.post("/api/agents/budgeted/rank", json={"budget": 5001})
    assert over.status_code == 400
    assert over.json()["detail"] == refused_by_the_command("rank", "budgeted", "--budget", "5001")
    with server.client() as client:
        assert client.get("/api/agents/hollow").status_code == 404


def test_an_arena_policy_folder_uploads_as_its_files(server, alice, tmp_path):
    queued = upload(server, alice, "folder-agent", policy_files(gobang_agent(tmp_path / "f", 5))).json()
    assert server.wait_job(queued["job"])["result"]["status"] == "active"


def test_refused_uploads_keep_nothing(server, alice, tmp_path):
    uploads = server.home / "uploads"
    cases = [
        ([("file", ("../escape.onnx", b"x"))], 400, "not allowed"),
        ([("file", ("weights.safetensors", b"x"))], 400, "an upload is one .onnx file"),
        ([("file", ("a.onnx", b"x")), ("file", ("b.onnx", b"y"))], 400, "an upload is one .onnx file"),
    ]
    for files, status, words in cases:
        response = upload(server, alice, "refused", files)
        assert response.status_code == status and words in response.json()["detail"], response.text
    typo = upload(server, alice, "refused", onnx_files(tmp_path, 6), game="Gobang-2T1P-v1")
    assert typo.status_code == 400 and "did you mean 'GoBang-2T1P-v1'" in typo.json()["detail"]
    bad_name = upload(server, alice, "a:b", onnx_files(tmp_path, 6))
    assert bad_name.status_code == 400 and "not allowed" in bad_name.json()["detail"]
    server.command("settings", "set", "web.upload_mib", "1")
    try:
        big = [("file", ("model.onnx", b"\0" * (3 << 20)))]
        too_big = upload(server, alice, "big", big)
        assert too_big.status_code == 413 and "over 1 MiB" in too_big.json()["detail"]
    finally:
        server.command("settings", "reset", "web.upload_mib")
    assert not uploads.exists() or list(uploads.iterdir()) == []
    with server.client() as client:
        assert client.get("/api/agents/refused").status_code == 404


def test_uploads_are_rate_limited_per_owner(server, tmp_path):
    token = server.token("hasty")
    server.command("settings", "set", "web.uploads_per_hour", "2")
    try:
        for seed in (11, 12):
            assert upload(server, token, f"hasty{seed}", onnx_files(tmp_path, seed)).status_code == 202
        limited = upload(server, token, "hasty13", onnx_files(tmp_path, 13))
        assert limited.status_code == 429 and "web.uploads_per_hour" in limited.json()["detail"]
        assert limited.headers["retry-after"] == "3600"
    finally:
        server.command("settings", "reset", "web.uploads_per_hour")


def test_the_log_is_its_owners_alone(server, alice, tmp_path):
    queued = upload(server, alice, "logged", onnx_files(tmp_path, 21)).json()
    server.wait_job(queued["job"])
    with server.client(alice) as client:
        log = client.get("/api/agents/logged/log").json()
    assert "[size] a forward of 128 rows" in log["validation_log"] and log["forfeits"] == []
    for token in (None, server.token("eve")):
        with server.client(token) as client:
            assert client.get("/api/agents/logged/log").status_code == 404
            assert "validation_log" not in client.get("/agents/logged.json").json()
    with server.client(server.token("root", admin=True)) as client:
        assert client.get("/api/agents/logged/log").status_code == 200


def test_a_placement_is_queued_streams_its_progress_and_lands_on_the_board(server, alice, tmp_path):
    queued = upload(server, alice, "climber", policy_files(gobang_agent(tmp_path / "c", 9))).json()
    server.wait_job(queued["job"])
    with server.client(server.token("other")) as client:
        assert client.post("/api/agents/climber/rank").status_code == 403
    with server.client(alice) as client:
        job = client.post("/api/agents/climber/rank", json={"budget": 20}).json()["job"]
        events = []
        with client.stream("GET", f"/api/jobs/{job}/events") as stream:
            for line in stream.iter_lines():
                if line.startswith("event: "):
                    events.append(line[7:])
                if line.startswith("data: ") and events[-1] == "done":
                    final = json.loads(line[6:])
                    break
    assert events[0] == "progress" and events[-1] == "done" and final["state"] == "done", final
    assert final["result"]["base"] == "base-v2:1" and final["result"]["matches"] > 0
    with server.client() as client:
        board = board_with(client, "climber")
        page = client.get(f"/games/{GAME}.json").json()
    row = next(r for r in board["rows"] if r["agent"] == "climber")
    assert board["population"] == "base-v2:1" and row["status"] == "placed" and row["rating"] is not None
    assert next(r for r in page["rows"] if r["agent"] == "climber")["owner"] == "alice"
    with server.client(alice) as client:
        assert next(r for r in client.get(f"/games/{GAME}.json").json()["rows"] if r["agent"] == "climber")["mine"]


def test_a_replay_is_recorded_on_demand_and_served_as_frames(server, alice, tmp_path):
    queued = upload(server, alice, "watched", policy_files(gobang_agent(tmp_path / "w", 13))).json()
    server.wait_job(queued["job"])
    with server.client(alice) as client:
        server.wait_job(client.post("/api/agents/watched/rank", json={"budget": 4}).json()["job"])
        match = client.get("/api/agents/watched").json()["recent_matches"][0]
        assert client.get(f"/api/matches/{match['id']}/replay").status_code == 404
        view = client.get(f"/api/matches/{match['id']}").json()
        assert view["replayable"] and not view["replay"]
        job = client.post(f"/api/matches/{match['id']}/replay").json()["job"]
        assert server.wait_job(job)["state"] == "done"
        document = client.get(f"/api/matches/{match['id']}/replay").json()
        page = client.get(f"/matches/{match['id']}", headers={"accept": "text/html"}).text
    stored = {t["team"]: t["outcome"] for t in view["teams"]}
    assert document["match"]["outcomes"] == [stored[t] for t in document["match"]["teams"]]
    assert len(document["frames"]) == document["match"]["steps"] + 1
    assert f'data-src="/api/matches/{match["id"]}/replay"' in page


def test_administrators_alone_manage_schedules_and_populations(server, alice):
    with server.client(alice) as client:
        assert client.get("/api/schedules").status_code == 403
        assert client.post(f"/api/games/{GAME}/population").status_code == 403
    with server.client(server.token("boss", admin=True)) as client:
        added = client.post("/api/schedules", json={"name": "nightly", "game": GAME, "cron": "0 3 * * *"})
        assert added.status_code == 201 and added.json()["name"] == "nightly"
        assert [s["name"] for s in client.get("/api/schedules").json()] == ["nightly"]
        assert client.delete("/api/schedules/nightly").json() == {"removed": "nightly"}
        assert client.post("/api/games/Snake-2T1P-v1/population").status_code == 400  # none shipped


def test_no_request_path_reaches_the_filesystem(server):
    with server.client() as client:
        for path in ("/static/../pyproject.toml", "/static/%2e%2e/app.py", "/static/..%2f..%2fREADME.md"):
            assert client.get(path).status_code == 404, path
        assert client.get("/static/replay.js").status_code == 200
        # a sign-in redirect goes to this site only
        token = server.token("visitor")
        form = client.get("/signin").cookies["arena_league_signin"]  # the sign-in form's own CSRF token
        response = client.post("/signin", data={"csrf_token": form, "token": token, "next": "https://evil.example/x"},
                               follow_redirects=False)
    assert response.status_code == 303 and response.headers["location"] == "/"


def test_every_request_is_one_log_line(server):
    with server.client() as client:
        client.get("/api/games")
        client.get("/api/agents/nobody")
    time.sleep(0.3)
    log = next(server.home.parent.glob("serve-*.log")).read_text()
    assert any(" GET /api/games 200 " in line for line in log.splitlines())
    assert any(" GET /api/agents/nobody 404 " in line for line in log.splitlines())
    assert "Traceback" not in log


@pytest.mark.postgres
def test_the_service_on_postgresql(tmp_path):
    with _own_schema() as url, running_server(tmp_path / "home", url) as server:
        token = server.token("pat")
        queued = upload(server, token, "pg-agent", onnx_files(tmp_path, 31)).json()
        assert server.wait_job(queued["job"])["result"]["status"] == "active"
        with server.client() as client:
            assert client.get("/api/agents/pg-agent").json()["owner"] == "pat"
            assert client.get(f"/games/{GAME}.json").status_code == 200
