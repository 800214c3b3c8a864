"""Matches/s and env steps/s of the batched match engine beside a naive one-match-at-a-time loop.

Prints one JSON document. For each game, a population of 100 distinct MLP agents (the ``mlp``
family, hidden (64, 64), tanh, each with its own seeded random weights) plays the first matches of
a round robin (least-played pairs first, so every agent is in play). Both sides play the same match
specs with the same agents:

* ``engine``: :class:`arena_league.matchmaking.LockstepRunner` with ``--batch-size`` matches in
  flight; the 100 agents stack into one bundle, so each step is one batched forward for every
  acting seat of every match;
* ``naive``: one match at a time, one forward per acting seat per step (each agent its own torch
  module, no batching), uniforms drawn from the same per-match generators.

Both run on one core (the process is pinned and torch uses one thread), and their results are
compared match by match. The estimate of a full round robin of 100 agents at 10 matches per pair
(4950 pairs, 49,500 matches) divides that count by each side's measured matches/s.

    python benchmarks/match_engine.py [--agents 100] [--matches 256] [--naive-matches 24] [--batch-size 128]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np
import torch

from arena_league.envs import make
from arena_league.matchmaking import (
    LockstepRunner,
    MatchSpec,
    action_spec_of,
    round_robin,
    specs_for_seatings,
)
from arena_league.matchmaking.specs import MatchResult
from arena_league.population.families import Architecture, TorchPolicy

GAMES = ("Crossroads-2T2P-v1", "GoBang-2T1P-v1")


def pin_to_one_core() -> str:
    torch.set_num_threads(1)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        return "pinned to one core, torch with one thread"
    return "not pinned (no sched_setaffinity), torch with one thread"


def population(game_id: str, n_agents: int) -> dict[str, TorchPolicy]:
    """``n_agents`` MLP agents for ``game_id``, agent ``i`` initialised from seed ``i``."""
    spec = action_spec_of(make(game_id))
    arch = Architecture("mlp", spec.obs_dim, spec.action_type, n_actions=spec.n_actions, act_dim=spec.act_dim,
                        hidden=(64, 64))
    return {f"mlp-{i:03d}": TorchPolicy(arch, seed=i, name=f"mlp-{i:03d}") for i in range(n_agents)}


def naive_play(spec: MatchSpec, policies: dict[str, TorchPolicy]) -> MatchResult:
    """One match, one forward per acting seat per step (the same seeds and acting rule as the engine)."""
    env = make(spec.game_id)
    rules = env.rules
    obs = env.reset_arrays(spec.seed)
    rng = spec.seat_rng()
    n = rules.n_agents
    k = policies[spec.seats[0]].spec.uniforms_per_seat
    seat_policies = [policies[key] for key in spec.seats]
    done = False
    while not done:
        uniforms = rng.random((n, k))
        mask = rules.action_mask()
        acting = [rules.current_player()] if rules.turn_based else np.flatnonzero(rules.measures.active)
        actions = np.zeros(n, dtype=np.int64)
        for seat in acting:
            row = slice(seat, seat + 1)
            action, _ = seat_policies[seat].act(obs[row], uniforms[row], None if mask is None else mask[row])
            actions[seat] = action[0]
        obs, _, terminated, truncated = env.step_arrays(actions)
        done = terminated or truncated
    return MatchResult.from_team_result(spec, rules.team_of, env.team_result(), env.step_count)


def measure(game_id: str, n_agents: int, n_matches: int, n_naive: int, batch_size: int) -> dict:
    policies = population(game_id, n_agents)
    seatings = round_robin(list(policies), 1, limit=n_matches)
    specs = specs_for_seatings(game_id, seatings, league_seed=2020)
    agents_in_play = len({key for spec in specs for key in spec.seats})

    runner = LockstepRunner(game_id, policies, batch_size=batch_size)
    start = time.perf_counter()
    engine_results = runner.play(specs)
    engine_s = time.perf_counter() - start
    engine_steps = sum(r.steps for r in engine_results)

    start = time.perf_counter()
    naive_results = [naive_play(spec, policies) for spec in specs[:n_naive]]
    naive_s = time.perf_counter() - start
    naive_steps = sum(r.steps for r in naive_results)

    engine = {"matches": len(engine_results), "env_steps": engine_steps, "seconds": round(engine_s, 3),
              "matches_per_s": round(len(engine_results) / engine_s, 2),
              "env_steps_per_s": round(engine_steps / engine_s), "batch_size": batch_size}
    naive = {"matches": len(naive_results), "env_steps": naive_steps, "seconds": round(naive_s, 3),
             "matches_per_s": round(len(naive_results) / naive_s, 2),
             "env_steps_per_s": round(naive_steps / naive_s)}
    round_robin_matches = n_agents * (n_agents - 1) // 2 * 10
    return {
        "game_id": game_id,
        "agents": n_agents,
        "agents_in_play": agents_in_play,
        "mean_match_steps": round(engine_steps / len(engine_results), 1),
        "engine": engine,
        "naive": naive,
        "speedup_env_steps_per_s": round(engine["env_steps_per_s"] / naive["env_steps_per_s"], 2),
        "results_identical_to_naive": [r for r in engine_results[:n_naive]] == naive_results,
        "round_robin_100x100_at_10_per_pair": {
            "matches": round_robin_matches,
            "engine_hours": round(round_robin_matches / engine["matches_per_s"] / 3600, 2),
            "naive_hours": round(round_robin_matches / naive["matches_per_s"] / 3600, 2),
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--agents", type=int, default=100)
    parser.add_argument("--matches", type=int, default=256, help="matches the engine plays per game")
    parser.add_argument("--naive-matches", type=int, default=24, help="matches the naive loop plays per game")
    parser.add_argument("--batch-size", type=int, default=128)
    parser.add_argument("--games", nargs="*", default=list(GAMES))
    args = parser.parse_args()
    pinning = pin_to_one_core()
    report = {
        "benchmark": "match_engine",
        "python": platform.python_version(),
        "torch": torch.__version__,
        "machine": platform.machine(),
        "cpu_setting": pinning,
        "policy": "mlp (64, 64) tanh, float64 compute (the population default), sampled with the engine's uniforms",
        "games": [measure(g, args.agents, args.matches, args.naive_matches, args.batch_size) for g in args.games],
    }
    json.dump(report, sys.stdout, indent=2)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
