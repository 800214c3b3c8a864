"""Warm starts by imitation (DAgger on the game's heuristic): the actor comes to play the heuristic's
actions, the warm-started learner beats the random agent before any RL, the run is a function of its
seed, the warm start lands in the snapshots' provenance, and bad options are refused with the fix."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from arena_league.policies import load_agent, scripted_policy
from arena_league.training import PPO, PPOConfig, run_scheme
from arena_league.training.curves import evaluate_learners
from arena_league.training.imitation import WarmStart, warm_start
from arena_league.training.schemes import make_env_fn

GAME = "Crossroads-2T1P-v1"
SMALL = WarmStart(steps=12_000, rounds=3, epochs=6, num_envs=8)


def _ppo(seed: int = 0, **config):
    env_fn = make_env_fn(GAME, max_cycles=120)
    return PPO(env_fn, PPOConfig(num_envs=4, num_steps=32, hidden=(32, 32), **config), seed=seed), env_fn


def _agreement(learner, seed: int = 5) -> float:
    """Share of states from heuristic play where the actor's greedy action is the heuristic's."""
    env_fn = make_env_fn(GAME, max_cycles=120)
    env, rng = env_fn(), np.random.default_rng(seed)
    heuristic = scripted_policy("heuristic", GAME)
    same = total = 0
    obs = env.reset_arrays(seed)
    for _ in range(200):
        expert, _ = heuristic.act(obs, rng.random((len(obs), 1)))
        with torch.no_grad():
            logits, _ = learner.actor(torch.from_numpy(obs[:, : env.rules.obs_dim]), None)
        same += int((logits.argmax(1).numpy() == expert).sum())
        total += len(expert)
        obs, _, terminated, truncated = env.step_arrays(expert)
        if terminated or truncated:
            obs = env.reset_arrays(int(rng.integers(1 << 30)))
    return same / total


def test_warm_start_copies_the_heuristic_and_beats_random():
    ppo, env_fn = _ppo()
    references = {"random": scripted_policy("random", GAME)}
    untrained = evaluate_learners(ppo.learners, GAME, references, 20, env_kwargs={"max_cycles": 120})
    before = _agreement(ppo.learners[0])
    record = warm_start(ppo.learners, env_fn, GAME, SMALL, seed=0)
    after = _agreement(ppo.learners[0])
    assert before < 0.5 and after > 0.7
    assert record["env_steps"] >= 10_000 and record["rows"] > record["env_steps"]
    assert record["fit"][0]["accuracy"] > 0.7
    result = evaluate_learners(ppo.learners, GAME, references, 20, env_kwargs={"max_cycles": 120})
    assert untrained["per_reference"]["random"] < 0.65 and result["per_reference"]["random"] >= 0.8


def test_warm_start_is_a_function_of_its_seed():
    runs = []
    for _ in range(2):
        ppo, env_fn = _ppo(seed=3)
        warm_start(ppo.learners, env_fn, GAME, WarmStart(steps=1_000, rounds=2, epochs=1, num_envs=4), seed=3)
        runs.append(ppo.learners[0].actor_parameters())
    assert all(torch.equal(runs[0][k], runs[1][k]) for k in runs[0])


def test_continuous_actions_are_fitted_by_their_mean():
    env_fn = make_env_fn(GAME, max_cycles=120, action_type="continuous")
    ppo = PPO(env_fn, PPOConfig(num_envs=4, num_steps=32, hidden=(32, 32)), seed=0)
    record = warm_start(ppo.learners, env_fn, GAME, WarmStart(steps=3_000, rounds=2, epochs=4, num_envs=8), seed=0)
    assert record["fit"][0]["mse"] < 0.2
    # the noise is brought down to the residual error, not below the floor (RL still explores)
    log_std = ppo.learners[0].log_std.detach()
    assert torch.all(log_std >= -1.6 - 1e-6) and torch.all(log_std < 0.0)
    assert record["fit"][0]["log_std"] == pytest.approx(float(log_std.mean()))


def test_run_scheme_keeps_the_warm_start_in_the_provenance(tmp_path):
    snapshots = run_scheme("ppo", GAME, steps=128, seed=0, snapshot_every=None, out_dir=tmp_path, max_cycles=40,
                           num_envs=2, num_steps=64, hidden=(8,), critic_hidden=(8,),
                           warm_start={"steps": 500, "rounds": 1, "epochs": 1, "num_envs": 2})
    provenance = snapshots[-1].provenance()
    assert provenance["metrics"]["warm_start"]["options"]["expert"] == "scripted:heuristic"
    assert provenance["steps"] == 128  # RL env steps only; the imitation's are in its record
    assert provenance["metrics"]["warm_start"]["env_steps"] >= 500
    manifest = json.loads((snapshots[-1].path / "manifest.json").read_text())
    assert manifest["provenance"]["metrics"]["warm_start"]["options"]["steps"] == 500
    load_agent(snapshots[-1].path, GAME)  # still a plain arena-policy folder
    run = json.loads((tmp_path / "ppo-seed0" / "run.json").read_text())
    assert run["request"]["warm_start"]["steps"] == 500


@pytest.mark.parametrize("bad, message", [
    ({"stpes": 10}, "unknown warm_start field.*stpes.*valid: expert, steps"),
    ({"steps": 0}, "warm_start.steps must be a positive integer"),
    ({"learning_rate": -1.0}, "warm_start.learning_rate must be positive"),
    ("heuristic", "warm_start must be a dict"),
])
def test_bad_warm_start_options_are_refused_with_the_fix(tmp_path, bad, message):
    with pytest.raises((TypeError, ValueError), match=message):
        run_scheme("ppo", GAME, steps=64, seed=0, snapshot_every=None, out_dir=tmp_path, max_cycles=20,
                   num_envs=2, num_steps=32, hidden=(8,), warm_start=bad)
    assert not (tmp_path / "ppo-seed0" / "run.json").exists()


def test_recurrent_actors_are_refused(tmp_path):
    with pytest.raises(ValueError, match="feed-forward actors.*family='mlp'"):
        run_scheme("ppo", GAME, steps=64, seed=0, snapshot_every=None, out_dir=tmp_path, max_cycles=20,
                   num_envs=2, num_steps=32, family="gru", warm_start=True)


def test_an_unknown_expert_names_the_agent():
    ppo, env_fn = _ppo()
    with pytest.raises(ValueError, match="genius"):
        warm_start(ppo.learners, env_fn, GAME, WarmStart(expert="scripted:genius", steps=100), seed=0)
