"""The HTML leaderboard report: one self-contained file a user can mail or archive.

It shows what Arena (Song et al., AAAI 2020) asks of a league's evaluation, side by side: the
leaderboard table with rank and rating intervals, a plot of every rated agent's interval, the
win-rate matrix as a heatmap in leaderboard order, and the mass each agent gets under the Nash
equilibrium of the logit win-rate meta-game (Balduzzi et al. 2018) and under alpha-Rank
(Omidshafiei et al. 2019). The report is a view of :class:`~arena_league.league.leaderboards.
Leaderboard` and of its JSON twin (:func:`leaderboard_json`); it computes nothing the board lacks.
The board of a base population tells Arena's ranking among it: the members at their frozen
ratings, the placed entrants (highlighted) with their intervals on the same scale, and the entrants
still pending; the win-rate, Nash and alpha-Rank figures belong to boards re-rated from matches.
Like the terminal table, the report's table leaves out the columns that hold one value on every row.

Figures are drawn with matplotlib's Agg canvas (no display, no pyplot state) and embedded as base64
PNG data URIs; the style sheet is inline. Nothing is fetched from anywhere when the file is opened.
"""

from __future__ import annotations

import base64
import html
import io
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.colors import LinearSegmentedColormap
from matplotlib.figure import Figure

from arena_league.league.leaderboards import (
    SCORE_RESOLUTION,
    Leaderboard,
    LeaderboardRow,
    leaderboard_table,
    rank_legend,
    short_name,
)

__all__ = ["ANNOTATE_LIMIT", "MASS_BARS_LIMIT", "leaderboard_json", "report_figures", "write_html_report"]

ANNOTATE_LIMIT = 20
"""Up to this many agents the heatmap prints each cell's win rate."""
MASS_BARS_LIMIT = 30
"""The mass bar charts show at most this many agents (the largest masses); the rest are summed."""
_LABEL_CHARS = 28
_DPI = 100
_WIN_RATE_COLORS = LinearSegmentedColormap.from_list("win_rate", ["#b2182b", "#f7f7f7", "#2166ac"])


def leaderboard_json(board: Leaderboard, *, generated_at: datetime | None = None,
                     title: str | None = None) -> dict[str, Any]:
    """The report's data as a JSON-ready dict: the board's :meth:`~Leaderboard.to_dict` plus the
    title and the generation time (UTC, ISO 8601)."""
    when = generated_at or datetime.now(UTC)
    return {"title": title or _default_title(board), "generated_at": when.isoformat(timespec="seconds"),
            **board.to_dict()}


def write_html_report(board: Leaderboard, path: str | Path, *, title: str | None = None,
                      generated_at: datetime | None = None) -> Path:
    """Writes the leaderboard report to ``path`` as one self-contained HTML file; returns the path.

    Args:
        board: the leaderboard (see :func:`~arena_league.league.leaderboards.compute_leaderboard`).
        path: the file to write (its folder must exist).
        title: the page's heading; default ``"<game> leaderboard"``.
        generated_at: the time printed as the generation time (default now, UTC).
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise FileNotFoundError(f"cannot write the report to {path}: the folder {path.parent} does not exist; "
                                "create it or choose another path")
    when = generated_at or datetime.now(UTC)
    title = title or _default_title(board)
    figures = report_figures(board)
    path.write_text(_page(board, title, when, figures), encoding="utf-8")
    return path


def report_figures(board: Leaderboard) -> dict[str, bytes]:
    """The report's figures as PNG bytes, by name: ``ratings``, ``win_rate``, ``nash``,
    ``alpharank`` (the last three only on a board re-rated from matches that reduce to pairwise
    results)."""
    figures = {"ratings": _png(_rating_figure(board))}
    if board.win_rate is not None:
        figures["win_rate"] = _png(_win_rate_figure(board))
        figures["nash"] = _png(_mass_figure(board, board.nash_p, "Nash equilibrium mass",
                                            "max-entropy Nash of logit(win rate)", None))
        interval = None
        if board.method == "alpharank":
            rated = board.rated_rows
            interval = (np.array([r.lower for r in rated]), np.array([r.upper for r in rated]))
        figures["alpharank"] = _png(_mass_figure(
            board, board.alpharank_pi, "alpha-Rank mass",
            f"single population, alpha = {board.alpharank_alpha:.3g}", interval))
    return figures


# --- figures ---------------------------------------------------------------------------------------

def _label(name: str, game_id: str) -> str:
    name = short_name(name, game_id)
    return name if len(name) <= _LABEL_CHARS else name[: _LABEL_CHARS - 1] + "…"


def _png(figure: Figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=_DPI, metadata={"Software": None})
    return buffer.getvalue()


def _label_size(n: int) -> float:
    return 9.0 if n <= 20 else 7.0 if n <= 50 else 5.5


def _rating_figure(board: Leaderboard) -> Figure:
    """Each rated agent's rating (point) and interval (bar), best at the top; on a population
    board, the placed entrants stand out from the members."""
    if board.basis == "population":
        return _population_figure(board)
    rows = board.rated_rows
    n = len(rows)
    figure = Figure(figsize=(8.0, max(2.2, 0.16 * n + 1.2)), layout="constrained")
    ax = figure.subplots()
    y = np.arange(n)[::-1]
    rating = np.array([r.rating for r in rows])
    has_interval = all(r.lower is not None for r in rows)
    if has_interval:
        lower = np.array([r.lower for r in rows])
        upper = np.array([r.upper for r in rows])
        # the bootstrap need not hold the point; draw the bar to include it
        ax.hlines(y, np.minimum(lower, rating), np.maximum(upper, rating), color="#6baed6", linewidth=3,
                  label=f"{board.level:.0%} interval" if board.method != "openskill" else "mu ± 3 sigma")
    elif board.method == "elo" and rows[0].method_columns.get("bt_rating") is not None:
        bt_lower = np.array([r.method_columns["bt_lower"] for r in rows])
        bt_upper = np.array([r.method_columns["bt_upper"] for r in rows])
        bt_rating = np.array([r.method_columns["bt_rating"] for r in rows])
        ax.hlines(y, bt_lower, bt_upper, color="#c6dbef", linewidth=3,
                  label=f"Bradley-Terry {board.level:.0%} interval")
        ax.plot(bt_rating, y, "|", color="#6baed6", markersize=8, label="Bradley-Terry rating")
    ax.plot(rating, y, "o", color="#08306b", markersize=3.5 if n > 40 else 5, label=board.rating_label)
    ax.set_yticks(y, [_label(r.agent, board.game_id) for r in rows], fontsize=_label_size(n))
    ax.set_ylim(-0.7, n - 0.3)
    ax.set_xlabel(board.rating_label)
    ax.grid(axis="x", color="#dddddd", linewidth=0.6)
    ax.set_axisbelow(True)
    ax.legend(loc="lower right", fontsize=8, frameon=False)
    ax.set_title("Ratings and intervals, best first", fontsize=11)
    return figure


def _population_figure(board: Leaderboard) -> Figure:
    """Members at their frozen ratings and intervals, placed entrants highlighted on the same scale."""
    rows = board.rated_rows
    n = len(rows)
    figure = Figure(figsize=(8.0, max(2.2, 0.16 * n + 1.2)), layout="constrained")
    ax = figure.subplots()
    y = np.arange(n)[::-1]
    size = 3.5 if n > 40 else 5
    for status, bar, point, label in (("member", "#c6dbef", "#08306b", f"member of {board.population}"),
                                      ("placed", "#fdae6b", "#d94801", "entrant, as placed")):
        chosen = [i for i, row in enumerate(rows) if row.status == status]
        if not chosen:
            continue
        rating = np.array([rows[i].rating for i in chosen])
        ends = [(i, r) for i, r in zip(chosen, rating) if rows[i].lower is not None and rows[i].upper is not None]
        if ends:
            at = np.array([i for i, _ in ends])
            ax.hlines(y[at], [min(rows[i].lower, r) for i, r in ends], [max(rows[i].upper, r) for i, r in ends],
                      color=bar, linewidth=3)
        ax.plot(rating, y[chosen], "o", color=point, markersize=size if status == "member" else size + 2,
                label=label)
    ax.set_yticks(y, [_label(r.agent, board.game_id) for r in rows], fontsize=_label_size(n))
    for tick, row in zip(ax.get_yticklabels(), rows):
        if row.status == "placed":
            tick.set_color("#d94801")
            tick.set_fontweight("bold")
    ax.set_ylim(-0.7, n - 0.3)
    ax.set_xlabel("Bradley-Terry rating (Elo scale)")
    ax.grid(axis="x", color="#dddddd", linewidth=0.6)
    ax.set_axisbelow(True)
    ax.legend(loc="lower right", fontsize=8, frameon=False)
    ax.set_title(f"Ratings on the scale of {board.population}, {board.level:.0%} intervals, best first",
                 fontsize=11)
    return figure


def _win_rate_figure(board: Leaderboard) -> Figure:
    """Row agent's win rate against column agent, agents in leaderboard order; unplayed pairs grey."""
    n = len(board.agents)
    side = min(14.0, max(4.5, 0.34 * n + 2.5))
    figure = Figure(figsize=(side + 1.2, side), layout="constrained")
    ax = figure.subplots()
    cmap = _WIN_RATE_COLORS.with_extremes(bad="#d9d9d9")
    rate = np.array(board.win_rate, dtype=np.float64)
    np.fill_diagonal(rate, np.nan)
    image = ax.imshow(np.ma.masked_invalid(rate), cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest",
                      aspect="equal")
    labels = [_label(name, board.game_id) for name in board.agents]
    size = _label_size(n)
    ax.set_xticks(np.arange(n), labels, rotation=90, fontsize=size)
    ax.set_yticks(np.arange(n), labels, fontsize=size)
    ax.tick_params(length=0)
    if n <= ANNOTATE_LIMIT:
        games = np.asarray(board.games)
        for i, j in zip(*np.nonzero(np.isfinite(rate))):
            text = f"{100 * rate[i, j]:.0f}"
            if n <= 10:
                text += f"\n({games[i, j]:.0f})"
            ax.text(j, i, text, ha="center", va="center", fontsize=7 if n <= 10 else 6,
                    color="white" if abs(rate[i, j] - 0.5) > 0.3 else "black")
    colorbar = figure.colorbar(image, ax=ax, shrink=0.8)
    colorbar.set_label("win rate of row against column (draws half)")
    note = "cells: win rate % (matches)" if n <= 10 else "cells: win rate %" if n <= ANNOTATE_LIMIT else ""
    ax.set_title("Win rates in leaderboard order" + (f"; {note}" if note else ""), fontsize=11)
    return figure


def _mass_figure(board: Leaderboard, mass: np.ndarray, title: str, subtitle: str,
                 interval: tuple[np.ndarray, np.ndarray] | None) -> Figure:
    """The largest masses as horizontal bars (at most MASS_BARS_LIMIT agents; the rest summed)."""
    mass = np.asarray(mass, dtype=np.float64)
    # masses equal to the solver's precision keep leaderboard order
    order = np.argsort(-np.round(mass, SCORE_RESOLUTION), kind="stable")
    shown = order[: MASS_BARS_LIMIT]
    rest = order[MASS_BARS_LIMIT:]
    k = shown.size
    figure = Figure(figsize=(5.6, max(2.2, 0.2 * k + 1.3)), layout="constrained")
    ax = figure.subplots()
    y = np.arange(k)[::-1]
    if interval is not None:
        lower, upper = interval
        error = np.stack([np.clip(mass[shown] - lower[shown], 0, None), np.clip(upper[shown] - mass[shown], 0, None)])
        ax.barh(y, mass[shown], color="#4292c6", xerr=error, error_kw={"ecolor": "#08306b", "capsize": 2,
                                                                     "linewidth": 0.8})
    else:
        ax.barh(y, mass[shown], color="#4292c6")
    ax.set_yticks(y, [_label(board.agents[i], board.game_id) for i in shown], fontsize=_label_size(k))
    ax.set_xlim(0, 1.0 if interval is not None else max(0.05, float(mass.max()) * 1.15))
    ax.set_ylim(-0.7, k - 0.3)
    for yi, i in zip(y, shown):
        if mass[i] >= 0.0005:
            ax.text(mass[i], yi, f" {mass[i]:.3f}", va="center", fontsize=7)
    ax.grid(axis="x", color="#dddddd", linewidth=0.6)
    ax.set_axisbelow(True)
    ax.set_xlabel("mass")
    if rest.size:
        subtitle += f"\n{k} largest shown; {rest.size} more agents hold {mass[rest].sum():.3g} in all"
    ax.set_title(f"{title}\n{subtitle}", fontsize=10)
    return figure


# --- the page --------------------------------------------------------------------------------------

_STYLE = """
body{font-family:-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;margin:0 auto;max-width:1200px;
padding:1.5rem;color:#1a1a1a;background:#fff}
h1{font-size:1.6rem;margin:0 0 .3rem}h2{font-size:1.2rem;margin:2rem 0 .6rem;border-bottom:1px solid #ddd;
padding-bottom:.2rem}
.meta{color:#555;margin:.2rem 0}.meta b{color:#1a1a1a}
table{border-collapse:collapse;font-size:.85rem;width:100%}
th,td{padding:.25rem .5rem;border-bottom:1px solid #eee;text-align:right;white-space:nowrap}
th{background:#f4f6f8;position:sticky;top:0}
td.name,th.name,td.kind,th.kind,td.status,th.status{text-align:left}td.name{font-weight:600}
tr.unrated td{color:#999}tr.placed td{background:#fff5eb}
.scroll{overflow-x:auto}
img{max-width:100%;height:auto}
.pair{display:flex;flex-wrap:wrap;gap:1rem}.pair figure{margin:0;flex:1 1 420px}
figcaption,.note{color:#555;font-size:.85rem}
footer{margin-top:2rem;color:#777;font-size:.8rem}
"""


def _default_title(board: Leaderboard) -> str:
    if board.basis == "population":
        return f"{board.game_id} leaderboard against {board.population}"
    return f"{board.game_id} leaderboard"


def _img(png: bytes, alt: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


_CELL_CLASSES = {"rank": "rank", "agent": "name", "kind": "kind", "status": "status"}


def _row_class(row: LeaderboardRow) -> str:
    rated = "rated" if row.rated else "unrated"
    return f"{rated} {row.status}" if row.status in ("member", "placed", "pending") else rated


def _table(board: Leaderboard) -> str:
    view = leaderboard_table(board, wide=True)
    classes = [_CELL_CLASSES.get(key, "") for key in view.keys]
    head = "".join(f'<th class="{c}">{html.escape(h)}</th>' for c, h in zip(classes, view.headers))
    body = []
    for row, line in zip(board.rows, view.cells):
        tds = "".join(f'<td class="{c}">{html.escape(text)}</td>' for c, text in zip(classes, line))
        body.append(f'<tr class="{_row_class(row)}">{tds}</tr>')
    table = f'<div class="scroll"><table><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table></div>'
    if view.same:
        table += f'<p class="note">Not shown as columns: {html.escape("; ".join(view.same))}.</p>'
    return table


def _population_header(board: Leaderboard) -> tuple[list[str], list[str], str]:
    """(meta items as HTML, details, the note on ranks) of a population board."""
    e = html.escape
    counts = {key: board.params.get(key, 0) for key in ("members", "placed", "pending")}
    meta = [f"Game <b>{e(board.game_id)}</b>", f"population <b>{e(str(board.population))}</b>: "
            f"{e(board.rating_label)}", f"<b>{counts['members']}</b> members, <b>{counts['placed']}</b> entrants "
            f"placed, <b>{counts['pending']}</b> pending", f"<b>{board.n_matches}</b> matches in this league"]
    details = [f"members' intervals: as frozen with {board.population} (the bootstrap of its build); an "
               f"entrant's: the {board.level:.0%} likelihood-ratio interval of its latest placement"]
    ranks = (f"{rank_legend(board)}. Pending: agents of the game not placed against {board.population} yet "
             f"(`arena-league rank AGENT --population {board.population}`).")
    return meta, details, ranks


def _page(board: Leaderboard, title: str, when: datetime, figures: dict[str, bytes]) -> str:
    e = html.escape
    rated = len(board.agents)
    if board.basis == "population":
        meta, details, ranks = _population_header(board)
    else:
        meta = [f"Game <b>{e(board.game_id)}</b>", f"method <b>{e(board.method)}</b>: {e(board.rating_label)}",
                f"<b>{board.n_matches}</b> matches", f"<b>{rated}</b> rated of {len(board.rows)} agents"]
        if board.population is not None:
            meta.append(f"members of <b>{e(board.population)}</b>")
        details = []
        if board.method != "openskill" or board.win_rate is not None:
            details.append(f"intervals: {board.level:.0%} percentile bootstrap, {board.rounds} rounds, "
                           f"seed {board.seed}")
        if board.intransitivity is not None:
            details.append(f"intransitivity (cyclic share of logit win rates): {board.intransitivity:.2f}")
        if board.alpharank_alpha is not None:
            swept = " (automatic sweep)" if board.params.get("alpha_from_sweep") else ""
            details.append(f"alpha-Rank alpha = {board.alpharank_alpha:.3g}{swept}")
        if board.seat_term is not None:
            details.append(board.seat_term["text"])
        ranks = f"{rank_legend(board)}." + "".join(f" {note[0].upper()}{note[1:]}." for note in board.notes)
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{e(title)}</title><style>{_STYLE}</style></head><body>",
        f"<header><h1>{e(title)}</h1>",
        f'<p class="meta">{" · ".join(meta)}</p>',
        f'<p class="meta">Generated {e(when.isoformat(timespec="seconds"))}</p>',
        f'<p class="meta">{e("; ".join(details))}</p></header>',
        "<section><h2>Leaderboard</h2>", _table(board), f'<p class="note">{e(ranks)}</p></section>',
        "<section><h2>Rating intervals</h2>", _img(figures["ratings"], "rating intervals"), "</section>",
    ]
    if "win_rate" in figures:
        parts += [
            "<section><h2>Win rates</h2>", _img(figures["win_rate"], "win-rate heatmap"),
            ('<p class="note">Each cell is the row agent\'s share of points against the column agent '
             "(draws count half); grey cells were never played.</p></section>"),
            "<section><h2>Nash and alpha-Rank</h2><div class=\"pair\">",
            (f'<figure>{_img(figures["nash"], "Nash equilibrium mass")}<figcaption>Maximum-entropy Nash '
             f"equilibrium of the meta-game logit(win rate), pseudo-count {board.params.get('pseudo_count')}"
             "; agents outside its support are beaten by some mixture of the others.</figcaption></figure>"),
            (f'<figure>{_img(figures["alpharank"], "alpha-Rank mass")}<figcaption>Stationary mass of '
             "alpha-Rank's evolutionary chain on the win-rate table; high mass survives invasion by the "
             "others.</figcaption></figure>"),
            "</div></section>",
        ]
    elif board.basis == "population":
        parts.append(f'<section><h2>Win rates, Nash and alpha-Rank</h2><p class="note">Not shown: this board '
                     f"keeps the frozen scale of {e(str(board.population))}, whose members' matches among "
                     "themselves were played when it was built, not in this league. The board of every agent "
                     "re-rated from this league's matches shows them: `arena-league leaderboard "
                     f"{e(board.game_id)} --population league`.</p></section>")
    else:
        parts.append('<section><h2>Win rates, Nash and alpha-Rank</h2><p class="note">Not shown: teams in '
                     "these matches hold several different agents, so the matches do not reduce to one agent "
                     "against another.</p></section>")
    parts.append("<footer>arena-league leaderboard report · self-contained: figures are embedded, nothing is "
                 "loaded from elsewhere.</footer></body></html>")
    return "\n".join(parts) + "\n"
