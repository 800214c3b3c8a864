"""Training curves: train() measures episode reward every iteration and population performance
against the scripted reference population through the match engine, and writes the two PNG plots
and their numbers; the reward curve is never broken or blank, and a warm start is marked."""

from __future__ import annotations

import json

import numpy as np
import pytest
from matplotlib import pyplot as plt
from PIL import Image

from arena_league.training import train
from arena_league.training.curves import reward_figure


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
