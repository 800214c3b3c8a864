"""The self-contained HTML leaderboard report and its JSON twin."""

import base64
import json
import re
import time
from datetime import UTC, datetime

import numpy as np
import pytest
from test_league_leaderboard import ENTRANT, GAME, SHIPPED, STRENGTHS, kinds, shipped_board, simulated_league

from arena_league.league.leaderboards import METHODS, compute_leaderboard, rank_text
from arena_league.league.report import leaderboard_json, report_figures, write_html_report

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
EMBEDDED_PNG = re.compile(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"')
WHEN = datetime(2026, 1, 2, 3, 4, 5, tzinfo=UTC)


@pytest.fixture(scope="module")
def board():
    rows, names = simulated_league(STRENGTHS, 400, seed=2)
    names = [*names, "<b>new & shiny</b>"]  # an unrated entrant whose name needs escaping
    return compute_leaderboard(rows, kinds(names), GAME, "bt", rounds=50)


def embedded_images(html_text):
    return [base64.b64decode(data) for data in EMBEDDED_PNG.findall(html_text)]


def assert_self_contained(html_text):
    lowered = html_text.lower()
    assert 'src="http' not in lowered and "href=" not in lowered
    assert "<link" not in lowered and "<script" not in lowered and "url(" not in lowered and "@import" not in lowered
    # every src is an embedded image
    assert lowered.count("src=") == lowered.count('src="data:image/png;base64,')


def test_report_is_one_self_contained_file_with_the_table_and_figures(board, tmp_path):
    path = write_html_report(board, tmp_path / "report.html", generated_at=WHEN)
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]
    text = path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>")
    assert_self_contained(text)
    images = embedded_images(text)
    assert len(images) >= 3  # ratings, win-rate heatmap, Nash and alpha-Rank bars
    assert all(image.startswith(PNG_SIGNATURE) for image in images)
    for row in board.rows[:-1]:
        assert f'<td class="name">{row.agent}</td>' in text
    # the entrant's name is escaped, never live markup
    assert "&lt;b&gt;new &amp; shiny&lt;/b&gt;" in text and "<b>new & shiny</b>" not in text
    assert GAME in text and "<b>bt</b>" in text and "<b>400</b> matches" in text
    assert "Generated 2026-01-02T03:04:05+00:00" in text
    assert "Win rates" in text and "Nash and alpha-Rank" in text and "unrated" in text


def test_figures_are_png_and_present_for_every_pairwise_method(board):
    figures = report_figures(board)
    assert set(figures) == {"ratings", "win_rate", "nash", "alpharank"}
    assert all(png.startswith(PNG_SIGNATURE) for png in figures.values())


@pytest.mark.parametrize("method", METHODS)
def test_every_method_renders_nash_and_alpharank_bars(method, tmp_path):
    rows, names = simulated_league([0.0, 150.0, 300.0, 450.0], 120, seed=4)
    board = compute_leaderboard(rows, kinds(names), GAME, method, rounds=10)
    text = write_html_report(board, tmp_path / f"{method}.html", title=f"{method} board").read_text()
    assert_self_contained(text)
    assert len(embedded_images(text)) == 4
    assert f"<title>{method} board</title>" in text
    assert board.rating_label in text


def test_report_without_pairwise_results_says_why(tmp_path):
    # teams of two different agents: OpenSkill only; no win-rate matrix to draw
    rng = np.random.default_rng(0)
    rows = []
    for match in range(60):
        lineup = rng.permutation(["a", "b", "c", "d"])
        winner = int(rng.integers(2))
        rows += [{"match_id": match, "seat": s, "agent": str(agent), "team": s // 2, "score": 0.0,
                  "outcome": "win" if s // 2 == winner else "loss", "position": None}
                 for s, agent in enumerate(lineup)]
    board = compute_leaderboard(rows, kinds("abcd"), "Soccer-2T2P-v1", "openskill")
    text = write_html_report(board, tmp_path / "teams.html").read_text()
    assert_self_contained(text)
    assert len(embedded_images(text)) == 1 and "teams in these matches hold several different agents" in text


def test_json_twin_holds_the_report_data(board):
    document = leaderboard_json(board, generated_at=WHEN, title="League")
    text = json.dumps(document, allow_nan=False)
    assert json.loads(text)["generated_at"] == "2026-01-02T03:04:05+00:00"
    assert document["title"] == "League" and document["game_id"] == GAME
    assert len(document["nash"]["p"]) == len(document["alpharank"]["pi"]) == len(board.agents)
    assert document["rows"][0]["agent"] == board.agents[0]


def test_missing_folder_is_refused_with_the_fix(board, tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist; create it"):
        write_html_report(board, tmp_path / "nowhere" / "report.html")


def test_a_hundred_agents_render_in_a_few_seconds(tmp_path):
    rows, names = simulated_league(np.linspace(-400, 400, 100), 4000, seed=7)
    # CPU seconds, not wall seconds: a loaded CI machine stretches the wall clock, not the work
    start = time.process_time()
    board = compute_leaderboard(rows, kinds(names), GAME, "bt", rounds=100)
    computed = time.process_time() - start
    text = write_html_report(board, tmp_path / "big.html").read_text()
    rendered = time.process_time() - start - computed
    print(f"100 agents, 4000 matches: leaderboard {computed:.2f} s, report {rendered:.2f} s of CPU")
    # a few seconds of one core
    assert computed + rendered < 15.0
    assert len(embedded_images(text)) == 4
    assert all(name in text for name in names)


def test_report_of_a_base_population_tells_members_placed_entrants_and_pending(tmp_path):
    board = shipped_board(next(path for path in SHIPPED if path.parent.parent.name == "GoBang-2T1P-v1"))
    text = write_html_report(board, tmp_path / "base.html", generated_at=WHEN).read_text()
    assert_self_contained(text)
    assert len(embedded_images(text)) == 1  # the ratings on the population's scale; nothing re-rated
    assert "GoBang-2T1P-v1 leaderboard against base-v1:1" in text and "population <b>base-v1:1</b>" in text
    assert "<b>100</b> members, <b>1</b> entrants placed, <b>2</b> pending" in text
    assert text.count('<tr class="rated member">') == 100 and text.count('<tr class="unrated pending">') == 2
    entrant = next(row for row in board.rows if row.agent == ENTRANT)
    placed = re.search(r'<tr class="rated placed">(.*?)</tr>', text).group(1)
    assert f'<td class="name">{ENTRANT}</td>' in placed
    assert f"{entrant.rating:.0f} ({entrant.lower:.0f}..{entrant.upper:.0f})" in placed
    assert f"<td class=\"rank\">{rank_text(entrant.rank, entrant.rank_lower, entrant.rank_upper, entrant.tied)}" in placed
    assert "rank: 1 + the members of base-v1:1 rated higher" in text
    assert '<td class="name">random@GoBang-2T1P-v1</td>' in text  # pending, listed by full name
    assert "--population league" in text  # where the win-rate, Nash and alpha-Rank figures are
    # the JSON twin keeps the keys of any board's
    rows, names = simulated_league(STRENGTHS, 100, seed=1)
    matches_board = leaderboard_json(compute_leaderboard(rows, kinds(names), GAME, "bt", rounds=10))
    document = leaderboard_json(board, generated_at=WHEN)
    assert set(document) == set(matches_board) and document["population"] == "base-v1:1"
    assert {tuple(sorted(row)) for row in document["rows"]} == {tuple(sorted(matches_board["rows"][0]))}
    assert json.dumps(document, allow_nan=False)
