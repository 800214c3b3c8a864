"""A build's round robin by role, and the Bradley-Terry spread a stronger top would give it.

In a game whose teams play different roles (YouShallNotPass: team 0 runs, team 1 blocks) a
candidate's rating mixes two skills. This reads the round robin a population build saved under its
``--work-dir`` and prints, as JSON lines:

* ``summary``: candidates, matches, the candidates' Bradley-Terry spread, the random agent's rating
  and the members' floor (``DEFAULT_FLOOR_MARGIN`` above it, or ``--floor-margin``);
* ``candidate``: the strongest and the weakest candidates above the floor (``--show`` of each) with
  their win rates as team 0 and as team 1;
* ``top``: a synthetic candidate added to the round robin, two matches against every candidate (one
  per team): it wins as team 0 as often as the best candidate does, and as team 1 it stops the
  share ``stops`` of the matches its opponent would otherwise win as team 0 (its opponent's own
  rate as team 0 over the round robin). Its rating and the spread from it down to the weakest
  candidate above the floor (the members' spread, had it joined) say how strong team 1's side of a
  top must be for a given spread (the shipped criterion is 800 Elo)::

    python benchmarks/population_roles.py WORK_DIR [--show 5] [--floor-margin 50]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from arena_league.league.population.build import DEFAULT_FLOOR_MARGIN
from arena_league.rating import bradley_terry

STOPS = (0.0, 0.25, 0.5, 0.7, 0.8, 0.9, 0.95, 1.0)


def round_robin(work_dir: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Candidate names, wins ``[i, j]`` of i over j, and ``[i, team, won/played]`` per candidate."""
    rows = []
    for chunk in sorted(work_dir.glob("matches/*/chunk-*.json")):
        saved = json.loads(chunk.read_text())
        rows += [(a, b, s) for (a, b), s in zip(saved["seatings"], saved["scores"])]
    if not rows:
        raise SystemExit(f"no round-robin chunks under {work_dir}/matches: give a build's --work-dir")
    names = sorted({a for a, _, _ in rows} | {b for _, b, _ in rows})
    index = {n: i for i, n in enumerate(names)}
    wins = np.zeros((len(names), len(names)))
    by_team = np.zeros((len(names), 2, 2))
    for a, b, score in rows:
        i, j = index[a], index[b]
        wins[i, j] += score
        wins[j, i] += 1.0 - score  # a draw counts half to each, as the build's ratings do
        by_team[i, 0] += (score, 1.0)
        by_team[j, 1] += (1.0 - score, 1.0)
    return names, wins, by_team


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("work_dir", type=Path, help="a population build's --work-dir")
    parser.add_argument("--show", type=int, default=5, help="candidates shown at each end (default 5)")
    parser.add_argument("--floor-margin", type=float, default=DEFAULT_FLOOR_MARGIN,
                        help=f"members start this far above the random agent (default {DEFAULT_FLOOR_MARGIN:g} Elo)")
    args = parser.parse_args()
    names, wins, by_team = round_robin(args.work_dir)
    rate = by_team[:, :, 0] / np.maximum(by_team[:, :, 1], 1.0)
    rating = bradley_terry(wins, agents=names)
    floor = float(rating[names.index("random")]) + args.floor_margin
    above = np.flatnonzero(rating >= floor)
    print(json.dumps({"summary": {"candidates": len(names), "matches": int(by_team[:, 0, 1].sum()),
                                  "spread": round(float(np.ptp(rating)), 1), "random": round(floor - args.floor_margin, 1),
                                  "floor": round(floor, 1), "above_floor": len(above)}}))
    order = above[np.argsort(-rating[above], kind="stable")]
    for k in list(order[: args.show]) + list(order[-args.show:]):
        print(json.dumps({"candidate": names[k], "rating": round(float(rating[k]), 1),
                          "team0_win_rate": round(float(rate[k, 0]), 3), "team1_win_rate": round(float(rate[k, 1]), 3)}))
    best = int(order[0])
    n = len(names)
    for stops in STOPS:
        grown = np.zeros((n + 1, n + 1))
        grown[:n, :n] = wins
        won = rate[best, 0] + 1.0 - rate[:, 0] * (1.0 - stops)  # of two matches, one per team
        grown[n, :n], grown[:n, n] = won, 2.0 - won
        fitted = bradley_terry(grown, agents=[*names, "top"])
        floor_now = float(fitted[names.index("random")]) + args.floor_margin
        weakest = float(fitted[:n][fitted[:n] >= floor_now].min())
        print(json.dumps({"top": {"stops": stops, "team0_win_rate": round(float(rate[best, 0]), 3),
                                  "rating": round(float(fitted[n]), 1),
                                  "spread_from_floor": round(float(fitted[n]) - weakest, 1)}}))


if __name__ == "__main__":
    main()
