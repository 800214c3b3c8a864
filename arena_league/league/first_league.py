"""A whole league on the embedded default, end to end: the workflow ``arena-league quickstart`` runs.

1. the league home (SQLite under ``ARENA_LEAGUE_HOME``) and the game's scripted agents;
2. where the game ships a base population, the newest one's import from where it is found (the
   checkout, the cache or the package, see :mod:`.population_index`; one not on this machine stops
   the quickstart, naming the pull that fetches it);
3. for Crossroads, the example ONNX submission (``submissions/`` in a checkout, carried by the
   wheel otherwise), validated and registered;
4. a round robin among the scripted agents;
5. the example ranked against the base population (or, without one, against the league's agents);
6. the Bradley-Terry leaderboard of the same base: its members at their frozen ratings, the example
   where its ranking placed it, the scripted agents pending (or, without a base, every agent
   re-rated from the league's matches).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from arena_league.league.leaderboards import Leaderboard
from arena_league.league.populations import describe_population, ensure_population, shipped_populations
from arena_league.league.service import (
    LEAGUE_WIDE,
    EvaluationReport,
    RankReport,
    ensure_scripted_agents,
    evaluate,
    leaderboard,
    rank,
    submit,
)
from arena_league.registry import League

__all__ = ["EXAMPLE_SUBMISSIONS", "QuickstartReport", "quickstart"]



def _example(filename: str) -> Path:
    """An example submission: the checkout's ``submissions/``, else the copy a built wheel carries."""
    checkout = Path(__file__).resolve().parents[2] / "submissions" / filename
    return checkout if checkout.is_file() else Path(__file__).resolve().parent / "packaged" / filename


#: Example submissions shipped with the package, by game.
EXAMPLE_SUBMISSIONS = {"Crossroads-2T2P-v1": _example("crossroads-2t2p-mlp.onnx")}

#: Progress callbacks: ``(stage, total) -> (done, total) -> None``, one per long stage.
StageProgress = Callable[[str, int], Callable[[int, int], None]]


@dataclass(frozen=True)
class QuickstartReport:
    """What the quickstart did: the home, the base population used and where it came from, the
    round robin, the ranking of the example submission (None where the game has no example) and
    the leaderboard."""

    home: str
    population: str | None
    evaluation: EvaluationReport
    ranked: RankReport | None
    board: Leaderboard
    population_origin: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"home": self.home, "population": self.population, "population_origin": self.population_origin,
                "evaluation": self.evaluation.to_dict(),
                "rank": self.ranked.to_dict() if self.ranked else None, "leaderboard": self.board.to_dict()}


def quickstart(league: League, game_id: str = "Crossroads-2T2P-v1", *, matches_per_pair: int = 10,
               budget: int = 40, seed: int = 0, base: bool = True, log: Callable[[str], None] | None = None,
               stage_progress: StageProgress | None = None) -> QuickstartReport:
    """Run the quickstart workflow on ``league`` (see the module docstring); ``base=False`` leaves
    the shipped base population out. ``log`` gets a line per stage; ``stage_progress(stage, total)``
    returns the progress callback of a long stage (round robin, ranking)."""
    say = log or (lambda line: None)

    def progress(stage: str, total: int) -> Callable[[int, int], None] | None:
        return stage_progress(stage, total) if stage_progress else None

    say(f"league home: {league.home}")
    names = ensure_scripted_agents(league, game_id)
    population = origin = None
    shipped = shipped_populations(game_id) if base else []
    if shipped:
        try:
            population, _ = ensure_population(league, game_id, shipped[-1])
        except ValueError as error:
            raise ValueError(f"{error}; or leave the base out with `arena-league quickstart --no-base`") from None
        origin = describe_population(league, game_id, population)
        say(f"base population {origin}")
    entrant = None
    example = EXAMPLE_SUBMISSIONS.get(game_id)
    if example is not None and not example.is_file():
        say(f"the example submission {example.name} is not here (a package built without it); skipped")
    elif example is not None:
        result = submit(league, example, game_id, "example-mlp", owner="arena-league")
        entrant = result.agent if result.status == "active" else None
        say(f"submitted {example.name}: {result.agent} {result.status}")
    report = evaluate(league, game_id, names, matches_per_pair=matches_per_pair, seed=seed,
                      progress=progress(f"round robin on {game_id}", 1))
    say(f"scripted round robin: {report.played} matches in {report.seconds:.1f} s")
    against = population or LEAGUE_WIDE  # the ranking and the board use one base
    ranked = None
    if entrant:
        ranked = rank(league, entrant, budget=budget, population=against, seed=seed,
                      progress=progress(f"ranking {entrant}", budget))
    board = leaderboard(league, game_id, "bt", population=against, seed=seed)
    return QuickstartReport(str(league.home), population, report, ranked, board, origin)
