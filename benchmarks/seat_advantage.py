"""Seat advantage of a shipped population: prints one JSON document on stdout.

    PYTHONPATH=. python3 benchmarks/seat_advantage.py [--game GoBang-2T1P-v1] [--population base-v2]
        [--matches-per-pair 2] [--rounds 100] [--seed 0] [--members N]

Plays a round robin among the population's members with the sides balanced (each pair meets
``--matches-per-pair`` times, as evenly on each side as the number allows: once per side by
default), in process on the game's batched engine. Then fits Bradley-Terry with 100 bootstrap
rounds twice on the same matches: with a seat term (:class:`arena_league.rating.SeatCounts`) and
seat-blind (:class:`arena_league.rating.PairCounts`). Reports the seat term with its interval and
its one-line description, each member's rating with and without it, the largest rating change,
and the rank changes. With balanced sides the seat term should move ratings little; what it adds
is the size of the first seat's edge and an honest account of it when sides are not balanced.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

from arena_league.league.population.loading import member_policy
from arena_league.league.population.round_robin import play_seatings
from arena_league.league.population_index import CHECKOUT_POPULATIONS
from arena_league.matchmaking import round_robin
from arena_league.rating import SeatCounts, bootstrap_ratings


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--game", default="GoBang-2T1P-v1")
    parser.add_argument("--population", default="base-v2", help="a population folder name under checkpoints/<game>/")
    parser.add_argument("--folder", type=Path, default=None, help="the population folder (overrides --population)")
    parser.add_argument("--matches-per-pair", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=100, help="bootstrap rounds")
    parser.add_argument("--seed", type=int, default=0, help="league seed of the matches and the bootstrap")
    parser.add_argument("--members", type=int, default=None, help="only the first N members (a quick run)")
    parser.add_argument("--batch-size", type=int, default=256, help="matches in flight")
    args = parser.parse_args(argv)
    if args.matches_per_pair < 1:
        parser.error("--matches-per-pair must be at least 1")

    folder = args.folder or CHECKOUT_POPULATIONS / args.game / args.population
    manifest_path = folder / "population.json"
    if not manifest_path.is_file():
        parser.error(f"no population.json in {folder}; pass --game and --population of a shipped population, "
                     "or --folder")
    manifest = json.loads(manifest_path.read_text())
    members = manifest["members"][: args.members]
    names = [m["name"] for m in members]
    policies = {m["name"]: member_policy(folder, m, args.game) for m in members}

    seatings = round_robin(names, args.matches_per_pair)
    start = time.perf_counter()
    scores = play_seatings(args.game, seatings, policies, args.seed, 0, args.batch_size)
    play_seconds = time.perf_counter() - start
    index = {name: i for i, name in enumerate(names)}
    first = [index[a] for a, _ in seatings]
    second = [index[b] for _, b in seatings]
    counts = SeatCounts.from_results(first, second, np.zeros(len(first)), np.ones(len(first)), scores, names, 2)

    start = time.perf_counter()
    seated = bootstrap_ratings(counts, rounds=args.rounds, seed=args.seed)
    blind = bootstrap_ratings(counts.pair_counts(), rounds=args.rounds, seed=args.seed)
    fit_seconds = time.perf_counter() - start

    change = seated.rating - blind.rating
    largest = int(np.argmax(np.abs(change)))
    moved = np.flatnonzero(seated.rank != blind.rank)
    score = np.asarray(scores)
    report = {
        "game": args.game,
        "population": manifest.get("name", args.population),
        "members": len(names),
        "matches": len(seatings),
        "matches_per_pair": args.matches_per_pair,
        "first_seat_score": round(float(score.mean()), 4),
        "draws": int((score == 0.5).sum()),
        "seat_term": seated.seats.to_dict(),
        "describe": seated.seats.describe(),
        "largest_rating_change": {"member": names[largest], "with_seat": round(float(seated.rating[largest]), 2),
                                  "without_seat": round(float(blind.rating[largest]), 2),
                                  "change": round(float(change[largest]), 2)},
        "mean_abs_rating_change": round(float(np.abs(change).mean()), 3),
        "rank_changes": {"members_moved": int(moved.size),
                         "largest": int(np.abs(seated.rank - blind.rank).max()),
                         "moved": [{"member": names[i], "without_seat": int(blind.rank[i]),
                                    "with_seat": int(seated.rank[i])} for i in moved]},
        "ratings": [{"member": name, "with_seat": round(float(seated.rating[i]), 2),
                     "with_seat_interval": [round(float(seated.lower[i]), 1), round(float(seated.upper[i]), 1)],
                     "without_seat": round(float(blind.rating[i]), 2),
                     "without_seat_interval": [round(float(blind.lower[i]), 1), round(float(blind.upper[i]), 1)]}
                    for i, name in enumerate(names)],
        "seconds": {"play": round(play_seconds, 2), "fit_both_with_bootstrap": round(fit_seconds, 3)},
        "bootstrap_rounds": args.rounds,
        "seed": args.seed,
        "python": platform.python_version(),
    }
    json.dump(report, sys.stdout, indent=1)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
