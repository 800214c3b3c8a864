"""Training schemes behind one call: ``run_scheme(scheme, game_id, ...) -> list[Snapshot]``.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) builds each game's base population from the snapshots that several
training schemes produce. This module is the one door the population build goes through:

* :data:`SCHEMES` maps a scheme name to a *runner*, a function
  ``runner(game_id, *, steps, seed, snapshot_every, out_dir, callback=None, log=None,
  checkpoint_seconds=120.0, **overrides) -> list[Snapshot]``. Registered here: ``"ppo"`` (one learner shared by every seat,
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
population build resumes run by run. An unfinished run keeps ``checkpoint.pt`` there (written every
``checkpoint_seconds`` of wall time, 120 by default, at an iteration boundary): asked for again with
the same arguments it continues from it, and ends exactly as the run would have uninterrupted.
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import json
import math
import os
import pickle
import shutil
import time
import warnings
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
    "CHECKPOINT_FILE",
    "CHECKPOINT_SECONDS",
    "ENV_OPTIONS",
    "RUN_RECORD",
    "SCHEMES",
    "Runner",
    "Snapshot",
    "check_scheme_options",
    "load_checkpoint",
    "make_env_fn",
    "register_scheme",
    "run_scheme",
    "run_trainer",
    "save_checkpoint",
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
#: The file an unfinished run continues from (removed once ``run.json`` is written).
CHECKPOINT_FILE = "checkpoint.pt"
#: Seconds of wall time between two checkpoints of a run, by default: a stop loses at most this.
CHECKPOINT_SECONDS = 120.0
#: The layout of a checkpoint; another one is not resumed.
CHECKPOINT_FORMAT = 1
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
               checkpoint_seconds: float | None = CHECKPOINT_SECONDS, **overrides: Any) -> list[Snapshot]:
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
        callback: called after every iteration with the trainer and the iteration's record. When it
            has a ``checkpoint()`` method (a function's attribute will do), what that returns is
            saved with each checkpoint and handed to ``callback.resume(state)`` when the run resumes,
            so the caller's own records (curves) continue too.
        log: called with a line per iteration.
        checkpoint_seconds: seconds of wall time between two checkpoints of the unfinished run (0:
            every iteration; None: none). A checkpoint never changes the run's results.
        **overrides: hyper-parameters, env options and scheme options (see the module docstring).
    """
    return _runner(scheme)(game_id, steps=steps, seed=seed, snapshot_every=snapshot_every, out_dir=out_dir,
                           callback=callback, log=log, checkpoint_seconds=checkpoint_seconds, **overrides)


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
               log: Callable[[str], None] | None = None, checkpoint_seconds: float | None = CHECKPOINT_SECONDS,
               **overrides: Any) -> list[Snapshot]:
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
        if checkpoint_seconds is not None and not checkpoint_seconds >= 0:
            raise ValueError(f"checkpoint_seconds must be >= 0 (0: every iteration) or None (no checkpoints), "
                             f"not {checkpoint_seconds!r}")
        # the whole run on one torch thread, its set-up and warm start too: with the caller's count
        # (the machine's cores) the actors' initial weights differed in their last bits
        with torch_threads(1):
            resumed = load_checkpoint(run_dir, request)
            if resumed is not None:
                trainer, progress, caller = resumed
                trainer.log = log
                if caller is not None and callable(getattr(callback, "resume", None)):
                    callback.resume(caller)
                if log is not None:
                    log(f"{trainer.scheme} resumed from {run_dir / CHECKPOINT_FILE} at iteration {trainer.iteration} "
                        f"({trainer.env_steps} env steps)")
            else:
                env_fn = make_env_fn(game_id, **env_options)
                trainer = trainer_cls(env_fn, config, seed, total_steps=int(steps), log=log, **scheme_options)
                if imitation is not None:
                    trainer.warm_start_record = warm_start(trainer.learners, env_fn, game_id, imitation, seed, log=log)
                progress = None
            return run_trainer(trainer, game_id=game_id, steps=steps, seed=seed, snapshot_every=snapshot_every,
                               run_dir=run_dir, callback=callback, request=request, snapshot_at=snapshot_at,
                               checkpoint_seconds=checkpoint_seconds, progress=progress)

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
                request: Mapping[str, Any] | None = None, snapshot_at: tuple[int, ...] = (),
                checkpoint_seconds: float | None = None, progress: _Progress | None = None) -> list[Snapshot]:
    """Iterate ``trainer`` until ``steps`` env steps, saving every learner every ``snapshot_every``
    env steps, at the first iteration boundary past each of ``snapshot_at`` (0: before training,
    e.g. the warm-started actors) and at the end into ``run_dir``; writes ``run.json`` when done.
    With ``checkpoint_seconds``, checkpoints the run (:func:`save_checkpoint`) at the first iteration
    boundary after that many seconds since the last (0: every iteration); ``progress`` continues a
    checkpointed run (:func:`load_checkpoint`)."""
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError(f"steps must be a positive number of env steps, not {steps!r}")
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / RUN_RECORD).unlink(missing_ok=True)
    every = int(snapshot_every or 0)
    if progress is None:
        progress = _Progress(next_snapshot=every if every > 0 else None,
                             marks=[m for m in snapshot_at if m < steps])
        if progress.marks and progress.marks[0] == 0:
            progress.snapshots += save_snapshots(trainer, game_id, seed, run_dir, {})
            progress.marks.pop(0)
    marks = progress.marks
    saved_at = time.monotonic()
    while trainer.env_steps < steps:
        record = trainer.iterate()
        progress.history.append(json_safe({k: v for k, v in record.items() if k != "losses"} | {
            "losses": record.get("losses", [])}))
        if callback is not None:
            callback(trainer, record)
        at_end = trainer.env_steps >= steps
        marked = bool(marks) and trainer.env_steps >= marks[0]
        while marks and marks[0] <= trainer.env_steps:
            marks.pop(0)
        if at_end or marked or (progress.next_snapshot is not None and trainer.env_steps >= progress.next_snapshot):
            progress.snapshots += save_snapshots(trainer, game_id, seed, run_dir, record)
            while progress.next_snapshot is not None and progress.next_snapshot <= trainer.env_steps:
                progress.next_snapshot += every
        if not at_end and checkpoint_seconds is not None and time.monotonic() - saved_at >= checkpoint_seconds:
            try:
                caller = callback.checkpoint() if callable(getattr(callback, "checkpoint", None)) else None
                save_checkpoint(run_dir, request, trainer, progress, caller)
            except (pickle.PicklingError, TypeError, AttributeError) as error:
                # a part that cannot be saved (an opponent on an ONNX session) must not stop the run
                warnings.warn(f"{run_dir}: this run cannot be checkpointed ({type(error).__name__}: {error}); it "
                              "goes on, but a stop will start it again from zero", RuntimeWarning, stacklevel=2)
                checkpoint_seconds = None
            saved_at = time.monotonic()
    document = {"request": json_safe(dict(request or {})),
                "snapshots": [_snapshot_entry(s, run_dir) for s in progress.snapshots], "history": progress.history}
    (run_dir / RUN_RECORD).write_text(json.dumps(document, indent=1, allow_nan=False) + "\n")
    # run.json supersedes the checkpoint: a finished run is read back, never resumed
    (run_dir / CHECKPOINT_FILE).unlink(missing_ok=True)
    return progress.snapshots


@dataclass
class _Progress:
    """Where :func:`run_trainer` stands besides the trainer: what a checkpoint holds with it."""

    next_snapshot: int | None
    """The env-step count of the next ``snapshot_every`` snapshot (None: none)."""
    marks: list[int]
    """The ``snapshot_at`` counts not reached yet."""
    snapshots: list[Snapshot] = field(default_factory=list)
    history: list[dict[str, Any]] = field(default_factory=list)
    """One record per iteration, as ``run.json`` keeps them."""

    def __getstate__(self) -> dict[str, Any]:
        # the snapshots are on disk already: a checkpoint names their folders, not their weights again
        state = dict(self.__dict__)
        state["snapshots"] = [_snapshot_entry(s, s.path.parent) for s in self.snapshots]
        return state


def save_checkpoint(run_dir: Path, request: Mapping[str, Any] | None, trainer: Any, progress: _Progress,
                    caller: Any = None) -> Path:
    """Write everything that continues the run at this iteration boundary to ``run_dir/checkpoint.pt``
    atomically (a temporary file, then a rename), so a stop at any moment leaves a whole checkpoint.

    The trainer is pickled whole (learners with their Adam state and generators, the run's
    generators, counters, scheme state, the collector's envs mid-episode); its log callback is not
    (a resumed run logs to the caller's). ``caller``: what the run's callback keeps of its own (its
    ``checkpoint()``), handed back to the resumed run's callback (its ``resume(state)``)."""
    log = getattr(trainer, "log", None)
    trainer.log = None
    path = run_dir / CHECKPOINT_FILE
    temporary = path.with_name(f".{CHECKPOINT_FILE}.{os.getpid()}.tmp")
    try:
        torch.save({"format": CHECKPOINT_FORMAT, "request": json_safe(dict(request or {})), "trainer": trainer,
                    "progress": progress, "torch_rng": torch.get_rng_state(), "caller": caller}, temporary)
        os.replace(temporary, path)
    finally:
        trainer.log = log
        temporary.unlink(missing_ok=True)
    return path


def load_checkpoint(run_dir: str | Path, request: Mapping[str, Any]) -> tuple[Any, _Progress, Any] | None:
    """The trainer, progress and caller's state of the unfinished run checkpointed in ``run_dir``, None when there is
    no checkpoint; a checkpoint of other arguments raises, naming the first difference and the fix.
    Restores torch's global generator as it stood at the checkpoint."""
    path = Path(run_dir) / CHECKPOINT_FILE
    if not path.exists():
        return None
    state = torch.load(path, weights_only=False)
    wanted = json_safe(dict(request))
    if state.get("format") != CHECKPOINT_FORMAT or state["request"] != wanted:
        difference = _first_difference(state.get("request", {}), wanted) if state.get("format") == CHECKPOINT_FORMAT \
            else f"format {state.get('format')!r}, not {CHECKPOINT_FORMAT}"
        raise ValueError(f"{path} is the checkpoint of a run with other arguments ({difference}); pass another "
                         "out_dir, or delete that checkpoint to start this run from zero")
    progress: _Progress = state["progress"]
    progress.snapshots = [_read_snapshot(Path(run_dir), entry) for entry in progress.snapshots]
    torch.set_rng_state(state["torch_rng"])
    return state["trainer"], progress, state.get("caller")


def _first_difference(had: Any, wanted: Any, where: str = "") -> str:
    """The first place two requests differ, as ``key: checkpoint X, now Y``."""
    if isinstance(had, dict) and isinstance(wanted, dict):
        for key in sorted(set(had) | set(wanted)):
            if had.get(key) != wanted.get(key):
                return _first_difference(had.get(key), wanted.get(key), f"{where}.{key}" if where else key)
    return f"{where or 'request'}: checkpoint {had!r}, now {wanted!r}"


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
    return [_read_snapshot(Path(run_dir), entry) for entry in document["snapshots"]]


def _read_snapshot(run_dir: Path, entry: Mapping[str, Any]) -> Snapshot:
    """A saved snapshot from its entry of ``run.json`` (or of a checkpoint)."""
    path = run_dir / entry["folder"]
    manifest = json.loads((path / MANIFEST_FILE).read_text())
    return Snapshot(entry["scheme"], entry["game_id"], entry["steps"], entry["seed"], manifest_architecture(manifest),
                    dict(load_file(str(path / WEIGHTS_FILE))), path, entry["learner"], entry["metrics"])


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
