"""The look-alike name check over a large league: how long one submission's name check takes.

Registers ``--agents`` agent names in one game (reserved rows: no artifacts needed), then times
:func:`arena_league.league.versions.version_name` for new names: the first check of the process
(every name's UTS #39 skeleton computed), warm checks, and a check after one more agent was
added (the per-game index brought up to date by that row alone). Prints one JSON document.

    PYTHONPATH=. python benchmarks/name_check.py [--agents 10000]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from arena_league import registry as reg
from arena_league.league import open_home
from arena_league.league.home import register_game
from arena_league.league.names import skeleton
from arena_league.league.versions import version_name

GAME = "GoBang-2T1P-v1"


def timed_check(league: reg.League, name: str) -> dict[str, float | int]:
    computed = skeleton.cache_info().misses
    start = time.perf_counter()
    with league.reading() as session:
        version_name(session, name, GAME, "mallory")
    return {"ms": round(1000 * (time.perf_counter() - start), 1), "skeletons_computed": skeleton.cache_info().misses
            - computed}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agents", type=int, default=10_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp, open_home(Path(tmp) / "home") as league:
        register_game(league, GAME)
        with league.transaction() as session:
            for i in range(args.agents):
                reg.create_agent(session, f"agent-{i:05d}", GAME, "submission", owner=f"o{i % 50}", reserved=True)
        first = timed_check(league, "new-name-1")
        warm = [timed_check(league, f"new-name-{i}") for i in range(2, 7)]
        with league.transaction() as session:
            reg.create_agent(session, "added-later", GAME, "submission", owner="x", reserved=True)
        after_one_more = timed_check(league, "new-name-7")
    print(json.dumps({"agents": args.agents, "first": first, "warm": warm, "after_one_more": after_one_more,
                      "load_average": os.getloadavg()[0]}, indent=1))


if __name__ == "__main__":
    main()
