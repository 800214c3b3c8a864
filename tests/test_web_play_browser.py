"""Playing in a real browser: Playwright driving Debian's Chromium against ``arena-league serve``.

A signed-in person plays GoBang against the base population by clicking cells until the match
ends, reads why it ended, and finds the match stored and themself placed on the game's leaderboard
with an interval; a guest steers a snake with the arrow keys and sees it turn. Skipped, with the
reason, where Chromium or Playwright is missing (``.ci/run`` installs both).
"""

from __future__ import annotations

import json

import pytest
from browser_helpers import chromium, playwright_or_skip, to_screen
from web_helpers import Server, running_server

pytestmark = pytest.mark.slow
sync_api = playwright_or_skip()


@pytest.fixture(scope="module")
def server(tmp_path_factory) -> Server:
    with running_server(tmp_path_factory.mktemp("play") / "home", workers=1) as running:  # its worker imports
        yield running


@pytest.fixture(scope="module")
def browser():
    with chromium(sync_api) as launched:
        yield launched


def wait_for_the_base(page) -> None:
    """A game's first play page queues the import of its shipped base population (a worker's job,
    never the page's) and reloads itself once the job is done."""
    sync_api.expect(page.locator("#importing")).to_have_count(0, timeout=180_000)


def start_as_guest(server, browser, game_id: str, guest: str):
    """A new page playing ``game_id`` as the guest ``guest``, once its first match is in play."""
    page = browser.new_page(viewport={"width": 1280, "height": 1000})
    page.set_default_timeout(60_000)
    page.goto(f"{server.url}/play/{game_id}")
    wait_for_the_base(page)
    page.fill('[data-role="guest"]', guest)
    page.click('[data-role="start"]')
    sync_api.expect(page.locator("#play")).to_have_attribute("data-state", "playing", timeout=120_000)
    return page


def gobang_cells(size: int = 15) -> list[tuple[int, int]]:
    """Cells to try, in order: a row of five across the middle first, then the board outward."""
    middle = size // 2
    first = [(middle, c) for c in range(middle - 4, middle + 5)] + [(middle + 1, c) for c in range(middle - 4, middle + 5)]
    rest = sorted(((r, c) for r in range(size) for c in range(size)),
                  key=lambda rc: (abs(rc[0] - middle) + abs(rc[1] - middle), rc))
    return first + [rc for rc in rest if rc not in first]


def test_a_person_plays_gobang_to_the_end_by_clicking_and_lands_on_the_leaderboard(server, browser):
    token = server.token("clicker")
    page = browser.new_page(viewport={"width": 1280, "height": 1000})
    page.set_default_timeout(60_000)
    page.goto(f"{server.url}/signin?next=/play/GoBang-2T1P-v1")
    page.fill('input[name="token"]', token)
    page.click('button[type="submit"]')
    # the first page of the league's game queues the import of its shipped base population
    sync_api.expect(page.locator("#importing")).to_contain_text("Importing base-v2 of GoBang-2T1P-v1 (job ")
    wait_for_the_base(page)
    page.click('[data-role="start"]')
    sync_api.expect(page.locator("#play")).to_have_attribute("data-state", "your-move", timeout=120_000)
    seats = page.locator('[data-role="seats"] li')
    sync_api.expect(seats).to_have_count(2)
    sync_api.expect(seats.nth(0)).to_contain_text("you (clicker@GoBang-2T1P-v1)")
    sync_api.expect(seats.nth(1)).to_contain_text("opponent: base-v2.")  # the base rank uses: GoBang ships base-v2
    size = 15
    for row, col in gobang_cells(size):
        if page.get_attribute("#play", "data-state") == "ended":
            break
        step = page.get_attribute("#play", "data-step")
        x, y = to_screen(page, col + 0.5, size - row - 0.5)
        page.mouse.click(x, y)
        # the server answers with the move and the opponent's reply, or refuses an occupied cell
        page.wait_for_function(
            "([step]) => { const root = document.getElementById('play');"
            " const refused = document.querySelector('[data-role=\"message\"]').textContent.includes('occupied');"
            " return root.dataset.state === 'ended' || refused ||"
            " (root.dataset.step !== step && root.dataset.state === 'your-move'); }", arg=[step])
        page.evaluate("document.querySelector('[data-role=\"message\"]').textContent = ''")
    sync_api.expect(page.locator("#play")).to_have_attribute("data-state", "ended")
    outcome = page.get_attribute("#play", "data-outcome")
    assert outcome in ("win", "loss", "draw")
    reason = page.locator('[data-role="reason"]').inner_text()
    assert reason.startswith("Why it ended: ") and ("five in a row" in reason or "board full" in reason), reason
    sync_api.expect(page.locator('[data-role="placement"]')).to_contain_text("95%")
    scores = page.locator('[data-role="scores"]').inner_text()
    match_id = int(scores.rsplit("stored as match ", 1)[1].rstrip("."))
    with server.client() as client:
        match = client.get(f"/api/matches/{match_id}").json()
        assert {s["agent"] for s in match["seats"]} >= {"clicker@GoBang-2T1P-v1"}
        assert next(s for s in match["seats"] if s["agent"] == "clicker@GoBang-2T1P-v1")["outcome"] == outcome
        board = client.get("/api/games/GoBang-2T1P-v1/leaderboard").json()
    row = next(r for r in board["rows"] if r["agent"] == "clicker@GoBang-2T1P-v1")
    assert row["kind"] == "human" and row["lower"] <= row["rating"] <= row["upper"]
    # the game's page lists the person among the base, and a next match can begin
    page.goto(f"{server.url}/games/GoBang-2T1P-v1")
    sync_api.expect(page.locator('table.data a[href="/agents/clicker@GoBang-2T1P-v1"]')).to_have_count(1)
    page.close()


def test_a_guest_turns_a_snake_with_the_arrow_keys(server, browser):
    page = start_as_guest(server, browser, "Snake-2T2P-v1", "snaky")
    sync_api.expect(page.locator('[data-role="seats"] li')).to_have_count(4)
    sync_api.expect(page.locator('[data-role="seats"] li[data-seat-role="teammate"]')).to_have_count(1)

    def positions(count: int) -> list[tuple[float, float]]:
        """Where the person's snake head is drawn on the next ``count`` steps (fewer if it dies)."""
        seen = []
        while len(seen) < count:
            step = page.get_attribute("#play", "data-step")
            page.wait_for_function("([step]) => document.getElementById('play').dataset.step !== step", arg=[step])
            you = page.get_attribute("#play", "data-you")
            if you is None:
                break
            seen.append(tuple(float(v) for v in you.split(",")))
        return seen

    before = positions(2)
    heading = (round(before[1][0] - before[0][0]), round(before[1][1] - before[0][1]))
    assert abs(heading[0]) + abs(heading[1]) == 1, heading
    bounds = json.loads(page.get_attribute("#play", "data-bounds"))
    x, y = before[1]
    if heading[0] != 0:  # going sideways: turn up or down, toward the roomier side
        key, wanted = ("ArrowUp", (0, 1)) if bounds[3] - y > y - bounds[1] else ("ArrowDown", (0, -1))
    else:
        key, wanted = ("ArrowRight", (1, 0)) if bounds[2] - x > x - bounds[0] else ("ArrowLeft", (-1, 0))
    page.keyboard.down(key)
    page.keyboard.up(key)
    after = positions(3)
    moves = [(round(b[0] - a[0]), round(b[1] - a[1])) for a, b in zip([before[1], *after], after)]
    events = page.locator('[data-role="events"]').inner_text()
    assert wanted in moves, (heading, key, moves, events)
    # resigning ends the match (unless it has ended already, the snake having run into something)
    page.evaluate("document.querySelector('[data-role=\"resign\"]').click()")
    sync_api.expect(page.locator("#play")).to_have_attribute("data-state", "ended")
    sync_api.expect(page.locator('[data-role="reason"]')).to_contain_text("Why it ended: ")
    page.close()


def test_a_guest_plays_both_halves_of_a_youshallnotpass_pair(server, browser):
    """A game played in pairs: the person runs in the first half and, from the same start, blocks in
    the second; the page says which half is in play and whom the person holds."""
    page = start_as_guest(server, browser, "YouShallNotPass-2T1P-v1", "runner")
    banner = page.locator('[data-role="banner"]')
    sync_api.expect(banner).to_contain_text("you play team 0 in the first half of a pair")
    page.keyboard.down("ArrowRight")  # trot toward the goal line until the half ends
    sync_api.expect(banner).to_contain_text("you play team 1 in the second half of the pair", timeout=90_000)
    page.keyboard.up("ArrowRight")
    sync_api.expect(page.locator('[data-role="events"]')).to_contain_text("half time")
    sync_api.expect(page.locator('[data-role="seats"] li').nth(1)).to_contain_text("you (guest-runner@YouShallNotPass")
    page.evaluate("document.querySelector('[data-role=\"resign\"]').click()")
    sync_api.expect(page.locator("#play")).to_have_attribute("data-state", "ended")
    sync_api.expect(page.locator('[data-role="reason"]')).to_contain_text("Why it ended: you resigned")
    page.close()


def scripted_base(server, game_id: str) -> None:
    """A game that ships no base population yet gets its scripted agents (random, heuristic) as a
    frozen one, so that its play page opens."""
    from arena_league.league import ensure_scripted_agents, open_home
    from arena_league.registry import add_population_member, create_population, freeze_population, get_agent

    with open_home(server.home, server.db) as league:
        names = ensure_scripted_agents(league, game_id)
        with league.transaction() as session:
            population = create_population(session, "scripted", game_id, provenance={"made_by": "test"})
            for name, rating in zip(names, (900.0, 1100.0), strict=True):
                add_population_member(session, population, get_agent(session, name), {"rating": rating})
            freeze_population(session, population)


def test_a_guest_moves_up_in_capture_the_flag_with_the_arrow_keys(server, browser):
    game_id = "CaptureFlag-2T1P-v1"
    scripted_base(server, game_id)
    page = start_as_guest(server, browser, game_id, "raider")
    sync_api.expect(page.locator('[data-role="seats"] li')).to_have_count(2)

    def position() -> tuple[float, float]:
        """Where the person is drawn after the next step."""
        step = page.get_attribute("#play", "data-step")
        page.wait_for_function("([step]) => document.getElementById('play').dataset.step !== step", arg=[step])
        return tuple(float(v) for v in page.get_attribute("#play", "data-you").split(","))

    start = position()
    page.keyboard.down("ArrowUp")  # from the start cell the way up is open on every map (the base stays clear)
    moved = [position() for _ in range(3)]
    page.keyboard.up("ArrowUp")
    assert any(y > start[1] + 0.5 and abs(x - start[0]) < 0.01 for x, y in moved), (start, moved)
def test_a_guest_walks_out_of_a_boomer_corner_with_the_arrow_keys(server, browser):
    scripted_base(server, "Boomer-2T1P-v1")
    page = start_as_guest(server, browser, "Boomer-2T1P-v1", "bomber")

    def you_after_the_next_step() -> tuple[float, float]:
        step = page.get_attribute("#play", "data-step")
        page.wait_for_function("([step]) => document.getElementById('play').dataset.step !== step", arg=[step])
        x, y = (float(v) for v in page.get_attribute("#play", "data-you").split(","))
        return x, y

    start = you_after_the_next_step()
    bounds = json.loads(page.get_attribute("#play", "data-bounds"))
    # a corner's two cells along the board's edge start clear: walk along it, away from the corner
    key, wanted = ("ArrowRight", 1) if start[0] < (bounds[0] + bounds[2]) / 2 else ("ArrowLeft", -1)
    page.keyboard.press(key)
    seen = [you_after_the_next_step() for _ in range(3)]
    moves = [round(x - start[0]) for x, _ in seen]
    assert wanted in moves and all(y == start[1] for _, y in seen), (start, key, seen)
    assert seen[-1] == seen[-2], "one press moves one cell, then the player stops"
    page.evaluate("document.querySelector('[data-role=\"resign\"]').click()")
    sync_api.expect(page.locator("#play")).to_have_attribute("data-state", "ended")
    sync_api.expect(page.locator('[data-role="reason"]')).to_contain_text("Why it ended: you resigned")
    page.close()


def drive_right_and_fire(page) -> None:
    """Hold ArrowRight (the person's start has open ground on both sides, whichever team they
    play) and see their seat move right on the view as drawn; Space fires."""

    def you() -> tuple[float, float]:
        step = page.get_attribute("#play", "data-step")
        page.wait_for_function("([step]) => document.getElementById('play').dataset.step !== step", arg=[step])
        return tuple(float(v) for v in page.get_attribute("#play", "data-you").split(","))

    start = you()
    page.keyboard.down("ArrowRight")
    for _ in range(6):
        moved = you()
    page.keyboard.up("ArrowRight")
    assert moved[0] > start[0] + 0.3, (start, moved)
    page.keyboard.down(" ")
    sync_api.expect(page.locator('[data-role="events"]')).to_contain_text("you fire")
    page.keyboard.up(" ")
    page.evaluate("document.querySelector('[data-role=\"resign\"]').click()")
    sync_api.expect(page.locator("#play")).to_have_attribute("data-state", "ended")


def test_a_guest_drives_a_battlecity_tank_with_the_arrow_keys_and_fires_with_space(server, browser):
    scripted_base(server, "BattleCity-2T1P-v1")
    page = start_as_guest(server, browser, "BattleCity-2T1P-v1", "tanker")
    drive_right_and_fire(page)
    page.close()


def test_a_guest_moves_a_fighter_with_the_arrow_keys_and_fires_with_space(server, browser):
    scripted_base(server, "Fighter-2T1P-v1")
    page = start_as_guest(server, browser, "Fighter-2T1P-v1", "flyer")
    drive_right_and_fire(page)
    page.close()
