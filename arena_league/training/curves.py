"""Training curves: episode reward and population performance over training, as PNG plots.

Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence" (AAAI 2020), Fig. 4, follows each baseline's training by its *population
performance*: the mean win rate against a fixed reference population. :func:`train` runs a scheme
(:func:`~arena_league.training.schemes.run_scheme`), and every ``eval_every`` iterations plays
each learner against every reference agent (default: the game's scripted ``random`` and
``heuristic``) through the league's match engine, ``eval_matches`` matches per reference with the
learner's team rotating over the sides. A learner's win rate against a reference is its share of
points (a draw counts half; with more than two teams, the share of the other teams beaten); its
population performance is the mean over the references.

``report_dir`` receives ``episode_reward.png``, ``population_performance.png`` and
``curves.json`` (the same figures as numbers). The episode-reward plot draws the iterations that
finished at least one episode, joined by one unbroken line (an iteration that finished none has no
return to draw: it is left out of the line and marked by a tick on the bottom edge); a run that
finished no episode at all says so on the plot. When the learners were warm-started by imitation
(``warm_start``, :mod:`arena_league.training.imitation`), both plots shade the warm start as the
span of its own env steps left of 0, where the RL env steps of the curves begin.

Evaluation does not stall training: an evaluation plays its learners x references x matches in one
batched call of the match engine (the learners stacked into one forward, the envs and loaded
references kept from one evaluation to the next), and on a machine with more than one core it runs
in background processes while training goes on, the learners' weights copied out at the iteration
it measures. Its results are the same wherever it runs (a match's result is a function of its spec
and its agents). The report's ``timing`` says how long the evaluations played and how long training
waited for them.
"""

from __future__ import annotations

import json
import os
import pickle
import queue
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.training.schemes import ENV_OPTIONS, Snapshot, json_safe, run_scheme

__all__ = ["EVAL_BATCH_MATCHES", "TrainingReport", "evaluate_learners", "performance_figure", "plot_curves", "pyplot",
           "reward_figure", "save_figure", "train"]

#: The default reference population: the game's built-in scripted agents.
DEFAULT_REFERENCE = ("scripted:random", "scripted:heuristic")
REWARD_PLOT = "episode_reward.png"
PERFORMANCE_PLOT = "population_performance.png"
CURVES_FILE = "curves.json"
#: The warm start's shade: a colour the curves (matplotlib's default cycle) do not take.
_WARM_START_COLOUR = "#6a51a3"
#: Matches an evaluation keeps in flight at most. Playing all of the default evaluation's 160 at
#: once (fewer, larger policy calls) took 20% more CPU than 64 at a time on Crossroads-2T2P, whose
#: rules' own step is 70% of an evaluation and slows as more matches' physics is kept live.
EVAL_BATCH_MATCHES = 64
#: How long train() waits for a background evaluation before looking whether its processes still live.
_POLL_SECONDS = 0.5
#: Background evaluation processes at most (one per core the trainer leaves, up to this many).
_MAX_WORKERS = 4


@dataclass
class TrainingReport:
    """What :func:`train` measured."""

    game_id: str
    scheme: str
    seed: int
    steps: int
    reference: tuple[str, ...]
    history: list[dict[str, Any]] = field(default_factory=list)
    """One record per iteration: ``env_steps``, ``episode_return``, ``steps_per_second``, losses..."""
    evaluations: list[dict[str, Any]] = field(default_factory=list)
    """One record per evaluation: ``env_steps``, ``population_performance`` (mean over learners),
    ``per_learner`` and ``per_reference`` win rates."""
    snapshots: list[Snapshot] = field(default_factory=list)
    plots: dict[str, Path] = field(default_factory=dict)
    warm_start: dict[str, Any] | None = None
    """The imitation before RL, when the learners were warm-started: ``expert``, ``env_steps``
    (imitation env steps, which the history's ``env_steps`` do not count), ``rows`` and ``fit``."""
    timing: dict[str, Any] = field(default_factory=dict)
    """Where the run's time went (seconds): ``seconds`` (all of :func:`train`), ``eval_seconds`` (the
    evaluations' play, wherever it ran; ``eval_cpu_seconds``: the CPU time it took, less than
    ``eval_seconds`` where its process waited for a core), ``eval_wait_seconds`` (how long training stood still for
    them: all their play when inline; copying the weights out and waiting for the last results
    when in the background), ``eval_share`` (``eval_wait_seconds / seconds``), ``plot_seconds``,
    ``eval_background``, ``eval_processes`` and ``evaluations``. Background play takes cores of
    its own: where no core is free it slows training instead of stalling it, which the wait does
    not show (``benchmarks/train_evaluation.py`` sets a run beside its training alone)."""

    @property
    def env_steps(self) -> int:
        """The RL env steps trained: ``steps`` rounded up to whole iterations."""
        return int(self.history[-1]["env_steps"]) if self.history else 0

    def as_dict(self) -> dict[str, Any]:
        return json_safe({"game_id": self.game_id, "scheme": self.scheme, "seed": self.seed, "steps": self.steps,
                           "env_steps": self.env_steps,
                           "reference": list(self.reference), "history": self.history,
                           "evaluations": self.evaluations,
                           "snapshots": [{"name": s.name, "path": str(s.path), "steps": s.steps} for s in self.snapshots],
                           "plots": {k: str(v) for k, v in self.plots.items()}, "warm_start": self.warm_start,
                           "timing": self.timing})


def train(game_id: str, scheme: str = "sp", steps: int = 100_000, seed: int = 0,
          report_dir: str | Path | None = None, *, eval_every: int = 10, eval_matches: int = 20,
          reference: Sequence[str] = DEFAULT_REFERENCE, snapshot_every: int | None = None,
          out_dir: str | Path | None = None, log: Callable[[str], None] | None = None,
          eval_background: bool | None = None, **overrides: Any) -> TrainingReport:
    """Train ``game_id`` with ``scheme`` and measure its curves; with ``report_dir``, write the plots.

    Args:
        game_id: a game id of :func:`arena_league.envs.list_games`.
        scheme: a training scheme of :data:`~arena_league.training.schemes.SCHEMES`.
        steps: env steps to train for.
        seed: the run's seed (training and evaluation matches).
        report_dir: where ``episode_reward.png``, ``population_performance.png`` and ``curves.json``
            go (None: measure only).
        eval_every: iterations between two evaluations against the reference population (the first
            iteration and the last are always evaluated).
        eval_matches: matches per learner and reference agent at each evaluation.
        reference: the fixed reference population, as agent references (``scripted:random``,
            ``onnx:path.onnx``, ``arena-policy:folder``).
        snapshot_every: env steps between saved snapshots (default: at the end only).
        out_dir: where the run's snapshots go (default ``report_dir/snapshots``, else a new
            temporary folder).
        log: called with a line per iteration and per evaluation (an evaluation's line comes once
            its results are in: with a background evaluation, a few iterations later).
        eval_background: play the evaluations in background processes (one per core beside the
            trainer's, at most four) while training goes on (None: when this process may run on
            more than one core). The results are the same.
        **overrides: hyper-parameters, env options and scheme options (see :func:`run_scheme`).
    """
    from arena_league.matchmaking import AgentRef

    started = time.perf_counter()
    if eval_every < 1 or eval_matches < 1:
        raise ValueError(f"eval_every and eval_matches must be at least 1, got {eval_every} and {eval_matches}")
    env_options = {k: v for k, v in overrides.items() if k in ENV_OPTIONS}
    match_env = {k: v for k, v in env_options.items() if k != "env_kwargs"} | dict(env_options.get("env_kwargs") or {})
    references = {text: AgentRef.parse(text, game_id, env_options.get("action_type")) for text in reference}
    if not references:
        raise ValueError("the reference population is empty; name at least one agent, e.g. 'scripted:random'")
    report = TrainingReport(game_id, scheme, int(seed), int(steps), tuple(reference))
    if out_dir is None:
        out_dir = Path(report_dir) / "snapshots" if report_dir is not None else Path(
            tempfile.mkdtemp(prefix="arena-train-"))
    if eval_background is None:
        eval_background = _cores() > 1

    def record(evaluation: dict[str, Any]) -> None:
        report.evaluations.append(evaluation)
        if log is not None:
            log(f"eval at {evaluation['env_steps']} steps: population performance "
                f"{evaluation['population_performance']:.3f} "
                + " ".join(f"{k} {v:.2f}" for k, v in evaluation["per_reference"].items())
                + f" ({evaluation['eval_seconds']:.2f} s)")

    evaluations = _Evaluations(game_id, references, eval_matches, int(seed), match_env, bool(eval_background),
                               record)

    def on_iteration(trainer: Any, record: Mapping[str, Any]) -> None:
        imitation = getattr(trainer, "warm_start_record", None)
        if imitation is not None and report.warm_start is None:
            report.warm_start = json_safe({"expert": imitation["options"]["expert"],
                                           "env_steps": imitation["env_steps"], "rows": imitation["rows"],
                                           "fit": imitation["fit"]})
        report.history.append(json_safe({k: v for k, v in record.items() if k != "losses"}))
        last = trainer.env_steps >= steps
        if trainer.iteration == 1 or trainer.iteration % eval_every == 0 or last:
            evaluations.submit(trainer.learners, env_steps=int(trainer.env_steps), iteration=int(trainer.iteration))
        evaluations.collect(wait=False)

    # a run resumed from its checkpoint continues the curves it had (see run_scheme's callback)
    def checkpoint() -> dict[str, Any]:
        return {"history": list(report.history), "evaluations": list(report.evaluations),
                "warm_start": report.warm_start, "pending": evaluations.state()}

    def resume(state: Mapping[str, Any]) -> None:
        report.history[:] = state["history"]
        report.evaluations[:] = state["evaluations"]
        report.warm_start = state["warm_start"]
        evaluations.resume(state["pending"])

    on_iteration.checkpoint = checkpoint  # type: ignore[attr-defined]
    on_iteration.resume = resume  # type: ignore[attr-defined]

    try:
        report.snapshots = run_scheme(scheme, game_id, steps=steps, seed=seed, snapshot_every=snapshot_every,
                                      out_dir=out_dir, callback=on_iteration, log=log, **overrides)
        evaluations.collect(wait=True)
    finally:
        evaluations.close()
    if not report.history:
        raise ValueError(f"{out_dir} already holds this finished run, so nothing was trained or measured; "
                         "pass another out_dir (or delete that run's folder) to train and plot again")
    report.timing = evaluations.timing(time.perf_counter() - started, 0.0)
    if report_dir is not None:
        plotting = time.perf_counter()
        report.plots = plot_curves(report, report_dir)
        # curves.json again, its timing now counting the plots too
        report.timing = evaluations.timing(time.perf_counter() - started, time.perf_counter() - plotting)
        report.plots["curves"].write_text(json.dumps(report.as_dict(), indent=1, allow_nan=False) + "\n")
    return report


def evaluate_learners(learners: Sequence[Any], game_id: str, references: Mapping[str, Any], matches: int, *,
                      league_seed: int = 0, first_match_id: int = 0,
                      env_kwargs: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Population performance of each learner against ``references`` (key -> AgentRef or Policy),
    from ``matches`` matches per pair played by the match engine (the learner's team rotating).

    All learner x reference x match matches are played by one batched call (learners of one
    architecture stacked into one forward); a match's result depends on its spec and its agents
    only, so the figures are those of one call per learner."""
    evaluator = _Evaluator(game_id, references, env_kwargs)
    return evaluator.evaluate(_learner_policies(learners), matches, league_seed, first_match_id)


def _learner_policies(learners: Sequence[Any]) -> list[Any]:
    """The learners' frozen policies (a copy of their weights now), under the keys ``learner:<i>``."""
    # Learner.policy computes in float32, the actors' training dtype: the rows an evaluation's
    # forwards batch follow from its specs and EVAL_BATCH_MATCHES alone, so its results are still a
    # function of the seed, the same inline and in a worker
    return [learner.policy(name=f"learner:{index}") for index, learner in enumerate(learners)]


class _Evaluator:
    """Evaluations of one game against one reference population: the references are loaded once
    and the match engine's envs are made once, then every evaluation only brings new learners."""

    def __init__(self, game_id: str, references: Mapping[str, Any], env_kwargs: Mapping[str, Any] | None) -> None:
        from arena_league.envs import game_spec
        from arena_league.matchmaking import AgentRef

        self.game_id = game_id
        self.references = dict(references)
        self.env_kwargs = dict(env_kwargs or {})
        self.n_teams = game_spec(game_id).n_teams
        # submitted (sandboxed) references play in the sandbox's child, which play_matches drives
        self.sandboxed = any(isinstance(r, AgentRef) and r.sandboxed for r in self.references.values())
        self._loaded: dict[str, Any] | None = None
        self._runner: Any = None

    def evaluate(self, policies: Sequence[Any], matches: int, league_seed: int, first_match_id: int
                 ) -> dict[str, Any]:
        from arena_league.matchmaking import LockstepRunner, load_agents, play_matches, specs_for_seatings

        n_teams = self.n_teams
        seatings, owners = [], []
        for index in range(len(policies)):
            key = f"learner:{index}"
            for ref in self.references:
                for m in range(matches):
                    team = m % n_teams
                    seatings.append(tuple(key if t == team else ref for t in range(n_teams)))
                    owners.append((index, ref, team))
        specs = specs_for_seatings(self.game_id, seatings, league_seed=league_seed, first_match_id=first_match_id)
        learners = {f"learner:{index}": policy for index, policy in enumerate(policies)}
        width = min(EVAL_BATCH_MATCHES, len(specs))
        if self.sandboxed:
            results = play_matches(specs, self.references | learners, backend="inprocess", batch_size=width,
                                   env_kwargs=self.env_kwargs)
        else:
            if self._loaded is None:
                self._loaded = load_agents(self.references)
            agents = self._loaded | learners
            self._runner = (LockstepRunner(self.game_id, agents, batch_size=EVAL_BATCH_MATCHES,
                                           env_kwargs=self.env_kwargs)
                            if self._runner is None else self._runner.with_policies(agents))
            results = self._runner.play(specs)
        points: dict[tuple[int, str], list[float]] = {}
        for (index, ref, team), result in zip(owners, results):
            score = result.team_scores()[team] / max(n_teams - 1, 1)
            points.setdefault((index, ref), []).append(score)
        per_learner = [float(np.mean([np.mean(points[(i, ref)]) for ref in self.references]))
                       for i in range(len(policies))]
        per_reference = {ref: float(np.mean([np.mean(points[(i, ref)]) for i in range(len(policies))]))
                         for ref in self.references}
        return {"population_performance": float(np.mean(per_learner)), "per_learner": per_learner,
                "per_reference": per_reference, "matches_per_pair": matches}


class _Evaluations:
    """:func:`train`'s evaluations, handed to ``record`` in the order they were asked for: played
    at once (inline), or by background processes (one per core left to spare, at most
    :data:`_MAX_WORKERS`), each playing whole evaluations while the trainer goes on (the learners'
    weights are copied out at :meth:`submit`, so training may change them at once)."""

    def __init__(self, game_id: str, references: Mapping[str, Any], matches: int, seed: int,
                 env_kwargs: Mapping[str, Any], background: bool, record: Callable[[dict[str, Any]], None]) -> None:
        self.matches = matches
        self.seed = seed
        self.record = record
        self.evaluator = _Evaluator(game_id, references, env_kwargs)
        self.pending: list[dict[str, Any]] = []  # asked for, not recorded yet: env_steps, iteration
        self.asked: dict[int, list[Any]] = {}  # index -> the policies of an evaluation not recorded yet
        self.finished: dict[int, tuple[dict[str, Any], float, float]] = {}  # index -> evaluation, seconds, CPU
        self.submitted = 0
        self.play_seconds = 0.0
        self.cpu_seconds = 0.0
        self.wait_seconds = 0.0
        self.workers: list[Any] = []
        if background and not self.evaluator.sandboxed and _pickles(self.evaluator.references):
            self._start_workers(game_id, references, env_kwargs, max(1, min(_MAX_WORKERS, _cores() - 1)))

    def _start_workers(self, game_id: str, references: Mapping[str, Any], env_kwargs: Mapping[str, Any],
                       n: int) -> None:
        import multiprocessing

        from arena_league.policies.sandbox import _without_main_module

        # spawned, not forked from a fork server: starting one returns at once (the process imports
        # the league on a core of its own), where the fork server's first start holds the caller
        # until it has imported torch
        context = multiprocessing.get_context("spawn")
        self.tasks, self.results = context.Queue(), context.Queue()
        args = (self.tasks, self.results, game_id, dict(references), dict(env_kwargs))
        # daemons: a worker left behind ends with this process
        self.workers = [context.Process(target=_evaluation_worker, name=f"arena-train-evaluation-{k}", args=args,
                                        daemon=True) for k in range(n)]
        with _without_main_module():
            for worker in self.workers:
                worker.start()

    def submit(self, learners: Sequence[Any], *, env_steps: int, iteration: int) -> None:
        """Evaluate ``learners`` as they are now, at ``env_steps`` (iteration ``iteration``)."""
        self._submit(_learner_policies(learners), {"env_steps": env_steps, "iteration": iteration})

    def _submit(self, policies: list[Any], asked: dict[str, Any]) -> None:
        started = time.perf_counter()
        index = self.submitted
        self.submitted += 1
        self.pending.append(asked)
        self.asked[index] = policies
        task = (index, policies, self.matches, self.seed, index * 1_000_000)
        if self.workers:
            self.tasks.put(task)
        else:
            self._play_here(task)
        self.wait_seconds += time.perf_counter() - started

    def state(self) -> dict[str, Any]:
        """What continues these evaluations after a stop: how many were recorded, and the frozen
        policies of those asked for but not recorded yet (:meth:`resume` asks for them again)."""
        recorded = self.submitted - len(self.pending)
        return {"recorded": recorded, "pending": [(self.asked[recorded + k], dict(asked))
                                                  for k, asked in enumerate(self.pending)]}

    def resume(self, state: Mapping[str, Any]) -> None:
        """Continue the evaluations of :meth:`state` (on evaluations that have asked for none yet):
        each evaluation keeps its index, so its matches are those it would have played."""
        self.submitted = int(state["recorded"])
        for policies, asked in state["pending"]:
            self._submit(policies, asked)

    def _play_here(self, task: tuple) -> None:
        """Play an evaluation task in this process."""
        index, policies, matches, seed, first_match_id = task
        started, cpu = time.perf_counter(), time.process_time()
        evaluation = self.evaluator.evaluate(policies, matches, seed, first_match_id)
        self.finished[index] = (evaluation, time.perf_counter() - started, time.process_time() - cpu)
        self._record_in_order()

    def collect(self, wait: bool) -> None:
        """Record the background results that are in. With ``wait``, all of them: training is over,
        so this process plays the tasks no worker has taken yet (a worker still starting, or all
        busy) beside them."""
        if not self.workers or not self.pending:
            return
        started = time.perf_counter()
        while self.pending:
            if wait:
                try:  # fails at once while a worker waits on the queue: that worker takes the task
                    self._play_here(self.tasks.get_nowait())
                    continue
                except queue.Empty:
                    pass
            try:
                index, evaluation, seconds, cpu, error = (self.results.get(timeout=_POLL_SECONDS) if wait
                                                          else self.results.get_nowait())
            except queue.Empty:
                if not wait:
                    break
                dead = [w for w in self.workers if not w.is_alive()]
                if dead:
                    raise RuntimeError(f"a training evaluation process ended (exit code {dead[0].exitcode}) before "
                                       "every evaluation was played; rerun with eval_background=False to see the "
                                       "evaluation's own error") from None
                continue
            if error is not None:
                raise error
            self.finished[index] = (evaluation, seconds, cpu)
            self._record_in_order()
        self.wait_seconds += time.perf_counter() - started

    def _record_in_order(self) -> None:
        """Record the finished evaluations that every earlier one precedes."""
        while self.pending and (self.submitted - len(self.pending)) in self.finished:
            index = self.submitted - len(self.pending)
            evaluation, seconds, cpu = self.finished.pop(index)
            del self.asked[index]
            self.play_seconds += seconds
            self.cpu_seconds += cpu
            evaluation.update(self.pending.pop(0), eval_seconds=round(seconds, 4), eval_cpu_seconds=round(cpu, 4))
            self.record(evaluation)

    def timing(self, seconds: float, plot_seconds: float) -> dict[str, Any]:
        """The run's time split (see :attr:`TrainingReport.timing`), the run having taken ``seconds``."""
        return {"seconds": round(seconds, 3), "eval_seconds": round(self.play_seconds, 3),
                "eval_cpu_seconds": round(self.cpu_seconds, 3), "eval_wait_seconds": round(self.wait_seconds, 3),
                "eval_share": round(self.wait_seconds / seconds, 4) if seconds > 0 else None,
                "plot_seconds": round(plot_seconds, 3), "eval_background": bool(self.workers),
                "eval_processes": len(self.workers), "evaluations": self.submitted}

    def close(self) -> None:
        """End the background processes at once (every evaluation is in, or the run failed: either
        way they hold nothing), then release the queues. A worker told to end by a message could
        still be starting, and would then find the queues it unpickles gone and print a traceback;
        ending it by its id is immediate and silent."""
        if not self.workers:
            return
        for worker in self.workers:
            worker.terminate()
        for worker in self.workers:
            worker.join()
        self.tasks.close()
        self.results.close()


def _evaluation_worker(tasks: Any, results: Any, game_id: str, references: dict[str, Any],
                       env_kwargs: dict[str, Any]) -> None:
    """A background evaluation process: plays the evaluations it takes from ``tasks`` until it
    takes None, putting ``(index, evaluation, seconds, CPU seconds, error)`` on ``results``."""
    import torch

    # one compute thread: the other cores are the trainer's, and the forwards are small
    torch.set_num_threads(1)
    evaluator = _Evaluator(game_id, references, env_kwargs)
    while (task := tasks.get()) is not None:
        index, policies, matches, seed, first_match_id = task
        started, cpu = time.perf_counter(), time.process_time()
        try:
            evaluation = evaluator.evaluate(policies, matches, seed, first_match_id)
        except Exception as error:  # handed to train(), which raises it
            results.put((index, None, 0.0, 0.0,
                         error if _pickles(error) else RuntimeError(f"{type(error).__name__}: {error}")))
            return
        results.put((index, evaluation, time.perf_counter() - started, time.process_time() - cpu, None))


def _pickles(value: Any) -> bool:
    """Whether ``value`` can be sent to another process."""
    try:
        pickle.dumps(value)
    except Exception:  # any failure means: keep it in this process
        return False
    return True


def _cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def plot_curves(report: TrainingReport, report_dir: str | Path) -> dict[str, Path]:
    """Write ``episode_reward.png``, ``population_performance.png`` and ``curves.json``."""
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    plots = {"episode_reward": save_figure(reward_figure(report), report_dir / REWARD_PLOT),
             "population_performance": save_figure(performance_figure(report), report_dir / PERFORMANCE_PLOT),
             "curves": report_dir / CURVES_FILE}
    report.plots = plots
    plots["curves"].write_text(json.dumps(report.as_dict(), indent=1, allow_nan=False) + "\n")
    return plots


def reward_figure(report: TrainingReport) -> Any:
    """The episode-reward plot of ``report`` (a matplotlib figure; :func:`plot_curves` saves it).

    One point per iteration that finished at least one episode (its mean episode return), and the
    points joined in order by a single line: an iteration that finished no episode has no return,
    so it is left out of the line (never drawn as a gap or a made-up value) and marked by a grey
    tick on the bottom edge. A moving mean over the points follows. A run in which no iteration
    finished an episode shows the ticks and a note saying so instead of an empty plot. A warm
    start is shaded (see :func:`performance_figure`).
    """
    plt = pyplot()
    steps = np.array([h["env_steps"] for h in report.history], dtype=float)
    returns = np.array([np.nan if h.get("episode_return") is None else h["episode_return"] for h in report.history],
                       dtype=float)
    finished = np.isfinite(returns)
    fig, ax = plt.subplots(figsize=(7, 4))
    _mark_warm_start(ax, report)
    if finished.any():
        x, y = steps[finished], returns[finished]
        ax.plot(x, y, color="tab:blue", alpha=0.45, linewidth=1, marker=".", markersize=4,
                label="per iteration (mean of its finished episodes)")
        ax.plot(x, _moving_mean(y, max(1, len(y) // 20)), color="tab:blue", linewidth=2, label="moving mean")
    else:
        ax.text(0.5, 0.55, "no episode finished in this run: every iteration ended mid-episode,\n"
                "so there is no episode return to plot. Train for more env steps,\n"
                "or shorten the episodes (max_cycles).", transform=ax.transAxes, ha="center", va="center",
                fontsize=10, color="dimgray", bbox={"facecolor": "white", "edgecolor": "lightgray", "alpha": 0.9})
    if not finished.all():
        ax.plot(steps[~finished], np.full(int((~finished).sum()), 0.02), linestyle="none", marker="|",
                markersize=9, color="tab:gray", transform=ax.get_xaxis_transform(), clip_on=False,
                label=f"no finished episode ({int((~finished).sum())} of {len(steps)} iterations)")
    title = f"Episode reward: {report.game_id}, {report.scheme} (seed {report.seed})"
    _label(fig, ax, "mean episode return of the learners' seats", title, report)
    return fig


def performance_figure(report: TrainingReport) -> Any:
    """The population-performance plot of ``report`` (a matplotlib figure; :func:`plot_curves`
    saves it): the win rate against each reference agent and their mean, at every evaluation.

    With a warm start, both plots shade it as the span ``[-w, 0]`` of its ``w`` imitation env
    steps: the curves' env steps count RL only, which begins where the warm start ends.
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    _mark_warm_start(ax, report)
    eval_steps = np.array([e["env_steps"] for e in report.evaluations], dtype=float)
    for ref in report.reference:
        ax.plot(eval_steps, [e["per_reference"][ref] for e in report.evaluations], linestyle="--", marker=".",
                label=f"vs {ref}")
    ax.plot(eval_steps, [e["population_performance"] for e in report.evaluations], color="black", linewidth=2,
            marker="o", label="population performance")
    ax.set_ylim(-0.02, 1.02)
    title = f"Population performance: {report.game_id}, {report.scheme} (seed {report.seed})"
    _label(fig, ax, "win rate (draws count half)", title, report)
    return fig


def pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend (files only, no display), imported on first use."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    return plt


def _mark_warm_start(ax: Any, report: TrainingReport) -> None:
    """Shades the warm start, ``[-imitation env steps, 0]``, with a label."""
    if not report.warm_start:
        return
    from matplotlib.transforms import blended_transform_factory

    width = float(report.warm_start["env_steps"])
    ax.axvspan(-width, 0.0, color=_WARM_START_COLOUR, alpha=0.18, linewidth=0,
               label=f"warm start: imitating {report.warm_start['expert']} ({width:,.0f} env steps)")
    ax.axvline(0.0, color=_WARM_START_COLOUR, linewidth=1.2)
    ax.text(-width / 2, 0.97, "warm start", transform=blended_transform_factory(ax.transData, ax.transAxes),
            ha="center", va="top", fontsize=8, color=_WARM_START_COLOUR)


def _label(fig: Any, ax: Any, ylabel: str, title: str, report: TrainingReport) -> None:
    ax.set_xlabel("env steps" if not report.warm_start else "env steps (RL from 0; the warm start's before 0)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=8)
    fig.tight_layout()


def save_figure(fig: Any, path: Path) -> Path:
    """Write ``fig`` to ``path`` as PNG and close it."""
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _moving_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over ``window`` points."""
    out = np.empty(values.shape, dtype=float)
    for i in range(len(values)):
        out[i] = np.mean(values[max(0, i - window + 1): i + 1])
    return out
