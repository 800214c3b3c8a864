"""Paired matches, the envs' side: each game declares its match format, each half of a pair gives its
``pair_points``, the same from the env and from the whole-array engines; YouShallNotPass scores its
runs (crossed sooner is better, otherwise the centimetres its runner got toward the goal line)."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

from arena_league.envs import game_spec, list_games, make, make_aec
from arena_league.envs.catalog import registered_rules
from arena_league.envs.core import MATCH_FORMATS
from arena_league.envs.games.youshallnotpass import BLOCKER, RUNNER, YouShallNotPassRules, run_score
from arena_league.envs.robots import StartPose, stand

YSNP = "YouShallNotPass-2T1P-v1"


def ysnp_actions(rules: YouShallNotPassRules, runner: str, blocker: str, rng: np.random.Generator) -> np.ndarray:
    """Both seats' torques: each side ``"heuristic"``, ``"stand"`` (holds the standing pose) or ``"random"``."""
    return seat_actions(rules.observe(), runner, blocker, rng)


def seat_actions(obs: np.ndarray, runner: str, blocker: str, rng: np.random.Generator) -> np.ndarray:
    """:func:`ysnp_actions` from the seats' observations."""
    actions = YouShallNotPassRules.heuristic(obs, "continuous").astype(np.float32)
    for seat, how in ((RUNNER, runner), (BLOCKER, blocker)):
        if how == "stand":
            actions[seat] = stand(obs[seat: seat + 1])[0]
        elif how == "random":
            actions[seat] = rng.uniform(-1.0, 1.0, 8)
    return actions


def ysnp_half(runner: str, blocker: str, seed: int = 0, max_cycles: int = 400, **options):
    """One half played to its end on the env; returns the env."""
    env = make(YSNP, max_cycles=max_cycles, **options)
    env.reset_arrays(seed)
    rng = np.random.default_rng(100 + seed)
    while True:
        _, _, terminated, truncated = env.step_arrays(ysnp_actions(env.rules, runner, blocker, rng))
        if terminated or truncated:
            return env


# --- YouShallNotPass's runs ---------------------------------------------------------------------------------
def test_a_run_that_crosses_scores_above_one_and_sooner_scores_more():
    long_field = ysnp_half("heuristic", "stand", field_length=6.0)
    short_field = ysnp_half("heuristic", "stand", field_length=4.0)
    standing = ysnp_half("stand", "stand")
    for env in (long_field, short_field):
        assert env.team_result().tolist() == [1.0, 0.0], "the heuristic runner gets past a standing blocker"
        steps = env.step_count
        assert env.pair_points().tolist() == [1.0 + (400 - steps) / 400, 0.0]
    assert short_field.step_count < long_field.step_count
    assert short_field.pair_points()[RUNNER] > long_field.pair_points()[RUNNER] > 1.0
    assert standing.pair_points()[RUNNER] < 1.0 < long_field.pair_points()[RUNNER]


def test_a_runner_that_never_moves_scores_about_nothing_and_the_blocker_always_nothing():
    still = ysnp_half("stand", "random", start_jitter=0.0)
    assert still.step_count == 400 and still.team_result().tolist() == [0.0, 1.0]
    assert still.pair_points()[RUNNER] <= 0.01
    for env in (still, ysnp_half("heuristic", "random", seed=1), ysnp_half("random", "heuristic", seed=2)):
        assert env.pair_points()[BLOCKER] == 0.0
        assert env.pair_points().dtype == np.float64 and env.pair_points().shape == (2,)


def test_a_fallen_runner_scores_where_it_fell_in_centimetres_of_the_field():
    rules = YouShallNotPassRules(2, 1)
    rules.reset(0)
    # the runner on its back 1.5 m past its start line (x = -2.5): it has fallen at the first step
    rules.arrange(StartPose(np.array([[-1.0, 0.0], [0.5, 0.0]]), np.array([0.0, np.pi]), np.zeros((0, 2)),
                            np.zeros(0), np.array([np.pi, 0.0])))
    rules.step(np.zeros((2, 8), np.float32))
    assert rules.game_over and rules.events() == [{"kind": "fall", "seat": RUNNER}]
    points = rules.pair_points()
    assert points[BLOCKER] == 0.0
    assert points[RUNNER] == pytest.approx(1.5 / 5.0, abs=0.011)
    centimetres = points[RUNNER] * 500
    assert centimetres == pytest.approx(round(centimetres), abs=1e-9)


def test_runs_are_rounded_to_centimetres_so_runs_within_one_draw():
    assert run_score(0, 2.504, 5.0, 400) == run_score(0, 2.496, 5.0, 400) == 0.5
    assert run_score(0, 2.51, 5.0, 400) == 2.51 / 5.0 > 0.5
    assert run_score(0, -0.3, 5.0, 400) == 0.0, "behind the start line"
    assert run_score(0, 4.999, 5.0, 400) == 4.99 / 5.0 < 1.0, "short of the line is short of crossing"
    assert run_score(400, 5.0, 5.0, 400) == 1.0 and run_score(1, 5.0, 5.0, 400) == 1.0 + 399 / 400
    assert run_score(100, 5.0, 5.0, 400) > run_score(101, 5.0, 5.0, 400)
    env = ysnp_half("heuristic", "heuristic", seed=0, max_cycles=60)  # cut long before the line
    assert env.step_count == 60 and 0.0 < env.pair_points()[RUNNER] < 1.0
    centimetres = env.pair_points()[RUNNER] * 500
    assert centimetres == pytest.approx(round(centimetres), abs=1e-9)


# --- the whole-array engines give what the env gives ----------------------------------------------------------
def _policy(game_id: str, seed: int):
    """Deterministic actions of one match from its observation and its own generator."""
    if game_id == YSNP:
        runner, blocker = [("heuristic", "stand"), ("heuristic", "random"), ("random", "heuristic"),
                           ("stand", "random")][seed % 4]

        return lambda obs, rng: seat_actions(obs, runner, blocker, rng)
    rules_cls, n_actions = game_spec(game_id).rules, make(game_id).rules.n_actions

    def act(obs, rng):  # the heuristic, now and then any move (an illegal one loses at once)
        actions = rules_cls.heuristic(obs, "discrete")
        explore = rng.random(len(obs)) < 0.3
        return np.where(explore, rng.integers(n_actions, size=len(obs)), actions).astype(np.int64)
    return act


def _on_env(game_id: str, seed: int, max_cycles: int) -> tuple[np.ndarray, np.ndarray, int]:
    env = make(game_id, max_cycles=max_cycles)
    obs = env.reset_arrays(seed)
    act, rng = _policy(game_id, seed), np.random.default_rng(1000 + seed)
    while True:
        obs, _, terminated, truncated = env.step_arrays(act(obs, rng))
        if terminated or truncated:
            return env.team_result(), env.pair_points(), env.step_count


def _on_engine(game_id: str, seeds: list[int], max_cycles: int) -> list[tuple[np.ndarray, np.ndarray, int]]:
    spec = game_spec(game_id)
    rules = make(game_id).rules
    engine = spec.rules.batched_matches(rules, len(seeds), max_cycles)
    try:
        for slot, seed in enumerate(seeds):
            engine.start(slot, seed)
        acts = [_policy(game_id, seed) for seed in seeds]
        rngs = [np.random.default_rng(1000 + seed) for seed in seeds]
        out: dict[int, tuple[np.ndarray, np.ndarray, int]] = {}
        while len(out) < len(seeds):
            obs = engine.observe()  # a finished slot's actions are ignored
            actions = np.stack([acts[slot](obs[slot], rngs[slot]) for slot in range(len(seeds))])
            ended = engine.step(actions)
            for slot in np.flatnonzero(ended):
                out[int(slot)] = (engine.team_result(int(slot)), engine.pair_points(int(slot)), engine.steps(int(slot)))
    finally:
        if hasattr(engine, "close"):
            engine.close()
    return [out[slot] for slot in range(len(seeds))]


@pytest.mark.parametrize("game_id, seeds, max_cycles", [
    (YSNP, [0, 1, 2, 3, 4, 5, 6, 7], 200),
    ("GoBang-2T1P-v1", [0, 1, 2, 3], 400),
    ("Snake-2T1P-v1", [0, 1, 2, 3], 150),
])
def test_the_batched_engine_gives_the_envs_pair_points_slot_by_slot(game_id, seeds, max_cycles):
    single = [_on_env(game_id, seed, max_cycles) for seed in seeds]
    batched = _on_engine(game_id, seeds, max_cycles)
    for (result, points, steps), (engine_result, engine_points, engine_steps) in zip(single, batched):
        assert engine_steps == steps
        assert np.array_equal(engine_result, result)
        assert np.array_equal(engine_points, points) and engine_points.dtype == np.float64
    if game_id == YSNP:
        runs = [points[RUNNER] for _, points, _ in single]
        assert any(run > 1.0 for run in runs) and any(run < 1.0 for run in runs), "both kinds of run were compared"
    else:
        assert all(np.array_equal(points, result) for result, points, _ in single)


# --- what each game declares --------------------------------------------------------------------------------
def test_every_game_declares_a_valid_format_and_only_youshallnotpass_is_paired_today():
    for game_id in list_games():
        spec = game_spec(game_id)
        assert spec.rules.match_format in MATCH_FORMATS
        assert spec.paired == (spec.rules.match_format == "paired")
    assert [g for g in list_games() if game_spec(g).paired] == [YSNP]


@pytest.mark.parametrize("game_id", [g for g in list_games() if not game_spec(g).paired])
def test_a_single_games_pair_points_are_its_team_result(game_id):
    env = make(game_id, max_cycles=25)
    env.reset(seed=3)
    rng = np.random.default_rng(3)
    while env.agents:
        env.step({agent: env.action_space(agent).sample() if env.rules.action_type == "continuous"
                  else env.rules.random_action(seat, rng)
                  for seat, agent in enumerate(env.possible_agents) if agent in env.agents})
    assert np.array_equal(env.pair_points(), env.team_result())
    assert env.pair_points().shape == (env.rules.n_teams,)


def test_the_native_aec_env_gives_pair_points_beside_team_result():
    env = make_aec("GoBang-2T1P-v1")
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in env.agent_iter():
        obs, _, terminated, truncated, _ = env.last()
        legal = np.flatnonzero(obs["action_mask"])
        env.step(None if terminated or truncated else int(legal[rng.integers(len(legal))]))
    assert np.array_equal(env.pair_points(), env.team_result())


class _PairedTriple(YouShallNotPassRules):
    name = "PairedTriple"
    layouts = ((3, 1),)


class _Pairs(YouShallNotPassRules):
    name = "Pairs"
    match_format = "pairs"


def test_the_catalog_refuses_a_paired_game_of_three_teams_and_an_unknown_format():
    with pytest.raises(ValueError, match=r"^PairedTriple declares match_format 'paired' but offers 3T1P: a pair "
                                         r"swaps the seats of two teams; declare 'single'"), \
            registered_rules(_PairedTriple):
        pass
    with pytest.raises(ValueError, match=r"^Pairs declares match_format 'pairs'; valid: 'single', 'paired'$"), \
            registered_rules(_Pairs):
        pass
    assert "PairedTriple-3T1P-v1" not in list_games() and "Pairs-2T1P-v1" not in list_games()


# --- copies ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("runner", ["heuristic", "stand"])
def test_a_copy_mid_half_ends_with_the_same_pair_points(runner):
    max_cycles = 250
    env = make(YSNP, max_cycles=max_cycles)
    env.reset_arrays(4)
    rng = np.random.default_rng(4)
    for _ in range(60):
        env.step_arrays(ysnp_actions(env.rules, runner, "random", rng))
    copies = [env, pickle.loads(pickle.dumps(env)), copy.deepcopy(env), None]
    rules_alone = pickle.loads(pickle.dumps(env.rules))  # the rules keep the cut they are played to
    assert rules_alone.max_cycles == max_cycles
    rngs = [copy.deepcopy(rng) for _ in copies]
    ended = []
    for k, twin in enumerate(copies[:3]):
        while True:
            _, _, terminated, truncated = twin.step_arrays(ysnp_actions(twin.rules, runner, "random", rngs[k]))
            if terminated or truncated:
                break
        ended.append((twin.step_count, twin.pair_points()))
    steps = 60
    while not rules_alone.game_over and steps < max_cycles:  # the env's own stepping, on the rules alone
        rules_alone.step(ysnp_actions(rules_alone, runner, "random", rngs[3]))
        steps += 1
    if not rules_alone.game_over:
        rules_alone.finish()
    ended.append((steps, rules_alone.pair_points()))
    assert all(steps == ended[0][0] and np.array_equal(points, ended[0][1]) for steps, points in ended)
    if runner == "heuristic":
        assert ended[0][1][RUNNER] > 1.0
