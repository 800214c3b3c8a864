"""Headroom of every shipped base population: its best member against the scripted heuristic.

For each folder under ``checkpoints/<game>/<name>/`` the best member (highest frozen rating) plays
the game's ``scripted:heuristic`` in ``--matches`` fresh matches, seats alternating, on the batched
engine; the JSON gives its wins, draws and losses, its win rate (the population table of ``docs/populations.md``) and
the figure the build recorded, where it did. A population has headroom when the win rate is at
least 0.6 (``build.HEADROOM``)::

    python benchmarks/population_headroom.py [--matches 200] [--seed 0] [FOLDER ...]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from arena_league.league.population.build import HEADROOM, best_against_heuristic
from arena_league.league.populations import SHIPPED_POPULATIONS


def headroom(folder: Path, matches: int, seed: int) -> dict:
    manifest = json.loads((folder / "population.json").read_text())
    started = time.perf_counter()
    best, wins, draws = best_against_heuristic(folder, matches, seed)
    recorded = manifest["provenance"]["figures"].get(HEADROOM[0])
    return {"game": manifest["game_id"], "population": manifest["name"], "best": best, "matches": matches,
            "wins": wins, "draws": draws, "losses": matches - wins - draws, "win_rate": round(wins / matches, 4),
            "headroom": wins / matches >= HEADROOM[2], "recorded_win_rate": recorded,
            "seconds": round(time.perf_counter() - started, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="*", type=Path, help="population folders (default: every shipped one)")
    parser.add_argument("--matches", type=int, default=200, help="matches per population (default 200)")
    parser.add_argument("--seed", type=int, default=0, help="the matches' league seed (default 0)")
    args = parser.parse_args()
    folders = args.folders or sorted(p.parent for p in SHIPPED_POPULATIONS.glob("*/*/population.json"))
    print(json.dumps([headroom(f, args.matches, args.seed) for f in folders], indent=1))


if __name__ == "__main__":
    main()
