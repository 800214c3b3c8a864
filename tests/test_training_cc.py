"""CC, the MAPPO-style centralised critic: it learns a tiny team game, its critic reads the global
state and the seat's id while the actor reads the observation only, and it runs through
``run_scheme`` into loadable arena-policy snapshots."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from line_race import make_line_race

from arena_league.policies import load_policy
from arena_league.training import run_scheme
from arena_league.training.cc import CC, CCConfig, CentralCriticLearner, central_critic_features

#: LineRace 2T2P with each team collaborating (CL): a seat earns its team's mean progress per step.
TEAM_TREE = {"scheme": "NL", "reward": "none", "children": [
    {"scheme": "CL", "reward": "team_target", "children": ["player_0", "player_1"]},
    {"scheme": "CL", "reward": "team_target", "children": ["player_2", "player_3"]}]}


def line_race_fn(max_cycles: int = 5):
    return lambda: make_line_race(2, 2, tree=TEAM_TREE, max_cycles=max_cycles)


def test_cc_improves_on_a_cooperative_line_race():
    # In 5 steps a seat can run all 10 units (action 2) only if it always runs; a uniform policy
    # covers about half. The team's return must rise clearly within a dozen short iterations.
    trainer = CC(line_race_fn(), CCConfig(num_envs=8, num_steps=32), seed=0)
    returns = [trainer.iterate()["episode_return"] for _ in range(12)]
    assert returns[0] < 6.0
    assert np.mean(returns[-3:]) > returns[0] + 2.5, returns
    assert np.mean(returns[-3:]) > 8.5, returns


def test_critic_reads_global_state_and_seat_id_while_actor_reads_observation():
    trainer = CC(line_race_fn(), CCConfig(num_envs=2, num_steps=4, update_epochs=1), seed=1)
    learner = trainer.learners[0]
    assert isinstance(learner, CentralCriticLearner)
    rollout = trainer.collector.collect(trainer.learners, 4)
    n = rollout.n_agents
    # the critic's recorded input of every learner row: env.state() of its env, then the one-hot seat
    t_idx, s_idx = np.nonzero(rollout.controllers == 0)
    rows = rollout.critic_inputs[0][t_idx, s_idx]
    state_dim = rollout.states.shape[2]
    np.testing.assert_array_equal(rows[:, :state_dim], rollout.states[t_idx, s_idx // n])
    np.testing.assert_array_equal(rows[:, state_dim:], np.eye(n, dtype=np.float32)[s_idx % n])
    # the actor reads the game's base observation only (3 cells in LineRace)
    assert learner.actor.hidden[0].in_features == 3
    assert learner.critic.hidden[0].in_features == state_dim + n


def test_central_critic_features_layout():
    state = np.array([[0.5, 0.25], [0.75, 1.0]], dtype=np.float32)
    out = central_critic_features(state, np.array([2, 0]), 3)
    np.testing.assert_array_equal(out, [[0.5, 0.25, 0, 0, 1], [0.75, 1.0, 1, 0, 0]])


def test_learner_team_swaps_and_opponents_play_the_other_team():
    trainer = CC(line_race_fn(), CCConfig(num_envs=2, num_steps=8, update_epochs=1), seed=2)
    rollout = trainer.collector.collect(trainer.learners, 8)
    team_of = np.array([0, 0, 1, 1])
    played = set()
    for episode in rollout.episodes:
        learner_teams = set(team_of[episode.controllers == 0].tolist())
        assert len(learner_teams) == 1  # one team per episode, both of its seats
        team = learner_teams.pop()
        assert (episode.controllers[team_of != team] < 0).all()  # snapshots of itself play the other
        played.add(team)
    assert played == {0, 1}  # the learner's team swaps between episodes


def test_cc_is_a_function_of_its_seed():
    def run(seed):
        trainer = CC(line_race_fn(), CCConfig(num_envs=2, num_steps=8, update_epochs=2), seed=seed)
        trainer.iterate()
        trainer.iterate()
        return trainer.learners[0].actor_parameters()

    a, b, c = run(5), run(5), run(6)
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)


def test_cc_runs_end_to_end_through_run_scheme(tmp_path):
    game = "Crossroads-2T2P-v1"
    snapshots = run_scheme("cc", game, steps=128, seed=3, snapshot_every=64, out_dir=tmp_path, max_cycles=16,
                           num_envs=2, num_steps=32, update_epochs=2, opponent="scripted:heuristic")
    assert [s.steps for s in snapshots] == [64, 128]
    for snapshot in snapshots:
        manifest = json.loads((snapshot.path / "manifest.json").read_text())
        assert manifest["provenance"]["scheme"] == "cc"
        assert manifest["provenance"]["metrics"]["opponent"] == "scripted:heuristic"
        policy = load_policy(snapshot.path, game)
        actions, _ = policy.act(np.zeros((3, 25), dtype=np.float32), np.full((3, 1), 0.5))
        assert actions.shape == (3,) and ((actions >= 0) & (actions < 5)).all()
    # MAPPO's values unless overridden
    assert snapshots[0].metrics["config"]["clip_coef"] == CCConfig().clip_coef
    assert snapshots[0].metrics["config"]["update_epochs"] == 2


def test_bad_opponent_and_team_are_refused_with_the_fix(tmp_path):
    with pytest.raises(ValueError, match="team must be a team index 0..1"):
        CC(line_race_fn(), CCConfig(num_envs=1, num_steps=2), team=2)
    with pytest.raises(ValueError, match="opponent_sampling"):
        CC(line_race_fn(), CCConfig(num_envs=1, num_steps=2), opponent_sampling="best")
    with pytest.raises(ValueError, match="scripted"):
        run_scheme("cc", "Crossroads-2T2P-v1", steps=8, seed=0, snapshot_every=None, out_dir=tmp_path,
                   opponent="scripted:clever")
