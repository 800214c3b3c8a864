"""Human ranking in the terminal: a person (here a scripted input) plays GoBang and Snake against a
frozen base population, bad input is refused and asked again, results are stored as a human agent,
and the placement is reported after each match."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest

from arena_league.envs.controls import ascii_topdown
from arena_league.league import import_population, open_home
from arena_league.league.human import play_human
from arena_league.policies import init_parameters, save_arena_policy
from arena_league.policies.architecture import Architecture
from arena_league.policies.families import with_spaces
from arena_league.policies.spaces import game_action_spec
from arena_league.registry import get_agent, match_seat_rows


def frozen_population(league, tmp_path: Path, game_id: str, ratings: list[float]) -> str:
    """A base population of small MLPs with fresh weights (near-uniform play), rated as given,
    written as a population folder and imported like a shipped one."""
    arch = with_spaces(Architecture("mlp", 1, "discrete", n_actions=1, hidden=(8,)), game_action_spec(game_id))
    folder = tmp_path / "population"
    members = []
    for i, rating in enumerate(ratings):
        name = f"base-t.m{i}@{game_id}"
        save_arena_policy(folder / "agents" / f"m{i}", arch, init_parameters(arch, seed=i), game_id, name=name)
        members.append({"name": name, "kind": "base", "artifact": f"agents/m{i}", "format": "arena-policy",
                        "metadata": {"rating": rating}, "agent_metadata": {}})
    (folder / "population.json").write_text(json.dumps({"name": "base-t", "version": 1, "game_id": game_id,
                                                        "provenance": {}, "members": members}))
    return import_population(league, folder)


class ScriptedGoBang:
    """Answers the prompts: first a non-number, a cell off the board, the centre, the centre again
    (now occupied), then the cells of the top row left to right (skipping none: an occupied cell
    is refused and the next one tried), and q when asked for another match."""

    def __init__(self) -> None:
        self.script = iter(["seven", "16 1", "8 8", "8 8"] + [f"{chr(ord('A') + c)}{r}" for r in range(1, 16)
                                                            for c in range(15)])
        self.prompts: list[str] = []

    def __call__(self, prompt: str) -> str:
        self.prompts.append(prompt)
        if prompt.startswith("Next match"):
            return "q"
        return next(self.script)


def test_gobang_human_plays_the_weakest_first_with_refused_input(tmp_path):
    game = "GoBang-2T1P-v1"
    league = open_home(tmp_path / "league")
    label = frozen_population(league, tmp_path, game, [1200.0, 800.0, 1000.0])
    out = io.StringIO()
    answers = ScriptedGoBang()
    session = play_human(game, label, league, player="ada", input_fn=answers, output=out, seed=3)
    text = out.getvalue()
    # bad input is refused with the reason, and asked again
    assert "'seven' is not a cell" in text
    assert "row 16, column 1 is off the board" in text
    assert "H8 is occupied" in text
    # the weakest member (rated 800) came first; one match was played, then the person stopped
    assert len(session.matches) == 1
    first = session.matches[0]
    assert first.opponent == "base-t.m1@GoBang-2T1P-v1" and first.opponent_rating == 800.0
    assert first.team == 0 and first.outcome in ("win", "loss", "draw")
    assert "X" in text and "Your estimated placement" in text
    # stored as a human agent with its match in the registry, placed by the rating engine
    with league.reading() as db:
        agent = get_agent(db, "ada@GoBang-2T1P-v1")
        assert agent.kind == "human" and agent.artifact is None
        rows = match_seat_rows(db, game, agents=["ada@GoBang-2T1P-v1", first.opponent])
    assert {r["agent"] for r in rows} == {"ada@GoBang-2T1P-v1", first.opponent}
    assert [r["outcome"] for r in rows if r["agent"] == "ada@GoBang-2T1P-v1"] == [first.outcome]
    assert session.total_matches == 1 and session.lower <= session.rating <= session.upper
    assert 1 <= session.rank_lower <= session.rank <= session.rank_upper <= 4


def test_gobang_human_climbs_after_a_win_and_a_later_session_continues(tmp_path):
    game = "GoBang-2T1P-v1"
    league = open_home(tmp_path / "league")
    label = frozen_population(league, tmp_path, game, [800.0, 900.0, 1000.0, 1100.0])
    first = play_human(game, label, league, player="bo", input_fn=ScriptedGoBang(), output=io.StringIO(),
                       matches=1, climb=2)
    assert first.matches[0].opponent_rating == 800.0
    second = play_human(game, label, league, player="bo", input_fn=lambda prompt: "q", output=io.StringIO())
    # q at the first move resigns: a loss, recorded, and the placement counts both sessions
    assert second.matches[0].resigned and second.matches[0].outcome == "loss"
    assert second.total_matches == 2


def test_snake_human_moves_on_the_board_as_drawn(tmp_path):
    game = "Snake-2T1P-v1"
    league = open_home(tmp_path / "league")
    label = frozen_population(league, tmp_path, game, [900.0, 1100.0])
    moves = iter(["x"] + ["w"] * 3 + ["d"] * 30 + [""] * 600)
    out = io.StringIO()

    def answer(prompt: str) -> str:
        return "q" if prompt.startswith("Next match") else next(moves)

    session = play_human(game, label, league, player="cy", input_fn=answer, output=out)
    text = out.getvalue()
    assert "'x' is not a move" in text
    assert "@" in text and "#" * 22 in text  # the head and the walls of a 20 x 20 board
    assert len(session.matches) == 1 and session.matches[0].steps > 3


def test_sumo_human_steers_an_ant_that_trots_as_told(tmp_path):
    """A robot game: the person names a direction on the arena as drawn (and how long to hold it);
    the scripted trot walks there. Team 0 starts left of the centre, so 'd' walks toward it."""
    game = "Sumo-2T1P-v1"
    league = open_home(tmp_path / "league")
    label = frozen_population(league, tmp_path, game, [900.0, 1100.0])
    answers = iter(["fly", "d 0", "ad", "d 20", "", "x 400"])
    out = io.StringIO()

    def answer(prompt: str) -> str:
        return "q" if prompt.startswith("Next match") else next(answers)

    session = play_human(game, label, league, player="cy", input_fn=answer, output=out)
    text = out.getvalue()
    assert "'fly' is not a direction" in text and "'d 0' is not a command" in text and "'ad' cancels out" in text
    distances = [float(line.split("you ")[1].split(" m")[0]) for line in text.splitlines()
                 if line.startswith("Ring radius 2.0 m")]
    assert distances[0] == pytest.approx(1.0, abs=0.05) and distances[2] < distances[0] - 0.3  # walked inward
    assert len(session.matches) == 1 and session.matches[0].steps > 40


def test_ascii_topdown_of_a_physics_game_shows_both_teams():
    from arena_league.envs import make

    env = make("Soccer-2T1P-v1")
    env.reset(seed=0)
    view = ascii_topdown(env.rules.render_topdown())
    assert "0" in view and "1" in view and "#" in view  # both teams and the stands around the field
    assert len(view.splitlines()) > 10


def test_unknown_population_is_refused_with_the_known_ones(tmp_path):
    league = open_home(tmp_path / "league")
    frozen_population(league, tmp_path, "GoBang-2T1P-v1", [1000.0, 1100.0])
    with pytest.raises(ValueError, match="Known for GoBang-2T1P-v1: base-t:1"):
        play_human("GoBang-2T1P-v1", "base-v9", league, input_fn=lambda p: "q", output=io.StringIO())
    with pytest.raises(ValueError, match="population import FOLDER.*population build GoBang-2T1P-v1"):
        play_human("GoBang-2T1P-v1", "base-v9", league, input_fn=lambda p: "q", output=io.StringIO())


def test_the_shipped_base_population_is_imported_when_the_league_lacks_it(tmp_path):
    """`arena-league play GAME` on a fresh home: the population shipped under checkpoints/ comes in,
    under its own version even when another game's base-v1 holds the name already."""
    league = open_home(tmp_path / "league")
    frozen_population(league, tmp_path, "GoBang-2T1P-v1", [1000.0, 1100.0])  # named base-t
    out = io.StringIO()
    moves = iter(["q"])
    session = play_human("Snake-2T2P-v1", "base-v1", league, player="cy", input_fn=lambda p: next(moves, "q"),
                         output=out)
    assert "imported the shipped base population base-v1:1 of Snake-2T2P-v1" in out.getvalue()
    assert session is not None
    again = io.StringIO()
    play_human("Snake-2T2P-v1", "base-v1", league, player="cy", input_fn=lambda p: "q", output=again)
    assert "imported" not in again.getvalue()  # registered now: not imported twice


def test_play_takes_the_population_rank_uses_by_default(tmp_path):
    """Without `--against`, a person plays the population entrants are ranked against: the newest
    shipped (base-v2 where one is shipped, not base-v1), then a newer frozen one of the league's own;
    a game with none says how to get one."""
    league = open_home(tmp_path / "league")
    out = io.StringIO()
    play_human("Snake-2T2P-v1", league=league, player="cy", input_fn=lambda p: "q", output=out)
    assert "imported the shipped base population base-v2:1 of Snake-2T2P-v1" in out.getvalue()
    assert "base-v2:1 has 100 agents" in out.getvalue()
    frozen_population(league, tmp_path, "Snake-2T2P-v1", [1000.0, 1100.0])
    again = io.StringIO()
    play_human("Snake-2T2P-v1", league=league, player="cy", input_fn=lambda p: "q", output=again)
    assert "imported" not in again.getvalue() and "base-t:1 has 2 agents" in again.getvalue()
    with pytest.raises(ValueError, match="Snake-2T1P-v1 has no base population.*population build"):
        play_human("Snake-2T1P-v1", league=league, input_fn=lambda p: "q", output=io.StringIO())
