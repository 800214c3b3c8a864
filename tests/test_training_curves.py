"""Training curves: train() measures episode reward every iteration and population performance
against the scripted reference population through the match engine, and writes the two PNG plots
and their numbers."""

from __future__ import annotations

import json

from arena_league.training import train


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
