"""Make the example community submissions in this folder (seeded; run from the repository root):

    PYTHONPATH=. python3 submissions/make_examples.py

Crossroads-2T2P-v1 (Song et al., "Arena", AAAI 2020): a small MLP (25 -> 32 -> 32 -> 5, tanh)
fitted to imitate the game's scripted heuristic by behaviour cloning with DAgger (Ross et al.,
AISTATS 2011): the first data come from the heuristic playing every seat with some random
actions mixed in, then each round the current network plays (sampling its own actions), the
heuristic labels the states it visited, and the network is refitted on everything gathered. It
is written twice: as an ONNX file (``crossroads-2t2p-mlp.onnx``) and as an ``arena-policy``
folder (``crossroads-2t2p-mlp/``) holding the same weights. The script prints JSON: the fit, the
play against the heuristic and against random play, and the sizes.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

from arena_league.envs import make
from arena_league.policies import (
    Architecture,
    TorchPolicy,
    export_onnx,
    init_parameters,
    save_arena_policy,
    scripted_policy,
    validate_submission,
)
from arena_league.policies.families import build_module

GAME = "Crossroads-2T2P-v1"
HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Config:
    """Behaviour-cloning settings."""

    seed: int = 7
    """Seed of everything: matches, exploration, initial weights, minibatch order."""
    hidden: tuple[int, ...] = (32, 32)
    """MLP hidden sizes (the ONNX file is about 9 KB)."""
    expert_matches: int = 24
    """Matches of the heuristic (with exploration) that seed the data set."""
    explore: float = 0.25
    """Chance that a seat plays a random action instead of the heuristic's in those matches."""
    dagger_rounds: int = 3
    """Rounds of: play the network, label with the heuristic, refit."""
    dagger_matches: int = 12
    """Matches the network plays per DAgger round."""
    epochs: int = 80
    """Passes over the data set per fit."""
    batch_size: int = 256
    learning_rate: float = 3e-3
    eval_matches: int = 20
    """Matches per side against each opponent for the reported results."""


def heuristic_labels(obs: np.ndarray) -> np.ndarray:
    return scripted_policy("heuristic", GAME).act(obs, np.zeros((len(obs), 1)))[0]


def collect(play, n_matches: int, seed: int, rng: np.random.Generator) -> np.ndarray:
    """Observations of every active seat over ``n_matches`` played by ``play(obs, uniforms)``."""
    env = make(GAME)
    rows = []
    for match in range(n_matches):
        obs = env.reset_arrays(seed + match)
        done = False
        while not done:
            rows.append(obs[obs[:, 9] > 0.5])  # cell 9: the seat is still driving
            actions = play(obs, rng.random((len(obs), 1)))
            obs, _, terminated, truncated = env.step_arrays(actions)
            done = terminated or truncated
    return np.concatenate(rows)


def fit(arch: Architecture, obs: np.ndarray, labels: np.ndarray, cfg: Config, generator: torch.Generator) -> nn.Module:
    module = build_module(arch, init_parameters(arch, cfg.seed)).train()
    optimiser = torch.optim.Adam(module.parameters(), lr=cfg.learning_rate)
    x, y = torch.from_numpy(obs), torch.from_numpy(labels)
    for _ in range(cfg.epochs):
        for batch in torch.randperm(len(x), generator=generator).split(cfg.batch_size):
            logits, _ = module(x[batch])
            loss = nn.functional.cross_entropy(logits, y[batch])
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
    return module.eval()


def play_against(policy, opponent, n_matches: int, seed: int) -> dict[str, float]:
    """Mean team result (1 win, 0.5 draw, 0 loss) of ``policy`` over matches on each side."""
    env = make(GAME)
    rng = np.random.default_rng(seed)
    results = []
    for match in range(2 * n_matches):
        side = match % 2  # the team ``policy`` drives
        obs = env.reset_arrays(seed + match)
        mine = env.rules.team_of == side
        done = False
        while not done:
            uniforms = rng.random((len(obs), 1))
            actions = opponent.act(obs, uniforms)[0]
            actions[mine] = policy.act(obs[mine], uniforms[mine])[0]
            obs, _, terminated, truncated = env.step_arrays(actions)
            done = terminated or truncated
        results.append(float(env.team_result()[side]))
    return {"mean_team_result": float(np.mean(results)), "matches": len(results)}


def main(cfg: Config = Config()) -> dict:
    torch.set_num_threads(1)
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    generator = torch.Generator().manual_seed(cfg.seed)
    heuristic = scripted_policy("heuristic", GAME)
    random = scripted_policy("random", GAME)
    arch = Architecture("mlp", obs_dim=heuristic.spec.obs_dim, action_type="discrete",
                        n_actions=heuristic.spec.n_actions, hidden=cfg.hidden)

    def explore(obs: np.ndarray, uniforms: np.ndarray) -> np.ndarray:
        actions = heuristic.act(obs, uniforms)[0]
        noisy = uniforms[:, 0] < cfg.explore
        actions[noisy] = random.act(obs[noisy], uniforms[noisy] / cfg.explore)[0]
        return actions

    obs = collect(explore, cfg.expert_matches, 1000 * cfg.seed, rng)
    module = fit(arch, obs, heuristic_labels(obs), cfg, generator)
    for round_ in range(cfg.dagger_rounds):
        policy = TorchPolicy(arch, module.state_dict())
        visited = collect(lambda o, u, p=policy: p.act(o, u)[0], cfg.dagger_matches,
                          1000 * cfg.seed + 100 * (round_ + 1), rng)
        obs = np.concatenate([obs, visited])
        module = fit(arch, obs, heuristic_labels(obs), cfg, generator)

    params = {k: v.detach() for k, v in module.state_dict().items()}
    policy = TorchPolicy(arch, params, name="crossroads-2t2p-mlp")
    with torch.inference_mode():
        accuracy = float((module(torch.from_numpy(obs))[0].argmax(1).numpy() == heuristic_labels(obs)).mean())
    onnx_path = HERE / "crossroads-2t2p-mlp.onnx"
    export_onnx(arch, params, onnx_path, game_id=GAME)
    folder = save_arena_policy(HERE / "crossroads-2t2p-mlp", arch, params, GAME, name="crossroads-2t2p-mlp",
                               description="MLP imitating the Crossroads heuristic (behaviour cloning + DAgger)",
                               provenance={"script": "submissions/make_examples.py", "seed": cfg.seed,
                                           "samples": len(obs)})
    report = {
        "game": GAME,
        "architecture": {"family": arch.family, "hidden": list(arch.hidden), "parameters": arch.n_parameters()},
        "samples": len(obs),
        "imitation_accuracy": accuracy,
        "vs_heuristic": play_against(policy, heuristic, cfg.eval_matches, 90_000),
        "vs_random": play_against(policy, random, cfg.eval_matches, 95_000),
        "onnx_bytes": onnx_path.stat().st_size,
        "validation": {str(p.relative_to(HERE.parent)): validate_submission(p, GAME).ok for p in (onnx_path, folder)},
    }
    return report


if __name__ == "__main__":
    json.dump(main(), sys.stdout, indent=2)
    print()
