"""Fighter: bunkers from the seed (mirrored, apart, the same for the same seed), the seat frames,
shots (hits and hit points, bunkers, reload, teammates passed), the ends of a match (the last
fighter destroyed, a cut match by damage), the observation and measures, determinism and copies,
the heuristic against random play, the default tree and the controls."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from physics2d_matches import (
    assert_a_copy_goes_on_as_the_original,
    assert_replays_bit_for_bit,
    heuristic_wins,
)

from arena_league.envs.games.fighter import FighterControls, FighterRules
from arena_league.envs.games.fighter.arena import COLS, HALF_X, HALF_Y, POSITION_UNIT, ROWS
from arena_league.envs.physics2d.shots import FIRE_ACTION

NOOP, E, N, W, S = 0, 1, 3, 5, 7
FIRE = FIRE_ACTION
EAST, WEST = (1.0, 0.0), (-1.0, 0.0)
BOTTOM = -HALF_Y + 0.5  # the bottom row's centre line: never a bunker


def rules(players: int = 1, action_type: str = "discrete", seed: int = 0, **kwargs) -> FighterRules:
    r = FighterRules(2, players, action_type, **kwargs)
    r.reset(seed)
    return r


def actions(*moves: int) -> np.ndarray:
    return np.array(moves, dtype=np.int64)


def events_of(r: FighterRules, moves: np.ndarray, steps: int) -> list[dict]:
    seen = []
    for _ in range(steps):
        r.step(moves)
        seen += r.events()
        if r.game_over:
            break
    return seen


# --- bunkers ------------------------------------------------------------------------------------------
def test_bunkers_are_mirrored_apart_and_the_same_for_the_same_seed():
    for seed in range(10):
        kinds = rules(seed=seed).kinds.copy()
        assert np.array_equal(kinds, kinds[:, ::-1]) and np.array_equal(kinds, rules(seed=seed).kinds)
        # open: the two columns by each wall, the two in the middle, the top and bottom rows
        for col in (0, 1, COLS // 2 - 1, COLS // 2, COLS - 2, COLS - 1):
            assert not kinds[:, col].any()
        assert not kinds[0].any() and not kinds[ROWS - 1].any()
        # four pairs of bunkers, none touching another (diagonally either)
        labels, count = np.zeros_like(kinds, dtype=int), 0
        for row, col in zip(*np.nonzero(kinds)):
            if labels[row, col]:
                continue
            count += 1
            stack = [(row, col)]
            while stack:
                r, c = stack.pop()
                if 0 <= r < ROWS and 0 <= c < COLS and kinds[r, c] and not labels[r, c]:
                    labels[r, c] = count
                    stack += [(r + dr, c + dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1)]
        assert count == 8
    assert not np.array_equal(rules(seed=0).kinds, rules(seed=1).kinds)
    assert (rules(bunker_pairs=1).kinds > 0).sum() <= 6


def test_each_seat_sees_at_the_start_what_its_counterpart_sees():
    for players in (1, 2):
        obs = rules(players, seed=7).observe()
        assert np.array_equal(obs[:players], obs[players:])


# --- shots --------------------------------------------------------------------------------------------
def test_hits_cost_hit_points_and_the_last_fighter_destroyed_loses():
    r = rules(hit_points=2)
    r.place([(-7.0, BOTTOM), (-3.0, BOTTOM)], [EAST, WEST])
    seen = events_of(r, actions(FIRE, NOOP), 12)
    assert [e["kind"] for e in seen] == ["fire", "hit", "fire", "hit", "destroyed"]
    assert seen[1] == {"kind": "hit", "seat": 0, "target": 1, "hit_points": 1}
    assert r.game_over and r.team_result().tolist() == [1.0, 0.0] and r.measures.outcome.tolist() == [1.0, -1.0]
    assert r.damage.tolist() == [2.0, 0.0] and r.measures.alive.tolist() == [True, False]


def test_a_bunker_stops_a_shell():
    r = rules(seed=3)
    row = int(np.nonzero(r.kinds)[0][0])
    y = -HALF_Y + row + 0.5
    r.place([(-7.5, y), (7.5, y)], [EAST, WEST])
    seen = events_of(r, actions(FIRE, NOOP), 15)
    assert [e["kind"] for e in seen if e["kind"] != "fire"] == [] and r.hits_left.tolist() == [5, 5]


def test_a_gun_fires_once_per_reload():
    r = rules()
    r.place([(-7.0, BOTTOM), (-5.0, BOTTOM)], [EAST, WEST])
    fired = [t for t in range(7) for e in events_of(r, actions(FIRE, NOOP), 1) if e["kind"] == "fire"]
    assert fired == [0, 3, 6]  # each shell hits within a step, then the gun takes 3 to reload


def test_shells_pass_teammates_and_hit_the_opponent_behind():
    r = rules(players=2)
    r.place([(-7.0, BOTTOM), (-5.0, BOTTOM), (-3.0, BOTTOM), (7.0, HALF_Y - 0.5)], [EAST, EAST, WEST, WEST])
    seen = events_of(r, actions(FIRE, NOOP, NOOP, NOOP), 4)
    assert {"kind": "hit", "seat": 0, "target": 2, "hit_points": 4} in seen
    assert not any(e.get("target") == 1 for e in seen)


def test_a_cut_match_goes_to_the_team_that_did_more_damage_else_a_draw():
    r = rules()
    r.place([(-7.0, BOTTOM), (-3.0, BOTTOM)], [EAST, WEST])
    events_of(r, actions(FIRE, NOOP), 4)
    r.finish()
    assert r.team_result().tolist() == [1.0, 0.0] and r.measures.outcome.tolist() == [1.0, -1.0]
    r = rules()
    r.finish()
    assert r.team_result().tolist() == [0.5, 0.5]


def test_a_destroyed_fighter_collides_with_nothing_and_its_actions_do_nothing():
    r = rules(players=2, hit_points=1)
    r.place([(-7.0, BOTTOM), (-7.0, HALF_Y - 0.5), (-5.0, BOTTOM), (7.0, 0.0)], [EAST, EAST, WEST, WEST])
    events_of(r, actions(FIRE, NOOP, NOOP, NOOP), 2)
    assert r.measures.active.tolist() == [True, True, False, True] and not r.game_over
    wreck = r.world.table[2, 0:2].copy()
    events_of(r, actions(E, NOOP, W, NOOP), 15)
    assert r.world.table[0, 0] > wreck[0] + 1.0 and np.array_equal(r.world.table[2, 0:2], wreck)
    assert r.measures.energy[2] == 0.0


# --- observation and measures ---------------------------------------------------------------------------
def test_observation_and_measures_in_the_seat_frame():
    r = rules(players=2)
    r.place([(-6.0, 1.0), (-6.0, -1.0), (2.0, 1.0), (6.0, -1.0)], [EAST, EAST, WEST, WEST])
    obs, at = r.observe(), r.layout.at
    assert obs[0, at("position"): at("position") + 2] == pytest.approx((-6.0 / POSITION_UNIT, 1.0 / POSITION_UNIT))
    assert obs[2, at("position"): at("position") + 2] == pytest.approx((-2.0 / POSITION_UNIT, 1.0 / POSITION_UNIT))
    assert obs[2, at("heading"): at("heading") + 2].tolist() == [1.0, 0.0]  # facing +x in its own frame
    assert obs[0, at("other_1"): at("other_1") + 2] == pytest.approx((8.0 / POSITION_UNIT, 0.0))
    assert not obs[:, at("shell_0_flying"): at("bunkers")].any()  # no shell flies
    assert obs.shape == (4, 213) and rules().obs_dim == 187 and r.state_dim == 14 * 4 + 160
    assert r.measures.target_distance.tolist() == pytest.approx([8.0, np.hypot(8.0, 2.0), 8.0, 12.0])
    assert r.measures.facing_target[0] == pytest.approx(1.0)
    plane = obs[2, at("bunkers"):].reshape(ROWS, COLS)
    assert np.array_equal(plane, r.kinds[:, ::-1] > 0)  # mirrored, and the same as the world's (symmetric)


def test_same_seed_same_actions_bit_identical_whatever_was_played_before():
    assert_replays_bit_for_bit(lambda: FighterRules(2, 2, "discrete"), ("active", "target_distance", "outcome"),
                               steps=60, detour=25)


@pytest.mark.parametrize("copier", [lambda r: pickle.loads(pickle.dumps(r)), copy.deepcopy], ids=["pickle", "deepcopy"])
def test_a_copy_mid_match_goes_on_bit_for_bit_as_the_original(copier):
    assert_a_copy_goes_on_as_the_original(rules(players=2, seed=4), copier, n_actions=10)


# --- the heuristic, the tree, the controls ------------------------------------------------------------------
@pytest.mark.parametrize("players, action_type, matches", [(1, "discrete", 16), (2, "discrete", 16),
                                                          (1, "continuous", 6), (2, "continuous", 6)])
def test_heuristic_beats_random_teams(players, action_type, matches):
    wins = heuristic_wins(FighterRules, players, action_type, matches)
    assert wins >= 0.9 * matches, wins


def test_heuristic_fires_along_a_clear_diagonal_and_turns_to_face_one():
    r = rules(seed=2)
    r.place([(-7.5, -HALF_Y + 0.5), (-7.5 + 0.7, -HALF_Y + 1.2)], [(np.sqrt(0.5), np.sqrt(0.5)), WEST])
    assert FighterRules.heuristic(r.observe(), "discrete")[0] == FIRE
    r.place([(-7.5, -HALF_Y + 0.5), (-7.5 + 0.7, -HALF_Y + 1.2)], [EAST, WEST])
    assert FighterRules.heuristic(r.observe(), "discrete")[0] == 2  # NE


def test_heuristic_does_not_shoot_into_a_bunker():
    r = rules(seed=3)
    row = int(np.nonzero(r.kinds)[0][0])
    y = -HALF_Y + row + 0.5
    r.place([(-7.5, y), (7.5, y)], [EAST, WEST])
    assert FighterRules.heuristic(r.observe(), "discrete")[0] != FIRE


def test_default_tree_ranks_by_survival_and_aims_each_fighter():
    tree = FighterRules.default_tree(2, 2)
    assert tree["reward"] == "ranking" and tree["params"] == {"order": "survive"}
    assert [child["reward"] for child in tree["children"]] == ["team_living_longer"] * 2
    assert {leaf["reward"] for child in tree["children"] for leaf in child["children"]} == {"facing_target"}


def test_controls_mirror_moves_for_the_second_team_and_fire_with_f():
    r = rules()
    first, second = r.human_controls(0), r.human_controls(1)
    assert isinstance(second, FighterControls)
    assert first.parse("e") == (E, None) and second.parse("e") == (W, None) and second.parse("n") == (N, None)
    assert second.parse("f") == (FIRE, None) and first.web()["keys"][" "] == "f"
    assert r.observe().shape[1] == r.obs_dim and HALF_X == 8.0


def test_heuristic_takes_any_batch_of_observations_and_refuses_another_games():
    obs = rules(players=2).observe()
    assert FighterRules.heuristic(obs, "discrete").shape == (4,)
    assert FighterRules.heuristic(obs[1:2], "continuous").shape == (1, 3)
    with pytest.raises(ValueError, match="not Fighter's"):
        FighterRules.heuristic(np.zeros((2, 369)), "discrete")


def test_tuned_heuristics_parse_are_bounded_and_default_to_the_heuristic():
    from arena_league.policies.scripted import scripted_policy

    game = "Fighter-2T1P-v1"
    tuned = scripted_policy("heuristic-dodge4-lead0.5", game)
    assert tuned.name == "heuristic-dodge4-lead0.5" and tuned.options == {"dodge": 4.0, "lead": 0.5}
    with pytest.raises(ValueError, match="dodge must be from 0 to 10, not 12"):
        scripted_policy("heuristic-dodge12", game)
    r = rules(players=2, seed=5)
    moves = np.random.default_rng(0)
    batch = []
    for _ in range(12):  # a few steps of random play: fighters moving, shells in flight
        r.step(moves.integers(0, 10, size=4))
        batch.append(r.observe())
    obs = np.concatenate(batch)
    for action_type in ("discrete", "continuous"):
        plain = FighterRules.heuristic(obs, action_type)
        np.testing.assert_array_equal(FighterRules.heuristic(obs, action_type, dodge=0.0, lead=0.0), plain)


def test_a_dodging_heuristic_sidesteps_a_shell_coming_its_way():
    r = rules(seed=2)
    r.place([(-6.0, BOTTOM), (-2.0, BOTTOM)], [EAST, WEST])
    r.step(actions(NOOP, FIRE))  # the opponent's shell flies west along the fighter's row
    obs = r.observe()
    assert FighterRules.heuristic(obs, "discrete")[0] == FIRE
    assert FighterRules.heuristic(obs, "discrete", dodge=4.0)[0] in (2, N, 4)  # NE, N or NW: the wall is south
    assert FighterRules.heuristic(obs, "discrete", dodge=2.0)[0] == FIRE  # not due within 2 steps
