"""Training curves: train() measures episode reward every iteration and population performance
against the scripted reference population through the match engine, and writes the two PNG plots
and their numbers; the reward curve is never broken or blank, and a warm start is marked."""

from __future__ import annotations

import json

import numpy as np
import pytest
from matplotlib import pyplot as plt
from PIL import Image

from arena_league.matchmaking import AgentRef, play_matches, specs_for_seatings
from arena_league.training import PPO, PPOConfig, curves, make_env_fn, train
from arena_league.training.curves import evaluate_learners, reward_figure

GAME = "Crossroads-2T1P-v1"


def test_train_writes_the_curves(tmp_path):
    lines = []
    report = train("Crossroads-2T1P-v1", "sp", steps=512, seed=0, report_dir=tmp_path, eval_every=2,
                   eval_matches=4, max_cycles=25, num_envs=2, num_steps=64, hidden=(16,), log=lines.append)
    assert [h["env_steps"] for h in report.history] == [128, 256, 384, 512]
    # evaluated after the first iteration, every second one, and the last
    assert [e["env_steps"] for e in report.evaluations] == [128, 256, 512]
    for evaluation in report.evaluations:
        assert set(evaluation["per_reference"]) == {"scripted:random", "scripted:heuristic"}
        assert 0.0 <= evaluation["population_performance"] <= 1.0
    assert any(line.startswith("eval at") for line in lines)
    for name in ("episode_reward", "population_performance"):
        assert report.plots[name].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    curves = json.loads(report.plots["curves"].read_text())
    assert curves["scheme"] == "sp" and len(curves["evaluations"]) == 3
    assert report.snapshots and report.snapshots[-1].path.parent.parent == tmp_path / "snapshots"


def _pixels_of(png, colour, tolerance=60):
    """How many pixels of the PNG lie within ``tolerance`` (summed over channels) of ``colour``."""
    pixels = np.asarray(Image.open(png).convert("RGB")).astype(int)
    return int((np.abs(pixels - np.asarray(colour)).sum(-1) < tolerance).sum())


def test_iterations_without_a_finished_episode_do_not_break_the_reward_curve(tmp_path):
    # 16 env steps an iteration, episodes of at most 40: most iterations finish no episode
    report = train("Crossroads-2T1P-v1", "sp", steps=96, seed=0, report_dir=tmp_path, eval_every=100,
                   eval_matches=1, max_cycles=40, num_envs=1, num_steps=16, hidden=(8,),
                   warm_start={"steps": 32, "rounds": 1, "num_envs": 2, "epochs": 1})
    returns = [h["episode_return"] for h in report.history]
    finished = [(h["env_steps"], h["episode_return"]) for h in report.history if h["episode_return"] is not None]
    assert len(returns) == 6 and 0 < len(finished) < len(returns)  # the run this test needs
    figure = reward_figure(report)
    ax = figure.axes[0]
    line = next(ln for ln in ax.get_lines() if ln.get_label().startswith("per iteration"))
    x, y = np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)
    assert np.isfinite(y).all() and len(x) == len(finished)  # one unbroken line through every return
    assert list(zip(x, y)) == finished
    ticks = next(ln for ln in ax.get_lines() if ln.get_label().startswith("no finished episode"))
    assert len(ticks.get_xdata()) == len(returns) - len(finished)
    # the warm start is shaded left of 0 over its own env steps, and named in the legend
    assert report.warm_start["env_steps"] > 0 and report.warm_start["expert"] == "scripted:heuristic"
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(t.startswith("warm start: imitating scripted:heuristic") for t in legend)
    span = next(p for p in ax.patches if p.get_label().startswith("warm start"))
    (left, _), (right, _) = span.get_path().get_extents(span.get_transform() - ax.transData).get_points()
    assert (left, right) == pytest.approx((-report.warm_start["env_steps"], 0.0), abs=1e-9)
    plt.close(figure)
    # the saved plot shows the curve (matplotlib's blue), beyond its legend
    assert _pixels_of(report.plots["episode_reward"], (31, 119, 180)) > 300
    assert json.loads(report.plots["curves"].read_text())["warm_start"]["env_steps"] == report.warm_start["env_steps"]


def test_a_run_that_finished_no_episode_says_so_on_the_plot(tmp_path):
    report = train("Crossroads-2T1P-v1", "sp", steps=32, seed=0, report_dir=tmp_path, eval_every=100,
                   eval_matches=1, max_cycles=300, num_envs=1, num_steps=16, hidden=(8,))
    assert [h["episode_return"] for h in report.history] == [None, None]
    assert report.warm_start is None
    figure = reward_figure(report)
    ax = figure.axes[0]
    assert any("no episode finished" in t.get_text() for t in ax.texts)
    assert not any(p.get_label().startswith("warm start") for p in ax.patches)
    plt.close(figure)
    assert report.plots["episode_reward"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _learners():
    """Two learners of different weights (two PPO runs' actors)."""
    return [PPO(make_env_fn(GAME, max_cycles=30), PPOConfig(num_envs=1, num_steps=8, hidden=(8,)), seed=seed).learners[0]
            for seed in (1, 2)]


def test_one_batched_evaluation_scores_as_the_matches_played_one_by_one():
    learners, matches = _learners(), 3
    references = {text: AgentRef.parse(text, GAME) for text in ("scripted:random", "scripted:heuristic")}
    batched = evaluate_learners(learners, GAME, references, matches, league_seed=5, first_match_id=100,
                                env_kwargs={"max_cycles": 30})
    # the same matches (ids, seats, seeds), played one at a time, each learner's by its own call
    per_learner = []
    for index, learner in enumerate(learners):
        key = f"learner:{index}"
        seatings = [(key, ref) if m % 2 == 0 else (ref, key) for ref in references for m in range(matches)]
        first = 100 + index * len(seatings)
        specs = specs_for_seatings(GAME, seatings, league_seed=5, first_match_id=first)
        results = play_matches(specs, {**references, key: learner.policy(name=key)}, batch_size=1,
                               env_kwargs={"max_cycles": 30})
        per_learner.append(float(np.mean([r.team_scores()[m % 2] for m, r in enumerate(results)])))
    assert batched["per_learner"] == pytest.approx(per_learner, abs=1e-12)
    assert batched["population_performance"] == pytest.approx(np.mean(per_learner), abs=1e-12)


def test_background_evaluation_gives_the_inline_results_and_the_time_split_is_recorded(tmp_path, monkeypatch):
    monkeypatch.setattr(curves, "_cores", lambda: 3)  # two background processes, whose results may cross
    options = {"steps": 256, "seed": 3, "eval_every": 2, "eval_matches": 2, "max_cycles": 25, "num_envs": 2,
               "num_steps": 32, "hidden": (8,)}
    inline = train(GAME, "ppo", out_dir=tmp_path / "inline", eval_background=False, **options)
    lines = []
    background = train(GAME, "ppo", out_dir=tmp_path / "background", report_dir=tmp_path / "report",
                       eval_background=True, log=lines.append, **options)
    timed = ("eval_seconds", "eval_cpu_seconds")
    strip = [{k: v for k, v in e.items() if k not in timed} for e in inline.evaluations]
    assert strip == [{k: v for k, v in e.items() if k not in timed} for e in background.evaluations]
    assert [e["env_steps"] for e in background.evaluations] == [64, 128, 256]
    assert sum(line.startswith("eval at") for line in lines) == 3
    for report, where in ((inline, False), (background, True)):
        timing = report.timing
        assert timing["eval_background"] is where and timing["evaluations"] == 3
        assert all(e["eval_seconds"] > 0 and e["eval_cpu_seconds"] > 0 for e in report.evaluations)
        assert timing["eval_cpu_seconds"] == pytest.approx(sum(e["eval_cpu_seconds"] for e in report.evaluations),
                                                           abs=1e-2)
        assert timing["eval_seconds"] == pytest.approx(sum(e["eval_seconds"] for e in report.evaluations), abs=1e-2)
        assert 0 < timing["eval_wait_seconds"] <= timing["seconds"]
        assert timing["eval_share"] == pytest.approx(timing["eval_wait_seconds"] / timing["seconds"], rel=0.02)
    assert inline.timing["eval_processes"] == 0 and background.timing["eval_processes"] == 2
    # inline, training waited for every evaluation's play
    assert inline.timing["eval_wait_seconds"] >= inline.timing["eval_seconds"]
    assert json.loads(background.plots["curves"].read_text())["timing"]["plot_seconds"] > 0
