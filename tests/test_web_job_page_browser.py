"""A finished job's page in Chromium: what the job made in words, links to it, a full bar with
where the job stopped, and the raw result only behind a toggle."""

from __future__ import annotations

import pytest
from browser_helpers import chromium, playwright_or_skip
from cli_helpers import gobang_agent
from web_helpers import running_server

from arena_league.league import LEAGUE_WIDE, ensure_scripted_agents, open_home, rank, submit

GAME = "GoBang-2T1P-v1"
pytestmark = pytest.mark.slow
sync_api = playwright_or_skip()


def test_a_finished_placement_reads_as_a_page(tmp_path):
    home = tmp_path / "home"
    with open_home(home) as league:
        ensure_scripted_agents(league, GAME)
        submit(league, gobang_agent(tmp_path / "agent", 3), GAME, "climber")
        report = rank(league, "climber", budget=60, population=LEAGUE_WIDE)
    with running_server(home, workers=0) as server, chromium(sync_api) as browser:
        page = browser.new_page()
        page.goto(f"{server.url}/jobs/{report.job_id}")
        bar = page.locator('#job [data-role="progress"]')
        assert bar.get_attribute("value") == bar.get_attribute("max")
        sync_api.expect(page.locator('[data-role="count"]')).to_contain_text(f"stopped after {report.matches} of")
        sync_api.expect(page.locator('[data-role="summary"]')).to_contain_text(
            f"climber placed against all active agents: rank {report.rank} of 3")
        raw = page.locator('[data-role="result"] pre')
        sync_api.expect(raw).to_be_hidden()  # the JSON waits behind its toggle
        page.click('[data-role="result"] summary')
        sync_api.expect(raw).to_contain_text('"base_size": 2')
        page.click('[data-role="agent"]')
        page.wait_for_url("**/agents/climber")
        sync_api.expect(page.locator("h1")).to_contain_text("climber")
