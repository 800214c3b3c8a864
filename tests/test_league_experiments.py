"""The paper's experiments end to end at tiny budgets, their behaviour measures on hand-built
episodes, and a population's averaged ranking (`rank --members`)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_helpers import gobang_agent, run

from arena_league.envs.games import crossroads as game
from arena_league.league.experiments import (
    BASELINES,
    _episode_measures,
    _finite,
    baselines,
    checkpoint_steps,
    crossroads_behaviour,
    ordering_flips,
)
from arena_league.policies.scripted import scripted_policy

pytest_plugins = ["cli_helpers"]  # the home fixture
L, V, R, HALF = game.ARM_LENGTH, game.TOP_SPEED, game.AGENT_RADIUS, game.ROAD_HALF_WIDTH
assert game.CrossroadsRules.geometry == {"arm_length": L, "road_half_width": HALF, "agent_radius": R, "top_speed": V}
TEAMS = np.array([0, 0, 1, 1])
DIRECTION = np.array([[1.0, 0.0], [0.0, 1.0]])


def _state(positions, velocities=None, active=None) -> np.ndarray:
    """One step's state ``[seats, 9]`` from world positions, velocities and active flags."""
    n = len(positions)
    s = np.zeros((n, 9))
    s[:, 0:2] = np.asarray(positions, dtype=float) / L
    s[:, 2:4] = (np.zeros((n, 2)) if velocities is None else np.asarray(velocities, dtype=float)) / V
    s[:, 8] = 1.0 if active is None else np.asarray(active, dtype=float)
    return s


def _measures(states, cycles=300):
    return _episode_measures(np.stack(states), TEAMS, DIRECTION, cycles, L, V, R, HALF)


def test_a_crash_at_the_centre_counts_once_and_arrivals_are_censored():
    far = [(-8, 0.6), (-8, -0.6), (0.6, -8), (-0.6, -8)]
    touching = [(-0.5, 0.0), (-8, -0.6), (0.45, 0.0), (-0.6, -8)]  # seats 0 and 2 touch at the centre
    arrived = [(9, 0.6), (-8, -0.6), (0.45, 0.0), (-0.6, -8)]
    m = _measures([_state(far), _state(touching), _state(touching),
                   _state(arrived, active=[0, 1, 1, 1])], cycles=300)
    assert m["collisions"] == 1 and m["centre_collisions"] == 1  # begun once, though touching two steps
    assert m["arrived_share"] == 0.25
    assert m["mean_arrival_step"] == (4 + 3 * 300) / 4 and m["last_arrival_step"] == 300


def test_standing_in_the_other_road_ahead_of_its_agents_is_blocking():
    # Seat 0 (team 0) stands on team 1's road north of team 1's agents while its teammate drives on.
    blocking = [(0.0, -3.0), (-6, -0.6), (0.6, -8), (-0.6, -8)]
    steps = [_state(blocking, velocities=[(0, 0), (2, 0), (0, 2), (0, 2)])] * 12
    m = _measures(steps)
    assert m["blocking_steps"] == 12 and m["blocking_share"] == 1.0
    # Not when moving, nor once the team's last other member has arrived.
    moving = _measures([_state(blocking, velocities=[(0, 2), (2, 0), (0, 2), (0, 2)])] * 12)
    alone = _measures([_state(blocking, active=[1, 0, 1, 1])] * 12)
    assert moving["blocking_steps"] == 0 and alone["blocking_steps"] == 0


def test_behaviour_of_the_heuristic_is_deterministic_and_plausible():
    heuristic = scripted_policy("scripted:heuristic", "Crossroads-2T2P-v1")
    first = crossroads_behaviour([heuristic] * 4, None, 4, seed=3)
    again = crossroads_behaviour([heuristic] * 4, None, 4, seed=3)
    assert first == again
    assert all(e["arrived_share"] == 1.0 and e["last_arrival_step"] < 200 for e in first)


def test_checkpoints_and_ordering_flips():
    # an iteration without a finished episode has no return, whichever way its trainer says so
    assert _finite(float("nan")) is None and _finite(None) is None and _finite(2) == 2.0
    assert checkpoint_steps(200_000, 6, 1024) == [6250, 12500, 25000, 50000, 100000, 200000]
    assert checkpoint_steps(2048, 4, 1024)[-1] == 2048
    assert ordering_flips({"a": [1, 2, 3], "b": [0, 1, 2]}) == 0.0
    assert ordering_flips({"a": [1, 0, 1], "b": [0, 1, 0]}) == 1.0


def test_crossroads_social_end_to_end_and_deterministic(capsys, tmp_path):
    argv = ["experiment", "crossroads-social", "--seeds", "0", "1", "--steps", "1024", "--episodes", "2",
            "--max-cycles", "40", "--json"]
    code, report, err = run(capsys, *argv, "--out", tmp_path / "a")
    assert code == 0, err
    assert set(report) >= {"game", "seeds", "steps_per_run", "trees"} and report["seeds"] == [0, 1]
    assert set(report["trees"]) == {"all_IS", "all_CL", "CL_under_CP"}
    for measures in report["trees"].values():
        for m in measures.values():
            assert m["lower"] <= m["mean"] <= m["upper"]
    saved = json.loads((tmp_path / "a" / "report.json").read_text())
    assert saved["trees"] == report["trees"]
    assert (tmp_path / "a" / "measures.png").stat().st_size > 0 and "## The paper's claims" in (
        tmp_path / "a" / "README.md").read_text()
    _, again, _ = run(capsys, *argv, "--out", tmp_path / "b")
    assert again["trees"] == report["trees"] and again["per_seed"] == report["per_seed"]


def test_baselines_end_to_end_at_a_tiny_budget(capsys, tmp_path):
    code, report, err = run(capsys, "experiment", "baselines", "Crossroads-2T2P-v1", "--seeds", "0", "1",
                            "--steps", "1024", "--checkpoints", "2", "--budget", "2", "--max-cycles", "40",
                            "--out", tmp_path, "--json")
    assert code == 0, err
    assert report["methods"] == list(BASELINES) and report["tree"] == "CL_under_CP" and report["base_size"] == 100
    for method in BASELINES:
        assert len(report["runs"][method]) == 2
        final = report["final"][method]
        assert final["lower"] <= final["iqm_final_percentile"] <= final["upper"]
        for run_ in report["runs"][method]:
            assert all(1 <= c["rank"] <= 101 and c["matches"] == 2 for c in run_["checkpoints"])
    poi = report["probability_of_improvement"]
    assert poi["dppo"]["sp"] + poi["sp"]["dppo"] == pytest.approx(1.0)
    assert {"episode_reward", "percentile"} <= set(report["noise"])
    assert (tmp_path / "curves.png").stat().st_size > 0 and (tmp_path / "report.json").exists()
    # again into the same folder, the log on: every run and placement is read back, the report the same
    code, _, err = run(capsys, "experiment", "baselines", "Crossroads-2T2P-v1", "--seeds", "0", "1", "--steps",
                       "1024", "--checkpoints", "2", "--budget", "2", "--max-cycles", "40", "--out", tmp_path)
    assert code == 0 and "dppo, seed 1: read back from" in " ".join(err.split()) and "trained" not in err
    assert json.loads((tmp_path / "report.json").read_text())["final"] == report["final"]


def test_experiment_errors_are_one_line_with_the_fix(capsys, tmp_path):
    # PushBox's actions are continuous: CF (COMA) cannot train it, and asked for alone it is refused
    code, _, err = run(capsys, "experiment", "baselines", "PushBox-2T2P-v1", "--methods", "cf", "--out",
                       tmp_path / "pushbox")
    assert code == 2 and "no method of those asked can train PushBox-2T2P-v1" in err and "discrete actions" in err
    assert not (tmp_path / "pushbox").exists()  # nothing written by a command that could not start
    with pytest.raises(ValueError, match="ships no base population 'base-v9'.*population build Crossroads-2T2P-v1"):
        baselines("Crossroads-2T2P-v1", tmp_path / "crossroads", population="base-v9")
    (tmp_path / "file").write_text("")
    code, _, err = run(capsys, "experiment", "crossroads-social", "--out", tmp_path / "file" / "report")
    assert code == 2 and "cannot write the report folder" in err and "--out" in err
    code, _, err = run(capsys, "experiment", "baselines", "--out", tmp_path)
    assert code == 2 and "name the game" in err
    code, _, err = run(capsys, "experiment", "baselines", "Snake-2T2P-v1", "--out", tmp_path)
    assert code == 2 and "runs on Crossroads-2T2P-v1 or PushBox-2T2P-v1" in err
    assert "Traceback" not in err


def test_rank_members_averages_the_population(capsys, home, tmp_path):
    folder = tmp_path / "mine"
    for seed in (1, 2, 3):
        gobang_agent(folder / f"agent-{seed}", seed=seed)
    code, report, err = run(capsys, "rank", "--members", folder, "--game", "GoBang-2T1P-v1", "--budget", "6",
                            "--json")
    assert code == 0, err
    assert report["base_size"] == 100 and len(report["members"]) == 3
    ranks = [m["rank"] for m in report["members"]]
    assert report["mean_rank"] == pytest.approx(np.mean(ranks))
    assert report["mean_rank_lower"] <= report["mean_rank"] <= report["mean_rank_upper"]
    assert report["mean_percentile_lower"] <= report["mean_percentile"] <= report["mean_percentile_upper"]
    # the same members by name, now registered (files submitted again keep their agents)
    names = [m["agent"] for m in report["members"]]
    assert names == ["mine.agent-1", "mine.agent-2", "mine.agent-3"]
    code, by_name, _ = run(capsys, "rank", "--members", *names, "--budget", "6", "--json")
    assert code == 0 and [m["agent"] for m in by_name["members"]] == names and by_name["base"] == report["base"]
    code, by_path, _ = run(capsys, "rank", "--members", folder, "--game", "GoBang-2T1P-v1", "--budget", "6", "--json")
    assert [m["agent"] for m in by_path["members"]] == names
    code, _, err = run(capsys, "rank", "--members", folder, "--budget", "6")
    assert code == 2 and "--game" in err
    code, _, err = run(capsys, "rank", "alice", "--members", "bob")
    assert code == 2 and "not both" in err
    code, _, err = run(capsys, "rank", "--members", "nobody-here")
    assert code == 2 and "neither a path nor an agent" in err


def test_the_command_offers_the_papers_baselines():
    from arena_league.cli import _BASELINES

    assert _BASELINES == BASELINES


def test_a_base_population_with_built_in_members_is_loaded_whole():
    """PushBox's base-v1 tops its ladder with tuned heuristics, members without an artifact: the
    experiment plays them as the built-in agents their names say."""
    from arena_league.league.experiments import _base_population
    from arena_league.policies.scripted import HeuristicPolicy

    names, ratings, policies = _base_population("PushBox-2T2P-v1", "base-v1")
    assert len(names) == len(ratings) == len(policies) == 100
    tuned = [name for name, policy in policies.items() if isinstance(policy, HeuristicPolicy)]
    assert len(tuned) == 5 and "base-v1.heuristic-kp1.75-lane0.6-period0.4-side0.3@PushBox-2T2P-v1" in tuned


def _without_timings(report: dict) -> dict:
    """A report without what depends on the machine: its seconds."""
    def strip(value):
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if not k.endswith("seconds")}
        if isinstance(value, list):
            return [strip(v) for v in value]
        return value
    return strip(report)


def test_runs_spread_over_processes_give_the_report_of_runs_here(capsys, tmp_path):
    """The runs trained and placed side by side in a process pool (as on a Ray cluster's tasks) are
    the runs trained here: the same report, read back from the same files."""
    argv = ["experiment", "baselines", "Crossroads-2T2P-v1", "--methods", "dppo", "sp", "--seeds", "0", "1",
            "--steps", "1024", "--checkpoints", "2", "--budget", "2", "--max-cycles", "40", "--json"]
    code, here, err = run(capsys, *argv, "--out", tmp_path / "here")
    assert code == 0, err
    code, spread, err = run(capsys, *argv, "--out", tmp_path / "pool", "--backend", "process", "--processes", "2")
    assert code == 0, err
    assert _without_timings(spread) == _without_timings(here)
    social = ["experiment", "crossroads-social", "--seeds", "0", "--steps", "1024", "--episodes", "2",
              "--max-cycles", "40", "--json"]
    _, alone, _ = run(capsys, *social, "--out", tmp_path / "social-here")
    code, pooled, err = run(capsys, *social, "--out", tmp_path / "social-pool", "--backend", "process",
                            "--processes", "2")
    assert code == 0, err
    assert pooled["per_seed"] == alone["per_seed"] and pooled["trees"] == alone["trees"]
    code, _, err = run(capsys, *argv, "--out", tmp_path / "x", "--address", "127.0.0.2:6379")
    assert code == 2 and "a Ray address is for --backend ray" in err
