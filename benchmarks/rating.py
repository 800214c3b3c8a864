"""Rating engine benchmark: prints one JSON document on stdout.

    PYTHONPATH=. python3 benchmarks/rating.py [--seed 0] [--repeats 5] [--quick]

Measures, on a seeded simulated league:
- Bradley-Terry plus 100 bootstrap rounds on 100 agents and 124,000 matches (target <= 1 s);
- Nash averaging on 200 agents (target <= 1 s);
- alpha-Rank on 100 agents, ours against OpenSpiel's ``open_spiel.python.egt.alpharank`` in the
  same run (aim: >= 10x faster), with the largest difference between the two distributions;
- entrant placement in simulation: matches to a 95% rank interval of +-3 places, adaptive against
  uniform opponent choice, on 100 base agents over 400 Elo (the issue's setting) and over 1600 Elo.

Timings are the median of ``--repeats`` runs (minimum also given), with BLAS limited to one thread
(unless OPENBLAS_NUM_THREADS / OMP_NUM_THREADS are set) so that both implementations are measured
alike on a shared machine.
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
import warnings

import numpy as np

from arena_league.rating import (
    PairCounts,
    alpha_rank,
    bootstrap_ratings,
    elo_online,
    nash_averaging,
    simulate_placement,
)


def timed(function, repeats: int) -> tuple[dict, object]:
    """Median and minimum wall time of ``repeats`` calls, the median CPU time of this process (what
    a quiet machine's wall time would be, single-threaded), and the last result."""
    seconds, cpu = [], []
    result = None
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = function()
        seconds.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return {"seconds": round(float(np.median(seconds)), 5), "seconds_min": round(min(seconds), 5),
            "cpu_seconds": round(float(np.median(cpu)), 5)}, result


def simulate_league(rng: np.random.Generator, ratings: np.ndarray, n_matches: int, draw_nu: float = 0.0,
                    cyclic: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random pairings with Bradley-Terry outcomes (Elo scale), draws by Davidson's model with
    parameter ``draw_nu``, and an optional antisymmetric cyclic term (in logits)."""
    n = ratings.size
    first = rng.integers(n, size=n_matches)
    second = (first + rng.integers(1, n, size=n_matches)) % n
    logit = (ratings[first] - ratings[second]) * np.log(10.0) / 400.0
    if cyclic is not None:
        logit = logit + cyclic[first, second]
    # P(first wins) : P(draw) : P(second wins) = e^(d/2) : nu : e^(-d/2)
    weights = np.stack([np.exp(0.5 * logit), np.full(n_matches, draw_nu), np.exp(-0.5 * logit)], axis=1)
    u = rng.random(n_matches) * weights.sum(axis=1)
    outcome = (u[:, None] > np.cumsum(weights, axis=1)).sum(axis=1)
    return first, second, np.array([1.0, 0.5, 0.0])[np.minimum(outcome, 2)]


def bench_bradley_terry(rng: np.random.Generator, repeats: int) -> dict:
    n_agents, n_matches, rounds = 100, 124_000, 100
    truth = rng.normal(1000.0, 200.0, n_agents)
    first, second, score = simulate_league(rng, truth, n_matches, draw_nu=0.2)
    counts_time, counts = timed(lambda: PairCounts.from_results(first, second, score, n_agents), repeats)
    half_time, half = timed(lambda: bootstrap_ratings(counts, rounds=rounds, seed=0), repeats)
    davidson_time, davidson = timed(
        lambda: bootstrap_ratings(counts, rounds=rounds, seed=0, draw_model="davidson"), repeats)
    elo_time, _ = timed(lambda: elo_online(first, second, score, n_agents), max(1, repeats // 2))
    centred = truth - truth.mean() + 1000.0
    return {
        "agents": n_agents, "matches": n_matches, "bootstrap_rounds": rounds, "target_seconds": 1.0,
        "count_matrix": counts_time,
        "fit_plus_bootstrap_half_draws": half_time,
        "fit_plus_bootstrap_davidson": davidson_time,
        "draws": "Davidson model, nu = 0.2 (draw share between equals 9%)",
        "median_ci_width_elo": round(float(np.median(half.upper - half.lower)), 2),
        "share_of_true_ratings_inside_ci_davidson": round(
            float(np.mean((davidson.lower <= centred) & (centred <= davidson.upper))), 3),
        "share_of_true_ratings_inside_ci_half_draws": round(
            float(np.mean((half.lower <= centred) & (centred <= half.upper))), 3),
        "davidson_draw_nu": round(float(davidson.draw_nu), 4),
        "elo_online_reference": elo_time,
    }


def league_meta_game(rng: np.random.Generator, n_agents: int, n_matches: int) -> PairCounts:
    """A league with transitive and cyclic structure, as a population of trained agents shows."""
    truth = rng.normal(1000.0, 200.0, n_agents)
    noise = rng.normal(0.0, 0.5, (n_agents, n_agents))
    first, second, score = simulate_league(rng, truth, n_matches, cyclic=noise - noise.T)
    return PairCounts.from_results(first, second, score, n_agents)


def bench_nash(rng: np.random.Generator, repeats: int) -> dict:
    n_agents = 200
    counts = league_meta_game(rng, n_agents, 400_000)
    A = counts.logit_payoff(pseudo_count=0.5)
    stats, (p, scores) = timed(lambda: nash_averaging(A), repeats)
    # the hard case: a purely random antisymmetric game, whose equilibrium keeps ~half the agents
    X = rng.normal(size=(n_agents, n_agents))
    random_stats, (p_random, _) = timed(lambda: nash_averaging(X - X.T), repeats)
    return {"agents": n_agents, "target_seconds": 1.0,
            "league": {"meta_game": "logit win rates, 400,000 matches, transitive + cyclic", **stats,
                       "support_size": int((p > 1e-9).sum()), "max_score": float(scores.max())},
            "random_antisymmetric": {**random_stats, "support_size": int((p_random > 1e-9).sum())}}


def bench_alpha_rank(rng: np.random.Generator, repeats: int) -> dict:
    n_agents, alpha, m = 100, 10.0, 50
    counts = league_meta_game(rng, n_agents, 124_000)
    win_rate = counts.win_rate(pseudo_count=0.5)
    ours_stats, ours = timed(lambda: alpha_rank([win_rate], alpha=alpha, m=m), repeats)
    result = {"agents": n_agents, "alpha": alpha, "m": m, "payoff": "win rate (pseudo-count 0.5)",
              "ours": ours_stats}
    try:
        from open_spiel.python.egt import alpharank as openspiel_alpharank
    except ImportError as error:
        result["openspiel"] = f"not available: {error}"
        return result

    def openspiel():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return openspiel_alpharank.compute([win_rate], alpha=alpha, m=m)[2]

    theirs_stats, theirs = timed(openspiel, max(1, min(repeats, 3)))
    result["openspiel"] = theirs_stats
    result["speedup"] = round(theirs_stats["seconds"] / ours_stats["seconds"], 1)
    result["max_abs_difference"] = float(np.abs(ours - theirs).max())
    return result


def bench_placement(rng: np.random.Generator, quick: bool) -> dict:
    entrants = 12 if quick else 40
    result = {"target_half_width_places": 3, "level": 0.95, "entrants": entrants, "settings": []}
    for spread, budget in ((400.0, 8000), (1600.0, 2000)):
        base = np.linspace(1000.0 - spread / 2, 1000.0 + spread / 2, 100)
        truth = rng.uniform(base.min(), base.max(), entrants)
        setting = {"base_agents": 100, "base_spread_elo": spread, "budget": budget}
        for chooser in ("adaptive", "uniform"):
            start = time.perf_counter()
            sim = simulate_placement(base, truth, chooser=chooser, budget=budget, seed=1)
            after_200 = simulate_placement(base, truth, chooser=chooser, target_half_width=-1, budget=200, seed=2)
            setting[chooser] = {
                "median_matches": float(np.median(sim.matches)),
                "quartiles_matches": [float(q) for q in np.percentile(sim.matches, [25, 75])],
                "reached_target": float(sim.reached.mean()),
                "rank_interval_coverage": float(sim.covered.mean()),
                "median_half_width_after_200_matches": float(np.median(after_200.final_half_width)),
                "simulation_seconds": round(time.perf_counter() - start, 2),
            }
        setting["adaptive_over_uniform"] = round(
            setting["adaptive"]["median_matches"] / setting["uniform"]["median_matches"], 3)
        result["settings"].append(setting)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="fewer placement entrants")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    report = {
        "benchmark": "rating",
        "command": "PYTHONPATH=. python3 benchmarks/rating.py " + " ".join(sys.argv[1:]),
        "seed": args.seed,
        "machine": {"python": platform.python_version(), "numpy": np.__version__, "cpus": os.cpu_count(),
                    "blas_threads": os.environ["OPENBLAS_NUM_THREADS"],
                    "load_average_1min": os.getloadavg()[0]},
    }
    report["bradley_terry"] = bench_bradley_terry(rng, args.repeats)
    report["nash_averaging"] = bench_nash(rng, args.repeats)
    report["alpha_rank"] = bench_alpha_rank(rng, args.repeats)
    report["placement"] = bench_placement(rng, args.quick)
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
