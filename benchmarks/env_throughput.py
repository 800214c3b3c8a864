"""Env steps/s of every game with random actions, beside PettingZoo's butterfly envs, in one run.

Prints one JSON document. Every env runs on one core (the process is pinned to CPU 0), through the
PettingZoo ParallelEnv API with vector observations and social-tree rewards included; actions come
from a pool drawn beforehand from a seeded generator, so no env pays for sampling. The grid games
are also timed as batched numpy engines (many boards stepped at once).

    python benchmarks/env_throughput.py [--seconds 2] [--games Crossroads-2T2P-v1 ...]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

from arena_league.envs import game_spec, list_games, make


def pin_to_one_core() -> str:
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        return "pinned to one core"
    return "not pinned (no sched_setaffinity)"


def steps_per_second(env, action_pool: list[dict], seconds: float, seed: int = 0) -> dict:
    """Step ``env`` with actions cycled from ``action_pool`` for about ``seconds``; resets count."""
    env.reset(seed=seed)
    episodes = 0
    steps = 0
    n_pool = len(action_pool)
    start = time.perf_counter()
    deadline = start + seconds
    while True:
        for _ in range(256):
            actions = action_pool[steps % n_pool]
            env.step({a: actions[a] for a in env.agents})
            steps += 1
            if not env.agents:
                episodes += 1
                env.reset(seed=seed + episodes)
        if time.perf_counter() >= deadline:
            break
    elapsed = time.perf_counter() - start
    return {"steps_per_s": round(steps / elapsed), "steps": steps, "episodes": episodes, "seconds": round(elapsed, 3)}


def ours(game_id: str, action_type: str, seconds: float) -> dict:
    env = make(game_id, action_type=action_type)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    pool = [{a: env.rules.random_action(i, rng) for i, a in enumerate(env.possible_agents)} for _ in range(1024)]
    result = steps_per_second(env, pool, seconds)
    result.update(game_id=game_id, action_type=action_type, agents=env.rules.n_agents, obs_dim=env.rules.obs_dim)
    return result


def pettingzoo_peer(name: str, seconds: float) -> dict:
    from pettingzoo.butterfly import knights_archers_zombies_v11, pistonball_v6

    factory = {"knights_archers_zombies_v11": knights_archers_zombies_v11, "pistonball_v6": pistonball_v6}[name]
    env = factory.parallel_env()
    env.reset(seed=0)
    pool = []
    for k in range(256):
        actions = {}
        for agent in env.possible_agents:
            space = env.action_space(agent)
            space.seed(k * 131 + len(actions))
            actions[agent] = space.sample()
        pool.append(actions)
    result = steps_per_second(env, pool, seconds)
    obs_shape = env.observation_space(env.possible_agents[0]).shape
    result.update(env=name, agents=len(env.possible_agents), obs_shape=list(obs_shape))
    return result


def board_steps(boards, seconds: float, observe: bool = False) -> tuple[int, float]:
    """Step a grid engine's auto-resetting ``boards`` (``GoBangBoards`` or ``SnakeBoards``) with
    uniformly random legal actions from the engine's own generator (sampling included) for about
    ``seconds``; returns (board steps, elapsed seconds). With ``observe``, every seat's observation
    is built every step too."""
    for _ in range(10):  # warm up: fill the boards a little
        boards.step(boards.random_actions())
    steps = 0
    start = time.perf_counter()
    while True:
        for _ in range(16):
            boards.step(boards.random_actions())
            if observe:
                boards.observe()
        steps += 16
        elapsed = time.perf_counter() - start
        if elapsed >= seconds:
            return steps * boards.n_boards, elapsed


def batched_grid(seconds: float) -> list[dict]:
    """Board steps/s of the batched grid engines (random legal actions)."""
    from arena_league.envs.games.gobang import GoBangBoards
    from arena_league.envs.games.snake import SnakeBoards

    n_boards = 4096
    results = []
    for name, boards in (("GoBang", GoBangBoards(n_boards, autoreset=True, seed=0)),
                         ("Snake-4T1P", SnakeBoards(n_boards, n_snakes=4, autoreset=True, seed=0))):
        steps, elapsed = board_steps(boards, seconds)
        results.append({"engine": name, "boards": n_boards, "board_steps_per_s": round(steps / elapsed),
                        "seconds": round(elapsed, 3)})
    return results


def robots(seconds: float) -> dict:
    """The MuJoCo games: physics, rules and env steps/s on one core, and the threaded batch on two
    (``benchmarks/robots_throughput.py``, which also runs on its own)."""
    import robots_throughput

    return robots_throughput.measure(seconds, repeats=1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="time per env (default 2)")
    parser.add_argument("--games", nargs="*", default=None, help="game ids (default: every id)")
    args = parser.parse_args(argv)
    pinning = pin_to_one_core()
    games = args.games or list_games()
    rows = []
    for game_id in games:
        for action_type in game_spec(game_id).rules.action_types:
            rows.append(ours(game_id, action_type, args.seconds))
            print(f"{game_id} {action_type}: {rows[-1]['steps_per_s']} steps/s", file=sys.stderr)
    peers = [pettingzoo_peer(name, args.seconds) for name in ("knights_archers_zombies_v11", "pistonball_v6")]
    fastest_peer = max(p["steps_per_s"] for p in peers)
    physics = [r for r in rows if r["game_id"].split("-")[0] in ("Crossroads", "Soccer", "AirHockey", "FightForFood", "BlowBlow", "Tennis")]  # the 2D ones
    document = {
        "benchmark": "env_throughput",
        "machine": {"python": platform.python_version(), "cpu": platform.processor() or platform.machine(),
                    "affinity": pinning},
        "arena_league": rows,
        "pettingzoo": peers,
        "grid_batched": batched_grid(args.seconds),
        "robots": robots(args.seconds),
        "summary": {
            "slowest_2d_physics_steps_per_s": min((r["steps_per_s"] for r in physics), default=None),
            "fastest_pettingzoo_steps_per_s": fastest_peer,
            "slowest_2d_physics_vs_fastest_pettingzoo": round(min(r["steps_per_s"] for r in physics) / fastest_peer, 1)
            if physics else None,
        },
    }
    print(json.dumps(document, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
