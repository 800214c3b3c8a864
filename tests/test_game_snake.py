"""Snake: walls, self and snake-on-snake collisions, food, frames, batched vs single board, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs import make
from arena_league.envs.games.snake import SnakeBoards, SnakeRules
from arena_league.envs.social.verify import verify

SIZE = 20
UP, RIGHT, DOWN, LEFT = range(4)


def cell(row: int, col: int) -> int:
    return row * SIZE + col


def board_actions(engine: SnakeBoards, *directions: int) -> np.ndarray:
    """Actions (each snake's own frame) that send snake s in board direction ``directions[s]``."""
    return ((np.array(directions) - engine.rotations) % 4)[None, :].astype(np.int64)


def two_snakes(**kwargs) -> SnakeBoards:
    return SnakeBoards(1, n_snakes=2, seed=0, **kwargs)


FAR_AWAY = [cell(17, 15), cell(18, 15), cell(19, 15)]  # a snake heading up, out of the way


def test_head_into_a_wall_dies_and_the_other_team_wins():
    rules = SnakeRules(2, 1, "discrete")
    rules.reset(0)
    rules.engine.set_board(0, [[cell(0, 5), cell(1, 5), cell(2, 5)], FAR_AWAY], food=[cell(10, 10)])
    rules.step(board_actions(rules.engine, UP, UP)[0])
    assert rules.measures.alive.tolist() == [False, True]
    assert rules.measures.active.tolist() == [False, True]
    assert {"kind": "death", "seat": 0, "cause": "wall"} in rules.events()
    assert rules.game_over
    assert rules.team_result().tolist() == [0.0, 1.0]
    assert rules.measures.outcome.tolist() == [-1.0, 1.0]


def test_head_into_own_body_dies_but_chasing_ones_tail_is_safe():
    engine = two_snakes()
    curled = [cell(5, 5), cell(5, 6), cell(6, 6), cell(6, 5), cell(7, 5)]  # (6, 5) is not the tail
    engine.set_board(0, [curled, FAR_AWAY])
    engine.step(board_actions(engine, DOWN, UP))
    assert engine.died[0].tolist() == [True, False] and engine.death_cause[0, 0] == 2  # self

    engine = two_snakes()
    square = [cell(5, 5), cell(5, 6), cell(6, 6), cell(6, 5)]  # (6, 5) is the tail: it moves away
    engine.set_board(0, [square, FAR_AWAY])
    engine.step(board_actions(engine, DOWN, UP))
    assert engine.alive[0].tolist() == [True, True]
    assert engine.head[0, 0] == cell(6, 5)


@pytest.mark.parametrize("length_1, dead", [(3, [True, True]), (4, [True, False]), (2, [False, True])])
def test_heads_meeting_in_one_cell_the_shorter_dies_equal_both(length_1, dead):
    engine = two_snakes()
    snake_0 = [cell(5, 5), cell(5, 4), cell(5, 3)]  # heading right
    snake_1 = [cell(5, 7 + k) for k in range(length_1)]  # heading left
    engine.set_board(0, [snake_0, snake_1], food=[cell(15, 15)])
    engine.step(board_actions(engine, RIGHT, LEFT))  # both into (5, 6)
    assert engine.died[0].tolist() == dead
    assert all(engine.death_cause[0, s] == 3 for s in range(2) if dead[s])
    assert engine.done[0]
    survivors = np.flatnonzero(~np.array(dead))
    if survivors.size:
        assert engine.head[0, survivors[0]] == cell(5, 6)
        assert engine.team_scores()[0].tolist() == [float(not dead[0]), float(not dead[1])]
    else:
        assert engine.team_scores()[0].tolist() == [0.5, 0.5]  # same step, same length: a draw


def test_heads_swapping_cells_collide():
    engine = two_snakes()
    engine.set_board(0, [[cell(5, 5), cell(5, 4), cell(5, 3)], [cell(5, 6), cell(5, 7), cell(5, 8)]])
    engine.step(board_actions(engine, RIGHT, LEFT))
    assert engine.died[0].tolist() == [True, True]


@pytest.mark.parametrize("long_one", [0, 1])
def test_head_into_another_body_the_shorter_snake_dies(long_one):
    engine = two_snakes()
    diver = [cell(4 - k, 6) for k in range(5 if long_one == 0 else 3)]  # heading down onto row 5
    crosser = [cell(5, 7 - k) for k in range(5 if long_one == 1 else 3)]  # heading right along row 5
    engine.set_board(0, [diver, crosser], food=[cell(15, 15)])
    engine.step(board_actions(engine, DOWN, RIGHT))  # the diver's head lands on (5, 6), the crosser's body
    assert engine.died[0].tolist() == [long_one == 1, long_one == 0]
    if long_one == 0:
        assert engine.head[0, 0] == cell(5, 6) and engine.grid(0)[5, 6] == 0
        assert engine.grid(0)[5, 8] == -1, "a dead snake leaves the board at once"


def test_eating_grows_by_one_and_food_reappears_on_an_empty_cell():
    rules = SnakeRules(2, 1, "discrete", n_food=3)
    rules.reset(3)
    body = [cell(10, 5), cell(11, 5), cell(12, 5)]
    rules.engine.set_board(0, [body, FAR_AWAY], food=[cell(9, 5), cell(0, 0), cell(0, 19)])
    spawns = int(rules.engine.spawns[0])
    rules.step(board_actions(rules.engine, UP, UP)[0])
    engine = rules.engine
    assert engine.length[0].tolist() == [4, 3] and engine.ate[0].tolist() == [True, False]
    assert rules.measures.resource_gain.tolist() == [1.0, 0.0]
    assert rules.measures.velocity_to_target[0] == 1.0
    assert {"kind": "eat", "seat": 0} in rules.events()
    grid = engine.grid(0)
    assert grid[12, 5] == 0, "the tail stays on the step the snake eats"
    food = engine.food[0]
    assert (food >= 0).sum() == 3 and len(set(food.tolist())) == 3
    assert cell(9, 5) not in food.tolist() and int(engine.spawns[0]) == spawns + 1
    assert all(grid.reshape(-1)[f] == -2 for f in food)  # food lies on cells no body covers
    assert rules.measures.target_distance[0] == min(abs(f // SIZE - 9) + abs(f % SIZE - 5) for f in food)


def test_reversal_continues_straight():
    engine = two_snakes()
    engine.set_board(0, [[cell(10, 5), cell(11, 5), cell(12, 5)], FAR_AWAY])
    engine.step(board_actions(engine, DOWN, UP))  # down is into the neck
    assert engine.alive[0].all() and engine.head[0, 0] == cell(9, 5)


def test_every_seat_sees_the_start_from_the_same_place_in_its_own_frame():
    rules = SnakeRules(4, 1, "discrete")
    rules.reset(0)
    obs = rules.observe()
    assert obs.shape == (4, 329) and obs.dtype == np.float32
    assert np.allclose(obs[:, :8], obs[0, :8])  # alive, position, heading, length
    w2 = 49
    own_view = obs[:, 23:23 + 2 * w2]  # wall and own-body channels of the window
    assert np.array_equal(own_view, np.repeat(own_view[:1], 4, axis=0))
    assert obs[0, 3:7].tolist() == [1, 0, 0, 0]  # heading "up" in its own frame
    heads = rules.engine.head[0].copy()
    rules.step(np.zeros(4, dtype=np.int64))  # everyone "up": straight ahead
    rows, cols = np.divmod(heads, SIZE)
    new_rows, new_cols = np.divmod(rules.engine.head[0], SIZE)
    assert (np.abs(new_rows - rows) + np.abs(new_cols - cols)).tolist() == [1, 1, 1, 1]
    assert rules.engine.direction[0].tolist() == [0, 1, 2, 3]  # each kept its own heading


def test_team_result_ranks_by_survival_then_length():
    engine = SnakeBoards(1, n_snakes=4, seed=0)
    bodies = [[cell(0, 2), cell(1, 2), cell(2, 2)],  # up into the wall at step 1
              [cell(1, 10), cell(2, 10), cell(3, 10)],  # up into the wall at step 2
              [cell(10, 5), cell(10, 4), cell(10, 3)],  # right: meets snake 3 head-on at step 2
              [cell(10, 8), cell(10, 9), cell(10, 10), cell(10, 11)]]  # left, one longer
    engine.set_board(0, bodies, food=[cell(19, 0)])
    engine.step(board_actions(engine, UP, UP, RIGHT, LEFT))
    assert engine.died[0].tolist() == [True, False, False, False]
    engine.step(board_actions(engine, UP, UP, RIGHT, LEFT))
    assert engine.died[0].tolist() == [False, True, True, False]
    assert engine.done[0]
    # snake 3 survives; snakes 1 and 2 died together, 2 is as long as 1: they tie; snake 0 died first
    assert engine.team_scores()[0].tolist() == [0.0, 1.5, 1.5, 3.0]


def test_batched_engine_and_single_board_agree_step_for_step():
    seeds = [11, 12, 13, 14, 15, 16]
    keys = [np.random.default_rng(s).integers(0, 2**64, size=1, dtype=np.uint64)[0] for s in seeds]
    boards = SnakeBoards(len(seeds), n_snakes=2, seed=99)
    boards.reset(keys=keys)
    singles = []
    for s in seeds:
        rules = SnakeRules(2, 1, "discrete")
        rules.reset(s)
        singles.append(rules)
    rng = np.random.default_rng(0)
    for _ in range(200):
        if boards.done.all():
            break
        # half heuristic, half random, so that matches run long and snakes eat
        actions = SnakeRules.heuristic(boards.observe().reshape(-1, boards.obs_dim), "discrete").reshape(-1, 2)
        explore = rng.random(actions.shape) < 0.3
        actions = np.where(explore, rng.integers(4, size=actions.shape), actions)
        boards.step(actions)
        obs = boards.observe()
        for b, rules in enumerate(singles):
            if rules.game_over:
                continue
            rules.step(actions[b])
            assert np.array_equal(rules.observe(), obs[b])
            assert np.array_equal(rules.engine.food[0], boards.food[b])
            assert rules.game_over == bool(boards.done[b])
            assert rules.measures.resource_gain.tolist() == boards.ate[b].astype(float).tolist()
    eaten = sum(int(r.engine.spawns[0]) - 3 for r in singles)  # 3 initial food items per board
    assert eaten >= 2 * len(seeds), "food was eaten and respawned along the way"


def test_every_body_holds_exactly_its_length_and_food_lies_on_free_cells():
    engine = SnakeBoards(16, n_snakes=4, seed=4, autoreset=True)
    rng = np.random.default_rng(4)
    for _ in range(80):
        actions = SnakeRules.heuristic(engine.observe().reshape(-1, engine.obs_dim), "discrete").reshape(16, 4)
        actions = np.where(rng.random(actions.shape) < 0.1, rng.integers(4, size=actions.shape), actions)
        engine.step(actions)
        for b in range(16):
            grid = engine.grid(b).reshape(-1)
            for s in range(4):
                expected = engine.length[b, s] if engine.alive[b, s] else 0
                assert (grid == s).sum() == expected
                if engine.alive[b, s]:
                    assert grid[engine.head[b, s]] == s
            food = engine.food[b]
            assert (grid == -2).sum() == (food >= 0).sum() == engine.n_food
    assert engine.length.max() > 3, "snakes grew along the way"


def rollout(seed: int, steps: int = 120) -> list[np.ndarray]:
    rules = SnakeRules(2, 2, "discrete")
    rules.reset(seed)
    rng = np.random.default_rng(1)
    trace = [rules.observe()]
    for _ in range(steps):
        if rules.game_over:
            break
        actions = SnakeRules.heuristic(rules.observe(), "discrete")
        actions[rng.random(4) < 0.2] = rng.integers(4)
        rules.step(actions)
        trace += [rules.observe(), rules.state(), rules.measures.target_distance.copy()]
    return trace


def test_same_seed_same_match_other_seed_other_food():
    first, second, other = rollout(5), rollout(5), rollout(6)
    assert len(first) == len(second)
    assert all(np.array_equal(a, b) for a, b in zip(first, second))
    assert not np.array_equal(first[0], other[0])


def test_autoreset_reports_finished_matches():
    engine = SnakeBoards(256, n_snakes=2, seed=3, autoreset=True)
    finished = 0
    for _ in range(60):
        engine.step(engine.random_actions())
        ended = engine.done
        finished += int(ended.sum())
        assert np.all(engine.t[ended] == 0) and np.all(engine.alive[ended])
        assert np.all(np.isin(engine.final_scores[ended], [0.0, 0.5, 1.0]))
    assert finished > 256


def test_heuristic_outlives_random_play():
    wins = 0
    for seed in range(20):
        rules = SnakeRules(2, 1, "discrete")
        rules.reset(seed)
        rng = np.random.default_rng(seed)
        skilled = seed % 2
        while not rules.game_over and rules.engine.t[0] < 500:
            actions = SnakeRules.heuristic(rules.observe(), "discrete")
            actions[1 - skilled] = rng.integers(4)
            rules.step(actions)
        wins += rules.team_result()[skilled] == 1.0
    assert wins >= 18


def test_bad_options_and_actions_name_the_fix():
    with pytest.raises(ValueError, match=r"Snake has no option 'grid'; its options: size: an integer in \[8, inf\], "
                                         r"default 20 .*n_food: an integer in \[0, inf\], default snakes \+ 1 "):
        make("Snake-2T1P-v1", grid=10)
    with pytest.raises(ValueError, match=r"Snake option start_length must be an integer in \[1, size // 4 = 5\] "
                                         r"\(default 3: cells of each snake at the start.*\), not 9$"):
        SnakeRules(2, 1, "discrete", start_length=9)
    with pytest.raises(ValueError, match=r"Snake option view_radius must be an integer in \[1, size = 12\]"):
        make("Snake-2T1P-v1", size=12, view_radius=13)
    with pytest.raises(ValueError, match=r"Snake option n_food must be an integer in \[0, inf\] \(default snakes \+ 1: "):
        make("Snake-2T1P-v1", n_food=True)
    assert make("Snake-4T1P-v1").rules.engine.n_food == 5 and make("Snake-2T1P-v1", n_food=0).rules.engine.n_food == 0
    with pytest.raises(ValueError, match="n_snakes must be an integer in 1..4"):
        SnakeBoards(4, n_snakes=5)
    engine = two_snakes()
    with pytest.raises(ValueError, match="0 up, 1 right, 2 down, 3 left"):
        engine.step(np.array([[0, 4]]))
    with pytest.raises(ValueError, match="not neighbours"):
        engine.set_board(0, [[cell(5, 5), cell(7, 5)], FAR_AWAY])


@pytest.mark.parametrize("game_id", ["Snake-2T1P-v1", "Snake-2T2P-v1"])
def test_default_tree_verifies_as_declared(game_id):
    report = verify(game_id, samples=8, seed=0)
    assert report.ok, [(n.path, n.declared, n.verified) for n in report.nodes]
    assert report.nodes[0].verified == "CP"


def search_actions(engine: SnakeBoards, width: int = 3, horizon: int = 4) -> np.ndarray:
    """The search agent's action for every snake of board 0 (its own frame)."""
    obs = engine.observe()[0]
    return SnakeRules.search(obs, np.zeros(len(obs)), action_type="discrete", width=width, rollouts=1, horizon=horizon,
                             epsilon=0.0)


def test_the_search_rams_a_shorter_snakes_body_and_the_collision_rule_kills_it():
    engine = two_snakes()
    mine = [cell(10, 5), cell(11, 5), cell(12, 5), cell(13, 5), cell(14, 5), cell(15, 5)]  # 6 long, heading up
    theirs = [cell(9, 6), cell(10, 6), cell(11, 6)]  # 3 long, heading up, its neck right of my head
    engine.set_board(0, [mine, theirs], food=[cell(1, 1), cell(1, 2), cell(1, 3)])
    assert search_actions(engine)[0] == RIGHT
    assert SnakeRules.heuristic(engine.observe()[0], "discrete")[0] != RIGHT  # the heuristic never enters a body
    engine.step(board_actions(engine, RIGHT, UP))
    assert engine.alive[0].tolist() == [True, False] and engine.death_cause[0, 1] == 3


def test_the_search_keeps_off_a_longer_snakes_body_and_head():
    engine = two_snakes()
    mine = [cell(10, 5), cell(11, 5), cell(12, 5)]  # 3 long
    theirs = [cell(9, 6), cell(10, 6), cell(11, 6), cell(12, 6), cell(13, 6)]  # 5 long; its head next to my "up"
    engine.set_board(0, [mine, theirs], food=[cell(1, 1), cell(1, 2), cell(1, 3)])
    assert search_actions(engine)[0] == LEFT


@pytest.mark.parametrize("width, horizon", [(1, 4), (3, 1), (3, 4)])
def test_a_seats_search_depends_on_its_row_alone_and_width_one_is_the_heuristic(width, horizon):
    engine = SnakeBoards(64, n_snakes=4, team_of=(0, 0, 1, 1), rotations=(0, 2, 1, 3), seed=5, autoreset=True)
    for _ in range(60):
        engine.step(engine.random_actions())
    obs = engine.observe().reshape(256, -1)
    uniforms = np.random.default_rng(0).random(256)
    budget = {"action_type": "discrete", "width": width, "rollouts": 1, "horizon": horizon, "epsilon": 0.3}
    whole = SnakeRules.search(obs, uniforms, **budget)
    rows = np.arange(0, 256, 7)
    assert (SnakeRules.search(obs[rows], uniforms[rows], **budget) == whole[rows]).all()
    living = obs[:, 0] > 0.5
    if width == 1:  # the same move (a reversal goes straight, so two actions may name it)
        heading = obs[:, 3:7].argmax(axis=1)

        def moves(actions: np.ndarray) -> np.ndarray:
            return np.where(actions == (heading + 2) % 4, heading, actions)

        assert (moves(whole)[living] == moves(SnakeRules.heuristic(obs, "discrete"))[living]).all()


def test_the_search_outlives_the_heuristic_from_either_side():
    from arena_league.matchmaking import play_matches, specs_for_seatings
    from arena_league.policies.scripted import scripted_policy

    game = "Snake-2T2P-v1"
    agents = {"search": scripted_policy("search-w3-r1-h4", game), "heuristic": scripted_policy("heuristic", game)}
    seatings = [("search", "heuristic"), ("heuristic", "search")] * 40
    results = play_matches(specs_for_seatings(game, seatings, 3), agents, backend="inprocess")
    scores = [r.team_scores()[s.index("search")] for s, r in zip(seatings, results)]
    assert np.mean(scores) >= 0.65 and np.mean(scores[::2]) >= 0.6 and np.mean(scores[1::2]) >= 0.6, scores
