"""Built-in agents against the game's scripted heuristic: how strong each search budget is.

Every agent named (``search-w8-r1-h40``, ``search-w8-r1-h40-v2``, ... or ``heuristic`` itself) plays
``--matches`` fresh matches against ``scripted:heuristic`` on the batched engine, seats (or teams)
taking turns, and the JSON gives its wins, draws and losses (first place alone, shared, other) and
the seconds it took. The figures in the games' manuals (their "Search agent" sections) come from it::

    python benchmarks/search_agents.py FightForFood-2T1P-v1 search-w4-r1-h40 search-w4-r1-h40-v2 [--matches 100]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from arena_league.envs import game_spec
from arena_league.matchmaking import play_matches, specs_for_seatings
from arena_league.policies.scripted import scripted_policy


def against_heuristic(game_id: str, name: str, matches: int, seed: int) -> dict:
    n_teams = game_spec(game_id).n_teams
    agents = {"agent": scripted_policy(name, game_id), "heuristic": scripted_policy("heuristic", game_id)}
    seatings = [tuple("agent" if team == k % n_teams else "heuristic" for team in range(n_teams))
                for k in range(matches)]
    started = time.perf_counter()
    results = play_matches(specs_for_seatings(game_id, seatings, seed), agents, backend="inprocess")
    seconds = time.perf_counter() - started
    # the agent's team result against the best of the heuristic's teams: above it, level, below
    margin = []
    for seats, result in zip(seatings, results):
        scores = result.team_scores()  # {team: score}
        agent = seats.index("agent")
        margin.append(scores[agent] - max(s for team, s in scores.items() if team != agent))
    margin = np.array(margin)
    return {"game": game_id, "agent": name, "matches": matches, "wins": int((margin > 0).sum()),
            "draws": int((margin == 0).sum()), "losses": int((margin < 0).sum()), "seconds": round(seconds, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("game", help="a game id, e.g. FightForFood-2T1P-v1")
    parser.add_argument("agents", nargs="+", help="built-in agents, e.g. search-w8-r1-h40-v2")
    parser.add_argument("--matches", type=int, default=100, help="matches per agent (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="the matches' league seed (default 0)")
    args = parser.parse_args()
    for name in args.agents:
        print(json.dumps(against_heuristic(args.game, name, args.matches, args.seed)), flush=True)


if __name__ == "__main__":
    main()
