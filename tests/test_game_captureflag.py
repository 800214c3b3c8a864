"""CaptureFlag: maps, tags, pick-ups, captures, respawns, the seat frame, the heuristic's skill."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs import make
from arena_league.envs.games.captureflag import CaptureFlagBoards, CaptureFlagRules

ROWS, COLS = 11, 20
STAY, UP, RIGHT, DOWN, LEFT = range(5)
OPEN = np.zeros((ROWS, COLS), dtype=bool)
STAND_0, STAND_1 = 5 * COLS + 1, 5 * COLS + 18


def cell(row: int, col: int) -> int:
    return row * COLS + col


def duel(positions: list[int], **options) -> CaptureFlagRules:
    """A 2T1P match on an open map with the seats on ``positions``."""
    rules = CaptureFlagRules(2, 1, "discrete", **options)
    rules.reset(0)
    rules.engine.set_board(0, OPEN, positions)
    return rules


def play(rules: CaptureFlagRules, *actions: int) -> None:
    rules.step(np.array(actions, dtype=np.int64))


def test_maps_come_from_the_seed_mirrored_between_the_teams():
    engine = CaptureFlagBoards(3, 2)
    engine.reset(keys=np.array([7, 7, 8], dtype=np.uint64))
    walls = engine.walls[:, engine._inner].reshape(3, ROWS, COLS)
    assert np.array_equal(walls[0], walls[1])
    assert not np.array_equal(walls[0], walls[2])
    for board in walls:
        assert board.any() and np.array_equal(board, board[:, ::-1])
        assert not board[3:8, 0:3].any()  # each base stays open
    a, b = make("CaptureFlag-2T2P-v1"), make("CaptureFlag-2T2P-v1")
    a.reset(seed=11)
    b.reset(seed=11)
    assert np.array_equal(a.unwrapped.rules.engine.walls, b.unwrapped.rules.engine.walls)
    # every open cell is reachable from both stands
    assert (engine.dist[:, :, engine._inner] < 1 << 20).sum() == 2 * (~walls).sum()


def test_a_raider_next_to_a_defender_at_home_is_tagged_and_respawns_after_the_delay():
    rules = duel([cell(5, 10), cell(5, 12)], respawn_delay=3)
    play(rules, STAY, RIGHT)  # team 1's "right" is the board's left: the defender steps next to the raider
    assert rules.events() == [{"kind": "tag", "seat": 0}]
    assert rules.measures.active.tolist() == [False, True]
    assert rules.engine.cell(rules.engine.pos[0, 0]) == cell(4, 0)  # back on its start cell
    for _ in range(3):
        play(rules, RIGHT, STAY)  # ignored while waiting
        assert rules.engine.cell(rules.engine.pos[0, 0]) == cell(4, 0)
    assert rules.measures.active.tolist() == [True, True]
    play(rules, RIGHT, STAY)
    assert rules.engine.cell(rules.engine.pos[0, 0]) == cell(4, 1)


def test_a_defender_in_its_own_half_is_never_tagged():
    rules = duel([cell(5, 9), cell(5, 10)])  # each on its own side of the middle, next to each other
    play(rules, STAY, STAY)
    assert rules.events() == [] and rules.measures.active.all()


def test_a_carrier_is_exposed_even_at_home_and_exposed_neighbours_tag_each_other():
    rules = duel([cell(5, 3), cell(5, 5)])
    rules.engine.carrier[0, 1] = 0  # seat 0 carries team 1's flag in its own half
    play(rules, STAY, RIGHT)  # the raider steps next to it, in team 0's half
    assert rules.events() == [{"kind": "tag", "seat": 0}, {"kind": "tag", "seat": 1}]
    assert rules.engine.flag_cells(0).tolist() == [STAND_0, STAND_1]


def test_a_tagged_carrier_drops_the_flag_and_it_goes_home():
    rules = duel([cell(5, 17), cell(3, 16)])
    play(rules, RIGHT, STAY)
    assert rules.events() == [{"kind": "pickup", "seat": 0}]
    assert rules.engine.flag_cells(0).tolist() == [STAND_0, STAND_1]
    play(rules, LEFT, STAY)  # one step home with the flag
    assert rules.engine.flag_cells(0)[1] == cell(5, 17)
    assert rules.measures.object_progress.tolist() == [1.0, 0.0]
    play(rules, LEFT, DOWN)  # the defender steps next to the carrier
    assert rules.events() == [{"kind": "tag", "seat": 0}]
    assert rules.engine.flag_cells(0).tolist() == [STAND_0, STAND_1]
    assert rules.measures.object_progress.tolist() == [-1.0, 0.0]  # the carry's gain is lost


def test_a_capture_needs_the_own_flag_at_home_and_wins_at_captures_to_win():
    rules = duel([cell(5, 2), cell(0, 5)], captures_to_win=2)
    engine = rules.engine
    engine.carrier[0] = [1, 0]  # each carries the other's flag
    play(rules, LEFT, STAY)
    assert engine.cell(engine.pos[0, 0]) == STAND_0 and engine.captures[0].tolist() == [0, 0]
    engine.carrier[0, 0] = -1  # the own flag is back: the waiting carrier scores
    play(rules, STAY, STAY)
    assert rules.events() == [{"kind": "capture", "team": 0}]
    assert engine.captures[0].tolist() == [1, 0] and not rules.game_over
    engine.carrier[0, 1] = 0
    play(rules, STAY, STAY)
    assert rules.game_over and rules.team_result().tolist() == [1.0, 0.0]
    assert rules.measures.outcome.tolist() == [1.0, -1.0]


def test_a_whole_carry_pays_the_team_the_distance_between_the_stands():
    rules = duel([cell(5, 17), cell(0, 15)], captures_to_win=1)
    progress, toward = 0.0, []
    play(rules, RIGHT, STAY)  # onto the opponents' stand: the pick-up
    toward.append(rules.measures.velocity_to_target[0])
    while not rules.game_over:
        play(rules, LEFT, STAY)
        progress += rules.measures.object_progress[0]
        toward.append(rules.measures.velocity_to_target[0])
    assert rules.events() == [{"kind": "capture", "team": 0}]
    assert progress == 17.0 == rules.engine.stand_distance[0]  # the last step, the capture, included
    assert toward == [1.0] * 18  # every step brought the raider, then the carrier, one step nearer
    assert rules.measures.outcome.tolist() == [1.0, -1.0]


def test_a_match_cut_at_max_cycles_is_decided_by_captures():
    env = make("CaptureFlag-2T1P-v1", max_cycles=4)
    env.reset(seed=2)
    for _ in range(4):
        env.step({"player_0": STAY, "player_1": STAY})
    assert not env.agents
    assert env.unwrapped.rules.team_result().tolist() == [0.5, 0.5]


def test_equal_captures_at_max_cycles_go_to_the_team_that_held_the_flag_longer():
    env = make("CaptureFlag-2T1P-v1", max_cycles=4)
    env.reset(seed=2)
    rules = env.unwrapped.rules
    rules.engine.set_board(0, OPEN, [cell(5, 17), cell(0, 5)])
    env.step({"player_0": RIGHT, "player_1": STAY})  # onto the opponents' stand: the pick-up
    for _ in range(3):
        env.step({"player_0": STAY, "player_1": STAY})
    assert not env.agents and rules.engine.captures[0].tolist() == [0, 0]
    assert rules.engine.held_steps[0].tolist() == [4, 0]
    assert rules.team_result().tolist() == [1.0, 0.0] and rules.measures.outcome.tolist() == [1.0, -1.0]
    # the batched engine ends its matches the same way, for either team
    boards = CaptureFlagBoards(2, 1, max_steps=4)
    boards.set_board(0, OPEN, [cell(5, 17), cell(0, 5)])
    boards.set_board(1, OPEN, [cell(0, 14), cell(5, 2)])
    boards.step(np.array([[RIGHT, STAY], [STAY, RIGHT]]))
    for _ in range(3):
        boards.step(np.array([[STAY, STAY], [STAY, STAY]]))
    assert boards.done.all() and boards.captures.tolist() == [[0, 0], [0, 0]]
    assert boards.held_steps.tolist() == [[4, 0], [0, 4]]
    assert boards.final_scores.tolist() == [[1.0, 0.0], [0.0, 1.0]]


def test_both_teams_see_the_map_from_their_own_side():
    env = make("CaptureFlag-2T1P-v1")
    obs, _ = env.reset(seed=5)
    assert np.array_equal(obs["player_0"], obs["player_1"])
    for action in (RIGHT, RIGHT, UP, RIGHT):  # the same move in each seat frame: mirror images on the board
        obs, *_ = env.step({"player_0": action, "player_1": action})
        assert np.array_equal(obs["player_0"], obs["player_1"])
    engine = env.unwrapped.rules.engine
    cells = engine.cell(engine.pos[0])
    assert cells[0] // COLS == cells[1] // COLS and cells[0] % COLS == COLS - 1 - cells[1] % COLS


def test_odd_columns_are_refused_with_the_fix():
    with pytest.raises(ValueError, match="cols must be even.*try 22"):
        make("CaptureFlag-2T2P-v1", cols=21)


@pytest.mark.parametrize("players", [1, 2])
def test_the_heuristic_beats_random_play(players):
    """Heuristic teams against uniformly random ones over 60 seeded matches, 30 on each side."""
    n_boards = 60
    engine = CaptureFlagBoards(n_boards, players, seed=1)
    rng = np.random.default_rng(4)
    n = 2 * players
    heuristic_team = np.arange(n_boards) % 2  # half the matches on each side
    seat_team = engine.team_of
    for _ in range(300):
        actions = CaptureFlagRules.heuristic(engine.observe().reshape(n_boards * n, -1), "discrete").reshape(n_boards, n)
        random = rng.integers(5, size=(n_boards, n))
        actions = np.where(seat_team[None, :] == heuristic_team[:, None], actions, random)
        engine.step(actions)
        if engine.done.all():
            break
    scores = engine.team_scores()[np.arange(n_boards), heuristic_team]
    assert (scores == 1.0).mean() >= 0.9, scores


def test_tuned_heuristics_parse_are_bounded_and_default_to_the_heuristic():
    from arena_league.policies.scripted import scripted_policy

    game = "CaptureFlag-2T1P-v1"
    tuned = scripted_policy("heuristic-commit0.5-hunt6-keep0.5-sortie0.9", game)
    assert tuned.name == "heuristic-commit0.5-hunt6-keep0.5-sortie0.9"
    assert tuned.options == {"commit": 0.5, "hunt": 6.0, "keep": 0.5, "sortie": 0.9}
    with pytest.raises(ValueError, match="keep must be from 0 to 10, not 12"):
        scripted_policy("heuristic-keep12", game)
    for players in (2, 1):
        engine = CaptureFlagBoards(16, players, seed=3)
        rng = np.random.default_rng(1)
        batch = []
        for _ in range(40):  # random play: seats on both halves, some tagged, some carrying
            engine.step(rng.integers(5, size=(16, 2 * players)))
            batch.append(engine.observe().reshape(16 * 2 * players, -1))
        obs = np.concatenate(batch)
        plain = CaptureFlagRules.heuristic(obs, "discrete")
        zeros = CaptureFlagRules.heuristic(obs, "discrete", commit=0.0, hunt=0.0, keep=0.0, sortie=0.0)
        np.testing.assert_array_equal(zeros, plain)
    assert (CaptureFlagRules.heuristic(obs, "discrete", commit=0.5, hunt=6.0, keep=0.5, sortie=0.9) != plain).any()


def test_a_keeper_waits_by_its_stand_while_the_raider_is_far():
    rules = duel([cell(5, 4), cell(5, 15)])
    obs = rules.engine.observe()[0]
    assert CaptureFlagRules.heuristic(obs[:1], "discrete")[0] == RIGHT
    assert CaptureFlagRules.heuristic(obs[:1], "discrete", keep=2.0)[0] == LEFT  # back toward its stand


def test_the_search_agent_is_bounded_and_corners_a_raider():
    """``search-w8-r1-h3`` parses and refuses budgets it cannot search with one clear ValueError; a raider in
    the map's corner, 3 steps off, is walked to (it stays put there) and tagged on the second step."""
    from arena_league.policies.scripted import scripted_policy

    game = "CaptureFlag-2T1P-v1"
    assert scripted_policy("search-w8-r1-h3", game).name == "search-w8-r1-h3"
    with pytest.raises(ValueError, match="ask for R = 1, as in search-w8-r1-h3, not R = 2"):
        scripted_policy("search-w8-r2-h3", game)
    with pytest.raises(ValueError, match="H \\(plies\\) from 1 to 4, not W = 8, H = 5"):
        scripted_policy("search-w8-r1-h5", game)
    rules = duel([cell(2, 1), cell(0, 0)])
    tagged = []
    for _ in range(2):
        obs = rules.engine.observe()[0]
        mine = CaptureFlagRules.search(obs[:1], np.ones(1), action_type="discrete", width=8, rollouts=1, horizon=3,
                                       epsilon=0.0)
        rules.step(np.array([mine[0], CaptureFlagRules.heuristic(obs[1:], "discrete")[0]]))
        tagged += [e["seat"] for e in rules._events if e["kind"] == "tag"]
    assert tagged == [1]


def test_the_search_agent_beats_the_heuristic():
    """Over 16 seeded duels, 8 on each side, the search agent wins most (it won 139 and 126 of 200 with league
    seeds 11 and 12, the manual's figures)."""
    n_boards = 16
    engine = CaptureFlagBoards(n_boards, 1, seed=2, max_steps=300)
    agent_team = np.arange(n_boards) % 2
    for _ in range(300):
        obs = engine.observe()
        actions = CaptureFlagRules.heuristic(obs.reshape(2 * n_boards, -1), "discrete").reshape(n_boards, 2)
        actions[np.arange(n_boards), agent_team] = CaptureFlagRules.search(
            obs[np.arange(n_boards), agent_team], np.ones(n_boards), action_type="discrete", width=8, rollouts=1,
            horizon=3, epsilon=0.0)
        engine.step(actions)
        if engine.done.all():
            break
    scores = engine.team_scores()[np.arange(n_boards), agent_team]
    assert (scores == 1.0).sum() >= 10 and (scores == 0.0).sum() <= 2, scores
