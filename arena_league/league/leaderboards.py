"""Leaderboards: a league's stored matches turned into ranked, interval-carrying tables.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) ranks agents against a population by their results; this module is the
view of those results a user reads. It knows nothing of SQL: the registry hands it per-seat rows in
match order, and every figure comes from the pure functions of :mod:`arena_league.rating`:

- ``"bt"`` (primary): Bradley-Terry ratings on the Elo scale with percentile-bootstrap intervals
  over resampled matches, and Chatbot Arena's rank intervals (Chiang et al. 2024);
- ``"elo"``: classic online Elo (Elo 1978) played in match order, with the Bradley-Terry interval
  columns beside it under ``bt_*`` names (Elo itself has no interval);
- ``"openskill"``: Plackett-Luce skill mu and uncertainty sigma (Weng & Lin 2011), for team games
  and free-for-all matches; sorted by the conservative score mu - 3 sigma;
- ``"nash"``: Nash averaging (Balduzzi et al. 2018, "Re-evaluating Evaluation") of the logit
  win-rate meta-game, with bootstrap intervals of the Nash-averaged score;
- ``"alpharank"``: single-population alpha-Rank mass (Omidshafiei et al. 2019) on the win-rate
  table, alpha from the automatic sweep unless given, with bootstrap intervals.

Each method is one entry of the method table: a function that computes its score, interval and own
columns, and how the board labels, sorts and shows them. Beside any method, wherever the league
reduces to pairwise results, the board shows the league's figures: the Bradley-Terry columns, the
Nash equilibrium, the alpha-Rank mass and the intransitivity share (the cyclic part of the Hodge
decomposition), so that a report always holds them. Every figure is computed at most once per
board, on first use, and only if the board shows it: the bootstraps of the Nash score and of the
alpha-Rank mass run for those methods only, and a method's own score is not computed again as a
league column. The win-rate matrices use the pseudo-count :data:`~arena_league.rating.PSEUDO_COUNT`
where logits or a complete payoff table are needed.

A game with a frozen base population has a second kind of board (:func:`population_leaderboard`):
Arena's ranking among the base population. Its members keep the Bradley-Terry ratings (and
intervals) frozen with the population, every other agent stands where its latest placement against
that population put it (:class:`~arena_league.rating.Placement`, with its interval), and agents not
placed yet are listed as pending. Nothing is re-rated from the league's matches, so a board of many
members and a few matches tells the same story as the placements themselves.

Every board ranks by the one definition of :func:`~arena_league.rating.competition_ranks` (``rank``,
``rank_lower``, ``rank_upper``): among the rated agents of a board of matches, among the members on a
population board. Where a method's order may mislead on the matches at hand (few matches behind a
high place, online Elo's dependence on match order, pairs that never met, mass ties), the board says
why in :attr:`Leaderboard.notes`, computed from those matches.

The views (:func:`render_terminal`, :func:`leaderboard_table`, the HTML report) leave out the
columns that carry no information (one value on every row); the JSON (:meth:`Leaderboard.to_dict`)
keeps every field.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from arena_league.league.home import short_name
from arena_league.rating import (
    DEFAULT_PRIOR_SD,
    PSEUDO_COUNT,
    OutcomeTable,
    PairCounts,
    PairwiseResults,
    Placement,
    Ranks,
    RatingIntervals,
    SeatCounts,
    SkillRatings,
    alpha_rank,
    alpha_rank_intervals,
    alpha_rank_sweep,
    bootstrap_ratings,
    competition_ranks,
    elo_online,
    intransitivity,
    nash_averaging,
    nash_intervals,
    openskill_ratings,
)

if TYPE_CHECKING:
    from rich.console import Console, ConsoleOptions, RenderableType, RenderResult
    from rich.table import Table

__all__ = [
    "AGENT_LINE_WIDTH",
    "AGENT_MIN_WIDTH",
    "ALPHA_RANK_M",
    "ELO_INITIAL",
    "ELO_K",
    "METHODS",
    "OPENSKILL_BAND",
    "PSEUDO_COUNT",
    "SCORE_RESOLUTION",
    "EntrantPlacement",
    "FrozenRating",
    "Leaderboard",
    "LeaderboardError",
    "LeaderboardRow",
    "LeaderboardTable",
    "Method",
    "board_title",
    "compute_leaderboard",
    "leaderboard_cells",
    "leaderboard_table",
    "outcome_table",
    "population_leaderboard",
    "rank_legend",
    "rank_text",
    "render_terminal",
    "short_name",
]

Method = Literal["bt", "elo", "openskill", "nash", "alpharank"]

ELO_K = 32.0
"""Online Elo's K-factor."""
ELO_INITIAL = 1000.0
"""Online Elo's starting rating (also the Bradley-Terry mean)."""
ALPHA_RANK_M = 50
"""Population size of alpha-Rank's evolutionary model (the paper's and OpenSpiel's default)."""
OPENSKILL_BAND = 3.0
"""OpenSkill intervals are mu -+ 3 sigma; the lower end is the conservative score sorted by."""

SCORE_RESOLUTION = 9
"""Nash scores and alpha-Rank masses are compared to this many decimals: the solvers are exact to
about 1e-12, and at a swept alpha the mass of every agent outside the top underflows to ~1e-30 or
0, so that smaller differences order agents by rounding noise. Ties go to the Bradley-Terry rating."""


class LeaderboardError(ValueError):
    """A leaderboard cannot be computed from these matches; the message names the fix."""


@dataclass
class LeaderboardRow:
    """One agent's line on a leaderboard. Rating fields are None for an agent without rated matches,
    or, on a population board, for an entrant not placed yet (it is listed, pending, at the bottom)."""

    agent: str
    kind: str | None
    rank: int | None
    """1 + the number of reference agents whose sort score is strictly above this one's (equal
    scores share a rank; :func:`~arena_league.rating.competition_ranks`). The reference agents are
    the other rated agents of a board of matches, and the population's members on a population
    board (where an entrant's rank is its placement's, and entrants do not move the members)."""
    rank_lower: int | None
    """The best place the interval allows: 1 + the reference agents scored above its upper end."""
    rank_upper: int | None
    """The worst place: 1 + the other reference agents scored at or above its lower end."""
    rating: float | None
    """The method's primary score (see :attr:`Leaderboard.rating_label`)."""
    lower: float | None
    upper: float | None
    """Interval of ``rating`` at the board's level (OpenSkill: mu -+ 3 sigma; online Elo: none)."""
    matches: int
    """Rated matches against other agents (matches against copies of itself say nothing)."""
    win_rate: float | None
    """Share of opposing teams finished ahead of, draws and ties counting half, over those matches."""
    percentile: float | None
    """Share of the other rated agents with a lower sort score, in percent."""
    method_columns: dict[str, float | int | None] = field(default_factory=dict)
    """Method-specific figures: ``mu``, ``sigma``, ``conservative`` (OpenSkill); ``nash_mass``,
    ``nash_score``, ``alpharank_mass`` (point estimates, wherever pairwise results exist, but not
    the method's own rating: no ``nash_score`` for ``"nash"``, no ``alpharank_mass`` for
    ``"alpharank"``);
    ``bt_rating``, ``bt_lower``, ``bt_upper``, ``bt_rank``, ``bt_rank_lower``, ``bt_rank_upper``
    (the Bradley-Terry columns, for every method but ``"bt"``); ``percentile_lower``,
    ``percentile_upper`` (``"bt"``). On a population board: ``percentile_lower``,
    ``percentile_upper``; ``job_id`` and ``placement_matches`` of a placed entrant's rank job."""
    status: str | None = None
    """``"rated"`` or ``"pending"`` (no rated matches) on a board of matches; ``"member"``,
    ``"placed"`` or ``"pending"`` (not placed against the population yet) on a population board."""
    tied: bool = False
    """Another row of the board has the same rank (shown as ``53=``)."""

    @property
    def rated(self) -> bool:
        return self.rating is not None


@dataclass
class Leaderboard:
    """A game's leaderboard by one method, with the league-level matrices it was computed from.

    The matrices and vectors are indexed by :attr:`agents`: the rated agents in leaderboard order.
    They are None when the matches do not reduce to pairwise results (teams of mixed agents).
    """

    game_id: str
    method: str
    level: float
    rounds: int
    seed: int
    rows: list[LeaderboardRow]
    """Best first; unrated agents last, by name."""
    rating_label: str
    sort_by: str
    """The row field sorted by, descending: ``"rating"``, or ``"lower"`` (OpenSkill's mu - 3 sigma)."""
    n_matches: int
    agents: list[str]
    win_rate: np.ndarray | None
    """``win_rate[i, j]``: share of points agent i took from agent j (draws half); NaN if unplayed."""
    games: np.ndarray | None
    """``games[i, j]``: matches played between agents i and j (pairwise results of free-for-all)."""
    nash_p: np.ndarray | None
    """Maximum-entropy Nash equilibrium of the logit win-rate meta-game."""
    nash_score: np.ndarray | None
    alpharank_pi: np.ndarray | None
    alpharank_alpha: float | None
    intransitivity: float | None
    """Cyclic share of the logit win-rate meta-game: 0 transitive, 1 rock-paper-scissors."""
    params: dict[str, Any] = field(default_factory=dict)
    population: str | None = None
    """``name:version`` of the population whose members the board lists (with the entrants, on a
    population board); None: every agent of the game."""
    basis: str = "matches"
    """``"matches"``: every rating re-rated by :attr:`method` from the stored matches;
    ``"population"``: members at the ratings frozen with :attr:`population`, entrants at their
    placements against it (:func:`population_leaderboard`)."""
    notes: list[str] = field(default_factory=list)
    """Why this method's order may mislead on these matches, each computed from them (few
    matches behind a high place, online Elo's dependence on match order, pairs that never met,
    many agents sharing a rank); shown beside every view of the board."""
    seat_term: dict[str, Any] | None = None
    """Bradley-Terry's term for the side (:class:`~arena_league.rating.SeatTerm` as a dict, with its
    sentence under ``"text"``): what holding team 0 is worth between equally rated agents; shown
    beside every view of the board."""

    @property
    def rated_rows(self) -> list[LeaderboardRow]:
        return [row for row in self.rows if row.rated]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready document: plain lists, floats and None (for NaN and missing values)."""
        return {
            "game_id": self.game_id,
            "population": self.population,
            "basis": self.basis,
            "method": self.method,
            "rating_label": self.rating_label,
            "sort_by": self.sort_by,
            "level": float(self.level),
            "rounds": int(self.rounds),
            "seed": int(self.seed),
            "n_matches": int(self.n_matches),
            "n_agents": len(self.rows),
            "n_rated": len(self.agents),
            "params": _plain(self.params),
            "rows": [_plain(asdict(row)) for row in self.rows],
            "agents": list(self.agents),
            "win_rate": _plain(self.win_rate),
            "games": _plain(self.games),
            "nash": {"p": _plain(self.nash_p), "score": _plain(self.nash_score)},
            "alpharank": {"pi": _plain(self.alpharank_pi), "alpha": _plain(self.alpharank_alpha)},
            "intransitivity": _plain(self.intransitivity),
            "notes": list(self.notes),
            "seat_term": self.seat_term,
            "rank_legend": rank_legend(self),
        }


def outcome_table(rows: Iterable[Mapping[str, Any]]) -> OutcomeTable:
    """The rating engine's :class:`OutcomeTable` from registry seat rows.

    Each row maps ``match_id``, ``seat``, ``agent``, ``team``, ``score``, ``outcome`` (``"win"``,
    ``"loss"``, ``"draw"``) and optionally ``position`` (finishing place, 1 first, for matches of more
    than two teams). A match whose seats all carry a position is ordered by position; otherwise by
    the outcome words (in a free-for-all without positions, the winner ahead of the others, tied).
    """
    by_match: dict[Hashable, list[Mapping[str, Any]]] = {}
    for row in rows:
        missing = [key for key in ("match_id", "seat", "agent", "team", "score", "outcome") if key not in row]
        if missing:
            raise LeaderboardError(f"a seat row lacks {', '.join(missing)}; pass registry seat rows "
                                   "(match_id, seat, agent, team, score, outcome, position)")
        by_match.setdefault(row["match_id"], []).append(row)
    records = []
    for match_id, seats in by_match.items():
        positions = [seat.get("position") for seat in seats]
        given = [position is not None for position in positions]
        if any(given) and not all(given):
            raise LeaderboardError(f"match {match_id!r} gives a finishing position for some seats only; "
                                   "give every seat its team's position, or none")
        for seat, position in zip(seats, positions):
            place = int(position) - 1 if all(given) else seat["outcome"]
            records.append((match_id, seat["seat"], seat["agent"], seat["team"], seat["score"], place))
    try:
        return OutcomeTable.from_rows(records)
    except ValueError as error:
        raise LeaderboardError(str(error)) from error


# --- the league's figures and the method table ----------------------------------------------------

class _Matches:
    """One board's matches: the seat table and, where they reduce to one agent against another,
    their pairwise results. OpenSkill's ratings are computed on first use and kept."""

    def __init__(self, table: OutcomeTable, results: PairwiseResults | None) -> None:
        self.table = table
        self.results = results

    @cached_property
    def skill(self) -> SkillRatings:
        return openskill_ratings(self.table)


class _League:
    """The pairwise figures of the rated agents (indexed like them), each computed on first use and
    kept: every method's board reads them from here, so that none is computed twice."""

    def __init__(self, counts: PairCounts, alpha: float | None, *, rounds: int, level: float,
                 seed: int, seats: SeatCounts | None = None) -> None:
        self.counts = counts
        self.seats = seats
        """The same results keeping each agent's side, for Bradley-Terry's seat term."""
        self.alpha_given = alpha
        self.rounds, self.level, self.seed = rounds, level, seed

    @cached_property
    def payoff(self) -> np.ndarray:
        """The logit win-rate meta-game."""
        return self.counts.logit_payoff(PSEUDO_COUNT)

    @cached_property
    def nash(self) -> tuple[np.ndarray, np.ndarray]:
        """(maximum-entropy Nash equilibrium, Nash-averaged scores) of the meta-game."""
        return nash_averaging(self.payoff)

    @cached_property
    def alpha_rank(self) -> tuple[np.ndarray, float]:
        """(alpha-Rank mass, alpha) on the smoothed win-rate table; alpha from the sweep unless given."""
        smoothed = self.counts.win_rate(PSEUDO_COUNT)
        if self.alpha_given is None:
            sweep = alpha_rank_sweep([smoothed], m=ALPHA_RANK_M)
            return sweep.pi, float(sweep.alpha)
        return alpha_rank([smoothed], alpha=self.alpha_given, m=ALPHA_RANK_M), float(self.alpha_given)

    @cached_property
    def bt(self) -> RatingIntervals:
        """Bradley-Terry ratings with bootstrap intervals, ranks and percentiles, fitted with a term
        for the side (team 0 or 1) beside the ratings, so that a seat's edge is not credited to
        whoever held it more often."""
        return bootstrap_ratings(self.seats if self.seats is not None else self.counts, rounds=self.rounds,
                                 level=self.level, seed=self.seed)

    @cached_property
    def intransitivity(self) -> float:
        return intransitivity(self.payoff).cyclic_share


_LEAGUE_COLUMNS: dict[str, Callable[[_League], np.ndarray]] = {
    "nash_mass": lambda league: league.nash[0],
    "nash_score": lambda league: league.nash[1],
    "alpharank_mass": lambda league: league.alpha_rank[0],
    "bt_rating": lambda league: league.bt.rating,
    "bt_lower": lambda league: league.bt.lower,
    "bt_upper": lambda league: league.bt.upper,
    "bt_rank": lambda league: league.bt.rank,
    "bt_rank_lower": lambda league: league.bt.rank_lower,
    "bt_rank_upper": lambda league: league.bt.rank_upper,
}
"""The league's figures shown as method columns beside every method (in this order), unless the
method's own score is the same figure (:attr:`_MethodSpec.replaces`)."""


@dataclass(frozen=True)
class _MethodScores:
    """What a method puts on the board, indexed by the rated agents."""

    rating: np.ndarray
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None
    sort_score: np.ndarray | None = None
    """The score the board is sorted by, descending; the rating when None."""
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class _MethodSpec:
    """One leaderboard method: how its scores are computed and how the board shows them."""

    score: Callable[[_Matches, np.ndarray, _League | None], _MethodScores]
    """``(matches, rated agents' indices into the table, league figures or None) -> scores``."""
    label: str
    """The board's :attr:`~Leaderboard.rating_label`."""
    header: str
    """Header of the rating column in the terminal and HTML tables."""
    decimals: int
    pairwise: bool = True
    """Needs matches of two teams of one agent each; otherwise rates team games and free-for-all,
    and its rated agents are OpenSkill's."""
    bootstrap: bool = False
    """Its interval is a bootstrap interval at the board's level (named in the header)."""
    sort_by: str = "rating"
    replaces: tuple[str, ...] = ()
    """League columns (:data:`_LEAGUE_COLUMNS`) left off its rows: its own score is that figure."""
    columns_shown: tuple[tuple[str, str], ...] = ()
    """(header, column key) of its own method columns in the tables, before the league's."""


def _score_bt(matches: _Matches, rated: np.ndarray, league: _League | None) -> _MethodScores:
    bt = league.bt
    return _MethodScores(bt.rating, bt.lower, bt.upper, columns={
        "percentile_lower": bt.percentile_lower, "percentile_upper": bt.percentile_upper})


def _score_elo(matches: _Matches, rated: np.ndarray, league: _League | None) -> _MethodScores:
    results = matches.results
    rating = elo_online(results.first, results.second, results.score, matches.table.n_agents, k=ELO_K,
                        initial=ELO_INITIAL)[rated]
    return _MethodScores(rating, params={"elo_k": ELO_K, "elo_initial": ELO_INITIAL})


def _score_openskill(matches: _Matches, rated: np.ndarray, league: _League | None) -> _MethodScores:
    skill = matches.skill
    mu, sigma = skill.mu[rated], skill.sigma[rated]
    lower = mu - OPENSKILL_BAND * sigma
    return _MethodScores(mu, lower, mu + OPENSKILL_BAND * sigma, sort_score=lower,
                         columns={"mu": mu, "sigma": sigma, "conservative": lower},
                         params={"openskill_model": "plackett_luce", "openskill_band": OPENSKILL_BAND,
                                 "openskill_skipped_matches": skill.skipped})


def _score_nash(matches: _Matches, rated: np.ndarray, league: _League | None) -> _MethodScores:
    interval = nash_intervals(league.counts, pseudo_count=PSEUDO_COUNT, rounds=league.rounds,
                              level=league.level, seed=league.seed, point=league.nash[1])
    return _MethodScores(interval.point, interval.lower, interval.upper,
                         sort_score=np.round(interval.point, SCORE_RESOLUTION))


def _score_alpharank(matches: _Matches, rated: np.ndarray, league: _League | None) -> _MethodScores:
    pi, alpha = league.alpha_rank
    interval = alpha_rank_intervals(league.counts, alpha=alpha, m=ALPHA_RANK_M, pseudo_count=PSEUDO_COUNT,
                                    rounds=league.rounds, level=league.level, seed=league.seed, point=pi)
    return _MethodScores(pi, interval.lower, interval.upper, sort_score=np.round(pi, SCORE_RESOLUTION))


_METHOD_TABLE: dict[str, _MethodSpec] = {
    "bt": _MethodSpec(
        score=_score_bt, label="Bradley-Terry rating (Elo scale)", header="BT rating", decimals=0,
        bootstrap=True, replaces=("bt_rating", "bt_lower", "bt_upper", "bt_rank", "bt_rank_lower", "bt_rank_upper"),
        columns_shown=(("Percentile CI", "percentile_lower"),)),
    "elo": _MethodSpec(score=_score_elo, label="Elo rating (online, match order)", header="Elo", decimals=0),
    "openskill": _MethodSpec(
        score=_score_openskill, label="OpenSkill mu (interval mu ± 3 sigma)", header="mu ± 3 sigma",
        decimals=2, pairwise=False, sort_by="lower",
        columns_shown=(("mu", "mu"), ("sigma", "sigma"), ("mu - 3 sigma", "conservative"))),
    "nash": _MethodSpec(
        score=_score_nash, label="Nash-averaged score (logit win rate)", header="Nash score", decimals=3,
        bootstrap=True, replaces=("nash_score",)),
    "alpharank": _MethodSpec(
        score=_score_alpharank, label="alpha-Rank mass", header="alpha-Rank mass", decimals=3,
        bootstrap=True, replaces=("alpharank_mass",)),
}
"""The leaderboard methods by name."""

METHODS: tuple[str, ...] = tuple(_METHOD_TABLE)


def compute_leaderboard(
    rows: Iterable[Mapping[str, Any]],
    agents_info: Mapping[str, Mapping[str, Any]],
    game_id: str,
    method: Method = "bt",
    *,
    rounds: int = 100,
    level: float = 0.95,
    seed: int = 0,
    alpha: float | None = None,
    population: str | None = None,
) -> Leaderboard:
    """The leaderboard of one game's matches by ``method`` (see the module docstring).

    Args:
        rows: per-seat rows in match order (see :func:`outcome_table`).
        agents_info: ``{name: {"kind": ..., ...}}`` for the agents to list; those without a rated
            match appear unrated at the bottom. Agents seated in ``rows`` but absent here are listed
            with kind None.
        game_id: the game, for the board's title and error messages.
        method: ``"bt"``, ``"elo"``, ``"openskill"``, ``"nash"`` or ``"alpharank"``.
        rounds: bootstrap rounds of every interval.
        level: interval level (OpenSkill's intervals are always mu -+ 3 sigma).
        seed: seed of the bootstrap.
        alpha: alpha-Rank's selection intensity; None picks it by the sweep (as large as the
            stationary distribution allows).
        population: ``name:version`` of the population whose members ``agents_info`` lists, for
            the board's title; None when it lists every agent of the game.

    Raises:
        LeaderboardError: an unknown method; no matches or fewer than two rated agents; more than
            two teams or teams of mixed agents with a method other than ``"openskill"``.
    """
    spec = _METHOD_TABLE.get(method)
    if spec is None:
        raise LeaderboardError(f"unknown leaderboard method {method!r}; choose one of {', '.join(METHODS)}")
    if not 0 < level < 1 or rounds < 2:
        raise LeaderboardError(f"intervals need 0 < level < 1 and at least 2 bootstrap rounds (100 is usual); "
                               f"got level={level}, rounds={rounds}")
    table = outcome_table(rows)
    if table.n_matches == 0:
        raise LeaderboardError(f"no matches of {game_id} to rank yet; play matches first: "
                               f"`arena-league evaluate {game_id}`")
    n_teams = np.bincount(np.unique(np.stack([table.match, table.team], axis=1), axis=0)[:, 0])
    if n_teams.max() > 2 and spec.pairwise:
        raise LeaderboardError(f"{game_id} has matches of {int(n_teams.max())} teams (free-for-all); "
                               f"{method!r} rates two-team games only: use --method openskill")
    try:
        results = table.pairwise()
    except ValueError as error:
        if spec.pairwise:
            raise LeaderboardError(f"{game_id}: a team holds several different agents, so its matches are "
                                   f"not one agent against another; {method!r} needs that: use --method "
                                   "openskill") from error
        results = None
    matches = _Matches(table, results)
    if spec.pairwise:
        rated = np.flatnonzero(np.bincount(np.r_[results.first, results.second], minlength=table.n_agents) > 0)
    else:
        rated = np.flatnonzero(matches.skill.matches > 0)
    if rated.size < 2:
        raise LeaderboardError(f"{game_id} needs rated matches between at least two different agents "
                               f"(it has {rated.size}); play matches first: `arena-league evaluate {game_id}`")
    names = [table.agents[i] for i in rated]
    params: dict[str, Any] = {"pseudo_count": PSEUDO_COUNT, "draw_model": "half", "prior_sd": DEFAULT_PRIOR_SD}

    league = None
    if results is not None:
        all_counts = PairCounts.from_results(results.first, results.second, results.score, table.agents)
        counts = PairCounts(names, all_counts.wins[np.ix_(rated, rated)], all_counts.draws[np.ix_(rated, rated)])
        sided = table.seat_counts()
        seats = SeatCounts(names, sided.n_sides, *(cells[:, rated][:, :, rated]
                                                  for cells in (sided.won, sided.lost, sided.drawn)))
        league = _League(counts, alpha, rounds=rounds, level=level, seed=seed, seats=seats)
        params.update(alpha=league.alpha_rank[1], alpha_from_sweep=alpha is None, alpha_rank_m=ALPHA_RANK_M)

    scores = spec.score(matches, rated, league)
    params.update(scores.params)
    columns: dict[str, np.ndarray] = {}
    if league is not None:
        columns.update((key, column(league)) for key, column in _LEAGUE_COLUMNS.items()
                       if key not in spec.replaces)
    columns.update(scores.columns)
    rating, lower, upper = scores.rating, scores.lower, scores.upper

    # Ranks, percentiles and the order, from the sort score; an interval on another scale than the
    # sort score (OpenSkill's mu +- 3 sigma around a sort by mu - 3 sigma) is widened to hold it.
    sort_score = rating if scores.sort_score is None else scores.sort_score
    ranks = competition_ranks(sort_score, lower, upper)
    percentile = 100.0 * (sort_score[None, :] < sort_score[:, None]).sum(axis=1) / (rated.size - 1)
    tie_break = league.bt.rating if league is not None else np.zeros(rated.size)
    order = np.array(sorted(range(rated.size), key=lambda i: (-sort_score[i], -tie_break[i], names[i])))

    played, points = _matches_and_points(table)
    board_rows = []
    for i in order:
        agent = rated[i]
        board_rows.append(LeaderboardRow(
            agent=names[i], kind=_kind(agents_info.get(names[i])), rank=int(ranks.rank[i]),
            rank_lower=int(ranks.rank_lower[i]), rank_upper=int(ranks.rank_upper[i]), rating=float(rating[i]),
            lower=None if lower is None else float(lower[i]), upper=None if upper is None else float(upper[i]),
            matches=int(played[agent]), win_rate=float(points[agent] / played[agent]) if played[agent] else None,
            percentile=float(percentile[i]),
            method_columns={key: _plain(values[i]) for key, values in columns.items()}, status="rated",
            tied=bool(ranks.tied[i])))
    agent_index = {name: i for i, name in enumerate(table.agents)}
    for name in sorted((set(agents_info) | set(table.agents)) - set(names)):
        board_rows.append(LeaderboardRow(
            agent=name, kind=_kind(agents_info.get(name)), rank=None, rank_lower=None, rank_upper=None,
            rating=None, lower=None, upper=None,
            matches=int(played[agent_index[name]]) if name in agent_index else 0,
            win_rate=None, percentile=None, status="pending"))

    figures: dict[str, Any] = dict.fromkeys(("win_rate", "games", "nash_p", "nash_score", "alpharank_pi",
                                             "alpharank_alpha", "intransitivity"))
    if league is not None:
        figures.update(
            win_rate=league.counts.win_rate()[np.ix_(order, order)],
            games=league.counts.games[np.ix_(order, order)], nash_p=league.nash[0][order],
            nash_score=league.nash[1][order], alpharank_pi=league.alpha_rank[0][order],
            alpharank_alpha=league.alpha_rank[1], intransitivity=league.intransitivity)
    notes = _method_notes(method, [short_name(name, game_id) for name in names], ranks, played[rated], matches,
                          rated, league)
    seat_term = None
    if league is not None and league.bt.seats is not None:
        seat_term = {**league.bt.seats.to_dict(), "text": seat_sentence(league.bt.seats)}
    return Leaderboard(
        game_id=game_id, method=method, level=level, rounds=rounds, seed=seed, rows=board_rows,
        rating_label=spec.label, sort_by=spec.sort_by, n_matches=table.n_matches,
        agents=[names[i] for i in order], params=params, population=population, notes=notes,
        seat_term=seat_term, **figures)


def seat_sentence(seats: Any) -> str:
    """What the Bradley-Terry seat term says, in the board's words."""
    return f"{seats.describe()}; the Bradley-Terry ratings are fitted beside this seat term"


FEW_MATCHES = 10
"""An agent rated from fewer matches stands where little evidence put it."""
_METHOD_NAMES = {"nash": "Nash averaging", "alpharank": "alpha-Rank"}


def _method_notes(method: str, names: list[str], ranks: Ranks, played: np.ndarray, matches: _Matches,
                  rated: np.ndarray, league: _League | None) -> list[str]:
    """Why the method's order may mislead on these matches, each condition computed from them."""
    notes = []
    n = len(names)
    top = max(3, n // 10)
    few = [i for i in np.argsort(ranks.rank, kind="stable") if ranks.rank[i] <= top and played[i] < FEW_MATCHES]
    if few:
        listed = ", ".join(f"{names[i]} ({ranks.rank[i]}, {played[i]} match{'es' if played[i] != 1 else ''})"
                           for i in few[:3])
        notes.append(f"placed in the top {top} from fewer than {FEW_MATCHES} matches: {listed}; "
                     f"{int((played < FEW_MATCHES).sum())} of {n} rated agents have so few, and their places "
                     "rest on little evidence")
    if method == "elo":
        results = matches.results
        backwards = elo_online(results.first[::-1], results.second[::-1], results.score[::-1],
                               matches.table.n_agents, k=ELO_K, initial=ELO_INITIAL)[rated]
        reverse = competition_ranks(backwards)
        moved = int((reverse.rank != ranks.rank).sum())
        if moved:
            first, again = int(np.argmin(ranks.rank)), int(np.argmin(reverse.rank))
            notes.append(f"online Elo depends on match order: replayed in reverse order, {moved} of {n} agents "
                         "change rank" + (f" and {names[again]} is first instead of {names[first]}"
                                          if reverse.rank[first] != 1 else ""))
    if method in ("nash", "alpharank") and league is not None:
        met = int(np.triu(league.counts.games > 0, 1).sum())
        pairs = n * (n - 1) // 2
        if 2 * met < pairs:
            notes.append(f"only {met} of {pairs} pairs of agents met; {_METHOD_NAMES[method]} scores every other "
                         "pair as even "
                         "(50% each way), so its order rests mostly on pairs that never played")
        shared = np.bincount(ranks.rank)
        if shared.max() >= max(3, n // 4):
            place = int(np.argmax(shared))
            notes.append(f"{int(shared.max())} of {n} agents share rank {place} (equal "
                         f"{'Nash scores' if method == 'nash' else 'alpha-Rank mass'}): the method does not "
                         "order them")
    return notes


# --- a base population's board ---------------------------------------------------------------------

@dataclass(frozen=True)
class FrozenRating:
    """A member's rating as frozen with its population, and its interval where one was stored."""

    rating: float
    lower: float | None = None
    upper: float | None = None


@dataclass(frozen=True)
class EntrantPlacement:
    """An entrant's latest placement against the population, and the ``rank`` job that made it."""

    placement: Placement
    job_id: int | None = None


def population_leaderboard(
    rows: Iterable[Mapping[str, Any]],
    agents_info: Mapping[str, Mapping[str, Any]],
    game_id: str,
    population: str,
    members: Mapping[str, FrozenRating],
    placements: Mapping[str, EntrantPlacement],
    *,
    level: float = 0.95,
    seat_term: Mapping[str, Any] | None = None,
) -> Leaderboard:
    """The board of a game ranked against a frozen base population (see the module docstring).

    Every rated row stands on one scale: a member at its frozen rating, an entrant at its
    placement's. Ranks count the members alone (:func:`~arena_league.rating.competition_ranks`
    with the members as reference), as a placement does: an entrant's row repeats its placement's
    rank and rank interval, a member's rank is its place among the other members, and entrants
    never move a member. An entrant therefore shares its rank with the member rated just below it.

    Args:
        rows: the stored seat rows of the matches among the listed agents (see
            :func:`outcome_table`), for each row's matches and win rate in this league; no rating
            is computed from them.
        agents_info: ``{name: {"kind": ...}}`` of the agents to list; the members, and the
            entrants (every other agent), placed or not. Members and placed entrants absent from
            it are listed with kind None.
        game_id: the game, for the title.
        population: ``name:version`` of the population.
        members: its members' frozen ratings.
        placements: the entrants' latest placements against it (members' are ignored).
        level: level of the intervals (the placements' and, as built, the members').
        seat_term: the seat term the members' ratings were fitted with, as the build recorded it
            (``provenance.figures.seat_term``), shown with the board; None where it fitted none.

    Raises:
        LeaderboardError: a member's or placement's rating that is not a finite number.
    """
    if not 0 < level < 1:
        raise LeaderboardError(f"intervals need 0 < level < 1; got level={level}")
    placed = {name: entry for name, entry in placements.items() if name not in members}
    names = [*members, *sorted(placed)]
    ratings = [*members.values(), *(FrozenRating(e.placement.rating, e.placement.lower, e.placement.upper)
                                    for e in (placed[name] for name in sorted(placed)))]
    rating = np.array([r.rating for r in ratings], dtype=np.float64)
    lower = np.array([np.nan if r.lower is None else r.lower for r in ratings], dtype=np.float64)
    upper = np.array([np.nan if r.upper is None else r.upper for r in ratings], dtype=np.float64)
    bad = [name for name, value in zip(names, rating) if not math.isfinite(value)]
    if bad:
        raise LeaderboardError(f"{population} gives {', '.join(bad[:3])} no finite rating; re-import the population "
                               "from a folder whose members carry their ratings, or re-rank the entrant")
    # intervals that do not hold their point (a bootstrap may not) are widened to hold it
    low = np.where(np.isnan(lower), rating, np.minimum(lower, rating))
    high = np.where(np.isnan(upper), rating, np.maximum(upper, rating))
    n = rating.size
    n_members = len(members)
    member = np.arange(n) < n_members
    ranks = competition_ranks(rating, low, high, reference=rating[:n_members],
                              self_index=np.where(member, np.arange(n), -1))
    shared = np.bincount(ranks.rank, minlength=n_members + 2)[ranks.rank] > 1
    others = ~np.eye(n, dtype=bool)
    below = rating[None, :] < rating[:, None]
    others_n = max(n - 1, 1)  # percentiles as a placement computes them: 100 * count / others
    columns = {
        "percentile_lower": 100.0 * ((rating[None, :] < low[:, None]) & others).sum(axis=1) / others_n,
        "percentile_upper": 100.0 * ((rating[None, :] < high[:, None]) & others).sum(axis=1) / others_n,
    }
    percentile = 100.0 * below.sum(axis=1) / others_n
    order = sorted(range(n), key=lambda i: (-rating[i], names[i]))

    rows = list(rows)
    table = outcome_table(rows)
    played: dict[str, tuple[int, float]] = {}
    if table.n_matches:
        counts, points = _matches_and_points(table)
        played = {name: (int(counts[i]), float(points[i])) for i, name in enumerate(table.agents)}

    def record(name: str) -> tuple[int, float | None]:
        count, won = played.get(name, (0, 0.0))
        return count, (won / count if count else None)

    board_rows = []
    for i in order:
        name = names[i]
        matches, win_rate = record(name)
        extra: dict[str, float | int | None] = {key: _plain(values[i]) for key, values in columns.items()}
        if not member[i]:
            extra.update(job_id=placed[name].job_id, placement_matches=_plain(placed[name].placement.matches))
        board_rows.append(LeaderboardRow(
            agent=name, kind=_kind(agents_info.get(name)), rank=int(ranks.rank[i]),
            rank_lower=int(ranks.rank_lower[i]), rank_upper=int(ranks.rank_upper[i]), rating=float(rating[i]), lower=None if np.isnan(lower[i]) else float(lower[i]),
            upper=None if np.isnan(upper[i]) else float(upper[i]), matches=matches, win_rate=win_rate,
            percentile=float(percentile[i]) if n > 1 else None, method_columns=extra,
            status="member" if member[i] else "placed", tied=bool(shared[i])))
    pending = sorted(set(agents_info) - set(names))
    for name in pending:
        matches, _ = record(name)
        board_rows.append(LeaderboardRow(
            agent=name, kind=_kind(agents_info.get(name)), rank=None, rank_lower=None, rank_upper=None,
            rating=None, lower=None, upper=None, matches=matches, win_rate=None, percentile=None, status="pending"))
    return Leaderboard(
        game_id=game_id, method="bt", level=level, rounds=0, seed=0, rows=board_rows,
        rating_label=f"Bradley-Terry rating (Elo scale) frozen with {population}; entrants placed against it",
        sort_by="rating", n_matches=table.n_matches, agents=[names[i] for i in order], win_rate=None, games=None,
        nash_p=None, nash_score=None, alpharank_pi=None, alpharank_alpha=None, intransitivity=None,
        params={"members": len(members), "placed": len(placed), "pending": len(pending)},
        population=population, basis="population",
        seat_term=None if seat_term is None else {**seat_term, "text": f"{seat_term['text']}; the members' ratings "
                                                  "were fitted beside this seat term, and placements use it"})


def _matches_and_points(table: OutcomeTable) -> tuple[np.ndarray, np.ndarray]:
    """Per agent: matches against other agents, and the points won in them (for each match, the
    share of opposing teams finished ahead of, ties half). Matches where the agent sat on two teams
    are left out."""
    n = table.n_agents
    n_teams_max = int(table.team.max()) + 1
    # one entry per (match, team): its place, in (match, team) order
    group_key = table.match * n_teams_max + table.team
    groups, first = np.unique(group_key, return_index=True)
    group_match, group_place = table.match[first], table.place[first]
    starts = np.flatnonzero(np.r_[True, np.diff(group_match) != 0])
    sizes = np.diff(np.r_[starts, groups.size])
    group_points = np.zeros(groups.size)
    for k in np.unique(sizes):
        index = starts[sizes == k][:, None] + np.arange(k)[None, :]
        place = group_place[index]
        ahead = (place[:, None, :] > place[:, :, None]).sum(axis=-1)
        tied = (place[:, None, :] == place[:, :, None]).sum(axis=-1) - 1
        group_points[index] = (ahead + 0.5 * tied) / (k - 1)
    # one entry per (match, team, agent); an agent on two teams of a match is a mirror
    triples = np.unique(np.stack([table.match, table.agent, group_key], axis=1), axis=0)
    _, where, seen = np.unique(triples[:, 0] * n + triples[:, 1], return_inverse=True, return_counts=True)
    keep = seen[where] == 1
    agent = triples[keep, 1]
    points = group_points[np.searchsorted(groups, triples[keep, 2])]
    return np.bincount(agent, minlength=n), np.bincount(agent, weights=points, minlength=n)


def _kind(info: Mapping[str, Any] | None) -> str | None:
    kind = None if info is None else info.get("kind")
    return None if kind is None else str(kind)


def _plain(value: Any) -> Any:
    """numpy values and containers as JSON-ready Python values; NaN and infinities as None."""
    if value is None or isinstance(value, (str, bool)):
        return value
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, (np.integer, int)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    return value


# --- views: the terminal table and the cells the HTML report shares -------------------------------

def _number(value: float | None, decimals: int) -> str:
    if value is None:
        return ""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text  # no "-0.000"


def _interval_text(row: LeaderboardRow, decimals: int) -> str:
    if row.rating is None:
        return "unrated"
    point = _number(row.rating, decimals)
    if row.lower is None or row.upper is None:
        return point
    up, down = _number(row.upper - row.rating, decimals), _number(row.rating - row.lower, decimals)
    return f"{point} ± {up}" if up == down else f"{point} +{up}/-{down}"


def _ends_text(row: LeaderboardRow) -> str:
    """A population board's rating: the point and the ends of its interval, as a placement reports them."""
    if row.rating is None:
        return ""
    if row.lower is None or row.upper is None:
        return _number(row.rating, 0)
    return f"{_number(row.rating, 0)} ({_number(row.lower, 0)}..{_number(row.upper, 0)})"


def rank_text(rank: int | None, lower: int | None = None, upper: int | None = None, tied: bool = False) -> str:
    """A rank as every view writes it: ``53``, ``53=`` when shared, ``53 (51..57)`` with the places
    its interval spans; ``-`` for none."""
    if rank is None:
        return "-"
    text = f"{rank}=" if tied else str(rank)
    if lower is None or upper is None or lower == upper:
        return text
    return f"{text} ({lower}..{upper})"


def _rank_text(row: LeaderboardRow) -> str:
    return rank_text(row.rank, row.rank_lower, row.rank_upper, row.tied)


def rank_legend(board: Leaderboard) -> str:
    """What a board's rank column means, for its caption or legend."""
    if board.basis == "population":
        text = (f"rank: 1 + the members of {board.population} rated higher (an entrant's is its placement's), "
                "and the places its interval spans")
    else:
        text = "rank: 1 + the agents scored higher, and the places the interval spans"
    if any(row.tied for row in board.rows):
        text += "; = shares its rank" + (" (equal ratings, or the member just below an entrant)"
                                          if board.basis == "population" else " (equal scores)")
    return text


_LEAGUE_COLUMNS_SHOWN: tuple[tuple[str, str], ...] = (
    ("BT rating ({level:.0%} CI)", "bt_rating"), ("Nash score", "nash_score"), ("Nash mass", "nash_mass"),
    ("alpha-Rank mass", "alpharank_mass"))
"""(header, column key) of the league columns in the tables, after the method's own."""
_COLUMN_DECIMALS = {"mu": 2, "sigma": 2, "conservative": 2, "nash_score": 3, "nash_mass": 3,
                    "alpharank_mass": 3}


def _method_column_specs(board: Leaderboard) -> list[tuple[str, str]]:
    """(header, method column key) of the method-specific columns shown."""
    spec = _METHOD_TABLE[board.method]
    shown = list(spec.columns_shown)
    if board.win_rate is not None:
        shown += [(header, key) for header, key in _LEAGUE_COLUMNS_SHOWN if key not in spec.replaces]
    return [(header.format(level=board.level), key) for header, key in shown]


def _method_cell(row: LeaderboardRow, key: str) -> str:
    columns = row.method_columns
    if key == "bt_rating":
        if columns.get("bt_rating") is None:
            return ""
        return (f"{columns['bt_rating']:.0f} [{columns['bt_lower']:.0f}, {columns['bt_upper']:.0f}]")
    if key == "percentile_lower":
        if columns.get("percentile_lower") is None:
            return ""
        low, high = f"{columns['percentile_lower']:.0f}", f"{columns['percentile_upper']:.0f}"
        return f"{low}%" if low == high else f"{low}-{high}%"
    value = columns.get(key)
    return "" if value is None else _number(value, _COLUMN_DECIMALS[key])


@dataclass(frozen=True)
class _Column:
    key: str
    header: str
    cell: Callable[[LeaderboardRow], str]
    left: bool = False
    essential: bool = False
    """Shown whatever its cells hold (rank, agent, rating)."""


_DEFAULT_COLUMNS = {"matches": ("rank", "agent", "kind", "rating", "matches"),
                    "population": ("rank", "agent", "status", "rating", "matches")}
"""The columns of the default terminal table, by :attr:`Leaderboard.basis`: they fit 80 terminal
columns beside an agent column of :data:`AGENT_MIN_WIDTH`."""


def _columns(board: Leaderboard, short_names: bool) -> list[_Column]:
    """Every column of the board's tables, in order."""
    def agent(row: LeaderboardRow) -> str:
        return short_name(row.agent, board.game_id) if short_names else row.agent

    def win_rate(row: LeaderboardRow) -> str:
        return "" if row.win_rate is None else f"{100 * row.win_rate:.1f}%"

    def percentile(row: LeaderboardRow) -> str:
        return "" if row.percentile is None else f"{row.percentile:.0f}"

    common = {
        "agent": _Column("agent", "Agent", agent, left=True, essential=True),
        "kind": _Column("kind", "Kind", lambda row: row.kind or "", left=True),
        "matches": _Column("matches", "Matches", lambda row: str(row.matches)),
        "win_rate": _Column("win_rate", "Win rate", win_rate),
        "percentile": _Column("percentile", "Percentile", percentile),
    }
    if board.basis == "population":
        return [
            _Column("rank", "Rank", _rank_text, essential=True),
            common["agent"], common["kind"],
            _Column("status", "Status", lambda row: row.status or "", left=True),
            _Column("rating", f"Rating ({board.level:.0%} CI)", _ends_text, essential=True),
            common["matches"], common["win_rate"], common["percentile"],
            _Column("percentile_lower", "Percentile CI", lambda row: _method_cell(row, "percentile_lower")),
        ]
    spec = _METHOD_TABLE[board.method]
    rating_header = spec.header + (f" ({board.level:.0%} CI)" if spec.bootstrap else "")
    columns = [
        _Column("rank", "Rank", _rank_text, essential=True), common["agent"], common["kind"],
        _Column("rating", rating_header, lambda row: _interval_text(row, spec.decimals), essential=True),
        common["matches"], common["win_rate"], common["percentile"]]
    columns += [_Column(key, header, lambda row, key=key: _method_cell(row, key) if row.rated else "")
                for header, key in _method_column_specs(board)]
    return columns


@dataclass(frozen=True)
class LeaderboardTable:
    """A leaderboard as text, as a view shows it: the columns kept and what the others held."""

    keys: list[str]
    """Column keys: ``rank``, ``agent``, ``kind``, ``status``, ``rating``, ``matches``,
    ``win_rate``, ``percentile`` and method column keys (see :attr:`LeaderboardRow.method_columns`)."""
    headers: list[str]
    left: list[bool]
    """Whether each column is text (left-aligned) rather than a figure."""
    cells: list[list[str]]
    """One line per row of the board, in its order."""
    same: list[str]
    """The columns left out for showing one value, where that value says something: e.g.
    ``"Kind scripted for every agent"``."""
    short_names: bool
    """Some names are shown without their ``@<game id>`` suffix."""


def leaderboard_table(board: Leaderboard, *, wide: bool = True, short_names: bool = False) -> LeaderboardTable:
    """The board's table as a view shows it: every column (``wide``) or the default few (rank,
    agent, kind or status, rating with its interval, matches), less those that carry no
    information. A column whose cells all show one value (blank where it does not apply) is left
    out, but for rank, agent and rating. ``short_names`` drops the ``@<game id>`` suffix of names."""
    columns = _columns(board, short_names)
    if not wide:
        columns = [column for column in columns if column.key in _DEFAULT_COLUMNS[board.basis]]
    shown: list[tuple[_Column, list[str]]] = []
    same: list[str] = []
    for column in columns:
        cells = [column.cell(row) for row in board.rows]
        values = {cell for cell in cells if cell}
        if column.essential or len(values) > 1:
            shown.append((column, cells))
        elif values and all(cells):
            same.append(f"{column.header} {values.pop()} for every agent")
        elif values and all(bool(cell) == row.rated for cell, row in zip(cells, board.rows)):
            same.append(f"{column.header} {values.pop()} for every rated agent")
    return LeaderboardTable(
        keys=[column.key for column, _ in shown], headers=[column.header for column, _ in shown],
        left=[column.left for column, _ in shown], cells=[list(line) for line in zip(*(c for _, c in shown))],
        same=same, short_names=short_names and any(short_name(row.agent, board.game_id) != row.agent
                                                   for row in board.rows))


def leaderboard_cells(board: Leaderboard, *, wide: bool = True, short_names: bool = False
                      ) -> tuple[list[str], list[list[str]]]:
    """The leaderboard as text: headers and one list of cells per row (see :func:`leaderboard_table`)."""
    view = leaderboard_table(board, wide=wide, short_names=short_names)
    return view.headers, view.cells


def board_title(board: Leaderboard) -> str:
    """One line naming the game, the population or method, and what the board holds."""
    if board.basis == "population":
        counts = ", ".join(f"{board.params.get(key, 0)} {word}" for key, word in
                           (("members", "members"), ("placed", "placed"), ("pending", "pending")))
        return f"{board.game_id} · {board.population} · {counts} · {board.n_matches} matches"
    title = f"{board.game_id} · {board.method} · {board.n_matches} matches"
    if board.population is not None:
        title += f" · members of {board.population}"
    if board.intransitivity is not None:
        title += f" · intransitivity {board.intransitivity:.2f}"
    return title


AGENT_MIN_WIDTH = 20
"""The agent column is never narrower than this (or the longest name, when shorter): a longer
name folds onto further lines, and columns that leave it less room are left out of the table."""
AGENT_LINE_WIDTH = 40
"""The agent column keeps room for names up to this long (whole on one line) before any column
but rank and rating is shown beside it."""


def render_terminal(board: Leaderboard, *, wide: bool = False) -> RenderableType:
    """The leaderboard as a rich renderable (print it with a rich console), fitted to the width it
    is printed at.

    The default table holds rank, agent, kind (status on a population board), the rating with its
    interval and the matches; ``wide=True`` every column. Both leave out columns that carry no
    information (see :func:`leaderboard_table`) and show names without their ``@<game id>``
    suffix. Rank, agent and rating are always shown: the agent column keeps room for names of up
    to :data:`AGENT_LINE_WIDTH` on one line (and at least :data:`AGENT_MIN_WIDTH`; a longer name
    folds onto further lines, never cut), and another column is shown only where it fits beside
    them, so that an 80-column terminal shows whole names. The caption says which columns were
    left out, what the rank means, and why the method's ranking may mislead on these matches
    (:attr:`Leaderboard.notes`).
    """
    return _TerminalBoard(board, leaderboard_table(board, wide=wide, short_names=True))


class _TerminalBoard:
    """A board's table, laid out when rich prints it (only then is the width known)."""

    def __init__(self, board: Leaderboard, view: LeaderboardTable) -> None:
        self.board, self.view = board, view

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        yield self.table(options.max_width)

    def table(self, width: int) -> Table:
        from rich.cells import cell_len
        from rich.table import Table

        board, view = self.board, self.view
        widths = [max([cell_len(header), *(cell_len(line[k]) for line in view.cells)])
                  for k, header in enumerate(view.headers)]
        agent = view.keys.index("agent")
        longest = widths[agent]
        widths[agent] = min(longest, AGENT_MIN_WIDTH)
        # rich's default box: a border left of every column and one at the right, one space each side
        essential = [k for k, key in enumerate(view.keys) if key in ("rank", "agent", "rating")]
        used = 1 + sum(widths[k] + 3 for k in essential)
        # room for whole names on one line first, then the columns that fit beside them
        widths[agent] = max(widths[agent], min(longest, AGENT_LINE_WIDTH, widths[agent] + width - used))
        used = 1 + sum(widths[k] + 3 for k in essential)
        kept = set(essential)
        for k in range(len(view.keys)):
            if k not in kept and used + widths[k] + 3 <= width:
                kept.add(k)
                used += widths[k] + 3
        dropped = [view.headers[k] for k in range(len(view.keys)) if k not in kept]
        notes = [board.rating_label, rank_legend(board)]
        if view.short_names:
            notes.append(f"names without @{board.game_id}")
        if dropped:
            notes.append(f"left out to fit {width} columns: {', '.join(dropped)} (all in --json)")
        notes += view.same
        if board.seat_term is not None:
            notes.append(board.seat_term["text"])
        notes += board.notes
        table = Table(title=board_title(board), caption="; ".join(notes))
        for k in sorted(kept):
            if k == agent:  # a name too long folds, never cut
                table.add_column(view.headers[k], justify="left", overflow="fold", min_width=widths[k])
            else:
                table.add_column(view.headers[k], justify="left" if view.left[k] else "right", no_wrap=True)
        for line, row in zip(view.cells, board.rows):
            table.add_row(*(line[k] for k in sorted(kept)), style=None if row.rated else "dim")
        return table
