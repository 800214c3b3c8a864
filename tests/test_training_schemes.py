"""The scheme registry behind the population build: the registered schemes, a scheme added with
register_scheme, overrides checked with the valid names listed, a finished run read back instead of
retrained, and ppo / dppo runs whose snapshots are arena-policy folders with their provenance."""

from __future__ import annotations

import json

import pytest
import torch

from arena_league.policies import load_agent
from arena_league.training import PPO, SCHEMES, register_scheme, run_scheme, scheme_runner
from arena_league.training.schemes import RUN_RECORD

GAME = "Crossroads-2T1P-v1"
TINY = {"max_cycles": 20, "num_envs": 2, "num_steps": 32, "hidden": (8,), "critic_hidden": (8,)}


def test_registered_schemes():
    assert {"ppo", "dppo", "sp", "pbt"} <= set(SCHEMES)
    with pytest.raises(ValueError, match="available: .*dppo.*pbt.*ppo.*sp"):
        run_scheme("qmix", GAME, steps=10, seed=0, snapshot_every=None, out_dir="unused")


def test_register_a_scheme():
    class Hasty(PPO):
        scheme = "hasty"

    register_scheme("hasty", scheme_runner(Hasty))
    try:
        assert SCHEMES["hasty"].__name__ == "run_hasty"
    finally:
        del SCHEMES["hasty"]
    with pytest.raises(ValueError, match="short word"):
        register_scheme("a b", scheme_runner(Hasty))


def test_unknown_option_lists_the_valid_ones(tmp_path):
    with pytest.raises(TypeError, match="unknown option.*pool_evry.*sp options \\(.*pool_every"):
        run_scheme("sp", GAME, steps=64, seed=0, snapshot_every=None, out_dir=tmp_path, pool_evry=3, **TINY)


def test_ppo_run_snapshots_and_resume(tmp_path):
    lines = []
    snapshots = run_scheme("ppo", GAME, steps=128, seed=7, snapshot_every=64, out_dir=tmp_path, log=lines.append,
                           **TINY)
    assert [s.steps for s in snapshots] == [64, 128]
    assert len(lines) == 2 and "SPS" in lines[0]
    first = snapshots[-1]
    assert first.path == tmp_path / "ppo-seed7" / "ppo-step000000128"
    manifest = load_agent(first.path, GAME).artifact.manifest()
    assert manifest["provenance"] | {"metrics": None} == {"scheme": "ppo", "game": GAME, "steps": 128, "seed": 7,
                                                          "learner": "ppo", "metrics": None}
    assert manifest["provenance"]["metrics"]["config"]["hidden"] == [8]
    record = json.loads((tmp_path / "ppo-seed7" / RUN_RECORD).read_text())
    assert [h["env_steps"] for h in record["history"]] == [64, 128]
    # asked again: read back, not retrained (no log line), the same weights
    again = run_scheme("ppo", GAME, steps=128, seed=7, snapshot_every=64, out_dir=tmp_path, log=lines.append, **TINY)
    assert len(lines) == 2
    assert [s.path for s in again] == [s.path for s in snapshots]
    for name, tensor in first.params.items():
        assert torch.equal(again[-1].params[name], tensor)
    # a finished run asked for with other arguments is not silently replaced
    with pytest.raises(ValueError, match="another out_dir"):
        run_scheme("ppo", GAME, steps=192, seed=7, snapshot_every=64, out_dir=tmp_path, **TINY)


def test_snapshot_at_adds_early_snapshots(tmp_path):
    """``snapshot_at`` marks: 0 saves the initial actors, a mark saves at the first iteration boundary
    past it, with the regular ``snapshot_every`` ones and the end."""
    snapshots = run_scheme("ppo", GAME, steps=320, seed=2, snapshot_every=256, out_dir=tmp_path,
                           snapshot_at=[0, 70, 100], **TINY)
    assert [s.steps for s in snapshots] == [0, 128, 256, 320]
    assert json.loads((tmp_path / "ppo-seed2" / RUN_RECORD).read_text())["request"]["snapshot_at"] == [0, 70, 100]
    load_agent(snapshots[0].path, GAME)
    with pytest.raises(ValueError, match="snapshot_at must hold env-step counts >= 0"):
        run_scheme("ppo", GAME, steps=64, seed=3, snapshot_every=None, out_dir=tmp_path, snapshot_at=[-5], **TINY)
    with pytest.raises(TypeError, match="snapshot_at must be a list of env-step counts"):
        run_scheme("ppo", GAME, steps=64, seed=3, snapshot_every=None, out_dir=tmp_path, snapshot_at=["soon"], **TINY)


def test_dppo_run_saves_one_agent_per_seat(tmp_path):
    snapshots = run_scheme("dppo", GAME, steps=64, seed=1, snapshot_every=0, out_dir=tmp_path, **TINY)
    assert [s.learner for s in snapshots] == ["seat0", "seat1"]
    assert [s.metrics["seats"] for s in snapshots] == [[0], [1]]
    assert snapshots[0].name == "dppo-s1-seat0-64"


@pytest.mark.parametrize("scheme", ["dppo", "sp", "pbt"])
def test_same_seed_same_snapshots(tmp_path, scheme):
    options = {"population_size": 2, "interval": 1, "min_matches": 1} if scheme == "pbt" else {}
    runs = [run_scheme(scheme, GAME, steps=128, seed=5, snapshot_every=None, out_dir=tmp_path / name, **TINY,
                       **options) for name in ("a", "b")]
    for first, second in zip(*runs, strict=True):
        for name, tensor in first.params.items():
            assert torch.equal(second.params[name], tensor), (scheme, first.learner, name)


def test_a_run_does_not_depend_on_the_callers_thread_count(tmp_path):
    """A run trains on one torch thread from its set-up on: with the caller's count (a machine's
    cores) the actors' first weights once differed in their last bits."""
    from arena_league.policies.threads import torch_threads

    runs = []
    for threads in (1, 2):
        with torch_threads(threads):
            runs.append(run_scheme("sp", "GoBang-2T1P-v1", steps=128, seed=0, snapshot_every=64,
                                   out_dir=tmp_path / f"threads{threads}", num_envs=2, num_steps=32, hidden=(32, 32)))
    assert len(runs[0]) == len(runs[1]) >= 2
    for first, second in zip(*runs, strict=True):
        for name, tensor in first.params.items():
            assert torch.equal(second.params[name], tensor), (first.steps, name)


@pytest.mark.parametrize("scheme, valid", [("cc", {"opponent_sampling": "80/20"}), ("cf", {"critic_epochs": 2})])
def test_the_papers_cc_and_cf_options_are_checked_before_a_run_starts(scheme, valid):
    """CC and CF take the paper's settings (paper_runner); their options are checked by their trainer's
    signature, as every other scheme's, so a long build refuses a misspelt one before training anything."""
    from arena_league.training.schemes import check_scheme_options

    check_scheme_options(scheme, "Crossroads-2T2P-v1", valid)
    with pytest.raises(TypeError, match=f"{scheme}: unknown option.*opponent_samplin\\b.*{scheme} options \\(.*opponent_sampling"):
        check_scheme_options(scheme, "Crossroads-2T2P-v1", {"opponent_samplin": "80/20"})
    with pytest.raises(ValueError, match="learning_rate must be positive"):
        check_scheme_options(scheme, "Crossroads-2T2P-v1", {"learning_rate": 0.0})
