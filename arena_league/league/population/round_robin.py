"""The round robin of a population build: its schedule, played and saved chunk by chunk (in worker
processes, as Ray tasks, or here), and the matches any stage plays on the batched engine."""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.league.population.loading import member_policy
from arena_league.league.population.options import BuildProgress
from arena_league.league.population.processes import run_tasks
from arena_league.league.population.records import REFERENCES, BuildReport, Candidate, write_json
from arena_league.policies.families import TorchPolicy
from arena_league.policies.threads import torch_threads

#: Matches per saved chunk of the round robin (the unit an interrupted build replays at most).
CHUNK_MATCHES = 512


def best_against_heuristic(folder: str | Path, matches: int, seed: int) -> tuple[str, int, int]:
    """(best member's name, wins, draws) of a frozen population's best member (highest frozen
    rating) against the scripted heuristic in ``matches`` fresh matches, seats alternating, match
    ids from 0 under league seed ``seed``: the population's headroom (:data:`HEADROOM`), replayed."""
    from arena_league.policies.scripted import scripted_policy

    manifest = json.loads((Path(folder) / "population.json").read_text())
    game = manifest["game_id"]
    best = max(manifest["members"], key=lambda m: m["metadata"]["rating"])
    policies = {"best": member_policy(folder, best, game), "heuristic": scripted_policy("heuristic", game)}
    seatings = [("best", "heuristic") if k % 2 == 0 else ("heuristic", "best") for k in range(matches)]
    return best["name"], *tally(play_seatings(game, seatings, policies, seed, 0, min(256, matches)))


def round_robin_policies(game_id: str, candidates: list[Candidate]) -> dict[str, Any]:
    """The policy of every candidate and of the scripted references, by key."""
    from arena_league.policies.scripted import scripted_policy

    policies: dict[str, Any] = {c.key: scripted_policy(c.scripted, game_id) if c.scripted else
                                TorchPolicy(c.architecture, c.params, name=c.key) for c in candidates}
    for ref in REFERENCES:
        policies[ref] = scripted_policy(ref, game_id)
    return policies


class Schedule:
    """The round robin of a build, played and saved chunk by chunk."""

    def __init__(self, game_id: str, keys: list[str], matches_per_pair: int, seed: int) -> None:
        from arena_league.matchmaking import round_robin

        self.game_id = game_id
        self.keys = keys
        self.index = {k: i for i, k in enumerate(keys)}
        self.seed = seed
        from arena_league.envs import game_spec

        self.seatings = round_robin(keys, matches_per_pair)
        schedule = {"game": game_id, "agents": keys, "matches_per_pair": matches_per_pair, "seed": seed}
        if game_spec(game_id).paired:  # a chunk of pairs is not a chunk of single matches
            schedule["paired"] = True
        identity = json.dumps(schedule)
        self.digest = hashlib.sha256(identity.encode()).hexdigest()[:16]

    def play(self, work: Path, policies: Mapping[str, Any], batch_size: int, report: BuildReport,
             progress: BuildProgress | None, say: Callable[[str], None], processes: int = 1,
             candidates: Sequence[Candidate] = (), backend: str = "local", address: str | None = None) -> np.ndarray:
        """``float64[matches, 3]``: team 0's agent index, team 1's, team 0's score. With
        ``processes`` above 1, the unplayed chunks are played in that many worker processes, with
        ``backend`` ``"ray"`` each as a Ray task of one CPU (on the cluster at ``address``); each
        worker holds ``candidates``. Every chunk is saved here, as it comes back."""
        folder = work / "matches" / self.digest
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "schedule.json").write_text(json.dumps({"game_id": self.game_id, "agents": self.keys,
                                                          "matches": len(self.seatings), "seed": self.seed}))
        n_chunks = math.ceil(len(self.seatings) / CHUNK_MATCHES)
        say(f"round robin: {len(self.keys)} agents, {len(self.seatings)} matches in {n_chunks} chunks")
        chunks = [(folder / f"chunk-{chunk:06d}.json", chunk * CHUNK_MATCHES) for chunk in range(n_chunks)]
        todo = [(path, first) for path, first in chunks if not path.exists()]
        saved = {path for path, _ in chunks} - {path for path, _ in todo}
        done = len(self.seatings) - sum(len(self.seatings[first: first + CHUNK_MATCHES]) for _, first in todo)

        def save(path: Path, first: int, scores: list[float]) -> None:
            nonlocal done
            write_json(path, {"first_match_id": first, "seatings": self.seatings[first: first + CHUNK_MATCHES],
                               "scores": scores})
            report.matches_played += len(scores)
            done += len(scores)
            if progress:
                progress("round_robin", done, len(self.seatings))

        on_ray = backend == "ray"
        if todo and (on_ray or (processes > 1 and len(todo) > 1)):
            say(f"playing {len(todo)} chunks " + ("as Ray tasks" if on_ray else
                                                  f"in {min(processes, len(todo))} processes"))
            run_tasks({(path, first): (_play_in_worker, (self.game_id, self.seatings[first: first + CHUNK_MATCHES],
                                                         self.seed, first, batch_size)) for path, first in todo},
                      lambda key, scores: save(*key, scores), backend="ray" if on_ray else "process",
                      processes=processes, address=address, initializer=_hold_policies,
                      initargs=(self.game_id, list(candidates)))
        else:
            for path, first in todo:
                save(path, first, play_seatings(self.game_id, self.seatings[first: first + CHUNK_MATCHES], policies,
                                                self.seed, first, batch_size))
        rows = []
        for path, first in chunks:
            seatings = self.seatings[first: first + CHUNK_MATCHES]
            scores = json.loads(path.read_text())["scores"]
            if path in saved:
                report.matches_reused += len(scores)
            rows += [(self.index[a], self.index[b], s) for (a, b), s in zip(seatings, scores)]
        return np.asarray(rows, dtype=np.float64).reshape(-1, 3)


#: The policies of a round-robin worker process (:func:`_hold_policies`).
_WORKER_POLICIES: dict[str, Any] = {}


def _hold_policies(game_id: str, candidates: list[Candidate]) -> None:
    _WORKER_POLICIES.update(round_robin_policies(game_id, candidates))


def _play_in_worker(game_id: str, seatings: list[Any], seed: int, first_match_id: int, batch_size: int) -> list[float]:
    return play_seatings(game_id, seatings, _WORKER_POLICIES, seed, first_match_id, batch_size)


def play_seatings(game_id: str, seatings: Sequence[Sequence[str]], policies: Mapping[str, Any], seed: int,
                  first_match_id: int, batch_size: int = 256) -> list[float]:
    """Team 0's score (1 win, 0.5 draw, 0 loss) in each match of ``seatings`` (team 0's agent,
    team 1's), played in process on the batched engine with match ids from ``first_match_id``; in a
    game played in pairs each seating is a pair, and its score the pair's."""
    from arena_league.matchmaking import play_matches, specs_for_seatings

    with torch_threads(1):  # many small batched forwards: one thread beats OpenMP's hand-offs
        specs = specs_for_seatings(game_id, [tuple(s) for s in seatings], seed, first_match_id)
        used = {k for s in seatings for k in s}
        results = play_matches(specs, {k: policies[k] for k in used}, batch_size=batch_size)
    return [float(r.scores[r.teams.index(0)]) for r in results]


def tally(scores: Sequence[float]) -> tuple[int, int]:
    """(wins, draws) of the agent seated first in the even matches and second in the odd ones, from
    team 0's scores."""
    own = [s if k % 2 == 0 else 1.0 - s for k, s in enumerate(scores)]
    return sum(s == 1.0 for s in own), sum(s == 0.5 for s in own)
