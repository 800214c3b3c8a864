"""Boomer: the rules as its manual states them, by scripted scenarios on small boards, checked
against Pommerman's on the rules the two share (bomb life 10, blast strength 2 reaching one cell,
flames for the explosion's step and 2 more, rigid walls stopping a blast, wooden ones stopping it
and burning, chain reactions, kicks)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from arena_league.envs import make
from arena_league.envs.games.boomer import BoomerRules
from arena_league.envs.games.boomer.boards import (
    BOMB_LIFE,
    EXTRA_BOMB,
    KICK,
    PASSAGE,
    RANGE,
    WOOD,
    BoomerBoards,
)
from arena_league.envs.games.boomer.heuristic import heuristic_actions

STOP, UP, DOWN, LEFT, RIGHT, BOMB = range(6)
OPEN = ["." * 7] * 7


def _boards(picture: list[str], seats: int = 2, hidden: dict[int, int] | None = None, **kwargs) -> BoomerBoards:
    """A 7 x 7 board holding ``picture``, every seat in the board's own frame (no quarter turns)."""
    boards = BoomerBoards(1, seats, size=7, n_rigid=0, n_wood=0, n_items=0, quarter_turns=[0] * seats, **kwargs)
    boards.set_board(0, picture, hidden)
    return boards


def _flames(boards: BoomerBoards) -> set[tuple[int, int]]:
    cells = np.flatnonzero(boards.flame[0, boards._inner] > 0)
    return {divmod(int(c), boards.size) for c in cells}


def _step(boards: BoomerBoards, *actions: int) -> None:
    boards.step(np.array([actions], dtype=np.int64))


def _cell(row: int, col: int) -> int:
    return row * 7 + col


def test_a_laid_bomb_explodes_on_its_tenth_step_in_a_cross_and_its_flames_burn_three_steps():
    boards = _boards([".......",
                      ".......",
                      ".......",
                      "...0...",
                      ".......",
                      ".......",
                      "......1"])
    _step(boards, BOMB, STOP)  # step 1: the bomb is laid (Pommerman: life 10, ticked once this step)
    assert boards.ammo[0, 0] == 0 and boards.bomb_timer[0, boards._inner[_cell(3, 3)]] == BOMB_LIFE - 1
    _step(boards, UP, STOP)
    _step(boards, LEFT, STOP)  # to (2, 2): diagonal to the bomb, outside its cross
    for _ in range(6):
        _step(boards, STOP, STOP)
    assert not _flames(boards)  # 9 steps: not yet
    _step(boards, STOP, STOP)  # the 10th step
    assert _flames(boards) == {(3, 3), (2, 3), (4, 3), (3, 2), (3, 4)}  # strength 2: one cell each way
    assert boards.ammo[0, 0] == 1 and boards.alive[0].all()
    for _ in range(2):
        _step(boards, STOP, STOP)
        assert len(_flames(boards)) == 5
    _step(boards, STOP, STOP)
    assert not _flames(boards)


def test_a_player_in_the_blast_dies_one_a_cell_further_lives_and_strength_widens_the_cross():
    picture = ["0......",
               ".......",
               ".......",
               ".......",
               ".......",
               ".......",
               "......1"]
    for strength, dies in ((2, False), (3, True)):
        boards = _boards(picture, blast_strength=strength)
        boards.lay_bomb(0, _cell(2, 0), owner=1, timer=1)
        _step(boards, STOP, STOP)
        assert boards.alive[0, 0] == (not dies)
        assert len(_flames(boards)) == (4 if strength == 2 else 7)  # the arm off the board is cut


def test_a_rigid_wall_stops_a_blast_before_it():
    boards = _boards(["...0...",
                      ".......",
                      "...#...",
                      ".......",
                      ".......",
                      ".......",
                      "......1"], blast_strength=5)
    boards.lay_bomb(0, _cell(4, 3), owner=1, timer=1)
    _step(boards, STOP, STOP)
    flames = _flames(boards)
    assert (3, 3) in flames and (2, 3) not in flames and (1, 3) not in flames
    assert (6, 3) in flames and (4, 0) in flames and (4, 6) in flames  # the other arms run on
    assert boards.alive[0, 0] and boards.grid(0)[2, 3] == 1  # behind the wall, and the wall stands


def test_a_wooden_wall_stops_a_blast_burns_down_and_shows_its_power_up_when_the_flame_goes_out():
    boards = _boards(["...0...",
                      ".......",
                      "...+...",
                      ".......",
                      ".......",
                      ".......",
                      "......1"], hidden={_cell(2, 3): RANGE}, blast_strength=5)
    boards.lay_bomb(0, _cell(4, 3), owner=1, timer=1)
    _step(boards, STOP, STOP)
    flames = _flames(boards)
    assert (2, 3) in flames and (1, 3) not in flames  # the wall's cell burns, the arm stops there
    assert boards.grid(0)[2, 3] == PASSAGE and boards.alive[0, 0]
    _step(boards, STOP, STOP)
    _step(boards, STOP, STOP)
    assert boards.grid(0)[2, 3] == PASSAGE  # still burning: the power-up stays hidden
    _step(boards, STOP, STOP)
    assert boards.grid(0)[2, 3] == RANGE
    _step(boards, DOWN, STOP)
    _step(boards, DOWN, STOP)
    assert boards.strength[0, 0] == 6 and boards.picked[0, 0] and boards.grid(0)[2, 3] == PASSAGE


def test_a_blast_that_reaches_a_bomb_sets_it_off_in_the_same_step():
    boards = _boards(["0......",
                      ".......",
                      ".......",
                      ".......",
                      ".......",
                      ".......",
                      "......1"], blast_strength=3)
    boards.lay_bomb(0, _cell(3, 1), owner=0, timer=1)
    boards.lay_bomb(0, _cell(3, 3), owner=1, timer=9)  # two cells away: inside the first blast
    boards.lay_bomb(0, _cell(3, 6), owner=1, timer=9)  # three cells past the second: outside both
    boards.ammo[0] = 0
    _step(boards, STOP, STOP)
    flames = _flames(boards)
    assert {(3, 5), (1, 3), (5, 3)} <= flames  # the second bomb's cross, reaching 2 cells
    assert (3, 6) not in flames and boards.bomb_timer[0, boards._inner[_cell(3, 6)]] == 8
    assert boards.ammo[0].tolist() == [1, 1]  # each exploded bomb came back to its owner


def test_a_kicked_bomb_slides_until_it_meets_a_wall_and_without_kick_the_move_fails():
    picture = [".......",
               ".......",
               "0.....#",
               ".......",
               ".......",
               ".......",
               "......1"]
    boards = _boards(picture)
    boards.lay_bomb(0, _cell(2, 1), owner=1, timer=9)
    _step(boards, RIGHT, STOP)
    assert boards.board_cell(boards.position)[0, 0] == _cell(2, 0)  # no kick: blocked by the bomb
    boards = _boards(picture)
    boards.can_kick[0, 0] = True
    boards.lay_bomb(0, _cell(2, 1), owner=1, timer=9)
    _step(boards, RIGHT, STOP)
    assert boards.kicked[0, 0] and boards.board_cell(boards.position)[0, 0] == _cell(2, 1)
    where = []
    for _ in range(5):
        _step(boards, STOP, STOP)
        where.append(int(np.flatnonzero(boards.bomb_timer[0, boards._inner] > 0)[0]))
    assert where == [_cell(2, 3), _cell(2, 4), _cell(2, 5), _cell(2, 5), _cell(2, 5)]  # stops before the wall
    assert boards.bomb_direction[0, boards._inner[_cell(2, 5)]] == -1


def test_moves_into_one_cell_and_swaps_fail_and_a_power_up_is_taken():
    boards = _boards([".......",
                      ".......",
                      "0.1....",
                      "...k...",
                      ".r.e...",
                      ".......",
                      "......."])
    _step(boards, RIGHT, LEFT)  # both into (2, 1)
    assert boards.board_cell(boards.position)[0].tolist() == [_cell(2, 0), _cell(2, 2)]
    _step(boards, RIGHT, STOP)
    _step(boards, RIGHT, LEFT)  # a swap
    assert boards.board_cell(boards.position)[0].tolist() == [_cell(2, 1), _cell(2, 2)]
    _step(boards, DOWN, RIGHT)
    _step(boards, DOWN, DOWN)
    assert boards.strength[0].tolist() == [3, 2] and boards.can_kick[0].tolist() == [False, True]
    _step(boards, STOP, DOWN)
    assert boards.ammo[0, 1] == 2 and boards.grid(0)[4, 3] == PASSAGE


def test_teams_rank_by_elimination_order_and_a_timed_out_match_ties_the_teams_left():
    boards = BoomerBoards(1, 4, size=7, n_rigid=0, n_wood=0, n_items=0, quarter_turns=[0, 1, 2, 3], max_steps=30)
    boards.set_board(0, ["0.....1",
                         ".......",
                         ".......",
                         ".......",
                         ".......",
                         ".......",
                         "3.....2"])
    boards.lay_bomb(0, _cell(1, 0), owner=0, timer=1)
    _step(boards, STOP, STOP, STOP, STOP)
    boards.lay_bomb(0, _cell(5, 6), owner=2, timer=2)
    _step(boards, STOP, STOP, STOP, STOP)
    _step(boards, STOP, STOP, STOP, STOP)
    assert boards.death_step[0].tolist() == [1, -1, 3, -1] and not boards.done[0]
    while not boards.done[0]:
        _step(boards, STOP, STOP, STOP, STOP)
    assert boards.truncated[0] and boards.final_scores[0].tolist() == [0.0, 2.5, 1.0, 2.5]


def test_maps_are_the_same_turned_by_a_quarter_and_the_same_seed_gives_the_same_map():
    boards = BoomerBoards(4, 4)
    boards.reset(keys=np.array([7, 7, 8, 9], dtype=np.uint64))
    grids = [boards.grid(b) for b in range(4)]
    assert np.array_equal(grids[0], grids[1]) and not np.array_equal(grids[0], grids[2])
    for b in range(4):
        assert np.array_equal(np.rot90(grids[b]), grids[b])
        assert (grids[b] == 1).sum() == 36 and (grids[b] == WOOD).sum() == 36
        assert (boards.hidden[b] > 0).sum() == 20
    first = [make("Boomer-2T2P-v1").reset(seed=s)[0]["player_0"] for s in (3, 3, 4)]
    assert np.array_equal(first[0], first[1]) and not np.array_equal(first[0], first[2])


def test_every_seat_starts_seeing_the_same_board_in_its_own_frame():
    for game_id in ("Boomer-2T1P-v1", "Boomer-4T1P-v1", "Boomer-2T2P-v1"):
        env = make(game_id)
        obs, _ = env.reset(seed=5)
        rows = np.stack([obs[a] for a in env.possible_agents])
        header = 4 * len(rows)
        assert (rows[:, header:] == rows[0, header:]).all(), game_id
        assert rows[0, 0] == 1.0 and rows.shape[1] == header + 11 * 121


def test_the_heuristic_outlives_random_play_in_at_least_nine_duels_of_ten():
    # 40 duels on one batched engine, the heuristic in seat 0 for 20 and in seat 1 for 20
    n = 40
    boards = BoomerBoards(n, 2, seed=11, max_steps=800)
    rng = np.random.default_rng(11)
    seat = np.arange(n) >= n // 2
    while not boards.done.all():
        obs = boards.observe()
        scripted = heuristic_actions(obs[np.arange(n), seat.astype(int)])
        actions = rng.integers(6, size=(n, 2))
        actions[np.arange(n), seat.astype(int)] = scripted
        boards.step(actions)
    wins = int((boards.final_scores[np.arange(n), seat.astype(int)] == 1.0).sum())
    assert wins >= 36, f"the heuristic won {wins} of {n} duels against random play"


def test_the_controls_turn_moves_on_the_board_as_drawn_into_the_seat_frame():
    rules = BoomerRules(4, 1, "discrete")
    rules.reset(0)
    controls = rules.human_controls(1)  # a quarter turn: "right" on the board is "up" in its frame
    assert controls.parse("d") == (UP, None) and controls.parse("w") == (LEFT, None)
    assert controls.parse("b") == (BOMB, None) and controls.parse("") == (STOP, None)
    assert controls.parse("z")[0] is None
    view = controls.view()
    assert "@" in view and "#" in view and "ammo 1" in view
    assert controls.web()["keys"][" "] == "b"


def test_options_are_checked_and_rules_pickle_mid_match():
    with pytest.raises(ValueError, match="multiples of 4"):
        make("Boomer-2T1P-v1", n_rigid=34)
    with pytest.raises(ValueError, match="n_items"):
        make("Boomer-2T1P-v1", size=9, n_rigid=0, n_wood=8, n_items=12)
    env = make("Boomer-2T2P-v1", size=9, n_rigid=16, n_wood=24, n_items=8)
    obs, _ = env.reset(seed=2)
    for _ in range(15):  # the heuristic lays bombs and gets away from them
        actions = heuristic_actions(np.stack([obs[a] for a in env.agents]))
        obs = env.step(dict(zip(env.agents, actions.tolist(), strict=True)))[0]
    assert env.rules.engine.laid.any() or (env.rules.engine.bomb_timer > 0).any()
    copy = pickle.loads(pickle.dumps(env))
    assert np.array_equal(copy.state(), env.state())
    actions = dict.fromkeys(env.agents, RIGHT)
    assert np.array_equal(copy.step(actions)[0]["player_0"], env.step(actions)[0]["player_0"])


@pytest.mark.parametrize("kind", [EXTRA_BOMB, RANGE, KICK])
def test_power_up_kinds_appear_in_the_picture_and_the_scene(kind):
    rules = BoomerRules(2, 1, "discrete")
    rules.reset(1)
    rules.engine.terrain[0, rules.engine._inner[_cell(0, 5)]] = kind
    assert (rules.picture_codes() == kind).any()
    assert len(next(e for e in rules.scene_entities(0) if e["id"] == "power_ups")["spheres"]) >= 1


def test_a_board_plays_the_same_alone_or_among_others():
    alone = BoomerBoards(1, 4)
    batch = BoomerBoards(3, 4)
    alone.reset(keys=np.array([21], dtype=np.uint64))
    batch.reset(keys=np.array([5, 21, 9], dtype=np.uint64))
    rng = np.random.default_rng(4)
    for _ in range(60):
        actions = rng.integers(6, size=(3, 4))
        alone.step(actions[1:2])
        batch.step(actions)
        assert np.array_equal(alone.observe()[0], batch.observe()[1])
        assert np.array_equal(alone.state()[0], batch.state()[1])
    assert alone.done[0] == batch.done[1] and np.array_equal(alone.team_scores(), batch.team_scores([1]))


def test_a_player_leaves_its_own_bomb_but_no_one_walks_onto_it_and_a_bomb_sliding_into_flames_explodes():
    boards = _boards([".......",
                      ".......",
                      ".01....",
                      ".......",
                      ".......",
                      ".......",
                      "......."])
    _step(boards, BOMB, STOP)
    _step(boards, LEFT, LEFT)  # seat 0 steps off its bomb; seat 1, without kick, cannot step onto it
    assert boards.board_cell(boards.position)[0].tolist() == [_cell(2, 0), _cell(2, 2)]
    boards = _boards(["0......",
                      ".......",
                      ".......",
                      ".......",
                      ".......",
                      ".......",
                      "......1"])
    boards.lay_bomb(0, _cell(4, 1), owner=1, timer=9)  # sliding right, toward a burning cell
    boards.bomb_direction[0, boards._inner[_cell(4, 1)]] = 1
    boards.flame[0, boards._inner[_cell(4, 3)]] = 3
    _step(boards, STOP, STOP)  # slides to (4, 2)
    assert boards.bomb_timer[0, boards._inner[_cell(4, 2)]] == 8
    _step(boards, STOP, STOP)  # slides into the flame and goes off at once
    assert boards.bomb_timer[0].max() == 0 and {(3, 3), (5, 3), (4, 4)} <= _flames(boards)


def test_a_tuned_heuristic_hunts_the_opponent_and_is_the_heuristic_at_its_defaults():
    """``heuristic-block10-hunt1-wary1`` parses and is bounded; at its defaults the tuned heuristic
    plays the heuristic on a batch of observations; with ``hunt`` a player walks toward the opponent
    where the heuristic walks to the wood beside it."""
    from arena_league.policies.scripted import heuristic_options, scripted_policy

    game = "Boomer-2T1P-v1"
    assert heuristic_options("heuristic-block10-hunt1-wary1") == {"block": 10.0, "hunt": 1.0, "wary": 1.0}
    assert scripted_policy("heuristic-block10-hunt1-wary1", game).name == "heuristic-block10-hunt1-wary1"
    with pytest.raises(ValueError, match="option wary must be from 0 to 3, not 4"):
        scripted_policy("heuristic-wary4", game)
    boards, rng, batch = BoomerBoards(8, 2, seed=1, autoreset=True), np.random.default_rng(0), []
    for _ in range(60):
        obs = boards.observe()
        batch.append(obs.reshape(-1, obs.shape[-1]))
        moves = heuristic_actions(batch[-1]).reshape(8, 2)
        boards.step(np.where(rng.random(moves.shape) < 0.3, rng.integers(0, 6, moves.shape), moves))
    obs = np.concatenate(batch)
    plain = BoomerRules.heuristic(obs, "discrete")
    np.testing.assert_array_equal(BoomerRules.heuristic(obs, "discrete", block=0, hunt=0, press=0, wary=0), plain)
    np.testing.assert_array_equal(scripted_policy("heuristic-block0-hunt0-press0-wary0", game)
                                  .act(obs, np.zeros((len(obs), 1)))[0], plain)
    assert (BoomerRules.heuristic(obs, "discrete", block=10, hunt=1, wary=1) != plain).any()
    boards = _boards(["1......", ".......", ".......", "0.+....", ".......", ".......", "......."])
    seat0 = boards.observe()[:, 0]
    assert BoomerRules.heuristic(seat0, "discrete")[0] == RIGHT  # toward the wood
    assert BoomerRules.heuristic(seat0, "discrete", hunt=1)[0] == UP  # toward the opponent


def test_the_search_agent_is_bounded_and_bombs_the_opponent_into_its_corner():
    """``search-w6-r1-h10`` parses and refuses budgets it cannot search with one clear ValueError; from a
    placed duel it lays the bomb that the heuristic's answer walks into, where the tuned heuristic it plays
    elsewhere walks on and both live, and in team games it is the tuned heuristic."""
    from arena_league.envs.games.boomer.search import OWN_PLAY, search_moves
    from arena_league.policies.scripted import scripted_policy

    game = "Boomer-2T1P-v1"
    assert scripted_policy("search-w6-r1-h10", game).name == "search-w6-r1-h10"
    with pytest.raises(ValueError, match="ask for W from 1 to 6, not 7"):
        scripted_policy("search-w7-r1-h10", game)
    with pytest.raises(ValueError, match="ask for R = 1, as in search-w6-r1-h10, not R = 2"):
        scripted_policy("search-w6-r2-h10", game)
    picture = ["1......", "+.0....", ".+..+.+", "....+.#", ".+...+.", ".......", ".+.+++."]

    def play(first: int) -> list[bool]:
        boards = BoomerBoards(1, 2, size=7, n_rigid=0, n_wood=0, n_items=0)
        boards.set_board(0, picture)
        for k in range(14):
            obs = boards.observe()
            own = first if k == 0 else heuristic_actions(obs[:, 0], **OWN_PLAY)[0]
            boards.step(np.array([[own, heuristic_actions(obs[:, 1])[0]]]))
        return boards.alive[0].tolist()

    boards = BoomerBoards(1, 2, size=7, n_rigid=0, n_wood=0, n_items=0)
    boards.set_board(0, picture)
    seat0 = boards.observe()[:, 0]
    assert heuristic_actions(seat0, **OWN_PLAY)[0] == UP
    assert search_moves(seat0, np.zeros(1), width=6, rollouts=1, horizon=10, epsilon=0)[0] == BOMB
    assert play(BOMB) == [True, False] and play(UP) == [True, True]
    team = BoomerBoards(2, 4, seed=3)
    obs = team.observe().reshape(8, -1)
    np.testing.assert_array_equal(BoomerRules.search(obs, np.zeros(8), action_type="discrete", width=6, rollouts=1,
                                                     horizon=10, epsilon=0), heuristic_actions(obs, **OWN_PLAY))
