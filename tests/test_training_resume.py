"""A training run stopped midway resumes from its checkpoint and ends bit for bit as if never stopped."""

import json

import pytest
import torch

from arena_league.training.schemes import CHECKPOINT_FILE, RUN_RECORD, run_scheme

GAME = "Crossroads-2T1P-v1"
#: A game whose envs step on a whole-array engine (pickled mid-episode with the run).
ENGINE_GAME = "Snake-2T1P-v1"
TINY = {"max_cycles": 20, "num_envs": 2, "num_steps": 16, "hidden": (8,), "critic_hidden": (8,), "update_epochs": 2}
#: Per scheme: options that make its own state move within a few iterations (pool additions, PBT's
#: exploit/explore steps, CC's and CF's opponent pools).
SCHEMES = {
    "dppo": {},
    "sp": {"pool_every": 1, "pool_size": 2, "opponent_sampling": "pfsp_var"},
    "pbt": {"population_size": 3, "interval": 2, "min_matches": 1, "threshold": 0.99},
    "cc": {"pool_every": 1},
    "cf": {"pool_every": 1},
}
STEPS = 6 * 32  # six iterations of 2 envs x 16 steps
STOP_AFTER = 4


class Stop(KeyboardInterrupt):
    """The interruption: raised by a callback, as Ctrl-C would arrive between two iterations."""


def _learner_state(learner):
    """Everything a learner carries on from one update to the next, as named tensors."""
    state = {f"actor.{k}": v for k, v in learner.actor.state_dict().items()}
    if learner.critic is not None:
        state |= {f"critic.{k}": v for k, v in learner.critic.state_dict().items()}
    for index, slot in learner.optimiser.state_dict()["state"].items():
        state |= {f"adam.{index}.{k}": torch.as_tensor(v) for k, v in slot.items()}
    return state


def _run(scheme, out_dir, callback=None, game=GAME, **options):
    return run_scheme(scheme, game, steps=STEPS, seed=3, snapshot_every=64, out_dir=out_dir, callback=callback,
                      checkpoint_seconds=0, **TINY, **SCHEMES[scheme], **options)


def _history(out_dir, scheme):
    """run.json's iteration records, timings aside."""
    document = json.loads((out_dir / f"{scheme}-seed3" / RUN_RECORD).read_text())
    return [{k: v for k, v in row.items() if "per_second" not in k} for row in document["history"]]


@pytest.mark.parametrize(("scheme", "game"), [(scheme, GAME) for scheme in SCHEMES] + [("dppo", ENGINE_GAME)])
def test_an_interrupted_run_resumes_bit_identically(tmp_path, scheme, game):
    trainers = {}
    straight = _run(scheme, tmp_path / "straight", game=game,
                    callback=lambda trainer, record: trainers.update(straight=trainer))

    def stop(trainer, record):
        if trainer.iteration == STOP_AFTER:
            raise Stop

    with pytest.raises(Stop):
        _run(scheme, tmp_path / "stopped", game=game, callback=stop)
    run_dir = tmp_path / "stopped" / f"{scheme}-seed3"
    assert (run_dir / CHECKPOINT_FILE).exists() and not (run_dir / RUN_RECORD).exists()
    seen = []
    resumed = _run(scheme, tmp_path / "stopped", game=game,
                   callback=lambda trainer, record: (seen.append(trainer.iteration), trainers.update(resumed=trainer)))
    # the iteration the stop cut short is played again, from the checkpoint written before it
    assert seen == list(range(STOP_AFTER, STEPS // 32 + 1))
    assert not (run_dir / CHECKPOINT_FILE).exists()
    assert [(s.learner, s.steps) for s in resumed] == [(s.learner, s.steps) for s in straight]
    for ours, theirs in zip(resumed, straight):
        assert ours.params.keys() == theirs.params.keys()
        assert all(torch.equal(ours.params[k], theirs.params[k]) for k in ours.params), ours.name
        assert ours.metrics == theirs.metrics
    for ours, theirs in zip(trainers["resumed"].learners, trainers["straight"].learners):
        a, b = _learner_state(ours), _learner_state(theirs)
        assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a), ours.name
    assert _history(tmp_path / "stopped", scheme) == _history(tmp_path / "straight", scheme)
    if scheme == "pbt":  # the exploit/explore state went through the checkpoint and was used
        assert any(trainers["straight"].lineage)


def test_a_resume_with_other_arguments_is_refused(tmp_path):
    def stop(trainer, record):
        if trainer.iteration == 2:
            raise Stop

    with pytest.raises(Stop):
        _run("dppo", tmp_path, callback=stop)
    with pytest.raises(ValueError, match=r"config\.learning_rate: checkpoint 0\.00025, now 0\.001\).*another out_dir"
                                         r".*delete that checkpoint") as error:
        _run("dppo", tmp_path, learning_rate=1e-3)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("background", [False, True], ids=["inline", "background"])
def test_arena_league_train_resumes_its_curves(tmp_path, monkeypatch, background):
    from arena_league.training import curves
    from arena_league.training.curves import train

    # background: an evaluation process beside training, so a checkpoint may hold evaluations asked
    # for and not played yet, which the resumed run asks for again
    monkeypatch.setattr(curves, "_cores", lambda: 2)
    options = {"steps": 6 * 32, "seed": 1, "eval_every": 2, "eval_matches": 1, "eval_background": background,
               "checkpoint_seconds": 0, **TINY}
    straight = train(GAME, "dppo", out_dir=tmp_path / "straight", **options)

    def stop(line):
        if " iter 4 " in line:  # inside iteration 4, after the checkpoint of iteration 3
            raise Stop

    with pytest.raises(Stop):
        train(GAME, "dppo", out_dir=tmp_path / "stopped", log=stop, **options)
    resumed = train(GAME, "dppo", out_dir=tmp_path / "stopped", **options)
    untimed = [{k: v for k, v in row.items() if "per_second" not in k} for row in straight.history]
    assert [{k: v for k, v in row.items() if "per_second" not in k} for row in resumed.history] == untimed
    timed = ("eval_seconds", "eval_cpu_seconds")
    assert [e["env_steps"] for e in resumed.evaluations] == [32, 64, 128, 192]
    assert ([{k: v for k, v in e.items() if k not in timed} for e in resumed.evaluations]
            == [{k: v for k, v in e.items() if k not in timed} for e in straight.evaluations])


def test_a_run_that_cannot_be_checkpointed_warns_and_finishes(tmp_path):
    def callback(trainer, record):
        pass

    callback.checkpoint = lambda: (lambda: None)  # what it keeps cannot be pickled
    with pytest.warns(RuntimeWarning, match="cannot be checkpointed.*start it again from zero"):
        snapshots = _run("dppo", tmp_path, callback=callback)
    assert [s.steps for s in snapshots][-1] == STEPS
    assert not (tmp_path / "dppo-seed3" / CHECKPOINT_FILE).exists()
    assert not list((tmp_path / "dppo-seed3").glob(".*.tmp"))
