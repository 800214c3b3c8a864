"""The training benchmarks run end to end at tiny settings and print the JSON they promise.

They check the documents' shape, not the figures: timings belong to the benchmarks themselves.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SPEED = ROOT / "benchmarks" / "training.py"
LEARNING = ROOT / "benchmarks" / "training_learning.py"


def run(script: Path, *arguments: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, str(script), *arguments], capture_output=True, text=True, env=env,
                          timeout=300, check=False)


@pytest.mark.parametrize("script", [SPEED, LEARNING], ids=["speed", "learning"])
def test_help_names_the_options(script: Path) -> None:
    proc = run(script, "--help")
    assert proc.returncode == 0, proc.stderr
    assert "--against" in proc.stdout
    assert "--schemes" in proc.stdout


@pytest.mark.parametrize("script", [SPEED, LEARNING], ids=["speed", "learning"])
def test_an_unknown_scheme_is_one_line_naming_the_valid_ones(script: Path) -> None:
    proc = run(script, "--schemes", "ppo,nope")
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0, proc.stderr
    assert "unknown scheme nope" in proc.stderr
    assert "dppo" in proc.stderr


def test_speed_cell_reports_env_figures_and_ratios() -> None:
    proc = run(SPEED, "--seconds", "0.5", "--games", "Crossroads-2T2P-v1", "--schemes", "ppo", "--no-peers")
    assert proc.returncode == 0, proc.stderr
    game = json.loads(proc.stdout)["games"]["Crossroads-2T2P-v1"]
    for api in ("parallel", "arrays"):
        assert game["env"][api]["steps_per_s"] > 0
    cell = game["schemes"]["ppo"]
    assert cell["ours"]["steps_per_s"] > 0
    assert cell["ours"]["arena_league"] == str(ROOT)  # the worker imported this tree, not another install
    assert cell["ratio_to_env_parallel"] == round(cell["ours"]["steps_per_s"] / game["env"]["parallel"]["steps_per_s"], 3)
    assert cell["criterion"]["share_of_env"] == 0.5
    assert game["peers"] == {}


@pytest.mark.slow  # four training processes, two at a time: about 25 s on the 2-core machine
def test_learning_against_the_same_tree_is_unchanged() -> None:
    proc = run(LEARNING, "--schemes", "ppo", "--seeds", "2", "--steps", "1024", "--matches", "2",
               "--against", str(ROOT))
    assert proc.returncode == 0, proc.stderr
    cell = json.loads(proc.stdout)["schemes"]["ppo"]
    new, old = cell["new"], cell["old"]
    assert set(new["runs"]) == {"seed0", "seed1"}
    # same tree, same seeds, same evaluation matches: the same win rates
    figures = ("population_performance", "per_reference", "per_learner", "untrained", "env_steps")
    for seed in ("seed0", "seed1"):
        assert {k: new["runs"][seed][k] for k in figures} == {k: old["runs"][seed][k] for k in figures}
    low, high = new["summary"]["population_performance"]["ci95"]
    assert low <= new["summary"]["population_performance"]["mean"] <= high
    for verdict in cell["unchanged"].values():
        assert verdict["new_mean_within_old_ci"] and verdict["old_mean_within_new_ci"]
        assert verdict["difference"] == 0.0
