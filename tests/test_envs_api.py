"""Every game id: PettingZoo's API tests, 200-step determinism, headless top-down render, bad input,
and what each game declares for the layers above (a person's controls, its replay scene)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test

from arena_league.envs import game_spec, list_games, make, make_aec
from arena_league.envs.controls import Controls
from arena_league.replay.schemas import scene_update_schema

GAMES = list_games()
TURN_BASED = [g for g in GAMES if game_spec(g).rules.turn_based]
VARIANTS = [(g, a) for g in GAMES for a in game_spec(g).rules.action_types]


def test_catalog_has_the_first_four_games_in_team_layouts():
    names = {g.split("-")[0] for g in GAMES}
    assert {"Crossroads", "Soccer", "GoBang", "Snake"} <= names
    for game in ("Crossroads", "Soccer"):
        assert f"{game}-2T1P-v1" in GAMES and f"{game}-2T2P-v1" in GAMES
    assert "Crossroads-2T4P-v1" in GAMES


@pytest.mark.parametrize("game_id, action_type", VARIANTS)
def test_parallel_api(game_id, action_type):
    parallel_api_test(make(game_id, action_type=action_type), num_cycles=200)


@pytest.mark.parametrize("game_id", TURN_BASED)
# masked games observe PettingZoo's classic dicts, about which its API test always warns
@pytest.mark.filterwarnings("ignore:Observation (space for each agent probably|is not a NumPy array):UserWarning")
def test_aec_api(game_id):
    api_test(make_aec(game_id), num_cycles=200)


def _vectors(obs, env):
    """Every seat's observation vector, and its action mask in games with illegal actions."""
    if env.rules.masks_actions:
        return np.stack([np.concatenate([obs[a]["observation"], obs[a]["action_mask"]]) for a in env.possible_agents])
    return np.stack([obs[a] for a in env.possible_agents])


def _random_rollout(game_id, action_type, seed, steps=200):
    env = make(game_id, action_type=action_type)
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    trace = [_vectors(obs, env)]
    episode = 0
    for _ in range(steps):
        if not env.agents:
            episode += 1
            obs, _ = env.reset(seed=seed + episode)
            trace.append(_vectors(obs, env))
        actions = {a: env.rules.random_action(i, rng) for i, a in enumerate(env.possible_agents)}
        obs, rewards, term, trunc, _ = env.step(actions)
        trace.append(_vectors(obs, env))
        trace.append(np.array([rewards[a] for a in env.possible_agents]))
        trace.append(np.array([[term[a], trunc[a]] for a in env.possible_agents]))
    trace.append(env.state())
    return trace


@pytest.mark.parametrize("game_id, action_type", VARIANTS)
def test_same_seed_same_trajectory_over_200_steps(game_id, action_type):
    first = _random_rollout(game_id, action_type, seed=7)
    second = _random_rollout(game_id, action_type, seed=7)
    assert len(first) == len(second)
    for a, b in zip(first, second):
        assert a.dtype == b.dtype and a.shape == b.shape
        assert np.array_equal(a, b), "same seed and actions must give bit-identical trajectories"
    other = _random_rollout(game_id, action_type, seed=8)
    assert any(not np.array_equal(a, b) for a, b in zip(first, other) if a.shape == b.shape)


@pytest.mark.parametrize("game_id", GAMES)
def test_top_down_render_is_headless(game_id, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    env = make(game_id, render_mode="rgb_array")
    env.reset(seed=0)
    env.step({a: env.rules.random_action(i, np.random.default_rng(0)) for i, a in enumerate(env.agents)})
    picture = env.render()
    assert picture.dtype == np.uint8 and picture.ndim == 3 and picture.shape[2] == 3
    assert picture.shape[0] >= 64 and picture.shape[1] >= 64
    assert len(np.unique(picture.reshape(-1, 3), axis=0)) > 2, "the picture shows the arena, not a blank"
    assert make(game_id).render() is None


@pytest.mark.parametrize("game_id", GAMES)
def test_state_and_state_in_observation(game_id):
    env = make(game_id, state_in_obs=True)
    obs, _ = env.reset(seed=1)
    state = env.state()
    assert state.shape == env.state_space.shape and state.dtype == np.float32
    base = env.rules.obs_dim
    for agent in env.possible_agents:
        vector = obs[agent]["observation"] if env.rules.masks_actions else obs[agent]
        assert vector.shape == (base + state.shape[0],)
        assert np.array_equal(vector[base:], state)


def test_unknown_game_id_lists_valid_ids():
    with pytest.raises(ValueError) as err:
        make("Crossroad-2T2P-v1")
    assert "unknown game id 'Crossroad-2T2P-v1'" in str(err.value) and "Crossroads-2T2P-v1" in str(err.value)
    with pytest.raises(ValueError, match="Soccer is offered as: Soccer-2T1P-v1"):
        make("Soccer-5T5P-v1")
    with pytest.raises(ValueError, match=r"ids follow '<Game>-<x>T<y>P-v<N>'"):
        make("soccer")


def test_action_type_and_turn_based_errors():
    with pytest.raises(ValueError, match="GoBang-2T1P-v1 has no continuous action variant; valid: 'discrete'"):
        make("GoBang-2T1P-v1", action_type="continuous")
    with pytest.raises(ValueError, match="unknown action_type 'analog'"):
        make("Crossroads-2T2P-v1", action_type="analog")
    with pytest.raises(ValueError, match="no native AEC env"):
        make_aec("Crossroads-2T2P-v1")


@pytest.mark.parametrize("game_id", [g for g in GAMES if "continuous" in game_spec(g).rules.action_types][:2])
def test_continuous_actions_out_of_range_or_wrong_shape(game_id):
    env = make(game_id, action_type="continuous")
    env.reset(seed=0)
    dim = env.rules.act_dim
    good = {a: np.zeros(dim, np.float32) for a in env.agents}
    with pytest.raises(ValueError, match="out of range; every component must be finite and within"):
        env.step({**good, "player_0": np.full(dim, 1.5, np.float32)})
    with pytest.raises(ValueError, match=f"continuous actions are {dim} floats"):
        env.step({**good, "player_1": np.zeros(dim + 1, np.float32)})
    with pytest.raises(ValueError, match="not NaN|finite"):
        env.step({**good, "player_0": np.full(dim, np.nan, np.float32)})


#: Answers some game's controls take (Enter, an action number, a cell, a direction).
SAMPLE_ANSWERS = ("", "1", "h8", "w", "d 3")


@pytest.mark.parametrize("game_id", GAMES)
def test_every_game_declares_a_persons_controls_and_its_replay_scene(game_id):
    env = make(game_id)
    env.reset(seed=0)
    rules = env.rules
    rng = np.random.default_rng(0)
    for seat in (0, rules.n_agents - 1):
        controls = rules.human_controls(seat)
        assert isinstance(controls, Controls) and controls.seat == seat
        assert controls.view().strip() and controls.prompt(0).strip() and controls.final_view().strip()
        command, problem = controls.parse("%%")  # nonsense is refused with what to type instead
        assert command is None and isinstance(problem, str) and problem
        accepted = [answer for answer in SAMPLE_ANSWERS if controls.parse(answer)[1] is None]
        assert accepted, f"{game_id}: the controls take none of {SAMPLE_ANSWERS}"
        assert controls.wants_command()
        action = controls.action(controls.parse(accepted[0])[0])
        actions = {a: rules.random_action(i, rng) for i, a in enumerate(env.possible_agents)}
        env.step({**actions, f"player_{seat}": action})  # the env takes the person's action as it is
    required = scene_update_schema()["properties"]["entities"]["items"]["required"]
    first = rules.scene_entities(1_500_000_000)
    assert first and json.loads(json.dumps(first, allow_nan=False)) == first
    ids = [e["id"] for e in first]
    assert len(set(ids)) == len(ids)
    for entity in first:
        assert set(required) <= set(entity) and entity["frame_id"] == "arena"
        assert entity["timestamp"] == {"sec": 1, "nsec": 500_000_000}
    if env.agents:
        env.step({a: rules.random_action(i, rng) for i, a in enumerate(env.agents)})
    assert [e["id"] for e in rules.scene_entities(1_600_000_000)] == ids  # ids stay: updates replace entities


@pytest.mark.parametrize("game_id", [g for g in GAMES if "continuous" in game_spec(g).rules.action_types
                                     and "discrete" in game_spec(g).rules.action_types])
def test_the_default_controls_ask_for_the_discrete_variant(game_id):
    env = make(game_id, action_type="continuous")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action_type='discrete'"):
        env.rules.human_controls(0)
