"""The lockstep runner: same specs, same results whatever the batch size; one call per policy per step."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs import game_spec, list_games, make
from arena_league.matchmaking import (
    AgentRef,
    LockstepRunner,
    MatchResult,
    PolicyError,
    action_spec_of,
    load_agents,
    play_matches,
    policy_units,
    round_robin,
    specs_for_seatings,
)
from arena_league.policies.architecture import Architecture
from arena_league.policies.families import TorchPolicy
from arena_league.policies.scripted import HeuristicPolicy, RandomPolicy
from arena_league.policies.threads import torch_threads


@pytest.fixture(autouse=True, scope="module")
def one_torch_thread():
    """Small batched forwards run fastest on one thread (waking a thread pool costs more than they do)."""
    with torch_threads(1):
        yield


def _scripted(game_id):
    return {name: AgentRef("scripted", name, game_id) for name in ("random", "heuristic")}


def _league(game_id, matches_per_pair, league_seed=7, first_match_id=0):
    return specs_for_seatings(game_id, round_robin(["random", "heuristic"], matches_per_pair), league_seed,
                              first_match_id)


def test_results_do_not_depend_on_the_batch_size():
    specs = _league("GoBang-2T1P-v1", 10) + _league("Soccer-2T1P-v1", 6, first_match_id=10)
    agents = {**_scripted("GoBang-2T1P-v1")}
    gobang = [s for s in specs if s.game_id.startswith("GoBang")]
    soccer = [s for s in specs if s.game_id.startswith("Soccer")]
    runs = {}
    for batch_size in (1, 7, 64):
        runs[batch_size] = (play_matches(gobang, agents, batch_size=batch_size)
                            + play_matches(soccer, _scripted("Soccer-2T1P-v1"), batch_size=batch_size,
                                           env_kwargs={"max_cycles": 60}))
    assert runs[1] == runs[7] == runs[64]
    results = runs[7]
    assert [r.match_id for r in results] == [s.match_id for s in gobang + soccer]
    for result in results[:10]:  # GoBang: the heuristic beats uniformly random play
        assert result.outcomes[result.seats.index("heuristic")] == "win"
        assert 0 < result.steps <= 225


def test_stacked_mlp_agents_match_one_forward_per_seat():
    game = "GoBang-2T1P-v1"
    spec = action_spec_of(make(game))
    arch = Architecture("mlp", spec.obs_dim, "discrete", n_actions=spec.n_actions, hidden=(16,))
    policies = {f"mlp-{i}": TorchPolicy(arch, seed=i) for i in range(5)}
    units = policy_units(list(policies.values()))
    assert len(units) == 1 and units[0].stacked  # one batched forward for the whole family
    specs = specs_for_seatings(game, round_robin(list(policies), 1), league_seed=1)
    batched = LockstepRunner(game, policies, batch_size=10).play(specs)
    assert batched == LockstepRunner(game, policies, batch_size=1).play(specs)
    for spec, result in zip(specs[:3], batched):  # each seat's own policy, one row at a time
        env = make(game)
        obs, rng, done = env.reset_arrays(spec.seed), spec.seat_rng(), False
        while not done:
            uniforms, mask = rng.random((2, 1)), env.rules.action_mask()
            actions = np.zeros(2, dtype=np.int64)
            for seat in range(2):
                actions[seat] = policies[spec.seats[seat]].act(obs[seat:seat + 1], uniforms[seat:seat + 1],
                                                               mask[seat:seat + 1])[0][0]
            obs, _, terminated, truncated = env.step_arrays(actions)
            done = terminated or truncated
        assert result == MatchResult.from_team_result(spec, env.rules.team_of, env.team_result(), env.step_count)


class CountingRandom(RandomPolicy):
    """The built-in random agent, counting its calls and rows."""

    def __init__(self, spec):
        super().__init__(spec)
        self.calls = []

    def act(self, obs, uniforms, mask=None, state=None):
        self.calls.append(len(obs))
        return super().act(obs, uniforms, mask, state)


def test_each_policy_makes_one_call_per_step_over_all_its_seats():
    game = "Crossroads-2T2P-v1"
    spec = action_spec_of(make(game))
    policies = {"a": CountingRandom(spec), "b": CountingRandom(spec)}
    specs = specs_for_seatings(game, [("a", "b"), ("b", "a")] * 4, league_seed=2)
    results = LockstepRunner(game, policies, batch_size=8, env_kwargs={"max_cycles": 25}).play(specs)
    assert [r.steps for r in results] == [25] * 8
    for policy in policies.values():
        assert len(policy.calls) == 25  # one call per step
        assert policy.calls[0] == 16  # two seats in each of 8 matches


class OutOfRange(RandomPolicy):
    def act(self, obs, uniforms, mask=None, state=None):
        return np.full(len(obs), 99, dtype=np.int64), None


def test_bad_input_is_refused_with_the_reason():
    game = "Crossroads-2T1P-v1"
    spec = action_spec_of(make(game))
    specs = specs_for_seatings(game, [("bad", "ok")])
    with pytest.raises(PolicyError, match="'bad'.*invalid action 99"):
        LockstepRunner(game, {"bad": OutOfRange(spec), "ok": RandomPolicy(spec)}).play(specs)
    with pytest.raises(KeyError, match="no policy for agent"):
        LockstepRunner(game, {"ok": RandomPolicy(spec)}).play(specs)
    with pytest.raises(ValueError, match="plays GoBang-2T1P-v1"):
        LockstepRunner(game, {"ok": RandomPolicy(spec)}).play(specs_for_seatings("GoBang-2T1P-v1", [("ok", "ok")]))
    with pytest.raises(ValueError, match="batch_size"):
        LockstepRunner(game, {}, batch_size=0)
    with pytest.raises(TypeError, match="AgentRef"):
        play_matches(specs, {"bad": RandomPolicy(spec), "ok": RandomPolicy(spec)}, backend="process")
    with pytest.raises(ValueError, match="unknown agent kind"):
        AgentRef("pickle", "x.pkl", game)
    with pytest.raises(ValueError, match="unknown scripted agent"):
        load_agents({"x": AgentRef("scripted", "genius", game)})


@pytest.mark.parametrize("game_id, env_kwargs", [("GoBang-2T1P-v1", {}), ("GoBang-2T2P-v1", {}),
                                                 ("GoBang-2T1P-v1", {"max_cycles": 8}),
                                                 ("GoBang-2T1P-v1", {"size": 7, "n_in_row": 4}),
                                                 ("Snake-4T1P-v1", {"max_cycles": 150}),
                                                 ("Snake-2T2P-v1", {"size": 12, "n_food": 2})])
def test_whole_array_engine_plays_exactly_like_one_env_per_match(game_id, env_kwargs):
    spec = action_spec_of(make(game_id, **env_kwargs))
    agents = {"random": RandomPolicy(spec), "heuristic": HeuristicPolicy(game_id, spec)}
    n_teams = game_spec(game_id).n_teams
    seatings = [(a, b) * (n_teams // 2) for a, b in round_robin(list(agents), 6)]
    specs = specs_for_seatings(game_id, seatings, league_seed=3)
    per_env = LockstepRunner(game_id, agents, batch_size=5, env_kwargs=env_kwargs, path="env").play(specs)
    engine = LockstepRunner(game_id, agents, batch_size=5, env_kwargs=env_kwargs)
    assert engine.stepping_path() == "engine"
    assert engine.play(specs) == per_env
    if game_id.startswith("GoBang") and "max_cycles" in env_kwargs:
        assert {r.steps for r in per_env} == {8} and {r.outcomes for r in per_env} == {("draw", "draw")}


@pytest.mark.parametrize("game_id", list_games())
def test_every_path_gives_the_env_results(game_id):
    env_kwargs = {"max_cycles": 40}
    agents = load_agents(_scripted(game_id))
    n_teams = game_spec(game_id).n_teams
    seatings = [tuple((["random", "heuristic"] * n_teams)[shift: shift + n_teams]) for shift in (0, 1)]
    specs = specs_for_seatings(game_id, seatings * 2, league_seed=8)
    expected = LockstepRunner(game_id, agents, batch_size=3, env_kwargs=env_kwargs, path="env").play(specs)
    paths = ["rules"] + (["engine"] if game_spec(game_id).rules.batched_matches is not None else [])
    for path in paths:
        runner = LockstepRunner(game_id, agents, batch_size=3, env_kwargs=env_kwargs, path=path)
        assert runner.stepping_path() == path
        assert runner.play(specs) == expected, path
    # a pair (a game played in pairs) is two matches of at most 40 steps each
    assert all(0 < h.steps <= 40 for r in expected for h in (r.halves or (r,)))
    if n_teams > 2:
        assert all(r.positions is not None and min(r.positions) == 1 for r in expected)


def test_a_runner_for_other_policies_reuses_the_envs_and_plays_as_a_new_runner():
    game_id = "Crossroads-2T1P-v1"
    env_kwargs = {"max_cycles": 30}
    specs = _league(game_id, 4)
    first = load_agents(_scripted(game_id))
    runner = LockstepRunner(game_id, first, batch_size=8, env_kwargs=env_kwargs)
    runner.play(specs)
    envs = runner.envs(8)
    spec = runner.spec
    arch = Architecture("mlp", spec.obs_dim, "discrete", n_actions=spec.n_actions, hidden=(8,))
    # the same keys now name torch agents: the new runner plays on the old runner's envs
    torch_agents = {"random": TorchPolicy(arch, seed=1), "heuristic": TorchPolicy(arch, seed=2)}
    again = runner.with_policies(torch_agents)
    assert all(a is b for a, b in zip(again.envs(8), envs))
    fresh = LockstepRunner(game_id, torch_agents, batch_size=8, env_kwargs=env_kwargs).play(specs)
    assert again.play(specs) == fresh
    assert runner.play(specs) == LockstepRunner(game_id, first, batch_size=8, env_kwargs=env_kwargs).play(specs)
