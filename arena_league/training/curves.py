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
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.training.schemes import ENV_OPTIONS, Snapshot, json_safe, run_scheme

__all__ = ["TrainingReport", "evaluate_learners", "performance_figure", "plot_curves", "pyplot", "reward_figure",
           "save_figure", "train"]

#: The default reference population: the game's built-in scripted agents.
DEFAULT_REFERENCE = ("scripted:random", "scripted:heuristic")
REWARD_PLOT = "episode_reward.png"
PERFORMANCE_PLOT = "population_performance.png"
CURVES_FILE = "curves.json"
#: The warm start's shade: a colour the curves (matplotlib's default cycle) do not take.
_WARM_START_COLOUR = "#6a51a3"


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
                           "plots": {k: str(v) for k, v in self.plots.items()}, "warm_start": self.warm_start})


def train(game_id: str, scheme: str = "sp", steps: int = 100_000, seed: int = 0,
          report_dir: str | Path | None = None, *, eval_every: int = 10, eval_matches: int = 20,
          reference: Sequence[str] = DEFAULT_REFERENCE, snapshot_every: int | None = None,
          out_dir: str | Path | None = None, log: Callable[[str], None] | None = None,
          **overrides: Any) -> TrainingReport:
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
        log: called with a line per iteration and per evaluation.
        **overrides: hyper-parameters, env options and scheme options (see :func:`run_scheme`).
    """
    from arena_league.matchmaking import AgentRef

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

    def on_iteration(trainer: Any, record: Mapping[str, Any]) -> None:
        imitation = getattr(trainer, "warm_start_record", None)
        if imitation is not None and report.warm_start is None:
            report.warm_start = json_safe({"expert": imitation["options"]["expert"],
                                           "env_steps": imitation["env_steps"], "rows": imitation["rows"],
                                           "fit": imitation["fit"]})
        report.history.append(json_safe({k: v for k, v in record.items() if k != "losses"}))
        last = trainer.env_steps >= steps
        if trainer.iteration == 1 or trainer.iteration % eval_every == 0 or last:
            evaluation = evaluate_learners(trainer.learners, game_id, references, eval_matches,
                                           league_seed=seed, first_match_id=len(report.evaluations) * 1_000_000,
                                           env_kwargs=match_env)
            evaluation.update(env_steps=int(trainer.env_steps), iteration=int(trainer.iteration))
            report.evaluations.append(evaluation)
            if log is not None:
                log(f"eval at {trainer.env_steps} steps: population performance "
                    f"{evaluation['population_performance']:.3f} "
                    + " ".join(f"{k} {v:.2f}" for k, v in evaluation["per_reference"].items()))

    report.snapshots = run_scheme(scheme, game_id, steps=steps, seed=seed, snapshot_every=snapshot_every,
                                  out_dir=out_dir, callback=on_iteration, log=log, **overrides)
    if not report.history:
        raise ValueError(f"{out_dir} already holds this finished run, so nothing was trained or measured; "
                         "pass another out_dir (or delete that run's folder) to train and plot again")
    if report_dir is not None:
        report.plots = plot_curves(report, report_dir)
    return report


def evaluate_learners(learners: Sequence[Any], game_id: str, references: Mapping[str, Any], matches: int, *,
                      league_seed: int = 0, first_match_id: int = 0,
                      env_kwargs: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Population performance of each learner against ``references`` (key -> AgentRef or Policy),
    from ``matches`` matches per pair played by the match engine (the learner's team rotating)."""
    from arena_league.envs import game_spec
    from arena_league.matchmaking import play_matches, specs_for_seatings

    n_teams = game_spec(game_id).n_teams
    agents: dict[str, Any] = dict(references)
    seatings, owners = [], []
    for index, learner in enumerate(learners):
        key = f"learner:{index}"
        agents[key] = learner.policy(name=key)
        for ref in references:
            for m in range(matches):
                team = m % n_teams
                seatings.append(tuple(key if t == team else ref for t in range(n_teams)))
                owners.append((index, ref, team))
    specs = specs_for_seatings(game_id, seatings, league_seed=league_seed, first_match_id=first_match_id)
    results = play_matches(specs, agents, backend="inprocess", batch_size=min(64, len(specs)),
                           env_kwargs=dict(env_kwargs or {}))
    points: dict[tuple[int, str], list[float]] = {}
    for (index, ref, team), result in zip(owners, results):
        score = result.team_scores()[team] / max(n_teams - 1, 1)
        points.setdefault((index, ref), []).append(score)
    per_learner = [float(np.mean([np.mean(points[(i, ref)]) for ref in references])) for i in range(len(learners))]
    per_reference = {ref: float(np.mean([np.mean(points[(i, ref)]) for i in range(len(learners))]))
                     for ref in references}
    return {"population_performance": float(np.mean(per_learner)), "per_learner": per_learner,
            "per_reference": per_reference, "matches_per_pair": matches}


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
