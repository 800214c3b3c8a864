"""The social-tree editor in a real browser: Playwright driving Debian's Chromium against ``arena-league serve``.

A researcher signs in, starts from the paper's all-IS Crossroads tree and builds the blocking tree
of its case study by hand: a CP ``ranking`` root over two CL ``team_target`` team nodes, the
agents dragged into them (HTML5 drag and drop). The editor checks the tree as it is edited, the
league's worker verifies it (every node painted with its verified scheme), and the saved tree's
YAML builds the env with ``make(game, tree=path)``. A second test previews a match under a tree
in the replay player and shows the library's message when an edit lists an agent twice. Skipped,
with the reason, where Chromium or Playwright is missing (``.ci/run`` installs both).
"""

from __future__ import annotations

import re

import httpx
import pytest
from browser_helpers import chromium, playwright_or_skip
from web_helpers import Server, running_server

from arena_league.envs import make

GAME = "Crossroads-2T2P-v1"
pytestmark = pytest.mark.slow
sync_api = playwright_or_skip()
expect = sync_api.expect


@pytest.fixture(scope="module")
def server(tmp_path_factory) -> Server:
    with running_server(tmp_path_factory.mktemp("trees-browser") / "home") as running:
        yield running


@pytest.fixture(scope="module")
def browser():
    with chromium(sync_api) as launched:
        yield launched


def signed_in_editor(browser, server: Server, owner: str):
    """A page signed in as ``owner`` (a new token) with the editor open on GAME, and the list its
    script errors go to."""
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.set_default_timeout(30_000)
    errors: list[str] = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    page.goto(f"{server.url}/signin?next=/trees/new")
    page.fill('input[name="token"]', server.token(owner))
    page.click('button[type="submit"]')
    expect(page.locator('[data-role="signed-in"]')).to_have_text(owner)
    page.goto(f"{server.url}/trees/new?game={GAME}")
    expect(page.locator("#tree-editor")).to_have_attribute("data-state", "ready")
    expect(page.locator('[data-role="check"]')).to_have_attribute("data-state", "ok")  # the game's default tree
    return page, errors


def own(card, role: str):
    """The control ``role`` of the node ``card`` itself (not of the nodes inside it)."""
    return card.locator(f':scope > :not(.tree-children) [data-role="{role}"]')


def team_nodes(page):
    """The node cards right under the root, in order."""
    return page.locator('[data-path="root"] > .tree-children > [data-role="node"]')


def set_reward(card, scheme: str, reward: str, scale: str | None = None) -> None:
    own(card, "scheme").select_option(scheme)
    own(card, "reward").select_option(reward)
    if scale is not None:
        own(card, "scale").fill(scale)


def test_build_verify_and_save_the_blocking_tree(server, browser, tmp_path):
    page, errors = signed_in_editor(browser, server, "builder")
    check = page.locator('[data-role="check"]')
    # from the paper's all-IS example to its blocking tree: a CP root over two CL teams
    page.click('[data-role="example-all_IS"]')
    root = page.locator('[data-path="root"]')
    expect(own(root, "scheme")).to_have_value("IS")
    expect(root.locator('[data-role="leaf"]')).to_have_count(4)
    set_reward(root, "CP", "ranking", "100")
    expect(own(root, "param-order")).to_have_value("depart")  # the function's parameters, as fields
    own(root, "add-node").click()
    own(root, "add-node").click()
    teams = team_nodes(page)
    expect(teams).to_have_count(2)
    expect(check).to_have_attribute("data-state", "error")  # empty team nodes: the library says so
    expect(check).to_contain_text("non-empty 'children'")
    for agent, team in (("player_0", 0), ("player_1", 0), ("player_2", 1), ("player_3", 1)):
        page.locator(f'[data-agent="{agent}"] [data-role="leaf-name"]').drag_to(teams.nth(team))
        expect(teams.nth(team).locator(f'[data-agent="{agent}"]')).to_have_count(1)
    for team in range(2):
        set_reward(teams.nth(team), "CL", "team_target")
    expect(teams.nth(0)).to_have_attribute("data-path", "root/0")
    expect(teams.nth(1)).to_have_attribute("data-path", "root/1")
    expect(page.locator('[data-agent="player_1"]')).to_have_attribute("data-path", "root/0/player_1")
    expect(page.locator('[data-agent="player_3"]')).to_have_attribute("data-path", "root/1/player_3")
    expect(check).to_have_attribute("data-state", "ok")
    expect(check).to_contain_text("ok")
    expect(page.locator(".invalid")).to_have_count(0)
    # the paper's sampling verification, run by the server's worker, paints every node
    page.click('[data-role="verify"]')
    expect(own(root, "verified-scheme")).to_have_text("CP", timeout=120_000)
    for team in range(2):
        expect(own(teams.nth(team), "verified-scheme")).to_have_text("CL")
        expect(own(teams.nth(team), "verified")).to_contain_text("declared CL")
    expect(root).to_have_class(re.compile(r"\bverified-ok\b"))
    expect(page.locator('[data-role="job"]')).to_have_attribute("data-state", "done")
    # saved in the registry, offered as YAML that make(game, tree=...) builds
    page.fill('[data-role="tree-name"]', "blocking tree")
    page.click('[data-role="save"]')
    saved = page.locator('[data-role="saved"]')
    expect(saved).to_have_attribute("data-state", "saved")
    expect(saved.locator('[data-role="tree-link"]')).to_have_text("blocking tree")
    href = saved.locator('[data-role="download-yaml"]').get_attribute("href")
    assert href.endswith("/download?format=yaml")
    answer = httpx.get(server.url + href, timeout=30)
    assert answer.status_code == 200, answer.text
    path = tmp_path / "tree.yaml"
    path.write_text(answer.text)
    env = make(GAME, tree=str(path))
    assert [(n["path"], n["scheme"], n["reward"], n["agents"]) for n in env.tree.describe()] == [
        ("root", "CP", "ranking", [0, 1, 2, 3]), ("root/0", "CL", "team_target", [0, 1]),
        ("root/1", "CL", "team_target", [2, 3])]
    assert env.tree.spec["scale"] == 100
    env.reset(seed=0)
    rewards = env.step({agent: env.action_space(agent).sample() for agent in env.agents})[1]
    assert sorted(rewards) == ["player_0", "player_1", "player_2", "player_3"]
    # the saved tree's own page opens it in the editor
    page.click('[data-role="tree-link"]')
    expect(page.locator("h1")).to_contain_text("blocking tree")
    expect(page.locator("#tree-editor")).to_have_attribute("data-state", "ready")
    expect(own(page.locator('[data-path="root"]'), "scheme")).to_have_value("CP")
    expect(team_nodes(page)).to_have_count(2)
    expect(page.locator('[data-role="check"]')).to_have_attribute("data-state", "ok")
    assert errors == []
    page.close()


def test_preview_plays_a_match_and_a_repeated_agent_is_named(server, browser):
    page, errors = signed_in_editor(browser, server, "previewer")
    check = page.locator('[data-role="check"]')
    page.click('[data-role="example-CL_under_CP"]')
    expect(check).to_have_attribute("data-state", "ok")
    # one recorded match under the tree, opened in the replay player
    page.click('[data-role="preview"]')
    player = page.locator('[data-role="preview-result"] .replay-player')
    expect(player).to_have_attribute("data-state", "ready", timeout=120_000)
    expect(player.locator('canvas[data-role="view"]')).to_be_visible()
    frames = int(player.locator('[data-role="seek"]').get_attribute("max"))
    assert frames > 1
    player.locator('[data-role="speed"]').select_option("4")
    player.locator('[data-role="play"]').click()
    expect(player).to_have_attribute("data-frame", str(frames), timeout=60_000)
    expect(player.locator('[data-role="outcome"]')).to_be_visible()
    expect(page.locator('[data-role="preview-result"] table')).to_contain_text("player_3")
    # a bad edit: a duplicated team node lists its agents twice; the library's message names one
    team = team_nodes(page).nth(0)
    own(team, "duplicate").click()
    expect(team_nodes(page)).to_have_count(3)
    expect(check).to_have_attribute("data-state", "error")
    expect(check).to_contain_text("agent 'player_0' is listed twice")
    marked = page.locator('[data-path="root/1/player_0"]')
    expect(marked).to_have_attribute("data-invalid", "true")
    expect(page.locator('[data-path="root/1"]')).to_have_attribute("data-invalid", "within")
    # deleting the copy keeps every seat (its agents move up), so the tree is still wrong; undo fixes it
    own(page.locator('[data-path="root/1"]'), "delete").click()
    expect(check).to_contain_text("listed twice")
    page.click('[data-role="undo"]')
    page.click('[data-role="undo"]')
    expect(team_nodes(page)).to_have_count(2)
    expect(check).to_have_attribute("data-state", "ok")
    expect(page.locator("[data-invalid]")).to_have_count(0)
    assert errors == []
    page.close()


def test_signed_out_the_editor_checks_but_does_not_run_jobs(server, browser):
    page = browser.new_page()
    page.goto(f"{server.url}/trees/new?game={GAME}")
    expect(page.locator('[data-role="check"]')).to_have_attribute("data-state", "ok")
    for role in ("verify", "preview", "save"):
        expect(page.locator(f'[data-role="{role}"]')).to_be_disabled()
    expect(page.locator('[data-role="signin"]')).to_have_attribute("href", "/signin?next=%2Ftrees%2Fnew%3Fgame%3D"
                                                                   + GAME)
    page.close()
