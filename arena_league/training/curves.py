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
``curves.json`` (the same figures as numbers).
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

__all__ = ["TrainingReport", "evaluate_learners", "plot_curves", "train"]

#: The default reference population: the game's built-in scripted agents.
DEFAULT_REFERENCE = ("scripted:random", "scripted:heuristic")
REWARD_PLOT = "episode_reward.png"
PERFORMANCE_PLOT = "population_performance.png"
CURVES_FILE = "curves.json"


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

    def as_dict(self) -> dict[str, Any]:
        return json_safe({"game_id": self.game_id, "scheme": self.scheme, "seed": self.seed, "steps": self.steps,
                           "reference": list(self.reference), "history": self.history,
                           "evaluations": self.evaluations,
                           "snapshots": [{"name": s.name, "path": str(s.path), "steps": s.steps} for s in self.snapshots],
                           "plots": {k: str(v) for k, v in self.plots.items()}})


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
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    title = f"{report.game_id}, {report.scheme} (seed {report.seed})"
    plots = {}

    steps = np.array([h["env_steps"] for h in report.history], dtype=float)
    returns = np.array([np.nan if h.get("episode_return") is None else h["episode_return"] for h in report.history],
                       dtype=float)
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(steps, returns, color="tab:blue", alpha=0.35, linewidth=1, label="per iteration")
    smooth = _moving_mean(returns, max(1, len(returns) // 20))
    ax.plot(steps, smooth, color="tab:blue", linewidth=2, label="moving mean")
    plots["episode_reward"] = _save(fig, ax, "mean episode return of the learners' seats",
                                    f"Episode reward: {title}", report_dir / REWARD_PLOT)

    fig, ax = plt.subplots(figsize=(7, 4))
    eval_steps = np.array([e["env_steps"] for e in report.evaluations], dtype=float)
    for ref in report.reference:
        ax.plot(eval_steps, [e["per_reference"][ref] for e in report.evaluations], linestyle="--", marker=".",
                label=f"vs {ref}")
    ax.plot(eval_steps, [e["population_performance"] for e in report.evaluations], color="black", linewidth=2,
            marker="o", label="population performance")
    ax.set_ylim(-0.02, 1.02)
    plots["population_performance"] = _save(fig, ax, "win rate (draws count half)",
                                            f"Population performance: {title}", report_dir / PERFORMANCE_PLOT)

    plots["curves"] = report_dir / CURVES_FILE
    report.plots = plots
    plots["curves"].write_text(json.dumps(report.as_dict(), indent=1, allow_nan=False) + "\n")
    return plots


def _save(fig: Any, ax: Any, ylabel: str, title: str, path: Path) -> Path:
    """Label a curve plot over env steps, write it to ``path`` as PNG and close it."""
    import matplotlib.pyplot as plt

    ax.set_xlabel("env steps")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _moving_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Trailing mean over ``window`` points, skipping NaN (iterations with no finished episode)."""
    out = np.full(values.shape, np.nan)
    for i in range(len(values)):
        chunk = values[max(0, i - window + 1): i + 1]
        if np.isfinite(chunk).any():
            out[i] = np.nanmean(chunk)
    return out
