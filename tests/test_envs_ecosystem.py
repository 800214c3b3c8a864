"""Every game id with the PettingZoo ecosystem's own tools: copies of the native AEC env and of
rules set by hand, SuperSuit's vector envs, PettingZoo's API test with its action-mask sampling, its
render test, and cells clipped to their bounds. Copies of every env at every point of an episode and
observations inside finite spaces are checks of ``arena_league.envs.check``, run over the catalog
in ``test_envs_conformance.py``."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
import supersuit
from pettingzoo.test import parallel_api_test, render_test
from pettingzoo.utils.conversions import parallel_to_aec

from arena_league.envs import game_spec, list_games, make, make_aec
from arena_league.envs.games.soccer import VELOCITY_BOUND, VELOCITY_UNIT
from arena_league.envs.rendering import DisplayError

GAMES = list_games()
TURN_BASED = [g for g in GAMES if game_spec(g).rules.turn_based]
MASKED = [g for g in GAMES if game_spec(g).rules.masks_actions]
MAX_CYCLES = 12


def _same(a, b) -> bool:
    """Equal bit for bit, through the dicts and tuples the PettingZoo API hands out."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (tuple, list)):
        return type(a) is type(b) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b)
    return type(a) is type(b) and a == b


def _play(env, steps: int, seed: int) -> list:
    """``steps`` steps of seeded random legal actions, a reset without a seed (the env's own seed
    sequence) whenever an episode ends; everything the env hands out, and its state."""
    rng = np.random.default_rng(seed)
    trace = []
    for _ in range(steps):
        if not env.agents:
            trace.append(env.reset())
        actions = {a: env.rules.random_action(i, rng) for i, a in enumerate(env.possible_agents)}
        trace += [env.step(actions), env.state(), env.step_count]
    return trace


# --- copies ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("game_id", TURN_BASED)
def test_a_copy_of_the_native_aec_env_goes_on_as_the_original(game_id):
    original = make_aec(game_id)
    original.reset(seed=0)
    for _ in range(7):
        original.step(int(np.flatnonzero(original.observe(original.agent_selection)["action_mask"])[3]))
    duplicate = copy.deepcopy(original)
    moves = {}
    for name, env in (("original", original), ("copy", duplicate)):
        moves[name] = []
        for agent in env.agent_iter(40):
            obs, reward, terminated, truncated, _ = env.last()
            action = None if terminated or truncated else int(np.flatnonzero(obs["action_mask"])[5])
            moves[name].append((agent, obs, reward, terminated, truncated, action))
            env.step(action)
    assert _same(moves["copy"], moves["original"])


def test_copies_keep_what_was_set_on_the_rules():
    soccer = make("Soccer-2T1P-v1", max_cycles=50)
    soccer.reset(seed=0)
    soccer.rules.place([[-1.0, 0.0], [1.0, 0.5]], ball_xy=(0.0, 0.3), ball_velocity=(1.5, -0.5))
    sumo = make("Sumo-2T1P-v1", max_cycles=20)
    sumo.reset(seed=0)
    sumo.rules.set_anneal(0.25)
    for env in (soccer, sumo):
        duplicate = pickle.loads(pickle.dumps(env))
        assert _same(_play(duplicate, 30, seed=9), _play(env, 30, seed=9))
    assert pickle.loads(pickle.dumps(sumo)).rules.anneal == 0.25


# --- SuperSuit ---------------------------------------------------------------------------------------
def _supersuit_seeds(n_envs: int, num_cpus: int, seed: int) -> list[int]:
    """The seed of each copy's first reset in ``concat_vec_envs_v1(...).reset(seed=seed)``: its
    ``ConcatVecEnv`` resets copy ``j`` with ``seed + j``; with worker processes (``num_cpus`` > 1)
    the copies are split into ``ceil(n_envs / num_cpus)`` per worker and worker ``w`` is reset
    with ``seed + w``, so its copy ``j`` gets ``seed + w + j`` (neighbouring workers' seeds
    overlap). Later resets, after an episode ends, come without a seed."""
    if num_cpus <= 1:
        return [seed + k for k in range(n_envs)]
    per_worker = -(-n_envs // num_cpus)
    return [seed + k // per_worker + k % per_worker for k in range(n_envs)]


def _vector_env_against_plain_loop(game_id: str, num_cpus: int, steps: int) -> list[list[int]]:
    """SuperSuit's vector env of 4 copies of ``game_id`` beside 4 fresh envs seeded as SuperSuit
    seeds its copies, stepped with the same seeded random actions: observations, rewards and
    episode ends must agree; returns the episode lengths of each."""
    n_envs, seed, max_cycles = 4, 100, 40
    template = make(game_id, max_cycles=max_cycles)
    rules = template.rules
    assert rules.action_mask() is None  # every action legal: uniform random actions are legal ones
    vector = supersuit.concat_vec_envs_v1(supersuit.pettingzoo_env_to_vec_env_v1(template), num_vec_envs=n_envs,
                                          num_cpus=num_cpus, base_class="gymnasium")
    plain = [make(game_id, max_cycles=max_cycles) for _ in range(n_envs)]
    agents = template.possible_agents
    try:
        obs, _ = vector.reset(seed=seed)
        firsts = [env.reset(seed=s)[0] for env, s in zip(plain, _supersuit_seeds(n_envs, num_cpus, seed))]
        assert np.array_equal(obs, np.stack([o[a] for o in firsts for a in agents]))
        rng = np.random.default_rng(0)
        lengths: list[list[int]] = [[] for _ in plain]
        vector_lengths: list[list[int]] = [[] for _ in plain]
        running = np.zeros(n_envs, dtype=np.int64)
        for _ in range(steps):
            actions = rng.integers(rules.n_actions, size=n_envs * len(agents))
            obs, rewards, terminations, truncations, _ = vector.step(actions)
            running += 1
            ended = (terminations | truncations).reshape(n_envs, len(agents)).all(axis=1)
            for k in np.flatnonzero(ended):
                vector_lengths[k].append(int(running[k]))
                running[k] = 0
            expected_obs, expected_rewards = [], []
            for k, env in enumerate(plain):
                out, reward, terminated, truncated, _ = env.step(
                    {a: int(actions[k * len(agents) + i]) for i, a in enumerate(agents)})
                if all(terminated.values()) or all(truncated.values()):
                    lengths[k].append(env.step_count)
                    out, _ = env.reset()
                expected_obs += [out[a] for a in agents]
                expected_rewards += [reward[a] for a in agents]
            assert np.array_equal(obs, np.stack(expected_obs))
            assert np.array_equal(rewards, np.array(expected_rewards, dtype=np.float32))
    finally:
        vector.close()
    assert vector_lengths == lengths
    return lengths


@pytest.mark.parametrize("game_id", ["Crossroads-2T2P-v1",
                                     # 8,000 steps of the slowest grid game, SuperSuit's and the plain loop's
                                     pytest.param("Snake-2T2P-v1", marks=pytest.mark.slow)])
def test_supersuit_vector_env_copies_play_as_fresh_envs(game_id):
    lengths = _vector_env_against_plain_loop(game_id, num_cpus=0, steps=1000)
    assert min(len(episodes) for episodes in lengths) >= 1000 // 40


def test_supersuit_vector_env_on_worker_processes_plays_as_fresh_envs():
    # num_cpus=2: SuperSuit's process-based vector env, whose workers build their envs from pickled copies
    lengths = _vector_env_against_plain_loop("Snake-2T2P-v1", num_cpus=2, steps=200)
    assert len({tuple(episodes) for episodes in lengths}) > 1  # the four copies play different matches


# --- PettingZoo's API test and action masks -----------------------------------------------------------
@pytest.mark.parametrize("game_id", MASKED)
def test_masked_games_observe_pettingzoo_dicts_and_the_api_test_plays_legal_moves(game_id):
    env = make(game_id)
    space = env.observation_space("player_0")
    assert set(space) == {"observation", "action_mask"}
    assert space["action_mask"].dtype == np.int8 and space["action_mask"].shape == (env.rules.n_actions,)
    assert space["observation"] is env.vector_observation_space("player_0")
    obs, infos = env.reset(seed=0)
    assert all(space.contains(o) for o in obs.values()) and infos == {a: {} for a in env.possible_agents}
    # the dict holds exactly the vector the array API (and an exported agent) reads
    arrays = make(game_id).reset_arrays(seed=0)
    assert all(np.array_equal(obs[a]["observation"], arrays[i]) for i, a in enumerate(env.possible_agents))

    illegal = []
    rules_step = env.rules.step

    def checked_step(actions):
        mover = env.rules.current_player()
        illegal.append(not env.rules.action_mask()[mover, actions[mover]])
        rules_step(actions)

    env.rules.step = checked_step
    parallel_api_test(env, num_cycles=300)
    assert len(illegal) > 20 and not any(illegal), "PettingZoo's sampler must play legal moves only"


# --- rendering ---------------------------------------------------------------------------------------
def _fast(env):
    env.metadata["render_fps"] = 1000  # a window paces frames at render_fps; the test draws at once
    return env


@pytest.mark.parametrize("game_id", GAMES)
def test_pettingzoo_render_test(game_id, monkeypatch):
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    render_test(lambda render_mode=None: parallel_to_aec(_fast(make(game_id, render_mode=render_mode,
                                                                     max_cycles=MAX_CYCLES))))
    if game_id in TURN_BASED:
        render_test(lambda render_mode=None: _fast(make_aec(game_id, render_mode=render_mode, max_cycles=MAX_CYCLES)))


def test_human_rendering_without_a_display_fails_at_make_with_the_fix(monkeypatch):
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    with pytest.raises(DisplayError, match=r"no display.*render_mode='rgb_array'.*SDL_VIDEODRIVER=dummy"):
        make("Crossroads-2T2P-v1", render_mode="human")
    assert make("Crossroads-2T2P-v1", render_mode="rgb_array").render_mode == "rgb_array"


def test_a_window_pygame_cannot_open_fails_at_render_with_the_fix(monkeypatch):
    import pygame

    pygame.display.quit()
    monkeypatch.setenv("SDL_VIDEODRIVER", "no-such-video-driver")
    env = make("Snake-2T1P-v1", render_mode="human")
    with pytest.raises(DisplayError, match=r"could not start pygame's display.*render_mode='rgb_array'"):
        env.reset(seed=0)


def test_a_human_window_shows_the_top_down_picture(monkeypatch):
    import pygame

    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = _fast(make("Soccer-2T1P-v1", render_mode="human"))
    picture = _fast(make("Soccer-2T1P-v1", render_mode="rgb_array"))
    env.reset(seed=4)
    picture.reset(seed=4)
    assert env.render() is None
    shown = pygame.surfarray.array3d(pygame.display.get_surface()).swapaxes(0, 1)
    assert np.array_equal(shown, picture.render())
    duplicate = pickle.loads(pickle.dumps(env))  # the window stays with its env; the copy opens its own
    env.close()
    assert not pygame.display.get_init()
    duplicate.step(dict.fromkeys(duplicate.possible_agents, 1))
    assert pygame.display.get_init() and duplicate.render() is None
    duplicate.close()


def test_cells_beyond_their_bounds_are_clipped():
    env = make("Soccer-2T1P-v1")
    env.reset(seed=0)
    env.rules.place([[-1.0, 0.0], [1.0, 0.0]], ball_xy=(0.0, 0.0), ball_velocity=(40.0, 0.0))
    vector = env.rules.observe()
    assert vector[0, 9] == VELOCITY_BOUND and vector[1, 9] == -VELOCITY_BOUND  # 40 m/s, seen clipped
    assert env.state()[4 * 2 + 2] == VELOCITY_BOUND
    assert 40.0 / VELOCITY_UNIT > VELOCITY_BOUND
    assert all(env.observation_space(a).contains(vector[i]) for i, a in enumerate(env.possible_agents))
