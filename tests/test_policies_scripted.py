"""Built-in scripted agents: random plays uniformly among legal actions from the engine's
uniforms; heuristic is the game's own scripted policy."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs import game_spec, list_games, make
from arena_league.policies import game_action_spec, load_agent, scripted_descriptor, scripted_policy


def test_random_respects_masks_and_is_uniform_over_legal_actions():
    policy = scripted_policy("random", "GoBang-2T1P-v1")
    n, n_actions = 6000, 225
    rng = np.random.default_rng(0)
    mask = np.zeros((n, n_actions), bool)
    mask[:, [3, 17, 200]] = True
    mask[:10, :] = False  # a full board: no legal move, the env ignores the seat
    actions, state = policy.act(np.zeros((n, 455), np.float32), rng.random((n, 1)), mask)
    assert state is None and actions.dtype == np.int64 and actions.shape == (n,)
    assert np.isin(actions[10:], [3, 17, 200]).all()
    assert ((actions[:10] >= 0) & (actions[:10] < n_actions)).all()
    counts = np.bincount(actions[10:], minlength=n_actions)[[3, 17, 200]]
    assert np.abs(counts / counts.sum() - 1 / 3).max() < 0.03


def test_random_is_a_function_of_the_uniforms():
    policy = scripted_policy("random", "Crossroads-2T2P-v1", action_type="continuous")
    uniforms = np.random.default_rng(1).random((8, 2))
    actions, _ = policy.act(np.zeros((8, 25), np.float32), uniforms)
    np.testing.assert_allclose(actions, 2 * uniforms - 1, rtol=1e-6)
    discrete = scripted_policy("random", "Crossroads-2T2P-v1")
    u = np.array([[0.0], [0.19], [0.21], [0.99]])
    np.testing.assert_array_equal(discrete.act(np.zeros((4, 25), np.float32), u)[0], [0, 0, 1, 4])


@pytest.mark.parametrize("game_id", ["Crossroads-2T2P-v1", "Soccer-2T1P-v1", "GoBang-2T1P-v1", "Snake-2T1P-v1"])
def test_heuristic_is_the_games_scripted_policy(game_id):
    env = make(game_id)
    obs = env.reset_arrays(3)
    policy = scripted_policy("heuristic", game_id)
    spec = game_action_spec(game_id)
    for _ in range(5):
        expected = game_spec(game_id).rules.heuristic(obs, spec.action_type)
        mask = env.rules.action_mask()
        actions, _ = policy.act(obs, np.zeros((len(obs), 1)), mask)
        np.testing.assert_array_equal(actions, expected)
        if mask is not None:
            assert mask[np.arange(len(actions)), actions].all()
        obs, _, terminated, truncated = env.step_arrays(actions)
        if terminated or truncated:
            break


def test_every_game_has_both_scripted_agents_and_stable_descriptors():
    for game_id in list_games():
        for name in ("random", "heuristic"):
            assert load_agent(f"scripted:{name}", game_id).info.kind == "scripted"
    assert scripted_descriptor("scripted:heuristic") == scripted_descriptor("heuristic")
    assert scripted_descriptor("random") != scripted_descriptor("heuristic")
    with pytest.raises(ValueError, match="unknown scripted agent 'greedy'"):
        scripted_policy("greedy", "Crossroads-2T2P-v1")


def _differs_from_the_heuristic(game: str, same, others: list, *, seed: int, steps: int) -> list[bool]:
    """Steps a match of ``game`` on the heuristic's own actions, checking that ``same`` plays
    exactly them, and says for each of ``others`` whether it ever played otherwise."""
    env = make(game)
    obs = env.reset_arrays(seed)
    heuristic = scripted_policy("heuristic", game)
    uniforms = np.zeros((len(obs), 1))
    differed = [False] * len(others)
    for _ in range(steps):
        expected, _ = heuristic.act(obs, uniforms)
        np.testing.assert_array_equal(same.act(obs, uniforms)[0], expected)
        differed = [d or not np.array_equal(o.act(obs, uniforms)[0], expected) for d, o in zip(differed, others)]
        obs, _, terminated, truncated = env.step_arrays(expected)
        if terminated or truncated:
            break
    return differed


def test_a_tuned_heuristic_is_the_games_heuristic_with_its_constants():
    """PushBox's heuristic with other constants, named with them: at the heuristic's own values it
    plays the heuristic exactly; at others it plays otherwise; it is refused where a game has no
    such option, out of bounds, or named in a second way."""
    from arena_league.envs.games import pushbox
    from arena_league.policies.scripted import heuristic_options, is_scripted_name

    game = "PushBox-2T2P-v1"
    same = scripted_policy(f"scripted:heuristic-gap{pushbox.PUSH_GAP:g}-kp{pushbox.KP:g}-lane{pushbox.PUSH_LANE:g}-"
                           f"period{pushbox.GAIT_PERIOD:g}-side{pushbox.PUSH_SIDE:g}", game)
    trotting = scripted_policy("heuristic-kp1.75-period0.4", game)
    assert trotting.options == {"kp": 1.75, "period": 0.4}
    tuned = scripted_policy("heuristic-lane0.6-side0.3", game)
    assert tuned.name == "heuristic-lane0.6-side0.3" and tuned.options == {"lane": 0.6, "side": 0.3}
    assert _differs_from_the_heuristic(game, same, [tuned, trotting], seed=0, steps=60) == [True, True]
    assert load_agent("scripted:heuristic-lane0.6-side0.3", game).info.kind == "scripted"
    assert scripted_descriptor("heuristic-lane0.6-side0.3") not in (scripted_descriptor("heuristic"),
                                                                     scripted_descriptor("heuristic-lane0.6"))
    assert heuristic_options("heuristic") is None and is_scripted_name("heuristic-lane0.6")
    for name, words in [("heuristic-side0.3-lane0.6", "alphabetical order.*heuristic-lane0.6-side0.3"),
                        ("heuristic-lane0.60", "written plainly: heuristic-lane0.6$"),
                        ("heuristic-lane0.6-lane0.7", "name each option once")]:
        assert not is_scripted_name(name)
        with pytest.raises(ValueError, match=words):
            scripted_policy(name, game)
    for game_id, name, words in [("GoBang-2T1P-v1", "heuristic-lane0.6",
                                  r"GoBang-2T1P-v1 has no tuned heuristic \(games with one: .*PushBox, .*YouShallNotPass"),
                                 (game, "heuristic-speed2", "no option 'speed'; its options: gap .*kp .*lane .*period .*side"),
                                 (game, "heuristic-period0.2", "period must be from 0.3 to 0.7, not 0.2"),
                                 (game, "heuristic-lane3", "lane must be from 0.1 to 1.5, not 3")]:
        with pytest.raises(ValueError, match=words):
            scripted_policy(name, game_id)


def test_youshallnotpass_tunes_its_heuristics_trot():
    """YouShallNotPass's tuned heuristic takes the trot's constants only: at the heuristic's own
    values it plays the heuristic exactly, on a quicker trot otherwise."""
    from arena_league.envs.robots import gait

    game = "YouShallNotPass-2T1P-v1"
    same = scripted_policy(f"heuristic-kp{gait.KP:g}-period{gait.GAIT_PERIOD:g}", game)
    quick = scripted_policy("heuristic-kp2.25-period0.4", game)
    assert _differs_from_the_heuristic(game, same, [quick], seed=3, steps=40) == [True]
    with pytest.raises(ValueError, match="no option 'lane'; its options: kp .*period"):
        scripted_policy("heuristic-lane0.6", game)
