"""EngineBatch: K envs on a game's whole-array engine give EnvList's arrays bit for bit."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from arena_league.envs import make
from arena_league.envs.social import team_tree
from arena_league.training.engine_batch import EngineBatch, engine_fits
from arena_league.training.vector import EnvList, env_batch


def _leaf(seat: int, reward: str, scale: float = 1.0, **params: object) -> dict:
    leaf: dict = {"agent": f"player_{seat}", "scheme": "IS", "reward": reward, "scale": scale}
    if params:
        leaf["params"] = params
    return leaf


#: Snake 2T2P: competitive ranking over collaborative teams, IS progress to food and a time cost.
SNAKE_TEAMS = {"scheme": "CP", "reward": "ranking", "scale": 5, "params": {"order": "survive", "tie_penalty": 0.25},
               "children": [{"scheme": "CL", "reward": "team_target", "scale": 2,
                             "children": [_leaf(2 * t, "target"), _leaf(2 * t + 1, "time_penalty", 0.1)]}
                            for t in range(2)]}
#: Snake 2T2P: the food shared out between a mixed win/loss pair and a collaborative pair.
SNAKE_MIXED = {"scheme": "CP", "reward": "resource_share", "children": [
    {"scheme": "CC", "reward": "team_win_loss", "scale": 3, "children": ["player_0", "player_2"]},
    {"scheme": "CL", "reward": "team_living_longer", "scale": 0.5, "children": ["player_1", "player_3"]}]}
#: GoBang 2T2P: mixed win/loss, a time cost for the teams, a constant on the first step.
GOBANG_MIXED = {"scheme": "CC", "reward": "team_win_loss", "scale": 2, "children": [
    {"scheme": "CL", "reward": "team_living_shorter", "scale": 0.01,
     "children": [_leaf(0, "time_penalty", 0.1), "player_1"]},
    {"scheme": "NL", "reward": "constant", "params": {"value": 0.5}, "children": ["player_2", "player_3"]}]}
#: Sumo: last standing first, and the motor skills the default tree does not pay.
SUMO_SKILLS = {"scheme": "CP", "reward": "ranking", "scale": 10, "params": {"order": "survive"}, "children": [
    {"scheme": "CL", "reward": "team_target", "children": [_leaf(0, "steady_velocity", 0.3)]},
    {"scheme": "NL", "reward": "none", "children": [_leaf(1, "big_force", 1.0, threshold=0.5)]}]}
#: RunToGoal: the first to arrive wins, with IS progress, heading and falling.
RUN_RACE = {"scheme": "CP", "reward": "ranking", "scale": 10, "children": [
    {"scheme": "IS", "reward": "facing_target", "scale": 0.1, "children": [_leaf(0, "target")]},
    {"scheme": "IS", "reward": "fall", "children": [_leaf(1, "robot_motion", 0.5)]}]}

CASES = [
    pytest.param("Snake-2T2P-v1", {}, 4, 300, id="snake-default"),
    pytest.param("Snake-2T2P-v1", {"tree": SNAKE_TEAMS, "max_cycles": 30}, 3, 200, id="snake-teams-cut"),
    pytest.param("Snake-2T2P-v1", {"tree": SNAKE_MIXED, "size": 12, "n_food": 2}, 5, 200, id="snake-mixed-small"),
    pytest.param("Snake-4T1P-v1", {"tree": team_tree(4, 1, "win_loss", leaf="target"), "render_mode": "rgb_array"},
                 3, 150, id="snake-4p-render"),
    pytest.param("GoBang-2T1P-v1", {"size": 9}, 4, 300, id="gobang-default"),
    pytest.param("GoBang-2T2P-v1", {"tree": GOBANG_MIXED, "max_cycles": 40}, 5, 300, id="gobang-mixed-cut"),
    pytest.param("Sumo-2T1P-v1", {"max_cycles": 50}, 3, 200, id="sumo-default"),
    pytest.param("Sumo-2T1P-v1", {"tree": SUMO_SKILLS, "max_cycles": 40, "anneal": 0.5}, 3, 120, id="sumo-skills"),
    pytest.param("RunToGoal-2T1P-v1", {"tree": RUN_RACE, "max_cycles": 40}, 3, 120, id="runtogoal-race"),
    pytest.param("PushBox-2T2P-v1", {"max_cycles": 25}, 3, 80, id="pushbox-default"),
    pytest.param("YouShallNotPass-2T1P-v1", {"max_cycles": 30}, 3, 100, id="youshallnotpass-default"),
    pytest.param("CaptureFlag-2T2P-v1", {"max_cycles": 60, "rows": 7, "cols": 10, "captures_to_win": 1}, 4, 200,
                 id="captureflag-small"),
    pytest.param("CaptureFlag-2T1P-v1", {"tree": team_tree(2, 1, "win_loss", leaf="target"), "max_cycles": 40}, 3,
                 120, id="captureflag-target"),
    pytest.param("Boomer-2T2P-v1", {}, 4, 150, id="boomer-default"),
    pytest.param("Boomer-4T1P-v1", {"max_cycles": 15, "size": 9, "n_rigid": 16, "n_wood": 24, "n_items": 8}, 3, 100,
                 id="boomer-4p-cut-small"),
]


def _same(expected: np.ndarray | None, got: np.ndarray | None, what: str, step: int) -> None:
    if expected is None or got is None:
        assert expected is None and got is None, f"{what} at step {step}: one side has none"
        return
    assert got.dtype == expected.dtype and got.shape == expected.shape, (
        f"{what} at step {step}: {got.dtype}{got.shape}, expected {expected.dtype}{expected.shape}")
    if got.tobytes() != expected.tobytes():
        where = np.argwhere(got != expected)[:4].tolist()
        raise AssertionError(f"{what} at step {step} differs at {where}")


def _actions(batch: EnvList, rng: np.random.Generator) -> np.ndarray:
    k, n = batch.n_envs, batch.n_agents
    if not batch.discrete:
        return rng.uniform(-1.0, 1.0, (k, n, batch.act_dim)).astype(np.float32)
    actions = rng.integers(batch.n_actions, size=(k, n))
    if batch.masked:
        # mostly legal moves (a random legal cell), now and then any cell: an illegal move ends the game
        masks = batch.action_masks()
        legal = np.argmax(rng.random(masks.shape) * masks, axis=2)
        actions = np.where(rng.random((k, n)) < 0.98, legal, actions)
    return actions


@pytest.mark.parametrize(("game_id", "kwargs", "n_envs", "steps"), CASES)
def test_engine_batch_matches_env_list(game_id: str, kwargs: dict, n_envs: int, steps: int) -> None:
    def env_fn():
        return make(game_id, **kwargs)

    engine = env_batch(env_fn, n_envs)
    assert isinstance(engine, EngineBatch)
    envs = EnvList([env_fn() for _ in range(n_envs)])
    for attribute in ("n_envs", "n_agents", "obs_dim", "state_dim", "discrete", "n_actions", "act_dim",
                      "turn_based", "masked", "game_id"):
        assert getattr(engine, attribute) == getattr(envs, attribute), attribute
    assert np.array_equal(engine.team_of, envs.team_of)
    rng = np.random.default_rng(37)
    seeds = np.random.default_rng(3)
    for k in range(n_envs):
        seed = int(seeds.integers(2**32))
        envs.reset(k, seed)
        engine.reset(k, seed)
    endings = 0
    try:
        for step in range(steps):
            if step == steps // 2:
                # a training run's checkpoint pickles its envs mid-episode: they go on as they were
                engine, old = pickle.loads(pickle.dumps(engine)), engine
                old.close()
            _same(envs.observations(), engine.observations(), "observations", step)
            _same(envs.acting(), engine.acting(), "acting", step)
            _same(envs.action_masks(), engine.action_masks(), "action masks", step)
            _same(envs.states(), engine.states(), "states", step)
            actions = _actions(envs, rng)
            rewards, ended = envs.step(actions)
            got_rewards, got_ended = engine.step(actions)
            _same(rewards, got_rewards, "rewards", step)
            _same(ended, got_ended, "endings", step)
            _same(envs.observations(), engine.observations(), "observations after the step", step)
            for k in np.flatnonzero(ended):
                endings += 1
                _same(envs.team_result(k), engine.team_result(k), f"team result of env {k}", step)
                seed = int(seeds.integers(2**32))
                envs.reset(k, seed)
                engine.reset(k, seed)
    finally:
        engine.close()
    assert endings >= n_envs, f"only {endings} episodes ended in {steps} steps: the test saw too few endings"


def test_env_batch_keeps_env_list_where_the_engine_cannot_build_the_observations() -> None:
    board_tree = {"scheme": "CP", "reward": "win_loss", "children": [
        {"scheme": "CL", "reward": "team_living_longer", "board": 2, "children": ["player_0", "player_1"]},
        {"scheme": "CL", "reward": "team_living_longer", "children": ["player_2", "player_3"]}]}
    for env_fn in (lambda: make("Snake-2T2P-v1", state_in_obs=True), lambda: make("Snake-2T2P-v1", tree=board_tree),
                   lambda: make("Crossroads-2T1P-v1")):
        assert not engine_fits(env_fn())
        batch = env_batch(env_fn, 2)
        assert isinstance(batch, EnvList) and batch.n_envs == 2
        with pytest.raises(ValueError, match="EnvList"):
            EngineBatch(env_fn(), 2)
    with pytest.raises(ValueError, match="num_envs"):
        env_batch(lambda: make("Snake-2T1P-v1"), 0)


def test_engine_batch_refuses_what_an_env_refuses() -> None:
    batch = EngineBatch(make("Snake-2T1P-v1"), 2)
    batch.reset(0, 1)
    with pytest.raises(RuntimeError, match="env 1's episode is over"):
        batch.step(np.zeros((2, 2), dtype=np.int64))
    batch.reset(1, 2)
    with pytest.raises(ValueError, match="seed"):
        batch.reset(0, -1)
    with pytest.raises(ValueError, match="shape"):
        batch.step(np.zeros(2, dtype=np.int64))
    with pytest.raises(ValueError, match="action 4 of player_1 in env 0"):
        batch.step(np.array([[0, 4], [0, 0]]))
    robots = EngineBatch(make("Sumo-2T1P-v1"), 2)
    try:
        robots.reset(0, 1)
        robots.reset(1, 2)
        actions = np.zeros((2, 2, robots.act_dim), dtype=np.float32)
        actions[1, 0, 3] = np.nan
        with pytest.raises(ValueError, match="player_0 in env 1"):
            robots.step(actions)
    finally:
        robots.close()
