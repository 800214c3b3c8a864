"""Outcome tables: the record of played matches that every rating in this package starts from.

The pairwise reduction (each pair of teams in a match is one win, loss or draw between the agents
holding those teams) is the one of Bradley & Terry (1952) and of the Elo system; the deduplicated
count matrix is what makes the bootstrap of Chatbot Arena (Chiang et al. 2024, "Chatbot Arena: An
Open Platform for Evaluating LLMs by Human Preference") fast: a league of 10^5 matches between 100
agents is a 100 x 100 matrix, and resampling the matches is one multinomial draw over its cells.

An :class:`OutcomeTable` holds one row per seat, as the registry stores them:
``(match_id, seat, agent, team, score, outcome)``, where ``outcome`` is ``"win"``, ``"loss"`` or
``"draw"`` for the seat's team, or an integer finishing place (lower is better, equal places tie)
when more than two teams finish in order. Agents are integer indices into ``agents`` (their names).
:class:`PairCounts` forgets which team each agent held; :class:`SeatCounts` keeps it, for games
where the side matters.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["OUTCOME_PLACE", "PSEUDO_COUNT", "OutcomeTable", "PairCounts", "PairwiseResults", "SeatCounts",
           "SeatResult"]

OUTCOME_PLACE: dict[str, int] = {"win": 0, "draw": 0, "loss": 1}
"""Finishing place of a team given its two-team outcome word (0 is first; equal places tie)."""

PSEUDO_COUNT: float = 0.5
"""Points added to each side of every pair before its win rate is smoothed or its logit taken (the
logit meta-game of Nash averaging, the alpha-Rank payoff table). Half a point each way is
Jeffreys-style smoothing: the win rate becomes the posterior mean under the Jeffreys prior
Beta(1/2, 1/2), and the logit becomes the Haldane-Anscombe log-odds log((w + 1/2) / (l + 1/2)).
So an unbeaten pair has a finite logit, an unplayed pair reads as even, and a well-played pair is
barely moved. Every default and caller in the package uses this one value."""


class SeatResult(NamedTuple):
    """One seat of one match, as a row of the registry's match table."""

    match_id: Hashable
    seat: int
    agent: str
    team: int
    score: float
    outcome: str | int
    """``"win"``, ``"loss"``, ``"draw"``, or the team's finishing place (0 or 1 is first)."""


@dataclass(frozen=True)
class PairwiseResults:
    """Matches reduced to pairwise results, in match order: ``first`` scored ``score`` against
    ``second`` (1 win, 0.5 draw, 0 loss). A match of k teams gives k(k-1)/2 results.
    ``first_team`` and ``second_team`` are the team indices (the sides) the two held in the match,
    ``first_team < second_team``; None when the results were not read from a match table."""

    agents: list[str]
    match: np.ndarray
    first: np.ndarray
    second: np.ndarray
    score: np.ndarray
    first_team: np.ndarray | None = None
    second_team: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.first.shape[0])


@dataclass(frozen=True)
class OutcomeTable:
    """Per-seat record of matches (one row per seat; see the module docstring).

    ``place`` is the finishing place of the seat's team within its match (0 is first; teams with
    equal places drew). Build it with :meth:`from_rows` from registry rows, or directly from
    arrays (which are validated).
    """

    agents: list[str]
    match: np.ndarray
    seat: np.ndarray
    agent: np.ndarray
    team: np.ndarray
    score: np.ndarray
    place: np.ndarray
    match_ids: list[Hashable] = field(default_factory=list)

    def __post_init__(self) -> None:
        columns = {}
        for name, dtype in (("match", np.int64), ("seat", np.int64), ("agent", np.int64),
                            ("team", np.int64), ("score", np.float64), ("place", np.int64)):
            columns[name] = np.asarray(getattr(self, name), dtype=dtype).reshape(-1)
            object.__setattr__(self, name, columns[name])
        lengths = {name: col.shape[0] for name, col in columns.items()}
        if len(set(lengths.values())) != 1:
            raise ValueError(f"OutcomeTable columns differ in length: {lengths}; pass one value per seat")
        object.__setattr__(self, "agents", [str(a) for a in self.agents])
        if self.agent.size and (self.agent.min() < 0 or self.agent.max() >= len(self.agents)):
            raise ValueError(
                f"agent indices must lie in [0, {len(self.agents)}); pass the full list of agent names"
            )
        if not self.match_ids:
            object.__setattr__(self, "match_ids", list(range(self.n_matches)))
        self._check_matches()

    @classmethod
    def from_rows(
        cls,
        rows: Iterable[SeatResult | Sequence | Mapping],
        agents: Sequence[str] | None = None,
    ) -> OutcomeTable:
        """Builds a table from per-seat rows ``(match_id, seat, agent, team, score, outcome)``.

        Rows may be tuples, :class:`SeatResult` or mappings with those keys (a SQL row mapping).
        ``agent`` is an agent name (any key is converted with ``str``). With ``agents`` given,
        indices follow that list and an unknown agent is an error; otherwise agents are numbered
        in order of first appearance. Matches are numbered in order of first appearance.
        """
        names = [str(a) for a in agents] if agents is not None else []
        agent_index = {name: i for i, name in enumerate(names)}
        match_index: dict[Hashable, int] = {}
        cols: dict[str, list] = {k: [] for k in ("match", "seat", "agent", "team", "score", "place")}
        words: dict[Hashable, set[str | None]] = {}
        for row in rows:
            if isinstance(row, Mapping):
                match_id, seat, agent, team, score, outcome = (row[k] for k in SeatResult._fields)
            else:
                match_id, seat, agent, team, score, outcome = row
            name = str(agent)
            if name not in agent_index:
                if agents is not None:
                    raise ValueError(f"match {match_id!r}: agent {name!r} is not in the agents list; "
                                     "add it to `agents` or leave `agents` unset")
                agent_index[name] = len(names)
                names.append(name)
            if isinstance(outcome, str):
                word = outcome.lower()
                if word not in OUTCOME_PLACE:
                    raise ValueError(f"match {match_id!r}: outcome {outcome!r} is not one of "
                                     "'win', 'loss', 'draw' or an integer finishing place")
                place = OUTCOME_PLACE[word]
            else:
                word, place = None, int(outcome)
            words.setdefault(match_id, set()).add(word)
            cols["match"].append(match_index.setdefault(match_id, len(match_index)))
            cols["seat"].append(int(seat))
            cols["agent"].append(agent_index[name])
            cols["team"].append(int(team))
            cols["score"].append(float(score))
            cols["place"].append(place)
        for match_id, seen in words.items():
            if None in seen and len(seen) > 1:
                raise ValueError(f"match {match_id!r} mixes outcome words and finishing places; "
                                 "use one or the other within a match")
            if {"win", "draw"} <= seen:
                raise ValueError(f"match {match_id!r} has both a 'win' and a 'draw'; a drawn match is "
                                 "'draw' for every team that shared first place")
            if seen in ({"win"}, {"loss"}):
                raise ValueError(f"match {match_id!r}: every team has outcome {next(iter(seen))!r}; one team "
                                 "wins and the others lose, or the first-placed teams draw")
        return cls(agents=names, match_ids=list(match_index), **cols)

    @property
    def n_matches(self) -> int:
        return int(self.match.max()) + 1 if self.match.size else 0

    @property
    def n_agents(self) -> int:
        return len(self.agents)

    def _team_groups(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per (match, team): match, team, agent (min, max over its seats) and place, sorted by match
        then team."""
        order = np.lexsort((self.team, self.match))
        match, team = self.match[order], self.team[order]
        starts = np.flatnonzero(np.r_[True, (np.diff(match) != 0) | (np.diff(team) != 0)])
        agent, place = self.agent[order], self.place[order]
        return (match[starts], team[starts], np.minimum.reduceat(agent, starts),
                np.maximum.reduceat(agent, starts), np.stack([np.minimum.reduceat(place, starts),
                                                              np.maximum.reduceat(place, starts)]))

    def _check_matches(self) -> None:
        if not self.match.size:
            return
        seat_key = np.stack([self.match, self.seat], axis=1)
        if np.unique(seat_key, axis=0).shape[0] != seat_key.shape[0]:
            raise ValueError("a (match, seat) pair occurs twice; each seat of a match is one row")
        match, _, _, _, place = self._team_groups()
        mixed = np.flatnonzero(place[0] != place[1])
        if mixed.size:
            raise ValueError(f"match {self.match_ids[match[mixed[0]]]!r}: seats of one team have different "
                             "outcomes; a team wins, loses or draws as one")
        n_teams = np.bincount(match, minlength=self.n_matches)
        lonely = np.flatnonzero(n_teams < 2)
        if lonely.size:
            raise ValueError(f"match {self.match_ids[lonely[0]]!r} has fewer than two teams; "
                             "a rated match needs at least two")

    def pairwise(self) -> PairwiseResults:
        """Each pair of teams in each match as one result between the agents holding them.

        A team must be held by one agent (in any number of seats); teams of mixed agents have no
        pairwise reading: rate them with :func:`arena_league.rating.openskill_ratings`. Results
        between an agent and itself carry no information and are left out.
        """
        if self.match.size == 0:
            empty = np.zeros(0, dtype=np.int64)
            return PairwiseResults(self.agents, empty, empty, empty, np.zeros(0), empty, empty)
        match, team, agent_lo, agent_hi, place = self._team_groups()
        mixed = np.flatnonzero(agent_lo != agent_hi)
        if mixed.size:
            raise ValueError(f"match {self.match_ids[match[mixed[0]]]!r}: a team holds several agents; "
                             "pairwise ratings need one agent per team; use openskill_ratings for "
                             "mixed teams")
        place = place[0]
        starts = np.flatnonzero(np.r_[True, np.diff(match) != 0])
        n_teams = np.diff(np.r_[starts, match.shape[0]])
        parts = []
        for k in np.unique(n_teams):
            first_rows = starts[n_teams == k]
            rows = first_rows[:, None] + np.arange(k)[None, :]
            a, b = np.triu_indices(k, 1)
            ra, rb = rows[:, a].reshape(-1), rows[:, b].reshape(-1)
            parts.append((match[ra], agent_lo[ra], agent_lo[rb],
                          0.5 * (1.0 + np.sign(place[rb] - place[ra])), team[ra], team[rb]))
        m, first, second, score, first_team, second_team = (np.concatenate(c) for c in zip(*parts))
        order = np.argsort(m, kind="stable")
        keep = order[first[order] != second[order]]
        return PairwiseResults(self.agents, m[keep], first[keep], second[keep], score[keep],
                               first_team[keep], second_team[keep])

    def pair_counts(self) -> PairCounts:
        """Deduplicated win and draw counts between agents (see :class:`PairCounts`)."""
        results = self.pairwise()
        return PairCounts.from_results(results.first, results.second, results.score, self.agents)

    def seat_counts(self) -> SeatCounts:
        """Win, loss and draw counts that keep the side (the team index in the match) each agent
        held (see :class:`SeatCounts`); teams of one agent each, as in :meth:`pairwise`. The number
        of sides is one more than the largest team index in the table."""
        results = self.pairwise()
        n_sides = max(2, int(self.team.max()) + 1 if self.team.size else 2)
        return SeatCounts.from_results(results.first, results.second, results.first_team, results.second_team,
                                       results.score, self.agents, n_sides)


@dataclass(frozen=True)
class PairCounts:
    """Deduplicated pairwise outcome counts: ``wins[i, j]`` matches agent i won against agent j,
    ``draws[i, j] == draws[j, i]`` matches they drew. Float arrays, so that weights are allowed."""

    agents: list[str]
    wins: np.ndarray
    draws: np.ndarray

    def __post_init__(self) -> None:
        wins = np.asarray(self.wins, dtype=np.float64)
        draws = np.zeros_like(wins) if self.draws is None else np.asarray(self.draws, dtype=np.float64)
        n = len(self.agents)
        if wins.shape != (n, n) or draws.shape != (n, n):
            raise ValueError(f"wins and draws must be ({n}, {n}) for {n} agents; got {wins.shape} and "
                             f"{draws.shape}")
        if (wins < 0).any() or (draws < 0).any():
            raise ValueError("counts must be non-negative")
        if not np.allclose(draws, draws.T):
            raise ValueError("draws must be symmetric (draws[i, j] == draws[j, i]); pass each drawn "
                             "match once in each direction, e.g. d + d.T of a one-sided count")
        if np.diag(wins).any() or np.diag(draws).any():
            raise ValueError("an agent's matches against itself carry no information; zero the diagonal")
        object.__setattr__(self, "wins", wins)
        object.__setattr__(self, "draws", draws)
        object.__setattr__(self, "agents", [str(a) for a in self.agents])

    @classmethod
    def from_matrices(cls, wins: ArrayLike, draws: ArrayLike | None = None,
                      agents: Sequence[str] | None = None) -> PairCounts:
        """Wraps count matrices; agents default to ``"0", "1", ...``."""
        wins = np.asarray(wins, dtype=np.float64)
        if wins.ndim != 2 or wins.shape[0] != wins.shape[1]:
            raise ValueError(f"wins must be a square matrix, got shape {wins.shape}")
        names = [str(i) for i in range(wins.shape[0])] if agents is None else list(agents)
        return cls(names, wins, np.zeros_like(wins) if draws is None else np.asarray(draws, float))

    @classmethod
    def from_results(cls, first: ArrayLike, second: ArrayLike, score: ArrayLike,
                     agents: Sequence[str] | int) -> PairCounts:
        """Counts pairwise results: ``first[k]`` scored ``score[k]`` (1, 0.5 or 0) against
        ``second[k]``. ``agents`` is the list of names or their number."""
        names = [str(i) for i in range(agents)] if isinstance(agents, int) else list(agents)
        n = len(names)
        first, second = np.asarray(first, np.int64), np.asarray(second, np.int64)
        score = np.asarray(score, np.float64)
        if not np.isin(score, (0.0, 0.5, 1.0)).all():
            raise ValueError("scores must be 1 (win), 0.5 (draw) or 0 (loss) for the first agent")
        winner = np.where(score == 0.0, second, first)
        loser = np.where(score == 0.0, first, second)
        decided = score != 0.5
        wins = np.bincount(winner[decided] * n + loser[decided], minlength=n * n).reshape(n, n)
        drawn = np.bincount(first[~decided] * n + second[~decided], minlength=n * n).reshape(n, n)
        return cls(names, wins.astype(np.float64), (drawn + drawn.T).astype(np.float64))

    @property
    def n_agents(self) -> int:
        return len(self.agents)

    @property
    def games(self) -> np.ndarray:
        """Matches played between each pair (symmetric)."""
        return self.wins + self.wins.T + self.draws

    @property
    def n_matches(self) -> float:
        return float(self.wins.sum() + np.triu(self.draws, 1).sum())

    def win_rate(self, pseudo_count: float = 0.0) -> np.ndarray:
        """Empirical payoff ``(wins + draws/2 + c) / (games + 2c)`` of row against column.

        With ``pseudo_count`` c = 0, unplayed pairs are NaN; c > 0 (:data:`PSEUDO_COUNT` is the
        package's choice) shrinks towards 0.5 and keeps logits finite. The diagonal is 0.5.
        """
        points = self.wins + 0.5 * self.draws + pseudo_count
        games = self.games + 2.0 * pseudo_count
        with np.errstate(invalid="ignore", divide="ignore"):
            rate = points / games
        np.fill_diagonal(rate, 0.5)
        return rate

    def logit_payoff(self, pseudo_count: float = PSEUDO_COUNT) -> np.ndarray:
        """The antisymmetric meta-game ``A = logit(win_rate)`` of Balduzzi et al. (2018), with a
        pseudo-count (default :data:`PSEUDO_COUNT`) so that unbeaten pairs stay finite; unplayed
        pairs give 0."""
        if pseudo_count <= 0 and (self.games + np.eye(self.n_agents) == 0).any():
            raise ValueError(f"some pairs never played; pass pseudo_count > 0 (e.g. {PSEUDO_COUNT})")
        points = self.wins + 0.5 * self.draws + pseudo_count
        return np.log(points) - np.log(points.T)

    def outcome_cells(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Deduplicated outcomes: flat indices into ``wins``, into ``draws`` (upper triangle), and
        their counts concatenated; the categories a match bootstrap resamples."""
        win_cells = np.flatnonzero(self.wins)
        draw_cells = np.flatnonzero(np.triu(self.draws, 1))
        counts = np.concatenate([self.wins.reshape(-1)[win_cells], self.draws.reshape(-1)[draw_cells]])
        return win_cells, draw_cells, counts

    def resample(self, rng: np.random.Generator, rounds: int) -> tuple[np.ndarray, np.ndarray]:
        """``rounds`` bootstrap replicates of the league: the matches resampled with replacement,
        as one multinomial draw over the deduplicated outcome cells. Returns stacked
        ``(wins, draws)`` of shape ``(rounds, n, n)``. Counts must be whole numbers."""
        win_cells, draw_cells, counts = self.outcome_cells()
        total = counts.sum()
        if total == 0:
            raise ValueError("there are no matches to resample; play some first")
        if not np.allclose(counts, np.round(counts)):
            raise ValueError("bootstrap resampling needs whole match counts, not weights")
        n = self.n_agents
        resampled = rng.multinomial(int(total), counts / total, size=rounds)
        wins = np.zeros((rounds, n * n))
        draws = np.zeros((rounds, n * n))
        wins[:, win_cells] = resampled[:, : win_cells.size]
        draws[:, draw_cells] = resampled[:, win_cells.size:]
        draws = draws.reshape(rounds, n, n)
        return wins.reshape(rounds, n, n), draws + draws.transpose(0, 2, 1)


@dataclass(frozen=True)
class SeatCounts:
    """Deduplicated pairwise outcome counts that keep which side each agent held.

    A side is a team position in the match (team 0, team 1, ...). The side pairs ``(a_k, b_k)``,
    ``a_k < b_k``, are numbered in ``np.triu_indices(n_sides, 1)`` order (one pair, (0, 1), for
    two-team games). ``won[k, i, j]`` counts matches where agent i at side a_k beat agent j at side
    b_k, ``lost[k, i, j]`` those i at side a_k lost to j at side b_k, and ``drawn[k, i, j]`` those
    they drew; each match is counted once. Float arrays of shape ``(K, n, n)``, K = n_sides
    (n_sides - 1) / 2, so that weights are allowed.
    """

    agents: list[str]
    n_sides: int
    won: np.ndarray
    lost: np.ndarray
    drawn: np.ndarray

    def __post_init__(self) -> None:
        n_sides = int(self.n_sides)
        if n_sides < 2:
            raise ValueError(f"n_sides must be at least 2 (a match has two teams), got {self.n_sides}")
        n = len(self.agents)
        shape = (n_sides * (n_sides - 1) // 2, n, n)
        arrays = {name: np.asarray(getattr(self, name), dtype=np.float64) for name in ("won", "lost", "drawn")}
        for name, array in arrays.items():
            if array.shape != shape:
                raise ValueError(f"{name} must have shape {shape} (side pairs, agents, agents) for {n_sides} "
                                 f"sides and {n} agents; got {array.shape}")
            if not np.isfinite(array).all() or (array < 0).any():
                raise ValueError(f"{name} counts must be finite and non-negative")
            if np.diagonal(array, axis1=1, axis2=2).any():
                raise ValueError(f"{name} counts an agent against itself; pairwise ratings leave such "
                                 "matches out: zero the diagonal of each side pair")
            object.__setattr__(self, name, array)
        object.__setattr__(self, "n_sides", n_sides)
        object.__setattr__(self, "agents", [str(a) for a in self.agents])

    @classmethod
    def from_results(cls, first: ArrayLike, second: ArrayLike, first_side: ArrayLike, second_side: ArrayLike,
                     score: ArrayLike, agents: Sequence[str] | int, n_sides: int = 2) -> SeatCounts:
        """Counts pairwise results: ``first[k]``, at side ``first_side[k]``, scored ``score[k]`` (1, 0.5
        or 0) against ``second[k]`` at side ``second_side[k]``. ``agents`` is the list of names or
        their number; sides run from 0 to ``n_sides - 1``."""
        names = [str(i) for i in range(agents)] if isinstance(agents, int) else list(agents)
        n = len(names)
        columns = [np.asarray(c, np.int64).reshape(-1) for c in (first, second, first_side, second_side)]
        score = np.asarray(score, np.float64).reshape(-1)
        if len({c.size for c in columns} | {score.size}) != 1:
            raise ValueError("first, second, first_side, second_side and score need one value per result")
        first, second, first_side, second_side = columns
        if not np.isin(score, (0.0, 0.5, 1.0)).all():
            raise ValueError("scores must be 1 (win), 0.5 (draw) or 0 (loss) for the first agent")
        if ((first < 0) | (first >= n) | (second < 0) | (second >= n)).any():
            raise ValueError(f"agent indices must lie in [0, {n}); pass the full list of agent names")
        if ((first_side < 0) | (first_side >= n_sides) | (second_side < 0) | (second_side >= n_sides)).any():
            raise ValueError(f"sides must lie in [0, {n_sides}); pass n_sides as the number of teams in a match")
        if (first_side == second_side).any():
            raise ValueError("the two agents of a result held the same side; each side is one team of the match")
        # order each result so that the lower side comes first
        swap = first_side > second_side
        low, high = np.where(swap, second, first), np.where(swap, first, second)
        side_low = np.minimum(first_side, second_side)
        side_high = np.maximum(first_side, second_side)
        low_score = np.where(swap, 1.0 - score, score)
        pair_index = np.full((n_sides, n_sides), -1, dtype=np.int64)
        a, b = np.triu_indices(n_sides, 1)
        pair_index[a, b] = np.arange(a.size)
        cell = (pair_index[side_low, side_high] * n + low) * n + high
        size = a.size * n * n
        won, lost, drawn = (np.bincount(cell[low_score == value], minlength=size).reshape(a.size, n, n)
                            .astype(np.float64) for value in (1.0, 0.0, 0.5))
        return cls(names, n_sides, won, lost, drawn)

    @property
    def n_agents(self) -> int:
        return len(self.agents)

    @property
    def side_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """The sides ``(a_k, b_k)`` of each side pair k."""
        return np.triu_indices(self.n_sides, 1)

    @property
    def n_matches(self) -> float:
        return float(self.won.sum() + self.lost.sum() + self.drawn.sum())

    def pair_counts(self) -> PairCounts:
        """The seat-blind counts (see :class:`PairCounts`): the same matches, sides forgotten."""
        wins = self.won.sum(axis=0) + self.lost.sum(axis=0).T
        drawn = self.drawn.sum(axis=0)
        return PairCounts(self.agents, wins, drawn + drawn.T)

    def resample(self, rng: np.random.Generator, rounds: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``rounds`` bootstrap replicates of the league, as :meth:`PairCounts.resample`: one
        multinomial draw over the non-zero outcome cells. Returns stacked ``(won, lost, drawn)`` of
        shape ``(rounds, K, n, n)``. Counts must be whole numbers."""
        stacked = np.stack([self.won, self.lost, self.drawn]).reshape(-1)
        cells = np.flatnonzero(stacked)
        counts = stacked[cells]
        total = counts.sum()
        if total == 0:
            raise ValueError("there are no matches to resample; play some first")
        if not np.allclose(counts, np.round(counts)):
            raise ValueError("bootstrap resampling needs whole match counts, not weights")
        resampled = np.zeros((rounds, stacked.size))
        resampled[:, cells] = rng.multinomial(round(total), counts / total, size=rounds)
        won, lost, drawn = np.moveaxis(resampled.reshape(rounds, 3, *self.won.shape), 1, 0)
        return won, lost, drawn
