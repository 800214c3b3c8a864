"""BattleCity: the maze from the seed (symmetric, open, the same for the same seed), the seat frames,
shots (bricks broken, steel, hits and hit points, reload, one shell in flight, teammates passed),
the ends of a match (a base shot, the last tank destroyed, a cut match by hit points), tanks out
of play, the observation cell by cell, determinism and copies, the heuristic against random play,
the default tree and the controls."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from physics2d_matches import (
    assert_a_copy_goes_on_as_the_original,
    assert_replays_bit_for_bit,
    heuristic_wins,
    play,
)

from arena_league.envs.games.battlecity import FIRE_ACTION, BattleCityControls, BattleCityRules
from arena_league.envs.games.battlecity.maze import (
    BASE,
    BASE_RING,
    BRICK,
    GRID,
    HALF,
    RELOAD_STEPS,
    STEEL,
    base_tiles,
    start_tiles,
    tile_centre,
    turned,
)

NOOP, E, N, W, S = 0, 1, 3, 5, 7
FIRE = FIRE_ACTION
UP, DOWN, RIGHT = (0.0, 1.0), (0.0, -1.0), (1.0, 0.0)


def rules(players: int = 1, action_type: str = "discrete", seed: int = 0, **kwargs) -> BattleCityRules:
    r = BattleCityRules(2, players, action_type, **kwargs)
    r.reset(seed)
    return r


def open_maze(*tiles: tuple[int, int, int]) -> np.ndarray:
    """A maze with nothing but the two bases and the given ``(row, col, kind)`` tiles."""
    kinds = np.zeros((GRID, GRID), dtype=np.int8)
    for tile in base_tiles():
        kinds[tile] = BASE
    for row, col, kind in tiles:
        kinds[row, col] = kind
    return kinds


def actions(*moves: int) -> np.ndarray:
    return np.array(moves, dtype=np.int64)


# --- the maze ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("players", [1, 2])
def test_the_maze_is_the_same_under_the_half_turn_and_the_same_for_the_same_seed(players):
    for seed in range(8):
        kinds = rules(players, seed=seed).kinds.copy()
        assert np.array_equal(kinds, kinds[::-1, ::-1])
        assert np.array_equal(kinds, rules(players, seed=seed).kinds)
        for tile in base_tiles():
            assert kinds[tile] == BASE
        for tile in BASE_RING:
            assert kinds[tile] == BRICK and kinds[turned(*tile)] == BRICK
        for row, col in start_tiles(players):
            assert kinds[row, col] == 0
    assert not np.array_equal(rules(seed=0).kinds, rules(seed=1).kinds)


def test_every_open_or_brick_tile_can_be_reached_from_the_starts_without_crossing_steel():
    for seed in range(10):
        kinds = rules(seed=seed, steel_density=0.2).kinds
        passable = (kinds == 0) | (kinds == BRICK)
        seen = {start_tiles(1)[0]}
        frontier = list(seen)
        while frontier:
            row, col = frontier.pop()
            for r, c in ((row + 1, col), (row - 1, col), (row, col + 1), (row, col - 1)):
                if 0 <= r < GRID and 0 <= c < GRID and passable[r, c] and (r, c) not in seen:
                    seen.add((r, c))
                    frontier.append((r, c))
        assert len(seen) == passable.sum()


def test_densities_shape_the_maze():
    empty = rules(brick_density=0.0, steel_density=0.0).kinds
    assert set(np.unique(empty).tolist()) == {0, BRICK, BASE} and (empty == BRICK).sum() == 10  # the rings
    dense = rules(brick_density=0.6, steel_density=0.0).kinds
    assert (dense == BRICK).sum() > 60


def test_each_seat_sees_at_the_start_what_its_counterpart_sees():
    for players in (1, 2):
        r = rules(players, seed=5)
        obs = r.observe()
        half = r.n_agents // 2
        assert np.array_equal(obs[:half], obs[half:])


# --- shots ------------------------------------------------------------------------------------------
def test_a_shell_flies_along_the_heading_and_breaks_the_first_brick():
    r = rules()
    r.place([tile_centre(3, 2), tile_centre(9, 10)], [UP, DOWN], open_maze((6, 2, BRICK), (8, 2, BRICK)))
    r.step(actions(FIRE, NOOP))
    assert r.events() == [{"kind": "fire", "seat": 0}]
    shell = r.observe()[0, r.layout.at("shell_0_flying"): r.layout.at("shell_0_flying") + 5]
    assert shell[0] == 1.0 and shell[1:3] == pytest.approx((0.0, 0.8 / HALF)) and shell[3:5].tolist() == [0.0, 1.0]
    r.step(actions(NOOP, NOOP))
    r.step(actions(NOOP, NOOP))
    assert r.events() == [] and r.kinds[6, 2] == BRICK  # 2.4 on from the tank's centre at y = -3
    r.step(actions(NOOP, NOOP))  # the brick's face at y = -0.5, 2.5 on: the fourth step
    assert r.events() == [{"kind": "brick", "seat": 0, "row": 6, "col": 2}]
    assert r.kinds[6, 2] == 0 and r.kinds[8, 2] == BRICK
    bricks = r.observe()[0, r.layout.at("bricks"):]
    assert bricks[6 * GRID + 2] == 0.0 and bricks[8 * GRID + 2] == 1.0
    assert r.observe()[0, r.layout.at("shell_0_flying")] == 0.0


def test_steel_stops_a_shell_and_stays():
    r = rules()
    r.place([tile_centre(3, 2), tile_centre(9, 10)], [UP, DOWN], open_maze((5, 2, STEEL)))
    for _ in range(4):
        r.step(actions(FIRE, NOOP))
    assert r.kinds[5, 2] == STEEL and r.observe()[0, r.layout.at("steel") + 5 * GRID + 2] == 1.0


def test_a_gun_fires_once_per_reload_and_holds_one_shell_in_flight():
    r = rules()
    r.place([tile_centre(1, 1), tile_centre(11, 11)], [UP, DOWN], open_maze())
    fired = []
    for t in range(12):
        r.step(actions(FIRE, NOOP))
        fired += [t for event in r.events() if event["kind"] == "fire"]
    # the shell flies 0.8 a step from y = -5 to the edge at 6.5: 15 steps in flight, so no second shot
    assert fired == [0]
    r = rules()
    r.place([tile_centre(1, 1), tile_centre(11, 11)], [UP, DOWN], open_maze((3, 1, BRICK), (4, 1, BRICK)))
    fired = []
    for t in range(8):
        r.step(actions(FIRE, NOOP))
        fired += [t for event in r.events() if event["kind"] == "fire"]
    assert fired == [0, RELOAD_STEPS]  # the brick stopped the first shell at once; the gun reloads in 5


def test_hits_cost_hit_points_and_the_last_tank_destroyed_loses_the_match():
    r = rules(hit_points=2)
    r.place([tile_centre(3, 2), tile_centre(7, 2)], [UP, DOWN], open_maze())
    kinds = []
    for _ in range(3 * RELOAD_STEPS):
        r.step(actions(FIRE, NOOP))
        kinds += [event["kind"] for event in r.events()]
        if r.game_over:
            break
    assert kinds == ["fire", "hit", "fire", "hit", "destroyed"]
    assert r.game_over and r.team_result().tolist() == [1.0, 0.0]
    assert r.measures.outcome.tolist() == [1.0, -1.0] and r.measures.alive.tolist() == [True, False]


def test_a_shell_on_a_base_destroys_it_and_decides_the_match_even_the_own_base():
    r = rules()
    r.place([tile_centre(10, 6), tile_centre(3, 3)], [UP, DOWN], open_maze())
    for _ in range(4):
        r.step(actions(FIRE, NOOP))
        if r.game_over:
            break
    assert {"kind": "base", "team": 1, "by": 0} in r.events()
    assert r.game_over and r.team_result().tolist() == [1.0, 0.0]
    assert r.measures.active.tolist() == [True, False]  # the team whose base fell is out of play
    r = rules()
    r.place([tile_centre(2, 6), tile_centre(9, 9)], [DOWN, DOWN], open_maze())
    r.step(actions(FIRE, NOOP))
    r.step(actions(NOOP, NOOP))  # the base's face 1.5 on
    assert {"kind": "base", "team": 0, "by": 0} in r.events() and r.team_result().tolist() == [0.0, 1.0]


def test_shells_pass_teammates_and_hit_the_opponent_behind():
    r = rules(players=2)
    r.place([tile_centre(2, 2), tile_centre(4, 2), tile_centre(6, 2), tile_centre(11, 11)],
            [UP, UP, DOWN, DOWN], open_maze())
    events = []
    for _ in range(5):  # 4 tiles apart: the shell meets the opponent 3.6 on, on the fifth step
        r.step(actions(FIRE, NOOP, NOOP, NOOP))
        events += r.events()
    assert {"kind": "hit", "seat": 0, "target": 2, "hit_points": 2} in events
    assert not any(event.get("target") == 1 for event in events)


def test_a_cut_match_goes_to_the_team_with_more_hit_points_left_else_a_draw():
    r = rules()
    r.place([tile_centre(3, 2), tile_centre(6, 2)], [UP, DOWN], open_maze())
    r.step(actions(FIRE, NOOP))
    for _ in range(3):  # the shell meets the tank 2.6 on, on the fourth step
        r.step(actions(NOOP, NOOP))
    r.finish()
    assert r.team_result().tolist() == [1.0, 0.0] and r.measures.outcome.tolist() == [1.0, -1.0]
    r = rules()
    r.finish()
    assert r.team_result().tolist() == [0.5, 0.5] and r.measures.outcome.tolist() == [0.0, 0.0]


def test_a_destroyed_tank_stops_collides_with_nothing_and_ignores_its_actions():
    r = rules(players=2, hit_points=1)
    r.place([tile_centre(2, 2), tile_centre(1, 10), tile_centre(4, 2), tile_centre(11, 11)],
            [UP, UP, DOWN, DOWN], open_maze())
    for _ in range(3):  # the opponent's disc 1.6 on
        r.step(actions(FIRE, NOOP, NOOP, NOOP))
    assert r.measures.active.tolist() == [True, True, False, True] and not r.game_over
    wreck = r.world.table[2, 0:2].copy()
    for _ in range(15):
        r.step(actions(N, NOOP, S, NOOP))  # seat 0 drives through the wreck; the wreck does not move
    assert r.observe()[0, r.layout.at("other_1_active")] == 0.0
    assert r.world.table[0, 1] > wreck[1] + 1.0 and np.array_equal(r.world.table[2, 0:2], wreck)
    assert r.measures.energy[2] == 0.0


# --- observation, measures, copies --------------------------------------------------------------------
def test_observation_cells_at_the_start():
    r = rules(players=2, seed=3)
    obs = r.observe()
    at = r.layout.at
    x, y = tile_centre(*start_tiles(2)[0])
    assert obs[0, at("active")] == 1.0 and obs[0, at("hit_points")] == 1.0 and obs[0, at("reload")] == 0.0
    assert obs[0, at("position"): at("position") + 2] == pytest.approx((x / HALF, y / HALF))
    assert obs[0, at("heading"): at("heading") + 2].tolist() == [0.0, 1.0]
    assert obs[0, at("own_base"): at("own_base") + 2] == pytest.approx(((0 - x) / HALF, (-6 - y) / HALF))
    assert obs[0, at("enemy_base"): at("enemy_base") + 2] == pytest.approx(((0 - x) / HALF, (6 - y) / HALF))
    teammate = tile_centre(*start_tiles(2)[1])
    assert obs[0, at("other_0"): at("other_0") + 2] == pytest.approx(((teammate[0] - x) / HALF, 0.0))
    assert r.obs_dim == 395 and rules().obs_dim == 369 and r.state_dim == 14 * 4 + 171
    assert obs[0, at("bricks"):].reshape(2, GRID, GRID)[0].sum() == (r.kinds == BRICK).sum()


def test_measures_track_the_way_to_the_enemy_base():
    r = rules()
    before = r.measures.target_distance.copy()
    for _ in range(3):
        r.step(actions(N, N))
    assert (r.measures.target_distance < before).all() and r.measures.energy.tolist() == [1.0, 1.0]


def test_same_seed_same_actions_bit_identical_whatever_was_played_before():
    assert_replays_bit_for_bit(lambda: BattleCityRules(2, 2, "discrete"), ("active", "target_distance", "outcome"),
                               steps=60, detour=25)


@pytest.mark.parametrize("copier", [lambda r: pickle.loads(pickle.dumps(r)), copy.deepcopy], ids=["pickle", "deepcopy"])
def test_a_copy_mid_match_goes_on_bit_for_bit_as_the_original(copier):
    assert_a_copy_goes_on_as_the_original(rules(players=2, seed=4), copier, n_actions=10)


# --- the heuristic and the tree -------------------------------------------------------------------------
@pytest.mark.parametrize("players, action_type, matches", [(1, "discrete", 20), (2, "discrete", 20),
                                                          (1, "continuous", 10), (2, "continuous", 10)])
def test_heuristic_beats_random_teams(players, action_type, matches):
    wins = heuristic_wins(BattleCityRules, players, action_type, matches)
    assert wins >= 0.9 * matches, wins


def test_heuristic_shoots_an_opponent_in_a_clear_line_and_turns_to_face_one():
    r = rules()
    r.place([tile_centre(3, 2), tile_centre(8, 2)], [UP, DOWN], open_maze())
    assert BattleCityRules.heuristic(r.observe(), "discrete")[0] == FIRE
    r.place([tile_centre(3, 2), tile_centre(3, 8)], [UP, DOWN], open_maze())
    assert BattleCityRules.heuristic(r.observe(), "discrete")[0] == E


def test_heuristic_shoots_the_brick_in_its_way_and_heads_for_the_enemy_base():
    r = rules()
    r.place([tile_centre(3, 6), tile_centre(0, 0)], [UP, DOWN], open_maze(*[(4, col, BRICK) for col in range(GRID)]))
    assert BattleCityRules.heuristic(r.observe(), "discrete")[0] == FIRE
    r.place([tile_centre(3, 6), tile_centre(0, 0)], [UP, DOWN], open_maze())
    assert BattleCityRules.heuristic(r.observe(), "discrete")[0] == N


def test_heuristic_finishes_a_match_against_itself():
    r = rules(players=2, seed=2)
    steps = play(r, lambda r: BattleCityRules.heuristic(r.observe(), "discrete"), max_cycles=600)
    assert steps < 600 and r.game_over


def test_a_tuned_heuristic_snipes_the_base_through_bricks_and_is_the_heuristic_at_its_defaults():
    """``heuristic-aim0.2-brick1-snipe12`` parses and is bounded; at the heuristic's own values it
    plays the heuristic on a batch of observations; with ``snipe`` a tank below the enemy base
    shoots it through the ring's brick where the heuristic drives on."""
    from arena_league.envs.games.battlecity.heuristic import BRICK_COST, IN_LINE
    from arena_league.policies.scripted import heuristic_options, scripted_policy

    game = "BattleCity-2T1P-v1"
    assert heuristic_options("heuristic-aim0.2-brick1-snipe12") == {"aim": 0.2, "brick": 1.0, "snipe": 12.0}
    assert scripted_policy("heuristic-aim0.2-brick1-snipe12", game).name == "heuristic-aim0.2-brick1-snipe12"
    with pytest.raises(ValueError, match="option snipe must be from 0 to 12, not 13"):
        scripted_policy("heuristic-snipe13", game)
    r, rng, batch = rules(seed=3), np.random.default_rng(0), []
    for _ in range(40):
        batch.append(r.observe())
        r.step(rng.integers(0, 10, 2))
    obs = np.concatenate(batch)
    plain = BattleCityRules.heuristic(obs, "discrete")
    same = BattleCityRules.heuristic(obs, "discrete", aim=IN_LINE, brick=BRICK_COST, snipe=0.0)
    np.testing.assert_array_equal(same, plain)
    np.testing.assert_array_equal(scripted_policy(f"heuristic-aim{IN_LINE:g}-brick{BRICK_COST:g}-snipe0", game)
                                  .act(obs, np.zeros((len(obs), 1)))[0], plain)
    r = rules()  # seat 0 in the enemy base's column, a brick of its ring between
    r.place([tile_centre(6, 6), tile_centre(0, 0)], [UP, DOWN],
            open_maze(*[(*tile, BRICK) for tile in BASE_RING], *[(*turned(*tile), BRICK) for tile in BASE_RING]))
    assert BattleCityRules.heuristic(r.observe(), "discrete")[0] == N
    assert BattleCityRules.heuristic(r.observe(), "discrete", snipe=12.0)[0] == FIRE


def test_default_tree_ranks_by_survival_over_team_living_time():
    tree = BattleCityRules.default_tree(2, 2)
    assert tree["reward"] == "ranking" and tree["params"] == {"order": "survive"}
    assert [child["reward"] for child in tree["children"]] == ["team_living_longer"] * 2
    assert [leaf["reward"] for leaf in tree["children"][0]["children"]] == ["target", "target"]
    assert [child["agent"] for child in BattleCityRules.default_tree(2, 1)["children"]] == ["player_0", "player_1"]


# --- controls ---------------------------------------------------------------------------------------------
def test_controls_fire_with_f_and_turn_moves_for_the_second_team():
    r = rules()
    first, second = r.human_controls(0), r.human_controls(1)
    assert isinstance(first, BattleCityControls)
    assert first.parse("f") == (FIRE, None) and second.parse("fire") == (FIRE, None)
    assert first.parse("n") == (N, None) and second.parse("n") == (S, None)
    assert second.parse("e") == (W, None)
    assert "f fires" in first.parse("x")[1]
    keys = first.web()["keys"]
    assert keys[" "] == "f" and keys["ArrowUp"] == "n"


def test_heuristic_takes_any_batch_of_observations_and_refuses_another_games():
    obs = rules(players=2).observe()
    assert BattleCityRules.heuristic(obs, "discrete").shape == (4,)
    assert BattleCityRules.heuristic(obs[:1], "continuous").shape == (1, 3)
    with pytest.raises(ValueError, match="not BattleCity's"):
        BattleCityRules.heuristic(np.zeros((2, 10)), "discrete")


def test_a_maze_is_open_exactly_when_its_passable_tiles_are_one_component():
    from scipy import ndimage

    from arena_league.envs.games.battlecity.maze import GRID, _open, start_tiles

    rng = np.random.default_rng(3)
    start = start_tiles(2)[0]
    answers = []
    for density in (0.1, 0.3, 0.5):
        for _ in range(150):
            shares = [0.6 * (1 - density), 0.3 * (1 - density), density, 0.1 * (1 - density)]  # steel and bases close
            kinds = rng.choice([0, 1, 2, 3], size=(GRID, GRID), p=shares).astype(np.int8)
            kinds[start] = 0
            passable = (kinds == 0) | (kinds == 1)
            labels, _ = ndimage.label(passable)  # four neighbours
            expected = bool((labels[passable] == labels[start]).all())
            assert _open(kinds, start) is expected
            answers.append(expected)
    assert 0 < sum(answers) < len(answers)
