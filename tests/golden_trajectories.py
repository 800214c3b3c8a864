"""Digests of seeded episodes of every game, to show a change of the engines changes nothing a user sees.

For every game id and action type, 20 episodes from seeds 0..19 are played with actions drawn from
a generator seeded by the episode's seed (legal actions where the game masks them). Every step's
observations, rewards, termination, truncation, global state, events, action mask and, at the end,
the teams' results go into one SHA-256 per episode. ``tests/data/golden_trajectories.json`` holds the
digests recorded before the 2D games moved onto one engine; ``test_envs_golden.py`` plays them again.

    python tests/golden_trajectories.py [--games ID ...]   # prints the digests as JSON
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

from arena_league.envs import game_spec, list_games, make

EPISODES = 20
GOLDEN = Path(__file__).parent / "data" / "golden_trajectories.json"


def _events_bytes(events: list) -> bytes:
    return json.dumps(events, sort_keys=True, default=lambda value: np.asarray(value).tolist()).encode()


def episode_digest(env, action_type: str, seed: int) -> str:
    rules = env.rules
    rng = np.random.default_rng(seed)
    digest = hashlib.sha256()
    obs = env.reset_arrays(seed=seed)
    masked = hasattr(rules, "action_mask") and env._masked
    n = rules.n_agents
    while True:
        digest.update(np.ascontiguousarray(obs).tobytes())
        digest.update(np.ascontiguousarray(env.state()).tobytes())
        if action_type == "discrete":
            if masked:
                mask = np.asarray(rules.action_mask(), dtype=bool)
                digest.update(mask.tobytes())
                actions = np.array([rng.choice(np.flatnonzero(row)) if row.any() else 0 for row in mask],
                                   dtype=np.int64)
            else:
                actions = rng.integers(0, rules.n_actions, size=n).astype(np.int64)
        else:
            actions = rng.uniform(-1.0, 1.0, size=(n, rules.act_dim))
        obs, rewards, terminated, truncated = env.step_arrays(actions)
        digest.update(np.asarray(rewards, dtype=np.float64).tobytes())
        digest.update(bytes([terminated, truncated]))
        digest.update(_events_bytes(rules.events()))
        if terminated or truncated:
            digest.update(np.ascontiguousarray(obs).tobytes())
            digest.update(np.asarray(env.team_result(), dtype=np.float64).tobytes())
            return digest.hexdigest()[:32]


def game_digests(game_id: str, action_type: str, episodes: int = EPISODES) -> list[str]:
    env = make(game_id, action_type=action_type)
    return [episode_digest(env, action_type, seed) for seed in range(episodes)]


def configurations(games: list[str] | None = None) -> list[tuple[str, str]]:
    out = []
    for game_id in games or list_games():
        for action_type in game_spec(game_id).rules.action_types:
            out.append((game_id, action_type))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--games", nargs="*")
    args = parser.parse_args(argv)
    out = {f"{game_id} {action_type}": game_digests(game_id, action_type)
           for game_id, action_type in configurations(args.games)}
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
