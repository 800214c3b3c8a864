"""GoBang: freestyle five in a row, illegal moves, draws, the heuristic, batched vs single board."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs import make, make_aec
from arena_league.envs.games.gobang import GoBangBoards, GoBangRules
from arena_league.envs.social.verify import verify

SIZE = 15
CENTRE = 7


def cell(row: int, col: int) -> int:
    return row * SIZE + col


def play(rules: GoBangRules, cells: list[int]) -> None:
    """Play ``cells`` in turn; every seat sends the same cell, only the seat to move counts."""
    for c in cells:
        rules.step(np.full(rules.n_agents, c, dtype=np.int64))


def new_game(players_per_team: int = 1) -> GoBangRules:
    rules = GoBangRules(2, players_per_team, "discrete")
    rules.reset(0)
    return rules


def interleave(black: list[int], white: list[int]) -> list[int]:
    moves = []
    for k, b in enumerate(black):
        moves.append(b)
        if k < len(white):
            moves.append(white[k])
    return moves


# four lines through the centre, and far-away cells for white that never line up
LINES = {
    "row": [cell(CENTRE, CENTRE + k) for k in range(-2, 3)],
    "column": [cell(CENTRE + k, CENTRE) for k in range(-2, 3)],
    "diagonal": [cell(CENTRE + k, CENTRE + k) for k in range(-2, 3)],
    "anti-diagonal": [cell(CENTRE + k, CENTRE - k) for k in range(-2, 3)],
}
WHITE_ELSEWHERE = [cell(0, 0), cell(0, 2), cell(2, 0), cell(14, 14), cell(14, 12)]


@pytest.mark.parametrize("line", sorted(LINES))
def test_five_in_a_row_wins_in_each_direction(line):
    rules = new_game()
    moves = interleave(LINES[line], WHITE_ELSEWHERE[:4])
    play(rules, moves[:-1])
    assert not rules.game_over, "four stones do not win"
    play(rules, moves[-1:])
    assert rules.game_over
    assert rules.measures.outcome.tolist() == [1.0, -1.0]
    assert rules.team_result().tolist() == [1.0, 0.0]
    assert {"kind": "five", "team": 0} in rules.events()


def test_white_wins_too_and_the_last_stone_may_be_in_the_middle():
    rules = new_game()
    row = [cell(3, c) for c in (4, 5, 7, 8, 6)]  # the fifth stone closes the gap
    black = [cell(10, 0), cell(12, 3), cell(10, 6), cell(12, 9), cell(10, 12)]
    play(rules, interleave(black, row))
    assert rules.game_over and rules.team_result().tolist() == [0.0, 1.0]
    assert rules.measures.outcome.tolist() == [-1.0, 1.0]


def test_six_in_a_row_also_wins_freestyle():
    rules = new_game()
    black = [cell(5, c) for c in (0, 1, 2, 4, 5)] + [cell(5, 3)]  # runs of 3 and 2, joined into 6
    play(rules, interleave(black, WHITE_ELSEWHERE))
    assert rules.game_over and rules.team_result().tolist() == [1.0, 0.0]
    assert int(rules.engine.n_stones[0]) == 11


def test_playing_an_occupied_cell_loses_at_once():
    rules = new_game()
    play(rules, [cell(7, 7), cell(0, 0), cell(7, 8)])
    play(rules, [cell(7, 7)])  # white (seat 1) plays on black's stone
    assert rules.game_over
    assert rules.team_result().tolist() == [1.0, 0.0]
    assert rules.measures.outcome.tolist() == [1.0, -1.0]
    assert {"kind": "illegal_move", "seat": 1, "cell": cell(7, 7)} in rules.events()


def test_full_board_without_five_is_a_draw():
    rows, cols = np.divmod(np.arange(SIZE * SIZE), SIZE)
    colour = np.array([0, 0, 1, 1])[(rows + 2 * cols) % 4]  # no line longer than 4 anywhere
    black, white = np.flatnonzero(colour == 0).tolist(), np.flatnonzero(colour == 1).tolist()
    assert len(black) == 113 and len(white) == 112
    rules = new_game()
    play(rules, interleave(black, white)[:-1])
    assert not rules.game_over
    play(rules, [black[-1]])
    assert rules.game_over
    assert rules.team_result().tolist() == [0.5, 0.5]
    assert rules.measures.outcome.tolist() == [0.0, 0.0]
    assert not rules.action_mask().any()


def test_seat_not_to_move_is_ignored_and_mask_marks_empty_cells():
    rules = new_game()
    assert rules.current_player() == 0
    rules.step(np.array([cell(7, 7), cell(7, 7)]))  # seat 1's action is ignored this turn
    assert rules.current_player() == 1 and not rules.game_over
    mask = rules.action_mask()
    assert mask.shape == (2, SIZE * SIZE) and mask[0].sum() == mask[1].sum() == SIZE * SIZE - 1
    assert not mask[:, cell(7, 7)].any()


def test_observation_is_from_each_seats_perspective():
    rules = new_game()
    play(rules, [cell(7, 7), cell(3, 3)])
    obs = rules.observe()
    n = SIZE * SIZE
    assert obs.shape == (2, 2 * n + 5) and obs.dtype == np.float32
    assert obs[0, cell(7, 7)] == 1 and obs[0, n + cell(3, 3)] == 1  # black: own, then opponent
    assert obs[1, cell(3, 3)] == 1 and obs[1, n + cell(7, 7)] == 1  # white sees the mirror image
    assert obs[:, 2 * n].tolist() == [1.0, 0.0]  # black to move
    assert obs[:, 2 * n + 2].tolist() == [1.0, 0.0]  # black moved first
    assert obs[:, 2 * n + 3].tolist() == pytest.approx([2 / n, 2 / n])
    assert obs[:, 2 * n + 4].tolist() == [1.0, 1.0]


def test_two_players_per_team_alternate_turns():
    rules = new_game(players_per_team=2)
    order = []
    for k in range(8):
        order.append(rules.current_player())
        play(rules, [cell(k // SIZE * 2, k * 2 % SIZE)])
    assert order == [0, 2, 1, 3, 0, 2, 1, 3]
    obs = rules.observe()
    n = SIZE * SIZE
    assert np.array_equal(obs[0, :2 * n], obs[1, :2 * n])  # teammates share a colour
    assert obs[:, 2 * n].tolist() == [1.0, 0.0, 0.0, 0.0]  # seat 0 to move
    assert obs[:, 2 * n + 1].tolist() == [1.0, 1.0, 0.0, 0.0]  # team 0 to move


def heuristic_vs_random(seed: int, heuristic_seat: int) -> float:
    rules = GoBangRules(2, 1, "discrete")
    rules.reset(seed)
    rng = np.random.default_rng(seed)
    while not rules.game_over:
        actions = GoBangRules.heuristic(rules.observe(), "discrete")
        random_seat = 1 - heuristic_seat
        actions[random_seat] = rules.random_action(random_seat, rng)
        rules.step(actions)
    return float(rules.team_result()[heuristic_seat])


def test_heuristic_beats_random_in_20_of_20_games():
    results = [heuristic_vs_random(seed, seed % 2) for seed in range(20)]
    assert results == [1.0] * 20


def test_heuristic_wins_when_it_can_and_blocks_a_five():
    rules = new_game()
    # black has four in a row open on the right; white to move must block, then black wins elsewhere
    play(rules, interleave([cell(7, c) for c in (3, 4, 5, 6)], [cell(0, 0), cell(0, 2), cell(0, 4)]))
    assert rules.current_player() == 1
    block = GoBangRules.heuristic(rules.observe(), "discrete")[1]
    assert block in (cell(7, 2), cell(7, 7))
    rules.step(np.array([0, block]))
    win = GoBangRules.heuristic(rules.observe(), "discrete")[0]
    assert win in (cell(7, 2), cell(7, 7)) and win != block
    rules.step(np.array([win, 0]))
    assert rules.game_over and rules.team_result().tolist() == [1.0, 0.0]


def test_batched_engine_and_single_board_agree_move_for_move():
    n_boards = 12
    boards = GoBangBoards(n_boards, seed=5)
    singles = [new_game() for _ in range(n_boards)]
    for _ in range(SIZE * SIZE):
        if boards.done.all():
            break
        actions = boards.random_actions()
        if _ % 17 == 16:
            actions[:3] = cell(7, 7)  # now and then an illegal move on a few boards
        boards.step(actions)
        for b, rules in enumerate(singles):
            if not rules.game_over:
                play(rules, [int(actions[b])])
            assert np.array_equal(rules.engine.cells[0], boards.cells[b])
            assert rules.game_over == bool(boards.done[b])
            assert int(rules.engine.winner[0]) == int(boards.winner[b])
            obs = rules.observe()
            if not rules.game_over:
                assert np.array_equal(obs, boards.observe()[b])
    assert boards.done.all()
    assert set(boards.winner.tolist()) <= {-1, 0, 1} and boards.illegal.any()


def test_autoreset_reports_the_finished_game_and_starts_afresh():
    boards = GoBangBoards(64, seed=1, autoreset=True)
    finished = 0
    for _ in range(400):
        boards.step(boards.random_actions())
        ended = boards.done
        finished += int(ended.sum())
        assert np.all(boards.n_stones[ended] == 0) and np.all(boards.to_move[ended] == 0)
        assert np.all(boards.winner[ended] >= 0) or np.all(boards.winner[~ended] == -1)
    assert finished > 64


def test_bad_options_and_actions_name_the_fix():
    with pytest.raises(ValueError, match=r"GoBang has no option 'board'; its options: size: an integer in \[2, inf\], "
                                         r"default 15 \(the board's side.*\); n_in_row: "):
        make("GoBang-2T1P-v1", board=19)
    with pytest.raises(ValueError, match=r"GoBang option size must be an integer in \[n_in_row = 5, inf\] "
                                         r"\(default 15: the board's side.*\), not 4$"):
        GoBangRules(2, 1, "discrete", size=4)
    with pytest.raises(ValueError, match=r"GoBang option n_in_row must be an integer in \[2, inf\] \(default 5: "
                                         r"stones in a line that win\), not 5.0$"):
        make("GoBang-2T1P-v1", n_in_row=5.0)
    with pytest.raises(ValueError, match=r"GoBang has no option 'sise' \(did you mean 'size'\?\)"):
        make("GoBang-2T1P-v1", sise=9)
    assert make("GoBang-2T1P-v1", size=9, n_in_row=4).rules.size == 9
    boards = GoBangBoards(2)
    with pytest.raises(ValueError, match=r"cells are 0..224"):
        boards.step(np.array([0, 225]))
    with pytest.raises(ValueError, match=r"one integer cell per board, shape \(2,\)"):
        boards.step(np.array([0]))


def test_native_aec_env_plays_a_whole_game():
    env = make_aec("GoBang-2T1P-v1")
    env.reset(seed=0)
    moves = 0
    for agent in env.agent_iter():
        _, _, terminated, truncated, _ = env.last()
        if terminated or truncated:
            env.step(None)
            continue
        obs = env.observe(agent)  # PettingZoo's dict: the vector and the legal moves
        assert obs["action_mask"].dtype == np.int8 and obs["action_mask"].sum() == 225 - moves
        env.step(int(GoBangRules.heuristic(obs["observation"][None], "discrete")[0]))
        moves += 1
    assert env.team_result().tolist() == [1.0, 0.0]  # the heuristic mirror match: black wins
    assert moves == int(env._par.rules.engine.n_stones[0])


def test_default_tree_verifies_as_declared():
    report = verify("GoBang-2T1P-v1", samples=8, seed=0)
    assert report.ok and [n.verified for n in report.nodes] == ["CP"]
