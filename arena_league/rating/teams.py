"""Gaussian skill ratings for team games and free-for-all matches of more than two teams.

Weng & Lin (2011), "A Bayesian Approximation Method for Online Ranking", JMLR 12, with the
Plackett-Luce model, as implemented by the ``openskill`` package (Joshy et al., OpenSkill). Each
agent has a skill mu with uncertainty sigma; a match updates everyone seated from the teams'
finishing order; an agent's conservative score is mu - 3 sigma (99.7% one-sided lower bound under
the Gaussian belief), the figure Kaggle-style leaderboards sort by.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from arena_league.rating.outcomes import OutcomeTable

__all__ = ["SkillRatings", "openskill_ratings"]

SkillModel = Literal["plackett_luce", "bradley_terry_full", "thurstone_mosteller_full"]


@dataclass(frozen=True)
class SkillRatings:
    """OpenSkill ratings after a sequence of matches."""

    agents: list[str]
    mu: np.ndarray
    sigma: np.ndarray
    matches: np.ndarray
    """Rated matches each agent took part in."""
    skipped: int
    """Matches left out because one agent sat on more than one team (no information)."""

    @property
    def conservative(self) -> np.ndarray:
        """mu - 3 sigma."""
        return self.mu - 3.0 * self.sigma


def openskill_ratings(
    table: OutcomeTable,
    *,
    model: SkillModel = "plackett_luce",
    mu: float = 25.0,
    sigma: float = 25.0 / 3.0,
) -> SkillRatings:
    """Rates the table's matches in order with an OpenSkill model (Plackett-Luce by default).

    Teams may hold several agents; an agent holding several seats of one team counts once. A match
    in which one agent sits on two different teams (self-play mirrors) says nothing about the agent
    against others and is skipped. Ties (equal places) are supported.
    """
    from openskill.models import BradleyTerryFull, PlackettLuce, ThurstoneMostellerFull

    models = {"plackett_luce": PlackettLuce, "bradley_terry_full": BradleyTerryFull,
              "thurstone_mosteller_full": ThurstoneMostellerFull}
    if model not in models:
        raise ValueError(f"model must be one of {sorted(models)}, got {model!r}")
    rater = models[model](mu=mu, sigma=sigma)
    n = table.n_agents
    mus, sigmas = np.full(n, mu), np.full(n, sigma)
    played = np.zeros(n, dtype=np.int64)
    skipped = 0
    order = np.lexsort((table.team, table.match))
    match, team = table.match[order], table.team[order]
    agent, place = table.agent[order], table.place[order]
    match_starts = np.flatnonzero(np.diff(match) != 0) + 1
    for rows in np.split(np.arange(match.size), match_starts) if match.size else ():
        team_starts = np.flatnonzero(np.r_[True, np.diff(team[rows]) != 0])
        lineups = [np.unique(agent[rows][s:e]) for s, e in zip(team_starts, np.r_[team_starts[1:], rows.size])]
        seated = np.concatenate(lineups)
        if np.unique(seated).size != seated.size:
            skipped += 1
            continue
        ranks = place[rows][team_starts].tolist()
        teams = [[rater.rating(mu=mus[a], sigma=sigmas[a]) for a in lineup] for lineup in lineups]
        for lineup, rated in zip(lineups, rater.rate(teams, ranks=ranks)):
            for a, r in zip(lineup, rated):
                mus[a], sigmas[a] = r.mu, r.sigma
        played[seated] += 1
    return SkillRatings(table.agents, mus, sigmas, played, skipped)
