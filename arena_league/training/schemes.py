"""Training schemes behind one call: ``run_scheme(scheme, game_id, ...) -> list[Snapshot]``.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) builds each game's base population from the snapshots that several
training schemes produce. This module is the one door the population build goes through:

* :data:`SCHEMES` maps a scheme name to a *runner*, a function
  ``runner(game_id, *, steps, seed, snapshot_every, out_dir, callback=None, log=None, **overrides)
  -> list[Snapshot]``. Registered here: ``"ppo"`` (one learner shared by every seat,
  :class:`~arena_league.training.trainer.PPO`), ``"dppo"`` (independent learners,
  :class:`~arena_league.training.dppo.DPPO`), ``"sp"`` (self-play,
  :class:`~arena_league.training.selfplay.SelfPlay`) and ``"pbt"``
  (:class:`~arena_league.training.pbt.PBT`). ``training/cc.py`` and ``training/cf.py`` add
  ``"cc"`` and ``"cf"`` by calling :func:`register_scheme` when imported; :func:`run_scheme`
  imports them lazily when they exist.
* A *trainer* is any class built as ``Trainer(env_fn, config, seed, *, total_steps, log,
  **scheme_options)`` with attributes ``scheme`` (its name), ``learners`` (a list of
  :class:`~arena_league.training.ppo.Learner`), ``env_steps``, ``iteration``, a method
  ``iterate() -> dict`` (one rollout and update; the iteration's log record, with at least
  ``env_steps`` and ``episode_return``) and optionally ``snapshot_metrics(index) -> dict``.
  :func:`scheme_runner` turns a trainer class into a runner; :func:`run_trainer` drives one.

Overrides: names of :class:`~arena_league.training.ppo.PPOConfig` fields set the
hyper-parameters; ``warm_start`` (a dict of :class:`~arena_league.training.imitation.WarmStart`
fields, or True) makes every learner imitate an expert, the game's heuristic by default, before RL; ``max_cycles``, ``tree``, ``action_type`` and ``env_kwargs`` (a dict of game
options) shape the env; ``snapshot_at`` (env-step counts, 0 for before training) adds snapshots to
the ``snapshot_every`` ones; ``architecture`` gives the actor's family and sizes; anything else goes to
the trainer as a scheme option (``opponent_sampling="pfsp_var"``, ``population_size=8``, ...).

Output: each run writes into ``out_dir/<scheme>-seed<seed>/`` one arena-policy folder per learner
and snapshot (``<learner>-step<env steps>/``, its manifest's ``provenance`` holding scheme, game,
steps, seed, learner, hyper-parameters and metrics) and, once finished, ``run.json``. A finished
run asked for again with the same arguments is read back instead of retrained, so an interrupted
population build resumes run by run.
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import json
import math
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import load_file

from arena_league.policies.architecture import Architecture
from arena_league.policies.artifacts import (
    MANIFEST_FILE,
    WEIGHTS_FILE,
    manifest_architecture,
    save_arena_policy,
)
from arena_league.policies.threads import torch_threads
from arena_league.training.dppo import DPPO
from arena_league.training.imitation import WarmStart, warm_start
from arena_league.training.pbt import PBT
from arena_league.training.ppo import PPOConfig
from arena_league.training.selfplay import SelfPlay
from arena_league.training.trainer import PPO

__all__ = [
    "ENV_OPTIONS",
    "RUN_RECORD",
    "SCHEMES",
    "Runner",
    "Snapshot",
    "check_scheme_options",
    "make_env_fn",
    "register_scheme",
    "run_scheme",
    "run_trainer",
    "scheme_action_types",
    "scheme_runner",
    "split_overrides",
]

#: A scheme's runner (see the module docstring).
Runner = Callable[..., list["Snapshot"]]
#: Overrides that shape the env rather than the learner.
ENV_OPTIONS = ("max_cycles", "tree", "action_type", "env_kwargs")
#: The file a finished run leaves in its folder.
RUN_RECORD = "run.json"
#: Modules that register more schemes when imported (another engineer's learners).
_LAZY_SCHEME_MODULES = {"cc": "arena_league.training.cc", "cf": "arena_league.training.cf"}


@dataclass
class Snapshot:
    """One learner's parameters at one point of one run, saved as an arena-policy folder."""

    scheme: str
    game_id: str
    steps: int
    """Env steps the run had taken."""
    seed: int
    architecture: Architecture
    params: dict[str, torch.Tensor]
    """The actor's float32 parameters (the arena-policy safetensors layout; a continuous actor's
    include its ``log_std``, and its architecture its noise, so the snapshot samples as it learned)."""
    path: Path
    """Its arena-policy folder (load with ``arena_league.policies.load_policy(path, game_id)``)."""
    learner: str = "learner"
    metrics: dict[str, Any] = field(default_factory=dict)
    """Episode return, hyper-parameters and scheme-specific figures (Elo, win rates)."""

    @property
    def name(self) -> str:
        return f"{self.scheme}-s{self.seed}-{self.learner}-{self.steps}"

    def provenance(self) -> dict[str, Any]:
        """The manifest's provenance object."""
        return {"scheme": self.scheme, "game": self.game_id, "steps": self.steps, "seed": self.seed,
                "learner": self.learner, "metrics": json_safe(self.metrics)}


#: Scheme name -> runner. Add one with :func:`register_scheme`.
SCHEMES: dict[str, Runner] = {}


def register_scheme(name: str, runner: Runner) -> None:
    """Make ``run_scheme(name, ...)`` call ``runner`` (see the module docstring for its signature).
    Re-registering a name replaces it (a module imported twice registers twice)."""
    if not isinstance(name, str) or not name or not name.replace("_", "").isalnum():
        raise ValueError(f"a scheme name is a short word such as 'cc', not {name!r}")
    if not callable(runner):
        raise TypeError(f"the runner of scheme {name!r} must be callable, not {type(runner).__name__}")
    SCHEMES[name] = runner


def run_scheme(scheme: str, game_id: str, *, steps: int, seed: int, snapshot_every: int | None, out_dir: str | Path,
               callback: Callable[[Any, dict[str, Any]], None] | None = None, log: Callable[[str], None] | None = None,
               **overrides: Any) -> list[Snapshot]:
    """Train ``game_id`` with ``scheme`` for ``steps`` env steps and return its snapshots.

    Args:
        scheme: a key of :data:`SCHEMES` (``"ppo"``, ``"dppo"``, ``"sp"``, ``"pbt"``, and ``"cc"`` /
            ``"cf"`` once their modules exist).
        game_id: a game id of :func:`arena_league.envs.list_games`.
        steps: env steps to train for (rounded up to whole iterations).
        seed: the run's seed; the same arguments give the same snapshots.
        snapshot_every: env steps between snapshots (each learner is saved at the first iteration
            boundary past every multiple, and at the end); None or 0: at the end only.
        out_dir: the run writes into ``out_dir/<scheme>-seed<seed>/``.
        callback: called after every iteration with the trainer and the iteration's record.
        log: called with a line per iteration.
        **overrides: hyper-parameters, env options and scheme options (see the module docstring).
    """
    return _runner(scheme)(game_id, steps=steps, seed=seed, snapshot_every=snapshot_every, out_dir=out_dir,
                           callback=callback, log=log, **overrides)


def check_scheme_options(scheme: str, game_id: str, overrides: Mapping[str, Any]) -> None:
    """Raise now, as :func:`run_scheme` would once it starts, when ``scheme`` is unknown or an
    override is not one of its options or holds a bad value (hyper-parameters, env options, scheme
    options, ``warm_start``, ``snapshot_at``): a long build checks every run before training any.
    Runners registered without a trainer class (a plain function) are checked by name only."""
    trainer_cls = getattr(_runner(scheme), "trainer_cls", None)
    if trainer_cls is None:
        return
    overrides = dict(overrides)
    imitation = WarmStart.parse(overrides.pop("warm_start", None))
    _snapshot_marks(overrides.pop("snapshot_at", ()))
    config, env_options, _ = split_overrides(overrides, trainer_cls)
    _check_warm_start_family(imitation, config)
    make_env_fn(game_id, **env_options)


def scheme_action_types(scheme: str) -> tuple[str, ...]:
    """The action types ``scheme`` can train: those its runner or trainer declares (``action_types``;
    CF: discrete only), else both."""
    runner = _runner(scheme)
    declared = getattr(runner, "action_types", None) or getattr(getattr(runner, "trainer_cls", None),
                                                                "action_types", None)
    return tuple(declared or ("discrete", "continuous"))


def _check_warm_start_family(imitation: WarmStart | None, config: PPOConfig) -> None:
    if imitation is not None and config.family != "mlp":
        raise ValueError(f"warm_start fits feed-forward actors; a {config.family!r} actor would be fitted "
                         "without its recurrent state. Drop warm_start or use family='mlp'")


def _runner(scheme: str) -> Runner:
    """The runner of ``scheme``, importing the modules of schemes registered on first use."""
    if scheme not in SCHEMES and scheme in _LAZY_SCHEME_MODULES:
        module = _LAZY_SCHEME_MODULES[scheme]
        if importlib.util.find_spec(module) is not None:
            importlib.import_module(module)
    if scheme not in SCHEMES:
        for module in _LAZY_SCHEME_MODULES.values():  # they may register other names too
            if importlib.util.find_spec(module) is not None:
                importlib.import_module(module)
    if scheme not in SCHEMES:
        raise ValueError(f"unknown training scheme {scheme!r}; available: {', '.join(sorted(SCHEMES))}")
    return SCHEMES[scheme]


def scheme_runner(trainer_cls: type) -> Runner:
    """A runner (see the module docstring) for a trainer class."""

    def runner(game_id: str, *, steps: int, seed: int, snapshot_every: int | None, out_dir: str | Path,
               callback: Callable[[Any, dict[str, Any]], None] | None = None,
               log: Callable[[str], None] | None = None, **overrides: Any) -> list[Snapshot]:
        imitation = WarmStart.parse(overrides.pop("warm_start", None))
        snapshot_at = _snapshot_marks(overrides.pop("snapshot_at", ()))
        config, env_options, scheme_options = split_overrides(overrides, trainer_cls)
        _check_warm_start_family(imitation, config)
        request = {"scheme": trainer_cls.scheme, "game_id": game_id, "steps": int(steps), "seed": int(seed),
                   "snapshot_every": int(snapshot_every or 0), "config": json_safe(config.__dict__),
                   "env": json_safe(env_options), "options": json_safe(scheme_options)}
        if imitation is not None:
            request["warm_start"] = imitation.as_dict()
        if snapshot_at:
            request["snapshot_at"] = list(snapshot_at)
        run_dir = Path(out_dir) / f"{trainer_cls.scheme}-seed{seed}"
        finished = load_run(run_dir, request)
        if finished is not None:
            return finished
        env_fn = make_env_fn(game_id, **env_options)
        # the whole run on one torch thread, its set-up and warm start too: with the caller's count
        # (the machine's cores) the actors' initial weights differed in their last bits
        with torch_threads(1):
            trainer = trainer_cls(env_fn, config, seed, total_steps=int(steps), log=log, **scheme_options)
            if imitation is not None:
                trainer.warm_start_record = warm_start(trainer.learners, env_fn, game_id, imitation, seed, log=log)
            return run_trainer(trainer, game_id=game_id, steps=steps, seed=seed, snapshot_every=snapshot_every,
                               run_dir=run_dir, callback=callback, request=request, snapshot_at=snapshot_at)

    runner.trainer_cls = trainer_cls  # type: ignore[attr-defined]  # check_scheme_options reads it
    runner.__name__ = f"run_{trainer_cls.scheme}"
    runner.__doc__ = f"Run :class:`{trainer_cls.__module__}.{trainer_cls.__name__}` (see run_scheme)."
    return runner


def split_overrides(overrides: Mapping[str, Any], trainer_cls: type
                    ) -> tuple[PPOConfig, dict[str, Any], dict[str, Any]]:
    """(the PPOConfig, env options, scheme options) of a runner's overrides; a name that is none
    of these raises, listing the valid ones."""
    config_names = {f.name for f in fields(PPOConfig)}
    accepted = _trainer_options(trainer_cls)
    config_fields = {k: v for k, v in overrides.items() if k in config_names}
    env_options = {k: v for k, v in overrides.items() if k in ENV_OPTIONS}
    scheme_options = {k: v for k, v in overrides.items() if k not in config_names and k not in ENV_OPTIONS}
    unknown = sorted(k for k in scheme_options if k not in accepted)
    if unknown:
        raise TypeError(f"{trainer_cls.scheme}: unknown option(s) {', '.join(unknown)}. Valid: PPOConfig fields "
                        f"({', '.join(sorted(config_names))}); env options ({', '.join(ENV_OPTIONS)}); "
                        f"{trainer_cls.scheme} options ({', '.join(sorted(accepted)) or 'none'})")
    return PPOConfig.with_overrides(**config_fields), env_options, scheme_options


def _trainer_options(trainer_cls: type) -> set[str]:
    parameters = inspect.signature(trainer_cls.__init__).parameters
    return {name for name, p in parameters.items()
            if p.kind == inspect.Parameter.KEYWORD_ONLY and name not in ("total_steps", "log")}


def make_env_fn(game_id: str, *, max_cycles: int | None = None, tree: Any = None, action_type: str | None = None,
                env_kwargs: Mapping[str, Any] | None = None) -> Callable[[], Any]:
    """A factory of envs of ``game_id`` with these options (checked now, by making one)."""
    from arena_league.envs import make

    kwargs = dict(env_kwargs or {})

    def env_fn() -> Any:
        return make(game_id, tree=tree, action_type=action_type, max_cycles=max_cycles, **kwargs)

    env_fn()  # unknown ids and bad options fail here, with the envs' own messages
    return env_fn


def _snapshot_marks(marks: Any) -> tuple[int, ...]:
    try:
        values = sorted({int(m) for m in marks})
    except (TypeError, ValueError):
        raise TypeError(f"snapshot_at must be a list of env-step counts, not {marks!r}") from None
    if values and values[0] < 0:
        raise ValueError(f"snapshot_at must hold env-step counts >= 0, not {values[0]}")
    return tuple(values)


def run_trainer(trainer: Any, *, game_id: str, steps: int, seed: int, snapshot_every: int | None,
                run_dir: str | Path, callback: Callable[[Any, dict[str, Any]], None] | None = None,
                request: Mapping[str, Any] | None = None, snapshot_at: tuple[int, ...] = ()) -> list[Snapshot]:
    """Iterate ``trainer`` until ``steps`` env steps, saving every learner every ``snapshot_every``
    env steps, at the first iteration boundary past each of ``snapshot_at`` (0: before training,
    e.g. the warm-started actors) and at the end into ``run_dir``; writes ``run.json`` when done."""
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError(f"steps must be a positive number of env steps, not {steps!r}")
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / RUN_RECORD).unlink(missing_ok=True)
    every = int(snapshot_every or 0)
    next_snapshot = every if every > 0 else None
    snapshots: list[Snapshot] = []
    history: list[dict[str, Any]] = []
    marks = [m for m in snapshot_at if m < steps]
    if marks and marks[0] == 0:
        snapshots += save_snapshots(trainer, game_id, seed, run_dir, {})
        marks.pop(0)
    while trainer.env_steps < steps:
        record = trainer.iterate()
        history.append(json_safe({k: v for k, v in record.items() if k != "losses"} | {
            "losses": record.get("losses", [])}))
        if callback is not None:
            callback(trainer, record)
        at_end = trainer.env_steps >= steps
        marked = bool(marks) and trainer.env_steps >= marks[0]
        while marks and marks[0] <= trainer.env_steps:
            marks.pop(0)
        if at_end or marked or (next_snapshot is not None and trainer.env_steps >= next_snapshot):
            snapshots += save_snapshots(trainer, game_id, seed, run_dir, record)
            while next_snapshot is not None and next_snapshot <= trainer.env_steps:
                next_snapshot += every
    document = {"request": json_safe(dict(request or {})), "snapshots": [_snapshot_entry(s, run_dir) for s in snapshots],
                "history": history}
    (run_dir / RUN_RECORD).write_text(json.dumps(document, indent=1, allow_nan=False) + "\n")
    return snapshots


def save_snapshots(trainer: Any, game_id: str, seed: int, run_dir: Path, record: Mapping[str, Any]) -> list[Snapshot]:
    """Every learner of ``trainer`` as an arena-policy folder under ``run_dir``."""
    snapshots = []
    for index, learner in enumerate(trainer.learners):
        metrics: dict[str, Any] = {"iteration": trainer.iteration, "episode_return": record.get("episode_return"),
                                   "updates": learner.updates}
        returns = record.get("learner_returns")
        if returns is not None:
            metrics["learner_return"] = returns[index]
        if hasattr(trainer, "snapshot_metrics"):
            metrics.update(trainer.snapshot_metrics(index))
        metrics["config"] = dict(learner.config.__dict__)
        record_of_warm_start = getattr(trainer, "warm_start_record", None)
        if record_of_warm_start is not None:
            metrics["warm_start"] = {k: v for k, v in record_of_warm_start.items() if k != "fit"} | {
                "fit": record_of_warm_start["fit"][index]}
        snapshot = Snapshot(trainer.scheme, game_id, int(trainer.env_steps), int(seed), learner.snapshot_architecture,
                            learner.snapshot_parameters(), run_dir / f"{learner.name}-step{trainer.env_steps:09d}",
                            learner.name, json_safe(metrics))
        save_arena_policy(snapshot.path, snapshot.architecture, snapshot.params, game_id, name=snapshot.name,
                          description=f"{trainer.scheme} snapshot of {learner.name} after {trainer.env_steps} env "
                                      f"steps (seed {seed})", provenance=snapshot.provenance())
        snapshots.append(snapshot)
    return snapshots


def load_run(run_dir: str | Path, request: Mapping[str, Any]) -> list[Snapshot] | None:
    """The snapshots of a finished run in ``run_dir`` made with ``request``; None when the run is
    absent or unfinished. A finished run made with other arguments raises (with the fix)."""
    record_path = Path(run_dir) / RUN_RECORD
    if not record_path.exists():
        return None
    document = json.loads(record_path.read_text())
    if document.get("request") != json_safe(dict(request)):
        raise ValueError(f"{run_dir} holds a finished run made with other arguments ({document.get('request')}); "
                         "pass another out_dir, or delete that folder to train again")
    snapshots = []
    for entry in document["snapshots"]:
        path = Path(run_dir) / entry["folder"]
        manifest = json.loads((path / MANIFEST_FILE).read_text())
        snapshots.append(Snapshot(entry["scheme"], entry["game_id"], entry["steps"], entry["seed"],
                                  manifest_architecture(manifest), dict(load_file(str(path / WEIGHTS_FILE))), path,
                                  entry["learner"], entry["metrics"]))
    return snapshots


def _snapshot_entry(snapshot: Snapshot, run_dir: Path) -> dict[str, Any]:
    return {"scheme": snapshot.scheme, "game_id": snapshot.game_id, "steps": snapshot.steps, "seed": snapshot.seed,
            "learner": snapshot.learner, "folder": snapshot.path.relative_to(run_dir).as_posix(),
            "metrics": json_safe(snapshot.metrics)}


def json_safe(value: Any) -> Any:
    """``value`` with tuples as lists, non-finite floats as None and numpy scalars as Python ones."""
    if isinstance(value, Mapping):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Architecture):
        return {"family": value.family, "sizes": value.sizes(), "spaces": value.spaces()}
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)


def remove_run(out_dir: str | Path, scheme: str, seed: int) -> None:
    """Delete a run's folder (to train it again)."""
    shutil.rmtree(Path(out_dir) / f"{scheme}-seed{seed}", ignore_errors=True)


for _trainer in (PPO, DPPO, SelfPlay, PBT):
    register_scheme(_trainer.scheme, scheme_runner(_trainer))
