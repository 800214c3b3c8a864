"""No dead ends on the web, over real HTTP: a game page whose shipped base population is not
imported yet queues its import once and shows the board when it is done; a match is the same
id in the terminal and on its page; a finished job's page says what it made and ends its bar."""

from __future__ import annotations

import re

import pytest
from cli_helpers import gobang_agent, run
from web_helpers import Server, running_server

from arena_league.league import ensure_scripted_agents, evaluate, open_home, submit

GOBANG = "GoBang-2T1P-v1"
CROSSROADS = "Crossroads-2T2P-v1"
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def idle_server(tmp_path_factory) -> Server:
    """A server without a job worker, over a league with GoBang's scripted agents and one match of them:
    jobs are run by the test's commands."""
    home = tmp_path_factory.mktemp("dead-ends") / "home"
    with open_home(home) as league:
        ensure_scripted_agents(league, GOBANG)
        evaluate(league, GOBANG, matches_per_pair=1)
    with running_server(home, workers=0) as running:
        yield running


def test_a_game_page_imports_the_shipped_base_through_one_job_then_shows_it(tmp_path):
    with running_server(tmp_path / "home") as server, server.client() as client:
        first = client.get(f"/games/{CROSSROADS}.json").json()["importing"]
        assert first["population"] == "base-v1" and first["state"] in ("queued", "running")
        job = first["job"]
        page = client.get(f"/games/{CROSSROADS}").text
        assert f"Importing base-v1 of {CROSSROADS} (<a href=\"/jobs/{job}\">job {job}</a>)" in page
        board = client.get(f"/api/games/{CROSSROADS}/leaderboard").json()
        assert board["importing"]["job"] == job  # asked again: the same job, not a second one
        assert f"/jobs/{job}" in client.get(f"/play/{CROSSROADS}").text
        done = server.wait_job(job)
        assert done["state"] == "done", done["error"]
        assert done["summary"] == f"base-v1:1 of {CROSSROADS} imported."
        assert done["links"] == [{"text": f"the {CROSSROADS} board", "href": f"/games/{CROSSROADS}"}]
        view = client.get(f"/games/{CROSSROADS}.json").json()
        assert view["importing"] is None and view["population"] == "base-v1:1" and view["n_agents"] == 100
        assert "Importing" not in client.get(f"/games/{CROSSROADS}").text
        assert "importing" not in client.get(f"/api/games/{CROSSROADS}/leaderboard").json()


def test_a_match_has_one_id_in_the_terminal_and_on_the_web(idle_server, capsys):
    home = ["--home", str(idle_server.home)]
    _, listed, _ = run(capsys, "matches", GOBANG, "--json", *home)
    [match] = listed["matches"]
    with idle_server.client() as client:
        shown = client.get(f"{match['page']}.json").json()
        assert shown["id"] == match["id"] and shown["key"] == match["match_key"]
        code, replay, err = run(capsys, "replay", match["id"], "--record", "--json", *home)
        assert code == 0 and replay["match"] == match["id"], err
        assert client.get(f"/matches/{match['id']}.json").json()["replay"] is True
        _, jobs, _ = run(capsys, "jobs", "list", "--json", *home)
        [job] = [j["id"] for j in jobs["jobs"] if j["kind"] == "replay"]
        view = client.get(f"/api/jobs/{job}").json()
        assert view["summary"].startswith(f"Match {match['id']} was played again and ended as stored")
        assert {"text": f"match {match['id']}", "href": match["page"]} in view["links"]
        assert view["progress"]["done"] == view["progress"]["total"]


def test_a_finished_placement_page_says_where_it_stopped_and_links_the_agent(idle_server, capsys, tmp_path):
    with open_home(idle_server.home) as league:
        submit(league, gobang_agent(tmp_path / "agent", 5), GOBANG, "walker")
    code, report, err = run(capsys, "rank", "walker", "--league-wide", "--budget", "60", "--json",
                            "--home", idle_server.home)
    assert code == 0, err
    assert report["matches"] < 60  # its interval was narrow enough before the budget ran out
    with idle_server.client() as client:
        view = client.get(f"/api/jobs/{report['job_id']}").json()
        budget = view["progress"]["total"]
        assert view["progress"]["done"] == budget
        assert view["progress"]["label"].startswith(f"stopped after {report['matches']} of {budget}: ")
        assert view["summary"].startswith(f"walker placed against all active agents: rank {report['rank']} of 3")
        page = client.get(f"/jobs/{report['job_id']}").text
        assert re.search(r'<progress data-role="progress" max="(\d+)" value="\1">', page)
        assert '<a href="/agents/walker" data-role="agent">' in page
        assert "<details data-role=\"result\">" in page and "<summary>The result as JSON</summary>" in page


def test_an_unknown_job_or_match_is_one_line(idle_server):
    with idle_server.client() as client:
        for path, detail in (("/api/jobs/9999", "there is no job 9999"), ("/api/matches/9999", "there is no match 9999")):
            answer = client.get(path)
            assert answer.status_code == 404 and answer.json()["detail"].startswith(detail)


def test_a_name_the_board_shows_opens_its_agent_and_a_typo_is_answered_with_the_name(idle_server):
    with idle_server.client() as client:
        board = client.get(f"/games/{GOBANG}.json", params={"method": "elo"}).json()
        for row in board["rows"]:
            assert client.get(f"/api/agents/{row['short']}").json()["name"] == row["agent"]
        answer = client.get("/api/agents/rando")
        assert answer.status_code == 404 and "Did you mean 'random'?" in answer.json()["detail"]


def test_a_cancelled_job_page_says_it_stopped_and_why(idle_server, capsys):
    home = ["--home", str(idle_server.home)]
    _, queued, _ = run(capsys, "evaluate", GOBANG, "--queue", "--matches-per-pair", "3", "--json", *home)
    assert run(capsys, "jobs", "cancel", queued["queued"], *home)[0] == 0
    with idle_server.client() as client:
        view = client.get(f"/api/jobs/{queued['queued']}").json()
    assert view["state"] == "cancelled" and view["finished"]
    assert view["progress"]["done"] == view["progress"]["total"]
    assert view["progress"]["label"] == "stopped after 0 of 1: cancelled"
    assert view["summary"] == "The evaluate job was cancelled; matches it had stored stay stored."
