"""Self-play: the PFSP weights and the four opponent-sampling rules, seats swapped every episode,
win rates tracked from results, a learner that improves on a tiny game, and a run whose snapshots
load as arena-policy agents and play in the league's match engine."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import torch
from line_race import make_line_race

from arena_league.matchmaking import play_matches, specs_for_seatings
from arena_league.policies import TorchPolicy, load_agent
from arena_league.training import PPOConfig, SelfPlay, pfsp_weights, run_scheme
from arena_league.training.schemes import make_env_fn
from arena_league.training.selfplay import OpponentPool

HURRY = {"scheme": "CP", "reward": "ranking", "scale": 1, "children": [
    {"agent": "player_0", "scheme": "IS", "reward": "time_penalty", "scale": 1},
    {"agent": "player_1", "scheme": "IS", "reward": "time_penalty", "scale": 1}]}
SMALL = PPOConfig(num_envs=8, num_steps=32, learning_rate=3e-3, hidden=(16,), critic_hidden=(16,))


def line_race():
    return make_line_race(2, 1, tree=HURRY)


def test_pfsp_weights():
    x = np.array([0.1, 0.5, 0.9])
    hard = pfsp_weights(x, "hard", p=2.0)
    np.testing.assert_allclose(hard, np.array([0.81, 0.25, 0.01]) / 1.07)
    var = pfsp_weights(x, "variance")
    assert var[1] > var[0] == pytest.approx(var[2])
    np.testing.assert_allclose(pfsp_weights(np.ones(4), "hard"), np.full(4, 0.25))  # nothing left to beat
    with pytest.raises(ValueError, match="'hard' or 'variance'"):
        pfsp_weights(x, "easy")


def test_opponent_sampling_rules():
    pool = OpponentPool(capacity=3)
    for update in range(5):  # the fourth and fifth replace the oldest in place
        pool.add({"w": torch.tensor(float(update))}, update)
    assert len(pool) == 3 and sorted(pool.added_at) == [2, 3, 4]
    assert pool.added_at[pool.latest] == 4
    rng = np.random.default_rng(0)
    assert {pool.sample("latest", rng, 2.0) for _ in range(50)} == {pool.latest}
    assert {pool.sample("uniform", rng, 2.0) for _ in range(200)} == {0, 1, 2}
    draws = np.array([pool.sample("80/20", rng, 2.0) for _ in range(4000)])
    assert (draws == pool.latest).mean() == pytest.approx(0.8, abs=0.025)
    # the learner beats one older member and loses to the other: f_hard picks the one it loses to
    beaten, unbeaten = [i for i in range(3) if i != pool.latest]
    for _ in range(30):
        pool.record(beaten, 1.0)
        pool.record(unbeaten, 0.0)
    assert pool.win_rate[beaten] > 0.9 and pool.win_rate[unbeaten] < 0.1
    draws = np.array([pool.sample("pfsp_hard", rng, 2.0) for _ in range(2000)])
    assert (draws == unbeaten).mean() > 0.6 and (draws == beaten).mean() < 0.02
    # f_var picks the even match: the unplayed latest member, still at its prior 0.5
    draws = np.array([pool.sample("pfsp_var", rng, 2.0) for _ in range(2000)])
    assert (draws == pool.latest).mean() > 0.6


def test_seats_swap_every_episode_and_results_are_tracked():
    sp = SelfPlay(line_race, SMALL, seed=0, opponent_sampling="uniform", pool_every=2)
    record = sp.iterate()
    episodes = sp.collector.collect(sp.learners, 32).episodes
    by_env: dict[int, list[int]] = {}
    for episode in episodes:
        learner_seat = int(np.flatnonzero(episode.controllers == 0)[0])
        by_env.setdefault(episode.env_index, []).append(learner_seat)
    for seats in by_env.values():
        assert all(a != b for a, b in itertools.pairwise(seats))  # team 0, team 1, team 0...
    assert record["pool_size"] == 1 and sum(sp.pool.games) > 0


def test_learner_teams_weight_the_roles_in_turn():
    sp = SelfPlay(line_race, SMALL, seed=0, learner_teams=[0, 1, 1, 1])
    episodes = sp.collector.collect(sp.learners, 64).episodes
    by_env: dict[int, list[int]] = {}
    for episode in episodes:
        by_env.setdefault(episode.env_index, []).append(int(np.flatnonzero(episode.controllers == 0)[0]))
    for k, seats in by_env.items():  # env k's episode e: team learner_teams[(k + e) mod 4]
        assert seats == [[0, 1, 1, 1][(k + e) % 4] for e in range(len(seats))]
    played = [s for seats in by_env.values() for s in seats]
    assert played.count(1) > 2 * played.count(0) > 0


@pytest.mark.parametrize("teams", [[], [0, 2], [True, 0], "01", 1])
def test_learner_teams_refuse_what_is_no_team_list(teams):
    with pytest.raises(ValueError, match="learner_teams must"):
        SelfPlay(line_race, SMALL, seed=0, learner_teams=teams)


def test_self_play_improves_and_beats_its_first_snapshot():
    sp = SelfPlay(line_race, SMALL, seed=1, opponent_sampling="pfsp_hard", pool_every=3)
    returns = [sp.iterate()["episode_return"] for _ in range(12)]
    assert np.mean(returns[-3:]) > np.mean(returns[:2]) + 2.0
    assert len(sp.pool) == 5
    assert sp.pool.win_rate[0] > 0.6  # the learner now outruns the initial, random, self


def test_run_scheme_snapshots_load_and_play(tmp_path):
    game = "Crossroads-2T1P-v1"
    snapshots = run_scheme("sp", game, steps=1500, seed=0, snapshot_every=500, out_dir=tmp_path, max_cycles=30,
                           num_envs=4, num_steps=64, hidden=(16,), opponent_sampling="80/20")
    assert [s.steps for s in snapshots] == [512, 1024, 1536]
    last = snapshots[-1]
    loaded = load_agent(last.path, game)
    assert isinstance(loaded.policy, TorchPolicy) and loaded.info.family == "mlp"
    manifest = loaded.artifact.manifest()
    assert manifest["provenance"]["scheme"] == "sp" and manifest["provenance"]["steps"] == 1536
    assert manifest["provenance"]["metrics"]["opponent_sampling"] == "80/20"
    for name, tensor in loaded.policy.parameters().items():
        assert torch.equal(tensor, last.params[name])
    specs = specs_for_seatings(game, [("first", "last"), ("last", "first")])
    results = play_matches(specs, {"first": load_agent(snapshots[0].path, game).policy, "last": loaded.policy},
                           env_kwargs={"max_cycles": 30})
    assert len(results) == 2


def test_fixed_opponents_take_their_share_and_are_recorded(tmp_path):
    game = "Crossroads-2T1P-v1"
    options = {"steps": 1024, "seed": 3, "snapshot_every": None, "max_cycles": 30, "num_envs": 4, "num_steps": 64,
               "hidden": (16,), "fixed_opponents": ("scripted:random", "scripted:heuristic"), "fixed_share": 0.5}
    first = run_scheme("sp", game, out_dir=tmp_path / "a", **options)
    again = run_scheme("sp", game, out_dir=tmp_path / "b", **options)
    for name, tensor in first[-1].params.items():  # same seed, same opponents drawn, same weights
        assert torch.equal(tensor, again[-1].params[name])
    metrics = load_agent(first[-1].path, game).artifact.manifest()["provenance"]["metrics"]
    assert metrics["fixed_share"] == 0.5
    assert set(metrics["fixed_win_rates"]) == {"scripted:random", "scripted:heuristic"}

    sp = SelfPlay(make_env_fn(game, max_cycles=30), PPOConfig(num_envs=4, num_steps=64, hidden=(16,)), seed=0,
                  fixed_opponents=("scripted:random",), fixed_share=0.5)
    episodes = sp.collector.collect(sp.learners, 256).episodes
    against_fixed = [e for e in episodes if (e.controllers == -1).any()]
    assert 0 < len(against_fixed) < len(episodes)  # both fixed and pool opponents were seated
    assert sp.fixed_rates.games[0] == len(against_fixed)
    assert sum(sp.pool.games) == len(episodes) - len(against_fixed)


@pytest.mark.parametrize(("options", "message"), [
    ({"fixed_share": 1.5, "fixed_opponents": ("scripted:random",)}, "fixed_share must lie in"),
    ({"fixed_share": 0.3}, "needs fixed_opponents"),
    ({"fixed_share": 0.3, "fixed_opponents": ("scripted:nobody",)}, "scripted"),
])
def test_fixed_opponents_refuse_bad_options(options, message):
    with pytest.raises(ValueError, match=message):
        SelfPlay(make_env_fn("Crossroads-2T1P-v1", max_cycles=30), SMALL, seed=0, **options)
