"""Steps/s of the MuJoCo robot games: physics alone, the rules, the ParallelEnv, and the batched path.

Prints one JSON document. For each robot game id, on one pinned core with random torques drawn
beforehand from a seeded generator (resets counted in):

* ``physics``: the rules' physics alone (``frame_skip`` MuJoCo sub-steps: ``rules.simulate``), the
  floor of any step;
* ``rules``: ``rules.step`` + ``rules.observe`` (what the match engine's rules path pays);
* ``env``: the PettingZoo ``ParallelEnv.step`` with its dicts, action checks and social-tree rewards;

then the batched path (:class:`arena_league.envs.robots.RobotMatches`, the match engine's engine
for many matches) with 1 and with 2 worker threads, the process allowed on CPUs 0 and 1, beside
its peer, MuJoCo's thread-pooled ``mujoco.rollout`` stepping the same matches' physics alone.

Mind the machine: with Linux's autogroup scheduling, a busy job of another session takes one of
two cores whatever this process asks, and two threads then cannot beat one (see ``load_average``).

Every figure is the best of ``--repeats`` runs of ``--seconds`` each (the machine may be shared),
with both rates: per wall-clock second and per CPU second of this process (``time.process_time``,
all threads). ``benchmarks/env_throughput.py`` may call :func:`measure` and embed its result.

    PYTHONPATH=. python benchmarks/robots_throughput.py [--seconds 2] [--repeats 3] [--slots 64]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

GAME_MODULES = ("sumo", "runtogoal", "youshallnotpass", "pushbox")


def _rules_class(module: str):
    import importlib

    return importlib.import_module(f"arena_league.envs.games.{module}").RULES


def _game_id(rules_cls) -> str:
    n_teams, players = rules_cls.layouts[0]
    return f"{rules_cls.name}-{n_teams}T{players}P-v{rules_cls.version}"


def _make_env(rules_cls):
    """A ParallelEnv of the game, built from its rules class (works whether or not the catalog
    lists the robot games yet)."""
    from arena_league.envs.env import ArenaParallelEnv
    from arena_league.envs.social.tree import SocialTree

    n_teams, players = rules_cls.layouts[0]
    rules = rules_cls(n_teams, players)
    names = [f"player_{i}" for i in range(rules.n_agents)]
    tree = SocialTree.build(rules_cls.default_tree(n_teams, players), names, rules.team_of,
                            frozenset(rules.measures_provided), game=_game_id(rules_cls))
    return ArenaParallelEnv(_game_id(rules_cls), rules, tree, rules.default_max_cycles)


def _pin(cpus: set[int]) -> str:
    if not hasattr(os, "sched_setaffinity"):
        return "not pinned (no sched_setaffinity)"
    allowed = sorted(os.sched_getaffinity(0) | cpus)
    wanted = {c for c in cpus if c in allowed} or {allowed[0]}
    os.sched_setaffinity(0, wanted)
    return f"pinned to CPU(s) {sorted(wanted)}"


def _rate(run, seconds: float, repeats: int) -> dict:
    """Best of ``repeats`` runs of ``run(deadline) -> steps``: steps per wall and per CPU second."""
    best_wall = best_cpu = 0.0
    for _ in range(repeats):
        wall0, cpu0 = time.perf_counter(), time.process_time()
        steps = run(wall0 + seconds)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        best_wall = max(best_wall, steps / wall)
        best_cpu = max(best_cpu, steps / max(cpu, 1e-9))
    return {"steps_per_s": round(best_wall), "steps_per_cpu_s": round(best_cpu)}


def _actions(n_agents: int, act_dim: int, count: int = 512) -> np.ndarray:
    return np.random.default_rng(0).uniform(-1.0, 1.0, (count, n_agents, act_dim)).astype(np.float32)


def single_core(rules_cls, seconds: float, repeats: int) -> dict:
    """Physics, rules and env steps/s of one game on the current (pinned) core."""
    env = _make_env(rules_cls)
    rules = env.rules
    pool = _actions(rules.n_agents, rules.act_dim)
    dict_pool = [{a: pool[k, i] for i, a in enumerate(env.possible_agents)} for k in range(len(pool))]

    def physics(deadline: float) -> int:
        rules.reset(0)
        data, simulate = rules.data, rules.simulate
        steps = 0
        while time.perf_counter() < deadline:
            for k in range(256):
                data.ctrl[:] = pool[k].reshape(-1)
                simulate(data)
            steps += 256
        return steps

    def rules_path(deadline: float) -> int:
        rules.reset(0)
        steps = episodes = 0
        while time.perf_counter() < deadline:
            for k in range(256):
                rules.step(pool[k])
                rules.observe()
                if rules.game_over:
                    episodes += 1
                    rules.reset(episodes)
            steps += 256
        return steps

    def env_path(deadline: float) -> int:
        env.reset(seed=0)
        steps = episodes = 0
        while time.perf_counter() < deadline:
            for k in range(256):
                env.step(dict_pool[k])
                if not env.agents:
                    episodes += 1
                    env.reset(seed=episodes)
            steps += 256
        return steps

    return {"game_id": env.game_id, "robots": rules.n_agents, "frame_skip": rules.frame_skip,
            "physics": _rate(physics, seconds, repeats), "rules": _rate(rules_path, seconds, repeats),
            "env": _rate(env_path, seconds, repeats)}


def batched(rules_cls, seconds: float, repeats: int, slots: int, threads: int) -> dict:
    """Match-steps/s of ``slots`` matches on :class:`RobotMatches` with ``threads`` workers."""
    from arena_league.envs.robots import RobotMatches

    n_teams, players = rules_cls.layouts[0]
    rules = rules_cls(n_teams, players)
    engine = RobotMatches(rules, slots, rules.default_max_cycles, threads=threads)
    pool = _actions(slots * rules.n_agents, rules.act_dim, 64).reshape(64, slots, rules.n_agents, rules.act_dim)

    def run(deadline: float) -> int:
        seed = 0
        for slot in range(slots):
            engine.start(slot, seed)
            seed += 1
        steps = 0
        while time.perf_counter() < deadline:
            for k in range(16):
                live = int((~engine.match.done).sum())
                ended = engine.step(pool[k % 64])
                engine.observe()
                steps += live
                for slot in np.flatnonzero(ended):
                    engine.start(int(slot), seed)
                    seed += 1
        return steps

    try:
        result = _rate(run, seconds, repeats)
    finally:
        engine.close()
    return {"game_id": _game_id(rules_cls), "slots": slots, "threads": threads, **result}


def rollout_peer(rules_cls, seconds: float, repeats: int, slots: int, threads: int) -> dict:
    """The peer: ``slots`` matches' physics alone stepped by MuJoCo's own thread-pooled
    ``mujoco.rollout`` (full physics state in and out per match step, random torques held for the
    step). Physics only: no observations, no measures, no judgement."""
    import mujoco
    from mujoco import rollout

    n_teams, players = rules_cls.layouts[0]
    rules = rules_cls(n_teams, players)
    model, skip = rules.model, rules.frame_skip
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    size = mujoco.mj_stateSize(model, spec)
    initial = np.zeros((slots, size))
    scratch = [mujoco.MjData(model) for _ in range(max(threads, 1))]
    for slot in range(slots):
        rng = np.random.default_rng(slot)
        rules.place(scratch[0], rules.start_pose(rng), rng)
        mujoco.mj_getState(model, scratch[0], initial[slot], spec)
    torques = np.random.default_rng(0).uniform(-1.0, 1.0, (slots, 1, model.nu))
    control = np.repeat(torques, skip, axis=1)  # one step's torques held over its sub-steps
    out = np.zeros((slots, skip, size))

    with rollout.Rollout(nthread=threads if threads > 1 else 0) as pool:
        def run(deadline: float) -> int:
            state = initial.copy()
            steps = 0
            while time.perf_counter() < deadline:
                for _ in range(8):
                    pool.rollout(model, scratch, state, control, state=out, nstep=skip)
                    state[:] = out[:, -1]
                    steps += slots
            return steps

        result = _rate(run, seconds, repeats)
    return {"game_id": _game_id(rules_cls), "slots": slots, "threads": threads, "physics_only": True, **result}


def measure(seconds: float = 2.0, repeats: int = 3, slots: int = 64, modules: tuple[str, ...] = GAME_MODULES) -> dict:
    """The whole document (see the module docstring); restores the process's CPU affinity."""
    original = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    try:
        pinning = _pin({0})
        rows = []
        for module in modules:
            rows.append(single_core(_rules_class(module), seconds, repeats))
            print(f"{rows[-1]['game_id']}: rules {rows[-1]['rules']['steps_per_s']} env {rows[-1]['env']['steps_per_s']}"
                  " steps/s", file=sys.stderr)
        two_ant = [m for m in modules if np.prod(_rules_class(m).layouts[0]) == 2]
        batch_rows = []
        for module in two_ant[:1] + [m for m in modules if m == "pushbox"]:
            rules_cls = _rules_class(module)
            _pin({0})
            one = batched(rules_cls, seconds, repeats, slots, threads=1)
            two_cpus = _pin({0, 1})
            two = batched(rules_cls, seconds, repeats, slots, threads=2)
            peer_one = rollout_peer(rules_cls, seconds, repeats, slots, threads=1)
            peer_two = rollout_peer(rules_cls, seconds, repeats, slots, threads=2)
            _pin({0})
            single = next(r for r in rows if r["game_id"] == one["game_id"])
            batch_rows.append({"game_id": one["game_id"], "slots": slots, "threads_1": one, "threads_2": two,
                               "peer_mujoco_rollout_physics_only": {"threads_1": peer_one, "threads_2": peer_two},
                               "affinity_2_threads": two_cpus,
                               "speedup_2_threads_vs_rules_one_core": round(two["steps_per_s"] / single["rules"]["steps_per_s"], 2),
                               "speedup_2_threads_vs_1_thread": round(two["steps_per_s"] / one["steps_per_s"], 2)})
            print(f"{one['game_id']} batched: 1 thread {one['steps_per_s']}, 2 threads {two['steps_per_s']} "
                  "match-steps/s", file=sys.stderr)
    finally:
        if original is not None:
            os.sched_setaffinity(0, original)
    two_ant_rows = [r for r in rows if r["robots"] == 2]
    target = 8000
    summary = {
        "target_env_steps_per_s_per_core_2_ants": target,
        "slowest_2_ant_rules_steps_per_s": min((r["rules"]["steps_per_s"] for r in two_ant_rows), default=None),
        "slowest_2_ant_env_steps_per_s": min((r["env"]["steps_per_s"] for r in two_ant_rows), default=None),
        "slowest_2_ant_physics_steps_per_s": min((r["physics"]["steps_per_s"] for r in two_ant_rows), default=None),
        "batched_2_threads_target": int(1.6 * target),
    }
    if batch_rows:
        summary["batched_2_ant_2_threads_steps_per_s"] = batch_rows[0]["threads_2"]["steps_per_s"]
    return {
        "benchmark": "robots_throughput",
        "command": "PYTHONPATH=. python benchmarks/robots_throughput.py " + " ".join(sys.argv[1:]),
        "machine": {"python": platform.python_version(), "cpu": platform.processor() or platform.machine(),
                    "cpus": os.cpu_count(), "load_average": [round(x, 2) for x in os.getloadavg()],
                    "affinity": pinning, "mujoco": __import__("mujoco").__version__},
        "seconds": seconds, "repeats": repeats,
        "single_core": rows,
        "batched": batch_rows,
        "summary": summary,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="time per run (default 2)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per figure, the best is kept (default 3)")
    parser.add_argument("--slots", type=int, default=64, help="matches in flight on the batched path (default 64)")
    parser.add_argument("--games", nargs="*", default=list(GAME_MODULES), choices=GAME_MODULES,
                        help="robot game modules (default: all)")
    args = parser.parse_args(argv)
    print(json.dumps(measure(args.seconds, args.repeats, args.slots, tuple(args.games)), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
