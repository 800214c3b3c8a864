"""The pages in a real browser: Playwright driving Debian's Chromium against ``arena-league serve``.

A submitter signs in with a token, uploads an agent through /submit, watches its validation job
finish (the page follows it over server-sent events), ranks it, finds it highlighted on the game's
page, records a replay of one of its matches and plays that replay to its last step. Skipped, with
the reason, where Chromium or Playwright is missing (``.ci/run`` installs both).
"""

from __future__ import annotations

import shutil

import pytest
from browser_helpers import CHROMIUM, chromium, playwright_or_skip
from cli_helpers import gobang_agent
from web_helpers import Server, running_server

GAME = "GoBang-2T1P-v1"
pytestmark = pytest.mark.slow
sync_api = playwright_or_skip()


@pytest.fixture(scope="module")
def server(tmp_path_factory) -> Server:
    with running_server(tmp_path_factory.mktemp("browser") / "home") as running:
        yield running


@pytest.fixture(scope="module")
def browser():
    with chromium(sync_api) as launched:
        yield launched


def wait_done(page, seconds: float = 120) -> None:
    """Wait on a job page until its state (updated live) says done."""
    sync_api.expect(page.locator('#job [data-role="state"]')).to_have_text("done", timeout=seconds * 1000)


def test_sign_in_upload_watch_rank_find_and_replay(server, browser, tmp_path):
    token = server.token("walker")
    folder = gobang_agent(tmp_path / "agent", 17)
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.set_default_timeout(60_000)
    # sign in: the token is kept in a cookie, and the header names its owner
    page.goto(f"{server.url}/signin?next=/submit")
    page.fill('input[name="token"]', token)
    page.click('button[type="submit"]')
    sync_api.expect(page.locator('[data-role="signed-in"]')).to_have_text("walker")
    assert page.url.endswith("/submit")
    # upload an arena-policy folder's two files; the job page follows the validation live
    page.select_option('select[name="game"]', GAME)
    page.fill('input[name="name"]', "walker-bot")
    page.set_input_files('input[name="file"]', [str(folder / "manifest.json"), str(folder / "weights.safetensors")])
    page.click('form[action="/submit"] button[type="submit"]')
    page.wait_for_url("**/jobs/*")
    wait_done(page)
    sync_api.expect(page.locator('[data-role="result"]')).to_contain_text('"status": "active"')
    # rank it from its page, then find it highlighted on the game's board
    page.click('[data-role="agent"]')
    page.click("text=Rank against the base population")
    page.wait_for_url("**/jobs/*")
    wait_done(page, 180)
    for _ in range(20):  # a served board may be a second behind the registry
        page.goto(f"{server.url}/games/{GAME}")
        mine = page.locator("tr.mine")
        if mine.count():
            break
        page.wait_for_timeout(500)
    sync_api.expect(mine).to_have_count(1)
    sync_api.expect(mine.locator("td.name")).to_contain_text("walker-bot")
    # a match of it: record its replay, then play it to the last step
    page.goto(f"{server.url}/agents/walker-bot")
    page.locator("table.data a[href^='/matches/']").first.click()
    match_url = page.url
    page.click("text=Record the replay")
    page.wait_for_url("**/jobs/*")
    wait_done(page)
    page.goto(match_url)
    player = page.locator(".replay-player")
    sync_api.expect(player).to_have_attribute("data-state", "ready")
    frames = int(page.locator('[data-role="seek"]').get_attribute("max"))
    page.select_option('[data-role="speed"]', "4")
    page.click('[data-role="play"]')
    sync_api.expect(player).to_have_attribute("data-frame", str(frames), timeout=120_000)
    sync_api.expect(player).to_have_attribute("data-playing", "false")
    sync_api.expect(page.locator('[data-role="outcome"]')).to_be_visible()
    sync_api.expect(page.locator('[data-role="step"]')).to_contain_text(f"/ {frames}")
    page.screenshot(path=str(tmp_path / "replay.png"))
    page.close()


def test_pages_read_without_javascript_and_without_a_token(server, browser):
    context = browser.new_context(java_script_enabled=False)
    page = context.new_page()
    page.goto(f"{server.url}/")
    sync_api.expect(page.locator("h1")).to_have_text("Games")
    page.click(f"text={GAME}")
    sync_api.expect(page.locator("#leaderboard")).to_be_visible()
    page.goto(f"{server.url}/submit")
    sync_api.expect(page.locator("main")).to_contain_text("Sign in with your token to submit")
    context.close()


def test_chromium_is_the_system_one():
    assert shutil.which("chromium") == str(CHROMIUM)
