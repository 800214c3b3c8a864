"""The placement budget a study needs for rank intervals of at most +-5 places: prints JSON.

    PYTHONPATH=. python3 benchmarks/placement_budget.py [--game Crossroads-2T2P-v1] [--population base-v1]
        [--target 5] [--members 1] [--max-budget 300] [--seed 0] [--simulated 200]

Places the base members rated nearest the population's median as the baselines experiment places a
checkpoint (``arena_league.league.experiments.placement_budget``), match by match until the rank
interval's half-width is at most ``--target`` places, and reports the matches that took beside a
simulation of the same placement (Bradley-Terry outcomes at the member's rating, no match played).
The experiment's ``--budget`` should be at least the larger of the two; entrants near the
population's ends need fewer (their interval is cut short by the last place).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import sys

from arena_league.league.experiments import RANK_TARGET, placement_budget


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--game", default="Crossroads-2T2P-v1")
    parser.add_argument("--population", default="base-v1")
    parser.add_argument("--target", type=float, default=RANK_TARGET, help="rank half-width to reach, in places")
    parser.add_argument("--members", type=int, default=1, help="members nearest the median rating to place")
    parser.add_argument("--max-budget", type=int, default=300, help="matches at most per placement")
    parser.add_argument("--seed", type=int, default=0, help="league seed of the matches and the simulation")
    parser.add_argument("--simulated", type=int, default=200, help="simulated entrants")
    parser.add_argument("--brief", action="store_true", help="leave out each member's half-width after every match")
    args = parser.parse_args(argv)
    try:
        result = placement_budget(args.game, args.population, target=args.target, members=args.members,
                                  max_budget=args.max_budget, seed=args.seed, simulated=args.simulated)
    except ValueError as error:
        parser.error(str(error))
    if args.brief:
        for member in result["members"]:
            member.pop("half_width_by_match")
    json.dump(result, sys.stdout, indent=1)
    print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
