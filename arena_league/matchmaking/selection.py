"""Opponent selection: round robin with the least-played pairs first, and adaptive placement.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) evaluates a population by its full payoff table (every pair plays) and
ranks a new agent by matches against the base population. Two schedules serve those:

* :func:`round_robin`: every pair of agents (two-team games) meets ``matches_per_pair`` times,
  counting the matches already played. Pairs are served in rounds, least-played first; within a
  level, in the order of the circle method (Berger tables), so that a schedule cut short still
  spreads matches evenly over agents. Each pair's seatings are balanced: an agent holds team 0 as
  often as team 1 (to within one match when the count is odd). Deterministic: the same agents and
  counts give the same list.
* :func:`play_adaptive`: an entrant against a base population, one opponent at a time, chosen by
  an *opponent chooser*, any object with ``next_opponent() -> int``, ``record(opponent, score,
  side)`` and ``done`` (the rating engine's ``AdaptivePlacement``, which picks the opponent with the
  largest expected information about the entrant's rating, fits; :class:`LeastPlayedChooser` is
  the uniform one). Each visit plays the opponent on both sides: two matches, or one pair in a game
  played in pairs (a pair holds both sides already, and counts as one match of the budget).
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Mapping, Sequence
from typing import Protocol, runtime_checkable

import numpy as np

from arena_league.matchmaking.specs import MatchResult, MatchSpec, specs_for_seatings

__all__ = [
    "LeastPlayedChooser",
    "OpponentChooser",
    "berger_round",
    "pair_counts",
    "play_adaptive",
    "round_robin",
]

Seating = tuple[str, str]


def berger_round(i: int, j: int, n_agents: int) -> int:
    """The round (0-based) in which agents ``i`` and ``j`` meet in the circle-method round robin
    of ``n_agents`` (a bye is added when odd): every agent plays once per round."""
    m = n_agents + (n_agents % 2)
    i, j = min(i, j), max(i, j)
    if j == m - 1:
        return i
    return ((i + j) * (m // 2)) % (m - 1)


def pair_counts(results: Sequence[MatchResult]) -> dict[Seating, int]:
    """Matches played per seating ``(team 0 agent, team 1 agent)`` from two-team results (the agent
    of a team is its first seat's)."""
    counts: dict[Seating, int] = {}
    for result in results:
        first = {}
        for agent, team in zip(result.seats, result.teams):
            first.setdefault(team, agent)
        if len(first) != 2:
            raise ValueError(f"match {result.match_id} has {len(first)} teams; pair counts are for two-team games")
        key = (first[0], first[1])
        counts[key] = counts.get(key, 0) + 1
    return counts


def round_robin(agents: Sequence[str], matches_per_pair: int, played: Mapping[Seating, int] | None = None, *,
                entrant: str | None = None, limit: int | None = None) -> list[Seating]:
    """The seatings ``(team 0 agent, team 1 agent)`` that bring every pair to ``matches_per_pair``.

    Args:
        agents: the agents (distinct names); their order breaks ties.
        matches_per_pair: the total each pair should reach, already played matches included.
        played: matches already played per seating ``(team 0 agent, team 1 agent)``; pairs past the
            target get no more.
        entrant: only the pairs of this agent with every other (placing a newcomer).
        limit: at most this many seatings (the least-played first).
    """
    names = list(agents)
    if len(set(names)) != len(names):
        raise ValueError("agents must be distinct names")
    if isinstance(matches_per_pair, bool) or not isinstance(matches_per_pair, int) or matches_per_pair < 0:
        raise ValueError(f"matches_per_pair must be a non-negative integer, not {matches_per_pair!r}")
    if entrant is not None and entrant not in names:
        raise ValueError(f"entrant {entrant!r} is not among the agents")
    played = played or {}
    unknown = sorted({a for pair in played for a in pair if a not in names})
    if unknown:
        raise ValueError(f"played counts name agents not in the list: {unknown[:5]}")
    n = len(names)
    heap: list[tuple[int, int, int, int]] = []
    side: dict[tuple[int, int], int] = {}
    for i in range(n):
        for j in range(i + 1, n):
            if entrant is not None and entrant not in (names[i], names[j]):
                continue
            forward = int(played.get((names[i], names[j]), 0))
            backward = int(played.get((names[j], names[i]), 0))
            total = forward + backward
            if total < matches_per_pair:
                side[(i, j)] = forward - backward
                heapq.heappush(heap, (total, berger_round(i, j, n), i, j))
    seatings: list[Seating] = []
    budget = np.inf if limit is None else int(limit)
    while heap and len(seatings) < budget:
        total, rnd, i, j = heapq.heappop(heap)
        balance = side[(i, j)]
        if balance > 0 or (balance == 0 and (rnd + total + i) % 2 == 1):
            seatings.append((names[j], names[i]))
            side[(i, j)] = balance - 1
        else:
            seatings.append((names[i], names[j]))
            side[(i, j)] = balance + 1
        if total + 1 < matches_per_pair:
            heapq.heappush(heap, (total + 1, rnd, i, j))
    return seatings


@runtime_checkable
class OpponentChooser(Protocol):
    """Picks an entrant's next opponent (an index into the base population) from the results so far."""

    def next_opponent(self) -> int: ...

    def record(self, opponent: int, score: float, side: int = 0) -> None:
        """The entrant scored ``score`` (1, 0.5, 0) against ``opponent``, holding team ``side``."""

    @property
    def done(self) -> bool: ...


class LeastPlayedChooser:
    """The uniform chooser: the opponent met least often (lowest index on ties), for ``budget``
    matches."""

    def __init__(self, n_opponents: int, budget: int) -> None:
        if n_opponents < 1 or budget < 1:
            raise ValueError("need at least one opponent and a budget of at least one match")
        self.games = np.zeros(n_opponents, dtype=np.int64)
        self.points = np.zeros(n_opponents, dtype=np.float64)
        self.budget = budget

    def next_opponent(self) -> int:
        return int(np.argmin(self.games))

    def record(self, opponent: int, score: float, side: int = 0) -> None:
        self.games[opponent] += 1
        self.points[opponent] += score

    @property
    def done(self) -> bool:
        return int(self.games.sum()) >= self.budget


def play_adaptive(entrant: str, opponents: Sequence[str], chooser: OpponentChooser,
                  play: Callable[[list[MatchSpec]], list[MatchResult]], game_id: str, *, league_seed: int = 0,
                  first_match_id: int = 0, max_matches: int = 10_000) -> list[MatchResult]:
    """Places ``entrant`` against ``opponents`` (two-team games): while the chooser is not done,
    plays its next opponent twice (entrant on team 0, then on team 1; once in a game played in pairs,
    whose pair swaps the sides itself) with ``play`` (e.g. ``lambda specs: play_matches(specs,
    agents)``) and records the entrant's score of each match (1 win, 0.5 draw, 0 loss) and its side.
    Match ids run on from ``first_match_id``. Placement stops early when ``play`` returns no result
    for a spec (its agents were skipped, e.g. an entrant past its forfeits)."""
    from arena_league.envs import game_spec

    paired = game_spec(game_id).paired
    results: list[MatchResult] = []
    match_id = first_match_id
    while not chooser.done and len(results) < max_matches:
        k = int(chooser.next_opponent())
        if not 0 <= k < len(opponents):
            raise ValueError(f"the chooser picked opponent {k}, outside 0..{len(opponents) - 1}")
        opponent = opponents[k]
        seatings = [(entrant, opponent)] if paired else [(entrant, opponent), (opponent, entrant)]
        specs = specs_for_seatings(game_id, seatings, league_seed, match_id)
        match_id += len(specs)
        # one match per call: once the chooser is done, the pair's second match is neither played nor stored
        for spec in specs:
            played = play([spec])
            if not played:
                return results
            for result in played:
                team = result.teams[result.seats.index(entrant)]
                chooser.record(k, result.team_scores()[team], team)
                results.append(result)
            if chooser.done:
                break
    return results
