"""The paper's experiments end to end at tiny budgets, their behaviour measures on hand-built
episodes, and a population's averaged ranking (`rank --members`)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_helpers import gobang_agent, run

from arena_league.envs.games import crossroads as game
from arena_league.league import experiments
from arena_league.league.experiments import (
    BASELINES,
    _episode_measures,
    _finite,
    baselines,
    checkpoint_steps,
    crossroads_behaviour,
    crossroads_social,
    curve_noise,
    ordering_flips,
    placement_budget,
    social_marks,
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


def test_social_marks_and_curve_noise():
    assert social_marks(10_000_000, 5) == [625_000, 1_250_000, 2_500_000, 5_000_000, 10_000_000]
    assert social_marks(10_000_000, marks_at=[2_500_000, 400_000, 1_000_000]) == [400_000, 1_000_000, 2_500_000,
                                                                                  10_000_000]
    with pytest.raises(ValueError, match="--marks-at takes env-step counts from 1 to --steps"):
        social_marks(1024, marks_at=[2048])
    assert curve_noise([[1.0, 2.0, 3.0, 4.0], [5.0, 5.0, 5.0]]) == 0.0  # a straight trend has no noise
    # residuals 2/3, -2/3, 2/3 about the moving average; the SD of the noise is sqrt(3/2) times their RMS
    assert curve_noise([[0, 1, 0, 1, 0]]) == pytest.approx(np.sqrt(1.5) * 2 / 3)
    assert curve_noise([[None, 1, 2, 4]]) == pytest.approx(np.sqrt(1.5) / 3)  # the triple with None is skipped
    assert curve_noise([[1, 2], [None, 1, 3]]) is None


def test_crossroads_social_marks_end_where_the_study_ends_and_resume(capsys, tmp_path, monkeypatch):
    """Evaluated at two marks, a run's last mark gives the figures of the study evaluated at its end
    only; again into the same folder, every evaluation is read back."""
    args = {"seeds": [0], "steps": 2048, "episodes": 2, "trees": ["all_IS", "all_CL"], "max_cycles": 40, "reps": 200}
    marked = crossroads_social(tmp_path / "marks", marks=2, **args)
    plain = crossroads_social(tmp_path / "end", marks=1, **args)
    assert marked["trees"] == plain["trees"] and marked["per_seed"] == plain["per_seed"]
    assert marked["marks"] == [1024, 2048] and marked["mark_steps"]["all_IS"] == [[1024, 2048]]
    for tree, by_measure in marked["trend"].items():
        assert all(len(points) == 2 and points[-1] == marked["trees"][tree][m] for m, points in by_measure.items())
    assert marked["findings_by_mark"][-1] == marked["findings"] and len(marked["findings_by_mark"]) == 2
    readme = (tmp_path / "marks" / "README.md").read_text()
    assert "## Trend with budget" in readme and "| 1,024 |" in readme and (tmp_path / "marks" / "trend.png").exists()
    assert "## Trend with budget" not in (tmp_path / "end" / "README.md").read_text()

    def played(*_, **__):
        raise AssertionError("an evaluation kept beside its run was played again")

    monkeypatch.setattr(experiments, "crossroads_behaviour", played)
    again = crossroads_social(tmp_path / "marks", marks=2, **args)
    assert again["trend"] == marked["trend"] and again["per_seed_trend"] == marked["per_seed_trend"]
    # marks of one's own on the command line: checked before anything trains
    code, _, err = run(capsys, "experiment", "crossroads-social", "--steps", "2048", "--marks-at", "4096", "--out",
                       tmp_path / "bad")
    assert code == 2 and "--marks-at takes env-step counts from 1 to --steps" in err


def test_the_committed_readmes_are_what_their_reports_give(capsys, tmp_path):
    """`--readme-only` writes a report folder's README again from its report.json; a baselines report
    made before the curve noise and rank half-widths were measured gets them from its checkpoints
    (whose rank interval's ends older reports name rank_best and rank_worst)."""
    import shutil
    from pathlib import Path

    committed = Path(__file__).resolve().parents[1] / "experiments"
    for name, which in [("crossroads-social", ["crossroads-social"]),
                        ("baselines-crossroads", ["baselines", "Crossroads-2T2P-v1"]),
                        ("baselines-pushbox", ["baselines", "PushBox-2T2P-v1"])]:
        folder = tmp_path / name
        shutil.copytree(committed / name, folder)
        report = json.loads((folder / "report.json").read_text())
        if "noise" in report:  # as the report was before these were measured
            for key in ("episode_reward", "percentile"):
                for field in ("curve_sd", "curve_sd_relative", "range"):
                    report["noise"][key].pop(field)
            report["noise"].pop("curve_trend")
            report.pop("rank_half_width")
            (folder / "report.json").write_text(json.dumps(report, indent=1))
        (folder / "README.md").unlink()
        code, _, err = run(capsys, "experiment", *which, "--readme-only", "--out", folder)
        assert code == 0, err
        assert (folder / "README.md").read_text() == (committed / name / "README.md").read_text()
        assert json.loads((folder / "report.json").read_text()) == json.loads(
            (committed / name / "report.json").read_text())
    rank = json.loads((committed / "baselines-crossroads" / "report.json").read_text())["rank_half_width"]
    first = json.loads((committed / "baselines-crossroads" / "report.json").read_text())["runs"]["dppo"][0]
    assert rank["target"] == 5 and len(rank["median"]) == len(first["checkpoints"]) == 6
    code, _, err = run(capsys, "experiment", "crossroads-social", "--readme-only", "--out", tmp_path / "none")
    assert code == 2 and "no report.json in" in err


def test_placement_budget_places_a_middle_member_until_its_interval_is_narrow():
    result = placement_budget("Crossroads-2T2P-v1", members=1, max_budget=24, simulated=20, target=5)
    member = result["members"][0]
    assert result["base_size"] == 100 and 40 <= member["rank_in_base"] <= 61
    widths = member["half_width_by_match"]
    assert 1 <= len(widths) <= 24 and member["rank_lower"] <= member["rank"] <= member["rank_upper"]
    assert member["matches_to_target"] in (None, len(widths))
    assert 0 <= result["simulated"]["reached_share"] <= 1 and result["simulated"]["median_matches"] <= 24
    with pytest.raises(ValueError, match="at least 1"):
        placement_budget("Crossroads-2T2P-v1", members=0)


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
    # fewer than three checkpoints: no interior one, so no noise about a trend; the rank half-width at each
    assert report["noise"]["percentile"]["curve_sd"] == dict.fromkeys(BASELINES)
    half = report["rank_half_width"]
    assert len(half["median"]) == len(half["met"]) == len(report["checkpoints"])
    assert set(half["by_method"]) == set(BASELINES)
    assert "Placement precision" in (tmp_path / "README.md").read_text()
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
