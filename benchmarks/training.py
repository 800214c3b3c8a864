"""PPO env steps/s on Crossroads-2T2P-v1: the league's PPO core beside a textbook single-file PPO.

Prints one JSON document. Both learners run the same game (default social tree and length), share
one policy over the four seats, and use the same hyper-parameters (CleanRL ``ppo.py``'s: clip 0.1,
4 epochs of 4 minibatches, entropy 0.01, value clipping, advantage normalisation, 64-64 tanh
networks, 4096 seat-samples per update); each process computes on one torch thread.

* ``ours``: :class:`arena_league.training.PPO`: 8 envs in lockstep through the array API, one
  actor and one critic forward per step for all 32 seats (:mod:`arena_league.training.rollout`).
* ``cleanrl_style``: written here, after CleanRL's single-file ``ppo.py`` (Huang et al. 2022): one
  env through the PettingZoo dict API, one forward per seat per step (actor and critic), sampling
  with ``torch.distributions.Categorical``, 1024 steps per rollout.

Each is measured in one process, and then as two processes at once (one per core of the 2-core
machine, two seeds): the ``two_processes`` figure is their summed env steps/s, what a population
build running two training runs side by side gets. Env steps are game steps (4 seat actions
each); the first iteration is a warm-up and is not counted.

    PYTHONPATH=. python benchmarks/training.py [--seconds 20]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time

import numpy as np

GAME = "Crossroads-2T2P-v1"


# --- ours --------------------------------------------------------------------------------------------

def run_ours(seconds: float, seed: int) -> dict:
    from arena_league.training import PPO, PPOConfig, make_env_fn

    ppo = PPO(make_env_fn(GAME), PPOConfig(), seed=seed)
    first = ppo.iterate()  # warm-up
    start_steps, start = ppo.env_steps, time.perf_counter()
    collect_seconds, records = 0.0, [first]
    while time.perf_counter() - start < seconds:
        record = ppo.iterate()
        collect_seconds += (record["env_steps"] - records[-1]["env_steps"]) / record["collect_steps_per_second"]
        records.append(record)
    elapsed = time.perf_counter() - start
    steps = ppo.env_steps - start_steps
    return {"env_steps_per_s": round(steps / elapsed), "collect_env_steps_per_s": round(steps / collect_seconds),
            "env_steps": steps, "seconds": round(elapsed, 2), "updates": len(records) - 1,
            "episode_return_first": _first_finite(r["episode_return"] for r in records),
            "episode_return_last": _first_finite(r["episode_return"] for r in reversed(records))}


# --- a textbook single-file PPO (CleanRL style), written for this comparison ----------------------------

def run_cleanrl_style(seconds: float, seed: int) -> dict:
    import torch
    from torch import nn
    from torch.distributions.categorical import Categorical

    from arena_league.envs import make

    # hyper-parameters: CleanRL ppo.py's, with one env and 1024 steps (4096 seat-samples per update)
    num_steps, learning_rate, gamma, gae_lambda = 1024, 2.5e-4, 0.99, 0.95
    num_minibatches, update_epochs, clip_coef, ent_coef, vf_coef, max_grad_norm = 4, 4, 0.1, 0.01, 0.5, 0.5

    # seeding
    np.random.seed(seed)
    torch.manual_seed(seed)
    torch.set_num_threads(1)

    env = make(GAME)
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
    env_steps, start, counted_from, counted_steps = 0, 0.0, None, 0
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
            np.random.shuffle(b_inds)
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
            counted_from, start = env_steps, now
            continue
        counted_steps = env_steps - counted_from
        if now - start >= seconds:
            break
    elapsed = time.perf_counter() - start
    return {"env_steps_per_s": round(counted_steps / elapsed), "env_steps": counted_steps,
            "seconds": round(elapsed, 2), "updates": len(iteration_returns) - 1,
            "episode_return_first": _first_finite(iteration_returns),
            "episode_return_last": _first_finite(reversed(iteration_returns))}


def _first_finite(values) -> float | None:
    for v in values:
        if v is not None and np.isfinite(v):
            return round(float(v), 3)
    return None


# --- driver ------------------------------------------------------------------------------------------

WORKERS = {"ours": run_ours, "cleanrl_style": run_cleanrl_style}


def run_processes(kind: str, seconds: float, seeds: list[int]) -> list[dict]:
    """``kind`` in one process per seed, all at once; each pinned to its own core when possible."""
    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    procs = []
    for i, seed in enumerate(seeds):
        cmd = [sys.executable, __file__, "--worker", kind, "--seconds", str(seconds), "--seed", str(seed)]
        if len(cores) >= len(seeds):
            cmd = ["taskset", "-c", str(cores[i]), *cmd]
        procs.append(subprocess.Popen(cmd, stdout=subprocess.PIPE, env=env, text=True))
    outputs = []
    for proc in procs:
        out, _ = proc.communicate()
        if proc.returncode != 0:
            raise RuntimeError(f"benchmark worker {kind} failed with exit code {proc.returncode}")
        outputs.append(json.loads(out.strip().splitlines()[-1]))
    return outputs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="measured seconds per learner and setting")
    parser.add_argument("--worker", choices=sorted(WORKERS), help=argparse.SUPPRESS)
    parser.add_argument("--seed", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(WORKERS[args.worker](args.seconds, args.seed)))
        return
    has_taskset = subprocess.run(["which", "taskset"], capture_output=True, check=False).returncode == 0
    results = {}
    for kind in ("ours", "cleanrl_style"):
        one = run_processes(kind, args.seconds, [0])[0] if has_taskset else WORKERS[kind](args.seconds, 0)
        two = run_processes(kind, args.seconds, [1, 2])
        results[kind] = {"one_process": one, "two_processes": {
            "env_steps_per_s": sum(r["env_steps_per_s"] for r in two), "runs": two}}
    ours, ref = results["ours"], results["cleanrl_style"]
    document = {
        "benchmark": "training",
        "game_id": GAME,
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(), "platform": platform.platform(),
                    "load_average_at_end": [round(x, 2) for x in os.getloadavg()]},
        "settings": {"seconds_per_measure": args.seconds, "torch_threads_per_process": 1,
                     "ours": "8 envs x 128 steps per update, batched forwards",
                     "cleanrl_style": "1 env x 1024 steps per update, one forward per seat",
                     "pinned_one_core_per_process": has_taskset},
        "ours": ours,
        "cleanrl_style": ref,
        "speedup_one_process": round(ours["one_process"]["env_steps_per_s"]
                                     / ref["one_process"]["env_steps_per_s"], 2),
        "speedup_two_processes": round(ours["two_processes"]["env_steps_per_s"]
                                       / ref["two_processes"]["env_steps_per_s"], 2),
    }
    print(json.dumps(document, indent=2))


if __name__ == "__main__":
    main()
