"""The training stage of a population build: the runs each scheme makes, trained (side by side in
worker processes or as Ray tasks, or here) or read back when finished, and their snapshots as
candidates."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from arena_league.league.population.options import BuildOptions, BuildProgress
from arena_league.league.population.processes import run_tasks
from arena_league.league.population.recipes import TOP_RUN_SEEDS, Recipe
from arena_league.league.population.records import BuildReport, Candidate

#: The CPUs a training run asks of Ray: a run trains on one thread (``torch_threads(1)``).
RUN_CPUS = 1


@dataclass
class PlannedRun:
    """One training run of a build."""

    scheme: str
    seed: int
    warm: bool
    """Whether its learners first imitate the heuristic."""
    steps: int
    """Its RL env steps."""
    every: int
    """Env steps between snapshots."""
    overrides: dict[str, Any]
    """Its options of :func:`arena_league.training.run_scheme`."""

    def finished(self, work: Path) -> bool:
        return (work / "runs" / f"{self.scheme}-seed{self.seed}" / "run.json").exists()


@dataclass
class TrainingPlan:
    """Every run of a build, and the budgets the provenance records."""

    runs: list[PlannedRun]
    steps: dict[str, int]
    """Env steps of each scheme's runs from scratch."""
    runs_per_scheme: dict[str, int]
    warm_runs: dict[str, int]
    """Warm-started runs per scheme."""
    warm_steps: dict[str, int]
    imitation: list[dict[str, Any]]
    """The warm start of each warm-started run, cycling."""
    snapshots: int
    """Snapshots per run."""

    def warm_build(self) -> dict[str, Any] | None:
        """The warm-started runs as the provenance records them (None: there are none)."""
        if not any(self.warm_runs.values()):
            return None
        return {"runs_per_scheme": self.warm_runs, "steps_per_scheme": self.warm_steps,
                "warm_start": self.imitation[0] if len(self.imitation) == 1 else self.imitation}


def plan_training(game_id: str, options: BuildOptions, recipe: Recipe, schemes: list[str],
                  top: list[dict[str, Any]]) -> TrainingPlan:
    """The runs of a build: ``runs_per_scheme`` from scratch of each scheme (seeds from ``seed``),
    then its warm-started runs (seeds following theirs; run ``r`` takes rung ``r`` of the imitation
    ladder, cycling), then the top runs (seeds from ``seed + TOP_RUN_SEEDS``), each run's options
    checked before any is trained."""
    from arena_league.training.schemes import check_scheme_options

    steps = steps_per_scheme_of(schemes, options.steps_per_scheme, recipe)
    n_runs = runs_per_scheme_of(schemes, options.runs_per_scheme)
    n_warm = runs_per_scheme_of(schemes, recipe.warm_runs if options.warm_runs_per_scheme is None
                                else options.warm_runs_per_scheme, minimum=0, what="warm_runs_per_scheme")
    imitation = imitation_ladder(recipe.warm_start if options.warm_start is None else options.warm_start)
    if any(n_warm.values()):
        from arena_league.training.imitation import WarmStart

        for rung in imitation:
            WarmStart.parse(rung)  # bad fields fail before any training
    if options.warm_steps_per_scheme is not None:
        warm_steps = steps_per_scheme_of(schemes, options.warm_steps_per_scheme, recipe)
    elif options.steps_per_scheme is None:
        warm_steps = {s: int(recipe.warm_steps or steps[s]) for s in schemes}
    else:
        warm_steps = dict(steps)
    n_snapshots = int(options.snapshots or recipe.snapshots)
    if n_snapshots < 1:
        raise ValueError(f"snapshots must be at least 1, not {options.snapshots}")
    seed = options.seed
    runs: list[tuple[str, int, Any, Mapping[str, Any] | None]] = \
        [(scheme, seed + r, None, None) for scheme in schemes for r in range(n_runs[scheme])]
    runs += [(scheme, seed + n_runs[scheme] + r, imitation[r % len(imitation)], None)
             for scheme in schemes for r in range(n_warm[scheme])]
    runs += [(run["scheme"], seed + TOP_RUN_SEEDS + r, run.get("warm_start"), run) for r, run in enumerate(top)]
    plan = []
    for scheme, run_seed, rung, own in runs:
        overrides = {**recipe.overrides(scheme), **dict((options.scheme_options or {}).get(scheme, {}))}
        if own is not None:  # a top run: its own options and budget
            overrides.update({key: v for key, v in own.items() if key not in ("scheme", "steps")})
            run_steps = int(own["steps"])
        else:
            run_steps = warm_steps[scheme] if rung else steps[scheme]
            if rung:
                overrides.update(dict(recipe.warm_overrides), warm_start=rung)
        every = max(1, run_steps // n_snapshots)
        if recipe.early_snapshots and own is None:
            overrides["snapshot_at"] = sorted({0} | {every >> k for k in range(1, recipe.early_snapshots)} - {every})
        check_scheme_options(scheme, game_id, overrides)  # a bad option fails now, not hours into the build
        plan.append(PlannedRun(scheme, run_seed, bool(rung), run_steps, every, overrides))
    return TrainingPlan(plan, steps, n_runs, n_warm, warm_steps, imitation, n_snapshots)


def train(game_id: str, plan: TrainingPlan, seed: int, work: Path, processes: int, report: BuildReport,
          progress: BuildProgress | None, say: Callable[[str], None], backend: str = "local",
          address: str | None = None) -> list[Candidate]:
    """Every run of ``plan`` trained (side by side with ``processes`` above 1, or each as a Ray task
    with ``backend`` ``"ray"``) or read back, and their snapshots in scheme order; ``report`` says
    which runs were trained and which reused."""
    snapshots_by_scheme: dict[str, list[Candidate]] = {}
    side_by_side = train_side_by_side(game_id, plan.runs, work, processes, say, backend, address)
    for k, run in enumerate(plan.runs):
        finished = k not in side_by_side and run.finished(work)
        say(f"train {run.scheme} (seed {run.seed}{', warm start' if run.warm else ''}): {run.steps} env steps, "
            f"a snapshot every {run.every}" + (" (finished run: reading it back)" if finished else ""))
        if progress:
            progress("train", k, len(plan.runs))
        snapshots_by_scheme.setdefault(run.scheme, []).extend(
            run_one(run.scheme, game_id, run.steps, run.seed, run.every, work, run.overrides))
        label = run.scheme if run.seed == seed else f"{run.scheme}-seed{run.seed}"
        (report.reused_runs if finished else report.trained).append(label)
    if progress:
        progress("train", len(plan.runs), len(plan.runs))
    return [s for trained in snapshots_by_scheme.values() for s in trained]


def steps_per_scheme_of(schemes: list[str], steps: int | Mapping[str, int] | None, recipe: Recipe) -> dict[str, int]:
    """Env steps of each scheme's runs: the recipe's, one number for all, or one per scheme."""
    if steps is None:
        return {s: int(recipe.scheme_steps.get(s, recipe.steps)) for s in schemes}
    if isinstance(steps, Mapping):
        missing = [s for s in schemes if s not in steps]
        if missing:
            raise ValueError(f"steps_per_scheme gives no budget for {', '.join(missing)}; give one per scheme or "
                             "a single number")
        return {s: int(steps[s]) for s in schemes}
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError(f"steps_per_scheme must be a positive number of env steps, not {steps!r}")
    return {s: int(steps) for s in schemes}


def runs_per_scheme_of(schemes: list[str], runs: int | Mapping[str, int], minimum: int = 1,
                     what: str = "runs_per_scheme") -> dict[str, int]:
    """Runs of each scheme: one number for all or one per scheme, each at least ``minimum``."""
    counts = ({s: runs.get(s, minimum) for s in schemes} if isinstance(runs, Mapping)
              else dict.fromkeys(schemes, runs))
    bad = {s: n for s, n in counts.items() if isinstance(n, bool) or not isinstance(n, int) or n < minimum}
    if bad:
        raise ValueError(f"{what} must be a number of runs >= {minimum} (per scheme), not {bad}")
    unknown = sorted(set(runs) - set(schemes)) if isinstance(runs, Mapping) else []
    if unknown:
        raise ValueError(f"{what} names {', '.join(unknown)}, which are not among the schemes {schemes}")
    return counts


def run_one(scheme: str, game_id: str, steps: int, seed: int, every: int, work: Path,
            overrides: Mapping[str, Any]) -> list[Candidate]:
    """The snapshots of one run as candidates: trained now, or read back when its run finished."""
    from arena_league.training import run_scheme

    log_path = work / f"train-{scheme}.log"
    with log_path.open("a") as handle:
        def log_line(line: str) -> None:  # runs trained side by side share the file: each line names its run
            handle.write(f"seed {seed}: {line}\n")
            handle.flush()

        snapshots = run_scheme(scheme, game_id, steps=steps, seed=seed, snapshot_every=every,
                               out_dir=work / "runs", log=log_line, **overrides)
    expert = overrides.get("warm_start")
    expert = None if not expert else dict(expert).get("expert", "scripted:heuristic")
    return [Candidate(s.name.replace(f"{s.scheme}-", f"{s.scheme}-ws-", 1) if expert else s.name, s.scheme,
                      int(s.steps), int(s.seed), s.learner, s.architecture,
                      {k: v.detach().to(torch.float32).contiguous() for k, v in s.params.items()}, expert)
            for s in snapshots]


def train_side_by_side(game_id: str, plan: list[PlannedRun], work: Path, processes: int,
                       say: Callable[[str], None], backend: str = "local", address: str | None = None) -> set[int]:
    """Train the unfinished runs of ``plan`` in ``processes`` worker processes, or each as a Ray
    task of :data:`RUN_CPUS` CPUs with ``backend`` ``"ray"``, the longest first; the indices of the
    runs trained (the caller then reads every run back); an empty set when ``processes`` is 1 or at
    most one run is left (locally) or when none is left."""
    todo = [k for k, run in enumerate(plan) if not run.finished(work)]
    on_ray = backend == "ray"
    if not todo or (not on_ray and (processes < 2 or len(todo) < 2)):
        return set()
    todo.sort(key=lambda k: -plan[k].steps)
    where = "worker process" if not on_ray else "Ray task"
    say(f"training {len(todo)} runs " + (f"as Ray tasks of {RUN_CPUS} CPU each" if on_ray else
                                         f"in {min(processes, len(todo))} processes") + ", the longest first")
    trained: list[int] = []

    def done(k: int, _: None) -> None:
        trained.append(k)
        say(f"trained {plan[k].scheme} (seed {plan[k].seed}) in a {where} ({len(trained)} of {len(todo)})")

    run_tasks({k: (_train_in_worker, (plan[k].scheme, game_id, plan[k].steps, plan[k].seed, plan[k].every,
                                      str(work), plan[k].overrides)) for k in todo},
              done, backend="ray" if on_ray else "process", processes=processes, address=address, num_cpus=RUN_CPUS)
    return set(todo)


def _train_in_worker(scheme: str, game_id: str, steps: int, seed: int, every: int, work: str,
                     overrides: Mapping[str, Any]) -> None:
    run_one(scheme, game_id, steps, seed, every, Path(work), overrides)


def thin(candidates: list[Candidate], limit: int) -> list[Candidate]:
    """At most ``limit`` candidates: each (scheme, learner) ladder keeps a share proportional to its
    length, evenly spaced over its steps, its first and last snapshots included."""
    if len(candidates) <= limit:
        return candidates
    ladders: dict[tuple[str, str], list[Candidate]] = {}
    for c in candidates:
        ladders.setdefault((c.scheme, c.learner), []).append(c)
    quota = {k: max(2, int(limit * len(v) / len(candidates))) for k, v in ladders.items()}
    kept = []
    for k, unsorted in ladders.items():
        ladder = sorted(unsorted, key=lambda c: c.steps)
        index = np.unique(np.round(np.linspace(0, len(ladder) - 1, min(quota[k], len(ladder)))).astype(int))
        kept += [ladder[i] for i in index]
    return kept


def checked_top_runs(runs: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Top runs whose shape is checked: each names a known scheme and a positive budget."""
    from arena_league.training import SCHEMES
    from arena_league.training.schemes import _LAZY_SCHEME_MODULES

    known = set(SCHEMES) | set(_LAZY_SCHEME_MODULES)
    checked = []
    for run in runs:
        if not isinstance(run, Mapping) or run.get("scheme") not in known or \
                not isinstance(run.get("steps"), int) or run["steps"] < 1:
            raise ValueError(f"a top run needs a scheme ({', '.join(sorted(known))}) and a positive number of "
                             f"steps, e.g. {{'scheme': 'sp', 'steps': 1_000_000}}; got {run!r}")
        checked.append(dict(run))  # its options are checked with every other run's before training
    return checked


def imitation_ladder(value: Mapping[str, Any] | Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The warm start of every warm-started run, in run order (one dict: all alike)."""
    if isinstance(value, Mapping):
        return [dict(value)]
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or not value \
            or not all(isinstance(rung, Mapping) for rung in value):
        raise TypeError(f"warm_start must be a dict of WarmStart fields or a non-empty list of them (one per "
                        f"warm-started run), not {value!r}")
    return [dict(rung) for rung in value]
