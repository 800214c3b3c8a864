"""Env steps/s of every game with random actions, beside PettingZoo's butterfly envs, in one run.

Prints one JSON document. Every env runs on one core (the process is pinned to CPU 0), through the
PettingZoo ParallelEnv API with vector observations and social-tree rewards included; actions come
from a pool drawn beforehand from a seeded generator, so no env pays for sampling. The grid games
are also timed as batched numpy engines (many boards stepped at once).

    python benchmarks/env_throughput.py [--seconds 2] [--games Crossroads-2T2P-v1 ...]

With ``--against PATH`` (a checkout of another commit) it compares instead: each game id and action
type (by default every id of the 2D physics games) is timed with this tree's ``arena_league`` and
with PATH's, in two worker processes that run this same timing loop and differ only in the
``arena_league`` they import (``PYTHONPATH``). Rounds alternate A B, B A, ... on the same pinned core,
so load from elsewhere on the machine falls on both alike; each side's figure is the median over
``--rounds``, per wall-clock second and per CPU second of the worker. The ratio compares steps per CPU
second, which time spent waiting for a shared core does not dilute. An id is within tolerance when
this tree is no slower than ``(1 - tolerance)`` times PATH; the exit status is 1 when a 2D id is not.
Short runs on a busy machine differ by several percent between identical trees: for a 5% verdict use the
defaults (2 s, 5 rounds: about 12 minutes for the 34 ids and action types) or more rounds.

    python benchmarks/env_throughput.py --against ../before [--rounds 5] [--tolerance 0.05]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from arena_league.envs import game_spec, list_games, make

PHYSICS_2D = ("Crossroads", "Soccer", "AirHockey", "FightForFood", "BlowBlow", "Tennis", "BattleCity", "Fighter")


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
    start_cpu = time.process_time()
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
    cpu = time.process_time() - start_cpu
    # per CPU second too: on a shared machine the wall clock also counts the time other processes held the core
    return {"steps_per_s": round(steps / elapsed), "steps_per_cpu_s": round(steps / cpu), "steps": steps,
            "episodes": episodes, "seconds": round(elapsed, 3)}


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


def board_steps(boards, seconds: float, observe: bool = False) -> tuple[int, float, float]:
    """Step a grid engine's auto-resetting ``boards`` (``GoBangBoards``, ``SnakeBoards``, ``BoomerBoards``)
    with uniformly random legal actions from the engine's own generator (sampling included) for about
    ``seconds``; returns (board steps, elapsed seconds, CPU seconds). With ``observe``, every seat's
    observation is built every step too."""
    for _ in range(10):  # warm up: fill the boards a little
        boards.step(boards.random_actions())
    steps = 0
    start = time.perf_counter()
    start_cpu = time.process_time()
    while True:
        for _ in range(16):
            boards.step(boards.random_actions())
            if observe:
                boards.observe()
        steps += 16
        elapsed = time.perf_counter() - start
        if elapsed >= seconds:
            return steps * boards.n_boards, elapsed, time.process_time() - start_cpu


def batched_grid(seconds: float, games: list[str] | None = None) -> list[dict] | str:
    """Board steps/s of the batched grid engines (random legal actions); with ``games``, only the
    engines of the games those ids name."""
    from arena_league.envs.games.boomer.boards import BoomerBoards
    from arena_league.envs.games.captureflag import CaptureFlagBoards
    from arena_league.envs.games.gobang import GoBangBoards
    from arena_league.envs.games.snake import SnakeBoards

    engines = {"GoBang": lambda: GoBangBoards(4096, autoreset=True, seed=0),
               "Snake-4T1P": lambda: SnakeBoards(4096, n_snakes=4, autoreset=True, seed=0),
               # the board count Boomer's goal is stated at (100,000 board steps/s on one core)
               "Boomer-4T1P": lambda: BoomerBoards(1024, n_seats=4, autoreset=True, seed=0),
               # CaptureFlag's too; these two also with every seat's observation built every step
               **{f"CaptureFlag-2T{p}P": (lambda p=p: CaptureFlagBoards(1024, p, autoreset=True, max_steps=300, seed=0))
                  for p in (1, 2)}}
    if games is not None:
        named = {game_id.split("-")[0] for game_id in games}
        engines = {name: build for name, build in engines.items() if name.split("-")[0] in named}
        if not engines:
            return "skipped: --games names no game with a batched grid engine"
    results = []
    for name, build in engines.items():
        for observe in (False, True) if name.startswith(("CaptureFlag", "Boomer")) else (False,):
            boards = build()
            steps, elapsed, cpu = board_steps(boards, seconds, observe=observe)
            # per CPU second too: on a shared machine the wall clock also counts other processes' turns
            results.append({"engine": name, "boards": boards.n_boards, "observe": observe,
                            "board_steps_per_s": round(steps / elapsed), "board_steps_per_cpu_s": round(steps / cpu),
                            "seconds": round(elapsed, 3)})
    return results


#: Why the Pommerman reference step is not timed where the package cannot be imported.
POMMERMAN_MISSING = ("not installable from the registry: PyPI has no 'pommerman' distribution (pypi.org/simple/"
                     "pommerman/ answers 404); it ships only as the GitHub repository MultiAgentLearning/playground")


def pommerman_peer(seconds: float) -> dict:
    """Env steps/s of Pommerman's own free-for-all (``PommeFFACompetition-v0``, four seats, uniformly
    random actions from a pool drawn beforehand), the reference Boomer's rules follow, where it can
    be imported; otherwise why not."""
    try:
        import pommerman
        from pommerman import agents
    except ImportError:
        return {"env": "PommeFFACompetition-v0", "skipped": POMMERMAN_MISSING}
    env = pommerman.make("PommeFFACompetition-v0", [agents.RandomAgent() for _ in range(4)])
    rng = np.random.default_rng(0)
    pool = rng.integers(6, size=(256, 4)).tolist()
    env.reset()
    steps = episodes = 0
    start = time.perf_counter()
    while time.perf_counter() - start < seconds:
        _, _, done, _ = env.step(pool[steps % len(pool)])
        steps += 1
        if done:
            episodes += 1
            env.reset()
    elapsed = time.perf_counter() - start
    return {"env": "PommeFFACompetition-v0", "steps_per_s": round(steps / elapsed), "steps": steps,
            "episodes": episodes, "seconds": round(elapsed, 3)}


def robots(seconds: float) -> dict:
    """The MuJoCo games: physics, rules and env steps/s on one core, and the threaded batch on two
    (``benchmarks/robots_throughput.py``, which also runs on its own)."""
    import robots_throughput

    return robots_throughput.measure(seconds, repeats=1)


def serve() -> int:
    """Worker of ``--against``: say which ``arena_league`` this process imports, then answer each
    request line ``{"game_id", "action_type", "seconds"}`` with the line :func:`ours` returns."""
    import arena_league

    pin_to_one_core()
    cpu = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    hello = {"arena_league": str(Path(arena_league.__file__).resolve().parent), "cpu": cpu}
    print(json.dumps(hello), flush=True)
    for line in sys.stdin:
        request = json.loads(line)
        result = ours(request["game_id"], request["action_type"], request["seconds"])
        print(json.dumps(result), flush=True)
    return 0


class Worker:
    """A ``--serve`` process of this script whose ``arena_league`` comes from ``tree``."""

    def __init__(self, tree: Path):
        environment = dict(os.environ, PYTHONPATH=str(tree))
        self.process = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--serve"], env=environment,
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        hello = self._answer()
        self.package = Path(hello["arena_league"])
        self.cpu = hello["cpu"]
        if self.package.parent != tree:
            self.close()
            raise SystemExit(f"the worker for {tree} imported arena_league from {self.package}, not from that tree: "
                             f"is {tree} a checkout with an arena_league package?")

    def _answer(self) -> dict:
        line = self.process.stdout.readline()
        if not line:
            raise SystemExit(f"a timing worker stopped (exit status {self.process.wait()}); its error is above")
        return json.loads(line)

    def time(self, game_id: str, action_type: str, seconds: float) -> dict:
        request = {"game_id": game_id, "action_type": action_type, "seconds": seconds}
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        return self._answer()

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait()


def commit_of(tree: Path) -> str | None:
    # a tree need not be a git checkout (an unpacked sdist): then the commit is unknown
    done = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"], check=False, capture_output=True,
                          text=True)
    return done.stdout.strip() or None


def against(other: Path, games: list[str], seconds: float, rounds: int, tolerance: float) -> dict:
    """Steps/s of ``games`` with this tree's ``arena_league`` and with ``other``'s, interleaved."""
    import arena_league

    this = Path(arena_league.__file__).resolve().parents[1]
    load_before = [round(x, 2) for x in os.getloadavg()]
    workers = {"this": Worker(this), "against": Worker(other)}
    try:
        rows = []
        for game_id in games:
            for action_type in game_spec(game_id).rules.action_types:
                timings = {"this": [], "against": []}
                for k in range(rounds):
                    # A B, then B A: neither side always runs first after the other has warmed the core
                    for side in ("this", "against") if k % 2 == 0 else ("against", "this"):
                        timings[side].append(workers[side].time(game_id, action_type, seconds))
                row = {"game_id": game_id, "action_type": action_type}
                for side in ("this", "against"):
                    row[f"{side}_steps_per_s"] = round(statistics.median(t["steps_per_s"] for t in timings[side]))
                    row[f"{side}_steps_per_cpu_s"] = round(statistics.median(t["steps_per_cpu_s"] for t in timings[side]))
                ratio = row["this_steps_per_cpu_s"] / row["against_steps_per_cpu_s"]
                row["ratio"] = round(ratio, 3)
                row["wall_ratio"] = round(row["this_steps_per_s"] / row["against_steps_per_s"], 3)
                for side in ("this", "against"):
                    row[f"{side}_rounds_steps_per_cpu_s"] = [t["steps_per_cpu_s"] for t in timings[side]]
                if game_id.split("-")[0] in PHYSICS_2D:
                    row["within_tolerance"] = ratio >= 1 - tolerance
                rows.append(row)
                print(f"{game_id} {action_type}: {row['this_steps_per_cpu_s']} vs {row['against_steps_per_cpu_s']} "
                      f"steps per CPU second (ratio {row['ratio']})", file=sys.stderr)
    finally:
        for worker in workers.values():
            worker.close()
    outside = [f"{r['game_id']} {r['action_type']}" for r in rows if r.get("within_tolerance") is False]
    return {
        "benchmark": "env_throughput --against",
        "machine": {"python": platform.python_version(), "cpu": platform.processor() or platform.machine(),
                    "affinity": f"both workers pinned to CPU {workers['this'].cpu}",
                    "load_average_before": load_before,
                    "load_average_after": [round(x, 2) for x in os.getloadavg()]},
        "this": {"tree": str(this), "commit": commit_of(this)},
        "against": {"tree": str(other), "commit": commit_of(other)},
        "seconds": seconds,
        "rounds": rounds,
        "tolerance": tolerance,
        "tolerance_rule": "a 2D id is within tolerance when ratio >= 1 - tolerance, ratio being "
                          "this_steps_per_cpu_s / against_steps_per_cpu_s (medians over the rounds)",
        "games": rows,
        "summary": {"lowest_ratio": min((r["ratio"] for r in rows), default=None),
                    "outside_tolerance": outside},
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="time per env (default 2)")
    parser.add_argument("--games", nargs="*", default=None,
                        help="game ids (default: every id; with --against, every id of the 2D physics games)")
    parser.add_argument("--against", type=Path, default=None, metavar="PATH",
                        help="a checkout of another commit: time each id with its arena_league too, interleaved")
    parser.add_argument("--rounds", type=int, default=5, help="with --against: timings per id and side (default 5)")
    parser.add_argument("--tolerance", type=float, default=0.05,
                        help="with --against: how much slower a 2D id may be (default 0.05)")
    parser.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.serve:
        return serve()
    if args.against is not None:
        other = args.against.resolve()
        if not (other / "arena_league").is_dir():
            parser.error(f"--against {args.against}: no arena_league package there; give a checkout of the project")
        if args.rounds < 1:
            parser.error("--rounds must be at least 1")
        pinning = pin_to_one_core()  # the workers inherit this process's one core
        games = args.games or [g for g in list_games() if g.split("-")[0] in PHYSICS_2D]
        document = against(other, games, args.seconds, args.rounds, args.tolerance)
        document["machine"]["affinity"] += f" ({pinning})"
        print(json.dumps(document, indent=2))
        if document["summary"]["outside_tolerance"]:
            print(f"slower than {1 - args.tolerance:.0%} of {other}: "
                  + ", ".join(document["summary"]["outside_tolerance"]), file=sys.stderr)
            return 1
        return 0
    pinning = pin_to_one_core()
    games = args.games or list_games()
    rows = []
    for game_id in games:
        for action_type in game_spec(game_id).rules.action_types:
            rows.append(ours(game_id, action_type, args.seconds))
            print(f"{game_id} {action_type}: {rows[-1]['steps_per_s']} steps/s", file=sys.stderr)
    peers = [pettingzoo_peer(name, args.seconds) for name in ("knights_archers_zombies_v11", "pistonball_v6")]
    fastest_peer = max(p["steps_per_s"] for p in peers)
    physics = [r for r in rows if r["game_id"].split("-")[0] in PHYSICS_2D]
    document = {
        "benchmark": "env_throughput",
        "machine": {"python": platform.python_version(), "cpu": platform.processor() or platform.machine(),
                    "affinity": pinning},
        "arena_league": rows,
        "pettingzoo": peers,
        # the engines' own sections time every game of their kind: with --games, only the ids named
        "grid_batched": batched_grid(args.seconds, args.games),
        "pommerman": pommerman_peer(args.seconds),
        "robots": robots(args.seconds) if args.games is None else "skipped: --games names the ids",
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
