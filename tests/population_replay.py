"""Outcomes of a sample of every shipped population's round robin, to show that a change of the engines or of
the population build changes no match a population's ratings rest on.

A shipped population keeps its members and their ratings, not its matches. For each population under
``checkpoints/``, 200 matches are drawn (by a generator seeded from the population's folder name) from the round
robin among its members and the scripted ``random`` and ``heuristic`` agents, scheduled as a build schedules
one (:func:`arena_league.matchmaking.round_robin` over the members in ``population.json`` order and the two
references, the build's matches per pair, match ids in schedule order, the build's league seed), and played
in one batch on the match engine. Each match's seating, id, seed, team 0's score and length go into
``tests/data/population_replay.json``, recorded at the commit before the 2D games moved onto one engine;
``test_population_replay.py`` plays them again.

    python tests/population_replay.py [--populations Crossroads-2T2P-v1/base-v1 ...] [--write]

A newly shipped population has no "before": record it with ``--populations GAME/NAME --write``.
"""

from __future__ import annotations

import argparse
import json
import sys
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.league.population.build import member_policy
from arena_league.matchmaking import play_matches, round_robin, specs_for_seatings
from arena_league.policies.scripted import scripted_policy
from arena_league.policies.threads import torch_threads

CHECKPOINTS = Path(__file__).resolve().parents[1] / "checkpoints"
RECORDED = Path(__file__).parent / "data" / "population_replay.json"
SAMPLED_MATCHES = 200
#: The scripted agents every build's round robin adds to its candidates.
REFERENCES = ("random", "heuristic")


def shipped_populations() -> list[str]:
    """``GAME/NAME`` of every population under ``checkpoints/``."""
    return sorted(f"{p.parent.parent.name}/{p.parent.name}" for p in CHECKPOINTS.glob("*/*/population.json"))


def manifest_of(population: str) -> dict[str, Any]:
    return json.loads((CHECKPOINTS / population / "population.json").read_text())


def member_key(name: str) -> str:
    """A member's key within its build: ``base-v1.pbt-s0-pbt2-20480@Game-2T2P-v1`` -> ``pbt-s0-pbt2-20480``."""
    return name.split(".", 1)[1].rsplit("@", 1)[0]


def sample(population: str) -> dict[str, Any]:
    """The population's agents and ``SAMPLED_MATCHES`` matches ``[team 0 agent, team 1 agent, match id]``
    (agents as indices into the agents) of its round robin, in match-id order."""
    manifest = manifest_of(population)
    build = manifest["provenance"]["build"]
    agents = [member_key(m["name"]) for m in manifest["members"]] + list(REFERENCES)
    if len(set(agents)) != len(agents):
        raise ValueError(f"{population}: a member's key is also a reference's ({REFERENCES})")
    seatings = round_robin(agents, build["matches_per_pair"])
    rng = np.random.default_rng(zlib.crc32(population.encode()))
    chosen = np.sort(rng.choice(len(seatings), size=min(SAMPLED_MATCHES, len(seatings)), replace=False))
    index = {a: i for i, a in enumerate(agents)}
    return {"game_id": manifest["game_id"], "league_seed": build["seed"], "agents": agents,
            "matches": [[index[seatings[k][0]], index[seatings[k][1]], int(k)] for k in chosen]}


def play(population: str, drawn: dict[str, Any]) -> list[list[Any]]:
    """``[match seed, team 0's score, steps]`` of each of ``drawn["matches"]``, played on the match engine."""
    folder = CHECKPOINTS / population
    manifest = manifest_of(population)
    game = drawn["game_id"]
    entries = {member_key(m["name"]): m for m in manifest["members"]}
    agents = drawn["agents"]
    used = sorted({agents[i] for a, b, _ in drawn["matches"] for i in (a, b)})
    policies = {key: scripted_policy(key, game) if key in REFERENCES else member_policy(folder, entries[key], game)
                for key in used}
    specs = [specs_for_seatings(game, [(agents[a], agents[b])], drawn["league_seed"], match_id)[0]
             for a, b, match_id in drawn["matches"]]
    with torch_threads(1):  # as a build plays its round robin: one thread, the whole sample in one batch
        results = play_matches(specs, policies, batch_size=len(specs))
    return [[r.seed, float(r.scores[r.teams.index(0)]), int(r.steps)] for r in results]


def record(population: str) -> dict[str, Any]:
    drawn = sample(population)
    outcomes = play(population, drawn)
    drawn["matches"] = [match + outcome for match, outcome in zip(drawn["matches"], outcomes)]
    return drawn


def dumps(document: dict[str, dict[str, Any]]) -> str:
    """JSON with one line per match, so that a changed outcome reads as a one-line diff."""
    parts = []
    for population, entry in document.items():
        head = {k: v for k, v in entry.items() if k != "matches"}
        lines = ",\n".join(f"   {json.dumps(m)}" for m in entry["matches"])
        parts.append(f" {json.dumps(population)}: {json.dumps(head)[:-1]}, \"matches\": [\n{lines}\n ]}}")
    return "{\n" + ",\n".join(parts) + "\n}\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--populations", nargs="*", default=None, help="GAME/NAME folders (default: every one)")
    parser.add_argument("--write", action="store_true",
                        help=f"put these populations' records into {RECORDED.name} instead of printing them")
    args = parser.parse_args(argv)
    document = {}
    for population in args.populations or shipped_populations():
        document[population] = record(population)
        print(f"{population}: {len(document[population]['matches'])} matches", file=sys.stderr)
    if args.write:  # the named populations replace theirs; the others' records stay as they were
        kept = json.loads(RECORDED.read_text()) if RECORDED.exists() else {}
        RECORDED.write_text(dumps(dict(sorted((kept | document).items()))))
    else:
        sys.stdout.write(dumps(document))
    return 0


if __name__ == "__main__":
    sys.exit(main())
