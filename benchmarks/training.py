"""Training env steps/s of every scheme on three engines, beside the env's own speed and peer libraries.

Prints one JSON document. For each game (Crossroads-2T2P-v1: pymunk 2D; Snake-2T2P-v1: numpy grid;
Sumo-2T1P-v1: MuJoCo robots) it measures, each figure in its own process pinned to one core
(``taskset``, when present) and computing on one torch thread:

* ``env``: the game's own env steps/s, one env stepped with uniformly random legal actions (a pool
  drawn beforehand from a seeded generator, or drawn from the mask each step in games with illegal
  actions), reset at each episode end, through the PettingZoo parallel API (``parallel``: dict in,
  dicts out) and through the array API (``arrays``: ``reset_arrays`` / ``step_arrays``);
* ``schemes``: each training scheme that applies to the game's action type (``ppo``, ``dppo``,
  ``sp``, ``pbt`` with 4 members, ``cc``, ``cf``), built from its public trainer class with
  :class:`~arena_league.training.PPOConfig`'s defaults (8 envs x 128 steps per update, 64-64 tanh
  actor and critic, 4 epochs x 4 minibatches; CC and CF keep these values, their critics' extra
  options take their defaults), with its ratio to both env figures and, for ``ppo`` (one policy
  shared by every seat, the setting the peers run), its speed-up over each peer;
* ``peers`` (``--peers``, the default, where installed): Stable-Baselines3 PPO over SuperSuit's vector
  envs (each seat of each of 8 envs one entry, 128 steps per entry and update, the same
  hyper-parameters and network sizes), RLlib PPO (new API stack, the env runner and the learner in
  the benchmark's process), on the same game, and ``cleanrl_style``, a textbook single-file PPO
  written here after CleanRL's ``ppo.py`` (one env through the dict API, one forward per seat per
  step; discrete games). A peer that is missing or cannot run a game is skipped with one line
  saying why.

An env step is one game step of all seats. Each training figure counts from the end of its first
iteration (a warm-up) for at least ``--seconds`` and whole iterations; ``steps_per_cpu_s`` divides
by the process's CPU time instead of the wall clock (the time a shared core spent on other
processes does not count).

With ``--against PATH`` (another checkout of the repository, e.g. ``git worktree add /tmp/old
347ea07``) every scheme cell also runs with ``PYTHONPATH=PATH``, in the same run and at the same
time as this tree's (one core each when ``--jobs`` is 2), and the document gives the ratio new/old.

    PYTHONPATH=. python benchmarks/training.py                      # defaults: about 5 minutes on 2 cores
    PYTHONPATH=. python benchmarks/training.py --against /tmp/old     # about 8 minutes
    PYTHONPATH=. python benchmarks/training.py --seconds 2 --games Crossroads-2T2P-v1 --schemes ppo,dppo
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
GAMES = ("Crossroads-2T2P-v1", "Snake-2T2P-v1", "Sumo-2T1P-v1")
SCHEMES = ("ppo", "dppo", "sp", "pbt", "cc", "cf")
PEERS = ("sb3", "rllib", "cleanrl_style")
ENGINES = {"Crossroads-2T2P-v1": "pymunk 2D", "Snake-2T2P-v1": "numpy grid", "Sumo-2T1P-v1": "MuJoCo robots"}
#: The issue's criteria: a scheme's env steps/s as a share of the env's own, per game and scheme.
CRITERIA = {("Crossroads-2T2P-v1", "ppo"): 0.5, ("Crossroads-2T2P-v1", "dppo"): 0.4,
            ("Crossroads-2T2P-v1", "pbt"): 0.4, ("Snake-2T2P-v1", "ppo"): 0.4, ("Sumo-2T1P-v1", "ppo"): 0.4}
#: The PPO settings every learner here runs (PPOConfig's defaults).
N_ENVS, N_STEPS, EPOCHS, MINIBATCHES = 8, 128, 4, 4
PEER_INSTALL = "pip install arena-league[peers]"


# --- workers: each runs in its own process and prints one JSON line ----------------------------------

def _one_thread() -> None:
    import torch

    torch.set_num_threads(1)


def _timed(step_once, seconds: float, counter) -> dict:
    """Call ``step_once()`` (one training iteration) once as a warm-up, then until ``seconds`` have
    passed; ``counter()`` gives env steps so far."""
    step_once()
    start_steps, start, start_cpu = counter(), time.perf_counter(), time.process_time()
    iterations = 0
    while True:
        step_once()
        iterations += 1
        elapsed = time.perf_counter() - start
        if elapsed >= seconds:
            break
    cpu = time.process_time() - start_cpu
    steps = counter() - start_steps
    return {"steps_per_s": round(steps / elapsed), "steps_per_cpu_s": round(steps / cpu), "env_steps": int(steps),
            "iterations": iterations, "seconds": round(elapsed, 2)}


def worker_env(game_id: str, api: str, seconds: float, seed: int) -> dict:
    from arena_league.envs import make

    env = make(game_id)
    rules = env.rules
    agents = list(env.possible_agents)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    masked = bool(getattr(rules, "masks_actions", False))
    pool = [[rules.random_action(i, rng) for i in range(len(agents))] for _ in range(1024)]
    if api == "arrays":
        pool_arrays = [np.asarray(actions) for actions in pool]

        def draw(k: int) -> np.ndarray:
            if masked:
                return np.asarray([rules.random_action(i, rng) for i in range(len(agents))])
            return pool_arrays[k % len(pool_arrays)]

        env.reset_arrays(seed)
        episodes = steps = 0

        def run(n: int) -> None:
            nonlocal episodes, steps
            for _ in range(n):
                _, _, terminated, truncated = env.step_arrays(draw(steps))
                steps += 1
                if terminated or truncated:
                    episodes += 1
                    env.reset_arrays(seed + episodes)
    else:
        pool_dicts = [dict(zip(agents, actions)) for actions in pool]

        def draw_dict(k: int) -> dict:
            if masked:
                return {a: rules.random_action(i, rng) for i, a in enumerate(agents) if a in env.agents}
            actions = pool_dicts[k % len(pool_dicts)]
            return {a: actions[a] for a in env.agents}

        env.reset(seed=seed)
        episodes = steps = 0

        def run(n: int) -> None:
            nonlocal episodes, steps
            for _ in range(n):
                env.step(draw_dict(steps))
                steps += 1
                if not env.agents:
                    episodes += 1
                    env.reset(seed=seed + episodes)

    run(64)  # warm-up
    start_steps, start, start_cpu = steps, time.perf_counter(), time.process_time()
    while time.perf_counter() - start < seconds:
        run(128)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    counted = steps - start_steps
    return {"steps_per_s": round(counted / elapsed), "steps_per_cpu_s": round(counted / cpu), "env_steps": counted,
            "episodes": episodes, "seconds": round(elapsed, 2),
            "actions": "drawn from the mask each step" if masked else "pool of 1024 drawn beforehand"}


def trainer_class(scheme: str):
    """The public trainer class of ``scheme`` and its options for this benchmark."""
    import arena_league.training as training

    if scheme == "ppo":
        return training.PPO, {}
    if scheme == "dppo":
        return training.DPPO, {}
    if scheme == "sp":
        return training.SelfPlay, {}
    if scheme == "pbt":
        return training.PBT, {"population_size": 4}
    if scheme == "cc":
        from arena_league.training.cc import CC

        return CC, {}
    if scheme == "cf":
        from arena_league.training.cf import CF

        return CF, {}
    raise ValueError(f"unknown scheme {scheme!r}; valid: {', '.join(SCHEMES)}")


def worker_scheme(game_id: str, scheme: str, seconds: float, seed: int) -> dict:
    import arena_league
    from arena_league.training import PPOConfig, make_env_fn

    _one_thread()
    cls, options = trainer_class(scheme)
    trainer = cls(make_env_fn(game_id), PPOConfig(), seed, total_steps=10**9, **options)
    result = _timed(trainer.iterate, seconds, lambda: trainer.env_steps)
    result["learners"] = len(trainer.learners)
    result["arena_league"] = str(Path(arena_league.__file__).parent.parent)
    return result


def worker_sb3(game_id: str, seconds: float, seed: int) -> dict:
    import supersuit as ss
    from stable_baselines3 import PPO as SB3PPO
    from stable_baselines3.common.utils import set_random_seed
    from torch import nn

    from arena_league.envs import make

    _one_thread()
    env = make(game_id)
    seats = len(env.possible_agents)
    vec = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), N_ENVS, num_cpus=0,
                                base_class="stable_baselines3")
    samples = seats * N_ENVS * N_STEPS
    # supersuit's ConcatVecEnv has no seed(), which SB3 calls for a seed given to PPO: seed torch and numpy here
    set_random_seed(seed)
    model = SB3PPO("MlpPolicy", vec, n_steps=N_STEPS, batch_size=samples // MINIBATCHES, n_epochs=EPOCHS,
                   clip_range=0.1, ent_coef=0.01, vf_coef=0.5, max_grad_norm=0.5, learning_rate=2.5e-4,
                   gae_lambda=0.95, gamma=0.99, device="cpu", verbose=0,
                   policy_kwargs={"net_arch": {"pi": [64, 64], "vf": [64, 64]}, "activation_fn": nn.Tanh})
    first = [True]

    def iterate() -> None:
        model.learn(total_timesteps=samples, reset_num_timesteps=first[0])
        first[0] = False

    result = _timed(iterate, seconds, lambda: model.num_timesteps // seats)
    result.update(vec_env_entries=seats * N_ENVS, samples_per_update=samples)
    return result


def worker_cleanrl_style(game_id: str, seconds: float, seed: int) -> dict:
    """A textbook single-file PPO written here after CleanRL's ``ppo.py`` (Huang et al. 2022): one env
    through the PettingZoo dict API, one forward per seat per step (actor and critic), sampling with
    ``torch.distributions.Categorical``, 1024 steps per rollout (4096 seat-samples on four seats).
    Discrete actions only."""
    import torch
    from torch import nn
    from torch.distributions.categorical import Categorical

    from arena_league.envs import make

    # hyper-parameters: CleanRL ppo.py's, with one env and 1024 steps (4096 seat-samples per update)
    num_steps, learning_rate, gamma, gae_lambda = 1024, 2.5e-4, 0.99, 0.95
    num_minibatches, update_epochs, clip_coef, ent_coef, vf_coef, max_grad_norm = 4, 4, 0.1, 0.01, 0.5, 0.5

    # seeding
    rng = np.random.default_rng(seed)
    torch.manual_seed(seed)
    torch.set_num_threads(1)

    env = make(game_id)
    agents = env.possible_agents
    n_agents = len(agents)
    obs_dim = env.observation_space(agents[0]).shape[0]
    n_actions = env.action_space(agents[0]).n

    def layer_init(layer: nn.Linear, std: float = np.sqrt(2), bias_const: float = 0.0) -> nn.Linear:
        torch.nn.init.orthogonal_(layer.weight, std)
        torch.nn.init.constant_(layer.bias, bias_const)
        return layer

    class Agent(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.critic = nn.Sequential(layer_init(nn.Linear(obs_dim, 64)), nn.Tanh(),
                                        layer_init(nn.Linear(64, 64)), nn.Tanh(), layer_init(nn.Linear(64, 1), std=1.0))
            self.actor = nn.Sequential(layer_init(nn.Linear(obs_dim, 64)), nn.Tanh(), layer_init(nn.Linear(64, 64)),
                                       nn.Tanh(), layer_init(nn.Linear(64, n_actions), std=0.01))

        def get_value(self, x):
            return self.critic(x)

        def get_action_and_value(self, x, action=None):
            probs = Categorical(logits=self.actor(x))
            if action is None:
                action = probs.sample()
            return action, probs.log_prob(action), probs.entropy(), self.critic(x)

    agent = Agent()
    optimizer = torch.optim.Adam(agent.parameters(), lr=learning_rate, eps=1e-5)

    # storage: one row per step, one column per seat
    obs = torch.zeros((num_steps, n_agents, obs_dim))
    actions = torch.zeros((num_steps, n_agents))
    logprobs = torch.zeros((num_steps, n_agents))
    rewards = torch.zeros((num_steps, n_agents))
    dones = torch.zeros((num_steps, n_agents))
    values = torch.zeros((num_steps, n_agents))

    episode = 0
    next_obs_dict, _ = env.reset(seed=seed)
    next_obs = torch.tensor(np.stack([next_obs_dict[a] for a in agents]))
    next_done = torch.zeros(n_agents)
    episode_return, returns = np.zeros(n_agents), []
    iteration_returns: list[float] = []
    env_steps, start, start_cpu, counted_from, counted_steps = 0, 0.0, 0.0, None, 0
    while True:
        iteration_start_returns = len(returns)
        # rollout: one env, one forward per seat per step
        for step in range(num_steps):
            obs[step] = next_obs
            dones[step] = next_done
            step_actions = {}
            for i, name in enumerate(agents):
                with torch.no_grad():
                    action, logprob, _, value = agent.get_action_and_value(next_obs[i].unsqueeze(0))
                values[step, i] = value.flatten()
                actions[step, i] = action
                logprobs[step, i] = logprob
                step_actions[name] = int(action.item())
            next_obs_dict, reward, terminations, truncations, _ = env.step(step_actions)
            env_steps += 1
            rewards[step] = torch.tensor([reward[a] for a in agents], dtype=torch.float32)
            episode_return += rewards[step].numpy()
            done = any(terminations.values()) or any(truncations.values())
            if done:
                returns.append(float(episode_return.mean()))
                episode_return[:] = 0.0
                episode += 1
                next_obs_dict, _ = env.reset(seed=seed + episode)
            next_obs = torch.tensor(np.stack([next_obs_dict[a] for a in agents]))
            next_done = torch.full((n_agents,), float(done))
        # GAE
        with torch.no_grad():
            next_value = agent.get_value(next_obs).reshape(1, -1)
            advantages = torch.zeros_like(rewards)
            lastgaelam = 0
            for t in reversed(range(num_steps)):
                if t == num_steps - 1:
                    nextnonterminal = 1.0 - next_done
                    nextvalues = next_value
                else:
                    nextnonterminal = 1.0 - dones[t + 1]
                    nextvalues = values[t + 1]
                delta = rewards[t] + gamma * nextvalues * nextnonterminal - values[t]
                advantages[t] = lastgaelam = delta + gamma * gae_lambda * nextnonterminal * lastgaelam
            returns_t = advantages + values
        # optimise
        b_obs = obs.reshape((-1, obs_dim))
        b_logprobs, b_actions = logprobs.reshape(-1), actions.reshape(-1)
        b_advantages, b_returns, b_values = advantages.reshape(-1), returns_t.reshape(-1), values.reshape(-1)
        batch_size = b_obs.shape[0]
        minibatch_size = batch_size // num_minibatches
        b_inds = np.arange(batch_size)
        for _epoch in range(update_epochs):
            rng.shuffle(b_inds)
            for begin in range(0, batch_size, minibatch_size):
                mb_inds = b_inds[begin:begin + minibatch_size]
                _, newlogprob, entropy, newvalue = agent.get_action_and_value(b_obs[mb_inds], b_actions.long()[mb_inds])
                ratio = (newlogprob - b_logprobs[mb_inds]).exp()
                mb_advantages = b_advantages[mb_inds]
                mb_advantages = (mb_advantages - mb_advantages.mean()) / (mb_advantages.std() + 1e-8)
                pg_loss = torch.max(-mb_advantages * ratio,
                                    -mb_advantages * torch.clamp(ratio, 1 - clip_coef, 1 + clip_coef)).mean()
                newvalue = newvalue.view(-1)
                v_loss_unclipped = (newvalue - b_returns[mb_inds]) ** 2
                v_clipped = b_values[mb_inds] + torch.clamp(newvalue - b_values[mb_inds], -clip_coef, clip_coef)
                v_loss = 0.5 * torch.max(v_loss_unclipped, (v_clipped - b_returns[mb_inds]) ** 2).mean()
                loss = pg_loss - ent_coef * entropy.mean() + v_loss * vf_coef
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), max_grad_norm)
                optimizer.step()
        # log
        new = returns[iteration_start_returns:]
        iteration_returns.append(float(np.mean(new)) if new else float("nan"))
        now = time.perf_counter()
        if counted_from is None:  # the first iteration is a warm-up
            counted_from, start, start_cpu = env_steps, now, time.process_time()
            continue
        counted_steps = env_steps - counted_from
        if now - start >= seconds:
            break
    elapsed, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    return {"steps_per_s": round(counted_steps / elapsed), "steps_per_cpu_s": round(counted_steps / cpu),
            "env_steps": counted_steps, "iterations": len(iteration_returns) - 1, "seconds": round(elapsed, 2)}


def worker_rllib(game_id: str, seconds: float, seed: int) -> dict:
    import ray
    from ray.rllib.algorithms.ppo import PPOConfig as RLlibPPOConfig
    from ray.rllib.core.rl_module.default_model_config import DefaultModelConfig
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv
    from ray.tune.registry import register_env

    from arena_league.envs import make

    _one_thread()
    seats = len(make(game_id).possible_agents)
    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    register_env("arena", lambda _config: ParallelPettingZooEnv(make(game_id)))
    config = (RLlibPPOConfig()
              .api_stack(enable_rl_module_and_learner=True, enable_env_runner_and_connector_v2=True)
              .environment("arena")
              .framework("torch", torch_compile_learner=False)
              .env_runners(num_env_runners=0, num_envs_per_env_runner=N_ENVS, rollout_fragment_length=N_STEPS,
                           num_cpus_per_env_runner=0)
              .learners(num_learners=0, num_cpus_per_learner=0)
              # RLlib counts a multi-agent batch in env steps, its minibatches in agent steps
              .training(train_batch_size_per_learner=N_ENVS * N_STEPS,
                        minibatch_size=seats * N_ENVS * N_STEPS // MINIBATCHES, num_epochs=EPOCHS, lr=2.5e-4,
                        gamma=0.99, lambda_=0.95, clip_param=0.1, entropy_coeff=0.01, vf_loss_coeff=0.5,
                        grad_clip=0.5)
              .multi_agent(policies={"shared"}, policy_mapping_fn=lambda agent_id, episode, **kwargs: "shared")
              .rl_module(model_config=DefaultModelConfig(fcnet_hiddens=[64, 64], fcnet_activation="tanh",
                                                         vf_share_layers=False))
              .debugging(seed=seed))
    algo = config.build_algo()
    sampled, trained = [0], [0]

    def iterate() -> None:
        record = algo.train()
        runners = record.get("env_runners", {})
        sampled[0] = int(runners.get("num_env_steps_sampled_lifetime", sampled[0]))
        trained[0] = int(record.get("learners", {}).get("shared", {}).get("num_module_steps_trained", 0))

    try:
        result = _timed(iterate, seconds, lambda: sampled[0])
    finally:
        algo.stop()
        ray.shutdown()
    result.update(samples_per_update=seats * N_ENVS * N_STEPS, samples_trained_last_update=trained[0],
                  note="env runner and learner in this process; ray's own services run beside it")
    return result


def run_worker(args: argparse.Namespace) -> dict:
    kind, game, seconds, seed = args.worker, args.worker_game, args.seconds, args.seed
    if kind in ("parallel", "arrays"):
        return worker_env(game, kind, seconds, seed)
    if kind == "sb3":
        return worker_sb3(game, seconds, seed)
    if kind == "rllib":
        return worker_rllib(game, seconds, seed)
    if kind == "cleanrl_style":
        return worker_cleanrl_style(game, seconds, seed)
    return worker_scheme(game, kind, seconds, seed)


# --- driver ------------------------------------------------------------------------------------------

class Cores:
    """Hands each running worker a core of its own."""

    def __init__(self, jobs: int) -> None:
        available = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
        self.taskset = shutil.which("taskset") is not None and bool(available)
        self.free = list(available[:jobs]) if self.taskset else [None] * jobs
        self.lock = threading.Condition()

    def take(self):
        with self.lock:
            while not self.free:
                self.lock.wait()
            return self.free.pop(0)

    def give(self, core) -> None:
        with self.lock:
            self.free.append(core)
            self.lock.notify()


def launch_command(cores: Cores, script: Path, arguments: list[str], tree: Path, timeout: float) -> dict:
    """``python script arguments`` in its own process on its own core, importing ``arena_league``
    from ``tree``; the JSON of its last line, or ``{"error": ...}``."""
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", PYTHONPATH=str(tree),
               PYTHONWARNINGS="ignore")
    cmd = [sys.executable, str(script), *arguments]
    core = cores.take()
    try:
        if core is not None:
            cmd = ["taskset", "-c", str(core), *cmd]
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout, check=False)
        except subprocess.TimeoutExpired:
            return {"error": f"timed out after {timeout:.0f} s"}
    finally:
        cores.give(core)
    lines = [line for line in proc.stdout.strip().splitlines() if line.startswith("{")]
    if proc.returncode != 0 or not lines:
        tail = [line for line in proc.stderr.strip().splitlines() if line.strip()][-1:] or ["no output"]
        return {"error": f"exit code {proc.returncode}: {tail[0][:300]}"}
    return json.loads(lines[-1])


def launch(cores: Cores, kind: str, game: str, seconds: float, seed: int, tree: Path, timeout: float) -> dict:
    """One cell's worker (see :func:`launch_command`)."""
    arguments = ["--worker", kind, "--worker-game", game, "--seconds", str(seconds), "--seed", str(seed)]
    return launch_command(cores, Path(__file__).resolve(), arguments, tree, timeout)


def peer_missing(peer: str) -> str | None:
    """Why ``peer`` cannot run here, or None."""
    import importlib.util

    needs = {"sb3": ("stable_baselines3", "supersuit"), "rllib": ("ray", "tree"), "cleanrl_style": ()}[peer]
    missing = [m for m in needs if importlib.util.find_spec(m) is None]
    if not missing:
        return None
    names = {"stable_baselines3": "stable-baselines3", "supersuit": "supersuit", "ray": "ray[rllib]",
             "tree": "dm-tree (ray[rllib])"}
    return f"{', '.join(names[m] for m in missing)} not installed: {PEER_INSTALL}"


def scheme_applies(scheme: str, action_type: str) -> bool:
    from arena_league.training.schemes import scheme_action_types

    return action_type in scheme_action_types(scheme)


def ratio(a: dict, b: dict, key: str = "steps_per_s") -> float | None:
    if "error" in a or "error" in b or not b.get(key):
        return None
    return round(a[key] / b[key], 3)


def parse_list(text: str, valid: tuple[str, ...], what: str) -> list[str]:
    items = [item.strip() for item in text.split(",") if item.strip()]
    unknown = [item for item in items if item not in valid]
    if unknown or not items:
        raise ValueError(f"unknown {what} {', '.join(unknown) or '(none given)'}; valid: {', '.join(valid)} "
                         "(comma-separated)")
    return items


def benchmark(args: argparse.Namespace) -> dict:
    from arena_league.envs import list_games, make

    known = set(list_games())
    games = [g.strip() for g in args.games.split(",") if g.strip()]
    bad = [g for g in games if g not in known]
    if bad or not games:
        raise ValueError(f"unknown game {', '.join(bad) or '(none given)'}; e.g. {', '.join(GAMES)}")
    schemes = parse_list(args.schemes, SCHEMES, "scheme")
    against = Path(args.against).resolve() if args.against else None
    if against is not None and not (against / "arena_league" / "__init__.py").exists():
        raise ValueError(f"--against {args.against}: no arena_league package there; give a checkout of the "
                         "repository, e.g. git worktree add /tmp/old 347ea07")
    cores = Cores(args.jobs)
    timeout = 120 + 10 * args.seconds
    tasks: list[tuple[tuple, tuple]] = []  # (where the result goes, launch arguments)
    document_games: dict[str, Any] = {}
    peer_skips = {peer: peer_missing(peer) for peer in PEERS} if args.peers else {}
    for game in games:
        action_type = make(game).rules.action_type
        entry: dict[str, Any] = {"engine": ENGINES.get(game, "other"), "action_type": action_type, "env": {},
                                 "schemes": {}, "peers": {}}
        document_games[game] = entry
        for api in ("parallel", "arrays"):
            tasks.append(((game, "env", api, "ours"), (api, game, ROOT)))
        for scheme in schemes:
            if not scheme_applies(scheme, action_type):
                entry["schemes"][scheme] = {"skipped": f"{scheme} does not train {action_type} actions"}
                continue
            entry["schemes"][scheme] = {}  # the document lists the schemes in the order asked
            tasks.append(((game, "schemes", scheme, "ours"), (scheme, game, ROOT)))
            if against is not None:
                tasks.append(((game, "schemes", scheme, "old"), (scheme, game, against)))
        for peer in PEERS if args.peers else ():
            if peer_skips[peer]:
                entry["peers"][peer] = {"skipped": peer_skips[peer]}
            elif peer == "cleanrl_style" and action_type != "discrete":
                entry["peers"][peer] = {"skipped": "the single-file PPO written here samples discrete actions only"}
            else:
                tasks.append(((game, "peers", peer, "ours"), (peer, game, ROOT)))

    def run(task):
        where, (kind, game, tree) = task
        return where, launch(cores, kind, game, args.seconds, args.seed, tree, timeout)

    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        results = list(pool.map(run, tasks))
    for (game, section, name, side), result in results:
        cell = document_games[game][section].setdefault(name, {})
        if section == "env":
            cell.update(result)
        elif side == "ours":
            cell["ours" if section == "schemes" else "result"] = result
        else:
            cell["old"] = result
    for game, entry in document_games.items():
        env_parallel, env_arrays = entry["env"]["parallel"], entry["env"]["arrays"]
        for scheme, cell in entry["schemes"].items():
            if "ours" not in cell:
                continue
            ours = cell["ours"]
            cell["ratio_to_env_parallel"] = ratio(ours, env_parallel)
            cell["ratio_to_env_arrays"] = ratio(ours, env_arrays)
            cell["cpu_ratio_to_env_parallel"] = ratio(ours, env_parallel, "steps_per_cpu_s")
            cell["cpu_ratio_to_env_arrays"] = ratio(ours, env_arrays, "steps_per_cpu_s")
            threshold = CRITERIA.get((game, scheme))
            if threshold is not None:
                cell["criterion"] = {"share_of_env": threshold,
                                     "met_vs_parallel": (cell["ratio_to_env_parallel"] or 0) >= threshold,
                                     "met_vs_arrays": (cell["ratio_to_env_arrays"] or 0) >= threshold}
            if "old" in cell:
                old = cell["old"]
                cell["ratio_new_over_old"] = ratio(ours, old)
                cell["cpu_ratio_new_over_old"] = ratio(ours, old, "steps_per_cpu_s")
                if "error" not in old:
                    cell["old_ratio_to_env_parallel"] = ratio(old, env_parallel)
            if scheme == "ppo":
                for peer, peer_cell in entry["peers"].items():
                    if "result" in peer_cell:
                        cell[f"speedup_over_{peer}"] = ratio(ours, peer_cell["result"])
                        cell[f"cpu_speedup_over_{peer}"] = ratio(ours, peer_cell["result"], "steps_per_cpu_s")
    return {
        "benchmark": "training",
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform(),
                    "load_average_at_end": [round(x, 2) for x in os.getloadavg()]},
        "settings": {
            "seconds_per_measure": args.seconds, "seed": args.seed, "jobs": args.jobs,
            "pinned_one_core_per_process": cores.taskset, "torch_threads_per_process": 1,
            "env_step": "one game step of all seats",
            "reading": "steps_per_s is per wall-clock second; on a shared machine steps_per_cpu_s (per CPU second "
                       "of the worker) and the cpu_ ratios are the steadier comparison",
            "ours": f"PPOConfig defaults: {N_ENVS} envs x {N_STEPS} steps per update, 64-64 tanh, "
                    f"{EPOCHS} epochs x {MINIBATCHES} minibatches; pbt: population_size 4; cc/cf: those values, "
                    "their critics' extra options at their defaults; first iteration a warm-up",
            "sb3": "stable-baselines3 PPO over supersuit pettingzoo_env_to_vec_env_v1 + concat_vec_envs_v1 "
                   f"({N_ENVS} envs, every seat an entry), n_steps {N_STEPS}, batch_size samples/{MINIBATCHES}, "
                   f"n_epochs {EPOCHS}, clip 0.1, ent 0.01, vf 0.5, max_grad_norm 0.5, lr 2.5e-4, gae 0.95, "
                   "gamma 0.99, pi/vf [64, 64] Tanh",
            "rllib": "RLlib PPO, new API stack, one shared policy, num_env_runners 0, num_learners 0, "
                     f"{N_ENVS} envs per runner, fragment {N_STEPS}, the same hyper-parameters and sizes",
            "cleanrl_style": "a textbook single-file PPO written here after CleanRL's ppo.py: one env through the "
                             "dict API, one forward per seat per step, 1024 steps per rollout, the same "
                             "hyper-parameters; discrete games only",
            "speedup_over_peer": "ppo only: the peers train one policy shared by every seat, as ppo does",
            "against": str(against) if against else None,
            "criteria": "issue 37: ppo on Crossroads-2T2P >= 50% of the env's own steps/s, dppo and pbt >= 40%, "
                        "ppo on Snake and Sumo >= 40%",
        },
        "peers_skipped": {peer: why for peer, why in peer_skips.items() if why} or None,
        "games": document_games,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--games", default=",".join(GAMES), help="comma-separated game ids (default: %(default)s)")
    parser.add_argument("--schemes", default=",".join(SCHEMES), help="comma-separated schemes (default: %(default)s)")
    parser.add_argument("--seconds", type=float, default=10.0, help="measured seconds per cell (default: %(default)s)")
    parser.add_argument("--peers", action=argparse.BooleanOptionalAction, default=True,
                        help="also time Stable-Baselines3 and RLlib PPO where installed (default: on)")
    parser.add_argument("--against", metavar="PATH", help="another checkout: run every scheme cell with it too")
    parser.add_argument("--jobs", type=int, default=min(2, len(os.sched_getaffinity(0)) if hasattr(
        os, "sched_getaffinity") else 1), help="cells measured at once, one core each (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="seed of every learner and env (default: 0)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--worker-game", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(run_worker(args)))
        return 0
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    try:
        if args.seconds <= 0:
            raise ValueError(f"--seconds must be positive, not {args.seconds}")
        if args.jobs < 1:
            raise ValueError(f"--jobs must be at least 1, not {args.jobs}")
        document = benchmark(args)
    except ValueError as error:
        print(f"training benchmark: {error}", file=sys.stderr)
        return 2
    print(json.dumps(document, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
