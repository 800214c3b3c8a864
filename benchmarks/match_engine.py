"""Matches/s and env steps/s of the batched match engine beside a naive one-match-at-a-time loop.

Prints one JSON document. For each game, a population of 100 distinct MLP agents (the ``mlp``
family, hidden (64, 64), tanh, each with its own seeded random weights) plays the first matches of
a round robin (least-played pairs first, so every agent is in play). Both sides play the same match
specs with the same agents:

* ``engine``: :class:`arena_league.matchmaking.LockstepRunner` with ``--batch-size`` matches in
  flight; the 100 agents stack into one bundle, so each step is one batched forward for every
  acting seat of every match. It steps the game rules directly (results need no social-tree
  rewards), GoBang's matches all at once on its whole-array engine;
* ``engine_env_path``: the same runner stepping one env per match through the env's array API
  (rewards computed), as the naive loop does, on the first ``--env-path-matches``: what batching
  the policy calls alone brings;
* ``engine_sandboxed``: the same specs with the same 100 agents as *submitted* agents, as a league
  worker plays them: saved as arena-policy folders, referenced as sandboxed agents and played with
  ``play_matches``, which runs the lockstep loop inside the inference sandbox's child process
  (memory limit, time budget per call, each call marked) while this process watches; the child is
  started and loaded before the timing. ``sandbox_cost`` is the share of matches per second the
  sandbox costs against ``engine``;
* ``naive``: one match at a time through the env's array API, one forward per seat per step
  (each agent its own torch module, no batching), uniforms drawn from the same per-match
  generators; for turn-based games also ``naive_acting_seat_only``, asking only the seat to move.

All run on one core (the process is pinned before the sandbox's child is forked, so the child
shares that core, and torch uses one thread), and their results are compared match by match. The estimate of a full round robin of 100 agents at 10 matches per pair
(4950 pairs, 49,500 matches) divides that count by each side's measured matches/s.

    python benchmarks/match_engine.py [--agents 100] [--matches N] [--naive-matches 24] [--batch-size N] [--repeats 3]
                                      [--games Crossroads-2T2P-v1 ...]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from arena_league.envs import make
from arena_league.matchmaking import (
    AgentRef,
    LockstepRunner,
    MatchSpec,
    action_spec_of,
    play_matches,
    round_robin,
    specs_for_seatings,
)
from arena_league.matchmaking.specs import MatchResult
from arena_league.policies.architecture import Architecture
from arena_league.policies.artifacts import save_arena_policy
from arena_league.policies.families import TorchPolicy

GAMES = ("Crossroads-2T2P-v1", "GoBang-2T1P-v1")
#: Per game: matches the engine plays, and matches in flight (the setting that ran fastest on the
#: 2-core development machine: 256 pymunk spaces in flight fall out of the CPU caches, while GoBang's
#: whole-array engine and the stacked forward want every agent present in each call).
DEFAULTS = {"Crossroads-2T2P-v1": (256, 64), "GoBang-2T1P-v1": (2048, 1024)}


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


def naive_play(spec: MatchSpec, policies: dict[str, TorchPolicy], acting_only: bool = False) -> MatchResult:
    """One match, one forward per seat per step, no batching (the same seeds as the engine). With
    ``acting_only``, only the seats whose action the rules take (the engine's rule) are asked."""
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
        if not acting_only:
            seats = range(n)
        elif rules.turn_based:
            seats = [rules.current_player()]
        else:
            seats = np.flatnonzero(rules.measures.active)
        actions = np.zeros(n, dtype=np.int64)
        for seat in seats:
            row = slice(seat, seat + 1)
            action, _ = seat_policies[seat].act(obs[row], uniforms[row], None if mask is None else mask[row])
            actions[seat] = action[0]
        obs, _, terminated, truncated = env.step_arrays(actions)
        done = terminated or truncated
    return MatchResult.from_team_result(spec, rules.team_of, env.team_result(), env.step_count)


def timed(play, repeats: int) -> tuple[list[MatchResult], dict]:
    """Runs ``play()`` ``repeats`` times; the figures are those of the fastest run (the machine is
    shared, so slower runs measure the neighbours)."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        results = play()
        times.append(time.perf_counter() - start)
    best = min(times)
    steps = sum(r.steps for r in results)
    return results, {"matches": len(results), "env_steps": steps, "seconds": round(best, 3),
                     "seconds_all_runs": [round(t, 3) for t in times],
                     "matches_per_s": round(len(results) / best, 2), "env_steps_per_s": round(steps / best)}


def measure(game_id: str, n_agents: int, n_matches: int, n_naive: int, n_env_path: int, batch_size: int,
            repeats: int) -> dict:
    policies = population(game_id, n_agents)
    seatings = round_robin(list(policies), 1, limit=n_matches)
    specs = specs_for_seatings(game_id, seatings, league_seed=2020)
    naive_specs = specs[:n_naive]
    turn_based = make(game_id).rules.turn_based

    runner = LockstepRunner(game_id, policies, batch_size=batch_size)
    engine_results, engine = timed(lambda: runner.play(specs), repeats)
    engine.update(batch_size=batch_size, path=runner.stepping_path())
    figures = {"engine": engine}
    # the same runner stepping one env per match through the env API (rewards computed), as the
    # naive loop does: what batching the policies alone brings
    env_path = LockstepRunner(game_id, policies, batch_size=min(batch_size, 64), path="env")
    env_specs = specs[:n_env_path]
    env_results, figures["engine_env_path"] = timed(lambda: env_path.play(env_specs), repeats)
    figures["engine_env_path"]["batch_size"] = env_path.batch_size
    assert env_results == engine_results[:n_env_path]
    with tempfile.TemporaryDirectory() as folder:
        refs = {key: AgentRef("arena-policy", str(save_arena_policy(Path(folder) / key, policy.architecture,
                                                                     policy.parameters(), game_id, name=key)),
                              game_id, sandboxed=True)
                for key, policy in policies.items()}
        play_matches(specs[:1], refs, batch_size=batch_size)  # start the child and load the agents
        sandboxed_results, figures["engine_sandboxed"] = timed(
            lambda: play_matches(specs, refs, batch_size=batch_size), repeats)
    figures["engine_sandboxed"]["batch_size"] = batch_size
    assert sandboxed_results == engine_results
    naive_results, figures["naive"] = timed(lambda: [naive_play(s, policies) for s in naive_specs], repeats)
    if turn_based:
        acting_results, figures["naive_acting_seat_only"] = timed(
            lambda: [naive_play(s, policies, acting_only=True) for s in naive_specs], repeats)
        assert acting_results == naive_results
    round_robin_matches = n_agents * (n_agents - 1) // 2 * 10
    return {
        "game_id": game_id,
        "agents": n_agents,
        "agents_in_play": len({key for spec in specs for key in spec.seats}),
        "mean_match_steps": round(engine["env_steps"] / engine["matches"], 1),
        **figures,
        "speedup_vs_naive": {name: round(engine["env_steps_per_s"] / f["env_steps_per_s"], 2)
                             for name, f in figures.items() if name.startswith("naive")},
        "results_identical_to_naive": engine_results[:n_naive] == naive_results,
        "results_identical_sandboxed": True,  # asserted above
        "sandbox_cost": round(1 - figures["engine_sandboxed"]["matches_per_s"] / engine["matches_per_s"], 3),
        "round_robin_100x100_at_10_per_pair": {
            "matches": round_robin_matches,
            "engine_hours": round(round_robin_matches / engine["matches_per_s"] / 3600, 2),
            "naive_hours": round(round_robin_matches / figures["naive"]["matches_per_s"] / 3600, 2),
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--agents", type=int, default=100)
    parser.add_argument("--matches", type=int, help="matches the engine plays per game (default: per game)")
    parser.add_argument("--naive-matches", type=int, default=24, help="matches the naive loop plays per game")
    parser.add_argument("--env-path-matches", type=int, default=128,
                        help="matches the engine plays on its env path per game")
    parser.add_argument("--batch-size", type=int, help="matches in flight (default: per game)")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each side; the fastest counts")
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
        "games": [measure(g, args.agents, args.matches or DEFAULTS.get(g, (256, 64))[0], args.naive_matches,
                          args.env_path_matches, args.batch_size or DEFAULTS.get(g, (256, 64))[1], args.repeats)
                  for g in args.games],
    }
    json.dump(report, sys.stdout, indent=2)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
