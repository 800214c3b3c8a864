"""A small frozen base for placement tests: the two scripted agents of a game at fixed ratings,
and the example submission as the entrant."""

from __future__ import annotations

from pathlib import Path

from arena_league.league import ensure_scripted_agents, evaluate, open_home, submit
from arena_league.registry import add_population_member, create_population, freeze_population, get_agent

EXAMPLE = Path(__file__).resolve().parent.parent / "submissions" / "crossroads-2t2p-mlp.onnx"


def scripted_base_with_entrant(home: Path, game_id: str, *, history: bool = False) -> None:
    """Population ``scripted:1`` of ``game_id`` (its scripted agents rated 900 and 1100) and the
    example entrant ``alice``; with ``history``, evaluation jobs and matches played first (so job
    ids and stored matches differ from a fresh league's)."""
    with open_home(home) as league:
        names = ensure_scripted_agents(league, game_id)
        if history:
            evaluate(league, game_id, names, matches_per_pair=4, seed=9)
            evaluate(league, game_id, names, matches_per_pair=6, seed=9)
        with league.transaction() as session:
            population = create_population(session, "scripted", game_id, provenance={"made_by": "test"})
            for name, rating in zip(names, (900.0, 1100.0)):
                add_population_member(session, population, get_agent(session, name), {"rating": rating})
            freeze_population(session, population)
        assert submit(league, EXAMPLE, game_id, "alice").status == "active"
