"""The Arena paper's experiments, reproduced with seeded runs and bootstrap intervals.

Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence" (AAAI 2020) make two empirical claims; each has a function here that trains, measures
and writes a report folder (``report.json``, plots, ``README.md``).

Crossroads social-tree study (:func:`crossroads_social`)
    The paper's three trees on Crossroads-2T2P-v1 (``CASE_STUDY_TREES`` of the game: ``all_IS``,
    ``all_CL``, ``CL_under_CP``), each trained from scratch with independent learners, one per
    seat (D-PPO, ``per="agent"``, so a seat can take a role of its own), for ``steps`` env steps
    and several seeds. The trained agents then play ``episodes`` evaluation episodes in their
    seats (actions sampled, as they were trained, from seeded uniforms), and these behaviour
    measures are read from the game's state after every step. They were fixed before any result
    was seen and are not tuned to favour a tree:

    * ``collisions``: contacts begun per episode: a pair of active agents whose centres come
      within ``2 * AGENT_RADIUS + CONTACT_TOLERANCE`` after being apart;
    * ``centre_collisions``: those whose midpoint lies in the crossing's centre square
      (``|x|, |y| <= ROAD_HALF_WIDTH``);
    * ``mean_arrival_step`` and ``last_arrival_step``: the step at which each agent (and the
      last agent) arrived, an agent that never arrives counting as ``max_cycles`` (censored);
    * ``arrived_share``: the share of agents that arrived;
    * ``blocking_steps``: per episode, the agent-steps in which an agent *blocks*: it is active,
      nearly standing (speed below ``STANDING_SPEED`` of the top speed), inside the other team's
      road strip (its lateral offset from that road's axis below ``ROAD_HALF_WIDTH``) and ahead of
      an active agent of that team on its way (farther along that team's direction of travel),
      while a teammate of its own is still active;
    * ``blocking_share``: the share of episodes in which some agent blocks for at least
      ``BLOCKING_MIN_STEPS`` steps.

    Each measure is averaged over a seed's episodes; across seeds the report gives the mean and a
    95% bootstrap interval (percentile, resampling seeds; with few seeds the interval is coarse).
    The agents are measured so at every mark of :func:`social_marks` (``marks`` log-spaced env-step
    counts ending at ``steps``, or ``marks_at``): each run snapshots its learners at the first
    iteration past a mark, and each mark's agents play the same seeded episodes, so the report
    (``trend``, the README's trend tables, ``trend.png``) gives every measure and the paper's
    claims by budget; the last mark is the end point, the figures of a run evaluated at its end
    only.
    A traffic jam can also put a standing agent on the other road: ``blocking_steps`` counts it,
    which is why the report sets it beside the collisions and the arrival steps.

Baselines by population performance (:func:`baselines`)
    D-PPO, SP, PBT, CC and CF on one game and tree (Crossroads-2T2P-v1 with the blocking tree
    ``CL_under_CP``; PushBox-2T2P-v1 with its default tree, the paper's), several seeds each, the
    same env-step budget. At log-spaced checkpoints, the run's first learner is placed against
    the game's frozen base population through the match engine (adaptive placement,
    :class:`~arena_league.rating.AdaptivePlacement`, ``budget`` matches), giving its rank and
    percentile; the run's episode reward is recorded at every iteration. The report holds both
    curves per method and seed, the interquartile mean of the final percentile per method with a
    stratified bootstrap interval, the probability-of-improvement matrix of the final
    percentiles, and each signal's *ordering noise*: how often the order of two methods (by their
    mean over seeds) flips between consecutive checkpoints, as a share of method pairs. Beside it,
    each method's *curve noise* per signal (:func:`curve_noise`: the SD of a run's checkpoint curve
    about its centred moving average over 3 checkpoints, pooled over seeds, also relative to the
    signal's range over the report), and the placements' rank-interval half-width by checkpoint
    (median over runs) against the target of :data:`RANK_TARGET` places;
    :func:`placement_budget` (``benchmarks/placement_budget.py``) measures the budget that meets it
    in the middle of a population.

Both are resumable: a run stopped anywhere resumes from its checkpoint under ``out/runs``, a
finished one is read back, not retrained, and what was measured of it, kept beside it (the social
study's evaluations at its marks, the baselines' placements of its checkpoints), is not played
again. :func:`rewrite_readme` writes a report folder's README again from its ``report.json``.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.envs import game_spec, make
from arena_league.rating.aggregate import (
    iqm,
    probability_of_improvement_matrix,
    stratified_bootstrap_ci,
)

__all__ = [
    "BASELINES",
    "BASELINE_GAMES",
    "CROSSROADS",
    "SOCIAL_MEASURES",
    "Spread",
    "baselines",
    "crossroads_behaviour",
    "crossroads_social",
    "curve_noise",
    "ordering_flips",
    "placement_budget",
    "rewrite_readme",
    "social_marks",
]

CROSSROADS = "Crossroads-2T2P-v1"
#: The five baselines of the paper, as training schemes.
BASELINES = ("dppo", "sp", "pbt", "cc", "cf")
#: The games of the baselines experiment and the tree each is trained with (None: the game's default).
BASELINE_GAMES: dict[str, str | None] = {CROSSROADS: "CL_under_CP", "PushBox-2T2P-v1": None}
#: Centre distance beyond touching (2 radii) still counted as a contact, in world units.
CONTACT_TOLERANCE = 0.05
#: Below this share of the top speed an agent counts as standing.
STANDING_SPEED = 0.2
#: Steps of blocking that make an episode count in ``blocking_share``.
BLOCKING_MIN_STEPS = 10
SOCIAL_MEASURES = {
    "collisions": "contacts begun per episode between active agents",
    "centre_collisions": "contacts begun per episode in the crossing's centre square",
    "mean_arrival_step": "mean step of arrival over agents (never arrived: max_cycles)",
    "last_arrival_step": "step at which the last agent arrived (not all arrived: max_cycles)",
    "arrived_share": "share of agents that arrived",
    "blocking_steps": "agent-steps per episode spent standing in the other team's path while a teammate is active",
    "blocking_share": f"share of episodes with an agent blocking for at least {BLOCKING_MIN_STEPS} steps",
}
REPORT_FILE = "report.json"
#: The rank interval the study's placements should reach: at most this many places either side.
RANK_TARGET = 5.0
CURVE_TREND = "centred moving average over 3 checkpoints"
LEVEL = 0.95


def _say(log: Callable[[str], None] | None) -> Callable[[str], None]:
    return log or (lambda line: None)


def _write(out: Path, report: Mapping[str, Any]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / REPORT_FILE).write_text(json.dumps(report, indent=1, allow_nan=False) + "\n")


def _report_folder(out: str | Path) -> Path:
    """``out``, made now: a folder that cannot be written fails before any training, not after."""
    out = Path(out)
    try:
        (out / "runs").mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ValueError(f"cannot write the report folder {out} ({error.strerror}); give another with --out") from None
    return out


def _check_budget(seeds: Sequence[int], steps: int, episodes_or_budget: int, what: str) -> list[int]:
    seeds = [int(s) for s in seeds]
    if not seeds or len(set(seeds)) != len(seeds):
        raise ValueError(f"give one or more distinct seeds, got {seeds}")
    if steps < 1:
        raise ValueError(f"steps must be at least 1 env step, got {steps}")
    if episodes_or_budget < 1:
        raise ValueError(f"{what} must be at least 1, got {episodes_or_budget}")
    return seeds


def _interval(values: Sequence[float], seed: int, reps: int) -> dict[str, float]:
    """Mean of per-seed values with a 95% percentile bootstrap interval over the seeds."""
    a = np.asarray(values, dtype=np.float64)
    if len(a) < 2:
        return {"mean": float(a.mean()), "lower": float(a.mean()), "upper": float(a.mean())}
    ci = stratified_bootstrap_ci(a[:, None], lambda s: s.mean(axis=(-2, -1)), reps=reps, level=LEVEL, rng=seed)
    return {"mean": float(ci.point), "lower": float(ci.lower), "upper": float(ci.upper)}


# --- the Crossroads social-tree study -------------------------------------------------------------

def crossroads_behaviour(policies: Sequence[Any], tree: Any, episodes: int, seed: int, *,
                         max_cycles: int | None = None) -> list[dict[str, float]]:
    """Plays ``episodes`` episodes of Crossroads-2T2P-v1 with ``policies[i]`` in seat ``i`` (all
    episodes in lockstep, one batched forward per policy and step) and returns each episode's
    measures (:data:`SOCIAL_MEASURES`)."""
    rules = game_spec(CROSSROADS).rules
    geometry = rules.geometry  # type: ignore[attr-defined]
    envs = [make(CROSSROADS, tree=tree, max_cycles=max_cycles) for _ in range(episodes)]
    agents = list(envs[0].possible_agents)
    n = len(agents)
    if len(policies) != n:
        raise ValueError(f"{CROSSROADS} has {n} seats; give one policy per seat, got {len(policies)}")
    cycles = int(max_cycles or rules.default_max_cycles)  # type: ignore[attr-defined]
    teams = np.repeat(np.arange(2), n // 2)
    direction = np.array([[1.0, 0.0], [0.0, 1.0]])  # team 0 west -> east, team 1 south -> north
    rng = np.random.default_rng(np.random.SeedSequence([seed, 7]))
    obs = [env.reset(seed=int(np.random.SeedSequence([seed, e]).generate_state(1)[0]))[0] for e, env in
           enumerate(envs)]
    states = [[] for _ in envs]
    live = list(range(episodes))
    recurrent = [p.initial_state(episodes) for p in policies]
    while live:
        actions = np.zeros((len(live), n), dtype=np.int64)
        for seat, policy in enumerate(policies):
            rows = np.stack([obs[e][agents[seat]] for e in live]).astype(np.float32)
            state = None if recurrent[seat] is None else recurrent[seat][live]
            act, new_state = policy.act(rows, rng.random((len(live), policy.spec.uniforms_per_seat)), None, state)
            if new_state is not None:
                recurrent[seat][live] = new_state
            actions[:, seat] = np.asarray(act).reshape(len(live), -1)[:, 0]
        still = []
        for row, e in enumerate(live):
            env = envs[e]
            step = {a: int(actions[row, i]) for i, a in enumerate(agents) if a in env.agents}
            obs[e], _, terminations, truncations, _ = env.step(step)
            states[e].append(np.asarray(env.state(), dtype=np.float64))
            if env.agents and not all(terminations.get(a) or truncations.get(a) for a in env.agents):
                still.append(e)
        live = still
    L, V, R = geometry["arm_length"], geometry["top_speed"], geometry["agent_radius"]
    return [_episode_measures(np.stack(s).reshape(len(s), n, -1), teams, direction, cycles, L, V, R,
                              geometry["road_half_width"]) for s in states]


def _episode_measures(state: np.ndarray, teams: np.ndarray, direction: np.ndarray, cycles: int, L: float,
                      V: float, R: float, half_width: float) -> dict[str, float]:
    """The measures of one episode from its states ``[steps, seats, 9]`` (world frame, scaled)."""
    steps, n = state.shape[:2]
    position, velocity, active = state[:, :, 0:2] * L, state[:, :, 2:4] * V, state[:, :, 8] > 0.5
    # Contacts: pairs of active agents touching now and not at the step before.
    gap = np.linalg.norm(position[:, :, None, :] - position[:, None, :, :], axis=-1)
    both = active[:, :, None] & active[:, None, :]
    touching = both & (gap <= 2 * R + CONTACT_TOLERANCE) & ~np.eye(n, dtype=bool)
    begun = touching & ~np.concatenate([np.zeros_like(touching[:1]), touching[:-1]], axis=0)
    pairs = np.triu(np.ones((n, n), dtype=bool), 1)
    begun &= pairs
    midpoint = 0.5 * (position[:, :, None, :] + position[:, None, :, :])
    centre = (np.abs(midpoint) <= half_width).all(axis=-1)
    # Arrival: the first step (1-based) at which a seat is no longer active.
    arrived = ~active
    first = np.where(arrived.any(axis=0), arrived.argmax(axis=0) + 1, cycles).astype(np.float64)
    # Blocking: standing in the other team's road strip, ahead of an active agent of that team.
    speed = np.linalg.norm(velocity, axis=-1)
    blocking = np.zeros((steps, n), dtype=bool)
    for seat in range(n):
        mine, other = teams[seat], 1 - teams[seat]
        d = direction[other]
        lateral = d[0] * position[:, seat, 1] - d[1] * position[:, seat, 0]
        progress = position[:, :, 0] * d[0] + position[:, :, 1] * d[1]
        opponents = teams == other
        behind = (active[:, opponents] & (progress[:, opponents] < progress[:, seat:seat + 1] - 2 * R)).any(axis=1)
        mates = (teams == mine) & (np.arange(n) != seat)
        blocking[:, seat] = (active[:, seat] & (speed[:, seat] < STANDING_SPEED * V) & (np.abs(lateral) < half_width)
                             & behind & active[:, mates].any(axis=1))
    return {"collisions": float(begun.sum()), "centre_collisions": float((begun & centre).sum()),
            "mean_arrival_step": float(first.mean()),
            "last_arrival_step": float(first.max() if arrived[-1].all() else cycles),
            "arrived_share": float(arrived[-1].mean()), "blocking_steps": float(blocking.sum()),
            "blocking_share": float((blocking.sum(axis=0) >= BLOCKING_MIN_STEPS).any())}


def social_marks(steps: int, marks: int = 5, marks_at: Sequence[int] | None = None) -> list[int]:
    """The env-step marks at which the social study evaluates its runs: ``marks_at`` (sorted, with
    ``steps`` added as the last), else ``marks`` log-spaced marks ending at ``steps``
    (:func:`checkpoint_steps`, one 1,024-step iteration apart at least)."""
    if marks_at:
        values = sorted({int(m) for m in marks_at})
        if values[0] < 1 or values[-1] > steps:
            raise ValueError(f"--marks-at takes env-step counts from 1 to --steps ({steps:,}), got {values}")
        return values if values[-1] == steps else [*values, steps]
    return checkpoint_steps(steps, marks, 1024)


def crossroads_social(out: str | Path, *, seeds: Sequence[int] = (0, 1, 2), steps: int = 300_000,
                      episodes: int = 50, trees: Sequence[str] | None = None, max_cycles: int | None = None,
                      marks: int = 5, marks_at: Sequence[int] | None = None, reps: int = 2000,
                      log: Callable[[str], None] | None = None, spread: Spread | None = None) -> dict[str, Any]:
    """Trains the paper's three Crossroads trees (D-PPO, one learner per seat) for ``steps`` env
    steps per seed, measures the agents' behaviour over ``episodes`` episodes at every mark of
    :func:`social_marks` (the last the trained agents), and writes ``report.json``,
    ``measures.png``, ``trend.png`` and ``README.md`` into ``out``; returns the report. With
    ``spread``, the runs are trained and evaluated first, side by side (:class:`Spread`)."""
    from arena_league.envs import example_trees

    say = _say(log)
    seeds = _check_budget(seeds, steps, episodes, "episodes")
    at = social_marks(steps, marks, marks_at)
    case_trees = example_trees(CROSSROADS)
    names = list(trees or case_trees)
    unknown = [t for t in names if t not in case_trees]
    if unknown:
        raise ValueError(f"unknown tree(s) {', '.join(unknown)}; the case study's: {', '.join(case_trees)}")
    out = _report_folder(out)
    started = time.perf_counter()
    if spread is not None:
        spread.run({(name, seed): (_social_run, (name, seed, steps, case_trees[name], max_cycles, out, at, episodes))
                    for name in names for seed in seeds}, say)
    # per tree and measure: one list of per-seed values per mark
    trend: dict[str, dict[str, list[list[float]]]] = {}
    mark_steps: dict[str, list[list[int]]] = {}
    for name in names:
        trend[name] = {m: [[] for _ in at] for m in SOCIAL_MEASURES}
        mark_steps[name] = []
        for seed in seeds:
            say(f"{name}, seed {seed}: {steps:,} env steps (D-PPO, one learner per seat), evaluated at {at}")
            evaluated, trained = _social_run(name, seed, steps, case_trees[name], max_cycles, out, at, episodes)
            say(f"{name}, seed {seed}: " + ("trained" if trained else f"read back from {out / 'runs' / name}"))
            mark_steps[name].append([e["env_steps"] for e in evaluated])
            for k, e in enumerate(evaluated):
                for m in SOCIAL_MEASURES:
                    trend[name][m][k].append(e["measures"][m])
            say(f"{name}, seed {seed}: " + ", ".join(f"{m} {evaluated[-1]['measures'][m]:.2f}"
                                                     for m in SOCIAL_MEASURES))
    per_seed = {name: {m: values[-1] for m, values in trend[name].items()} for name in names}
    report = {"game": CROSSROADS, "seeds": seeds, "steps_per_run": int(steps),
              "trees": {name: {m: _interval(v, 0, reps) for m, v in per_seed[name].items()} for name in names},
              "scheme": "dppo (one learner per seat)", "episodes_per_seed": int(episodes),
              "max_cycles": max_cycles, "level": LEVEL, "measures": SOCIAL_MEASURES, "per_seed": per_seed,
              "tree_specs": {name: case_trees[name] for name in names}, "marks": at, "mark_steps": mark_steps,
              "trend": {name: {m: [_interval(v, 0, reps) for v in values] for m, values in trend[name].items()}
                        for name in names},
              "per_seed_trend": trend, "seconds": round(time.perf_counter() - started, 1)}
    report["findings"] = social_findings(report)
    report["findings_by_mark"] = [social_findings({"trees": {name: {m: report["trend"][name][m][k]
                                                                     for m in SOCIAL_MEASURES} for name in names}})
                                  for k in range(len(at))]
    _write(out, report)
    _social_files(report, out)
    return report


def rewrite_readme(out: str | Path) -> dict[str, Any]:
    """Writes the ``README.md`` of a report folder again from its ``report.json``, training and
    playing nothing (after the README's wording changed); a baselines report made before the curve
    noise and the rank half-widths were measured gets them, from the checkpoints it holds, in its
    ``report.json`` too. Returns the report."""
    out = Path(out)
    path = out / REPORT_FILE
    if not path.is_file():
        raise ValueError(f"no {REPORT_FILE} in {out}; give the folder of a report with --out")
    report = json.loads(path.read_text())
    if "trees" in report:
        (out / "README.md").write_text(social_readme(report))
        return report
    if "curve_sd" not in report["noise"]["percentile"] or "rank_half_width" not in report:
        _baselines_spread(report)
        _write(out, report)
    (out / "README.md").write_text(baselines_readme(report))
    return report


def _social_files(report: Mapping[str, Any], out: Path) -> None:
    """The plots and README of a social report (``trend.png`` only when it has a trend)."""
    _social_plot(report, out / "measures.png")
    if len(report.get("marks", [])) > 1:
        _social_trend_plot(report, out / "trend.png")
    (out / "README.md").write_text(social_readme(report))


def _social_run(name: str, seed: int, steps: int, tree: Any, max_cycles: int | None, out: Path, marks: list[int],
                episodes: int) -> tuple[list[dict[str, Any]], bool]:
    """One run of the social study, trained into (or found in) ``out/runs/name`` with a snapshot
    at every mark, and its agents evaluated at each mark (kept beside the run, in
    ``behaviour-seed<seed>.json``, and read back from it): per mark, the env steps of its
    snapshot and the measures' means over the episodes. Also whether the run trained now."""
    from arena_league.policies.families import TorchPolicy
    from arena_league.policies.threads import torch_threads
    from arena_league.training.schemes import run_scheme

    folder = out / "runs" / name
    iterations: list[Any] = []
    # only marks before the end: one mark (the end) asks for the run the study trained before marks
    extra = {"snapshot_at": [m for m in marks if m < steps]} if len(marks) > 1 else {}
    with torch_threads(1):
        snapshots = run_scheme("dppo", CROSSROADS, steps=steps, seed=seed, snapshot_every=None, out_dir=folder,
                               tree=tree, per="agent", max_cycles=max_cycles,
                               callback=lambda trainer, row: iterations.append(row), **extra)
    taken = sorted({s.steps for s in snapshots if s.steps > 0})
    path = folder / f"behaviour-seed{seed}.json"
    key = {"episodes": int(episodes), "max_cycles": max_cycles}
    saved = json.loads(path.read_text()) if path.exists() else {}
    # evaluations of a retrained run, or of other episodes, are not these
    done = saved.get("evaluations", {}) if saved.get("key") == key and not iterations else {}
    evaluated = []
    for mark in marks:
        at = next((t for t in taken if t >= mark), taken[-1])
        if str(at) not in done:
            seats = sorted((s for s in snapshots if s.steps == at), key=lambda s: s.learner)
            with torch_threads(1):
                policies = [TorchPolicy(s.architecture, s.params, name=s.learner) for s in seats]
                measured = crossroads_behaviour(policies, tree, episodes, seed, max_cycles=max_cycles)
            done[str(at)] = {m: float(np.mean([e[m] for e in measured])) for m in SOCIAL_MEASURES}
            path.write_text(json.dumps({"key": key, "evaluations": done}))
        evaluated.append({"mark": mark, "env_steps": at, "measures": done[str(at)]})
    return evaluated, bool(iterations)


def _separated(a: Mapping[str, float], b: Mapping[str, float]) -> str:
    """``"higher"``/``"lower"`` when ``a``'s interval lies wholly above/below ``b``'s, else ``"overlap"``."""
    if a["lower"] > b["upper"]:
        return "higher"
    if a["upper"] < b["lower"]:
        return "lower"
    return "overlap"


def social_findings(report: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The paper's three claims, each checked by comparing two trees' intervals on the measure
    that states it (fixed in advance; ``holds`` only where the intervals do not overlap)."""
    trees = report["trees"]
    checks = [
        ("all_IS agents crash at the centre more than all_CL agents (traffic jam vs waiting)",
         "all_IS", "all_CL", "centre_collisions", "higher"),
        ("all_CL agents all get across sooner than all_IS agents (they wait for each other and cross)",
         "all_CL", "all_IS", "last_arrival_step", "lower"),
        ("CL_under_CP agents block the other team's road more than all_CL agents",
         "CL_under_CP", "all_CL", "blocking_steps", "higher"),
    ]
    findings = []
    for claim, a, b, measure, expected in checks:
        if a not in trees or b not in trees:
            continue
        seen = _separated(trees[a][measure], trees[b][measure])
        findings.append({"claim": claim, "measure": measure, "trees": [a, b], "expected": expected,
                         "observed": seen, "holds": seen == expected})
    return findings


def _social_plot(report: Mapping[str, Any], path: Path) -> None:
    from arena_league.training.curves import pyplot, save_figure

    plt = pyplot()
    measures = list(SOCIAL_MEASURES)
    names = list(report["trees"])
    fig, axes = plt.subplots(2, math.ceil(len(measures) / 2), figsize=(13, 6))
    for ax, m in zip(axes.flat, measures):
        means = [report["trees"][t][m]["mean"] for t in names]
        low = [report["trees"][t][m]["mean"] - report["trees"][t][m]["lower"] for t in names]
        high = [report["trees"][t][m]["upper"] - report["trees"][t][m]["mean"] for t in names]
        ax.bar(names, means, yerr=[low, high], capsize=4, color=["tab:red", "tab:green", "tab:blue"][:len(names)])
        for i, t in enumerate(names):
            ax.plot([i] * len(report["per_seed"][t][m]), report["per_seed"][t][m], "k.", markersize=4)
        ax.set_title(m, fontsize=9)
        ax.tick_params(labelsize=8)
    for ax in list(axes.flat)[len(measures):]:
        ax.axis("off")
    fig.suptitle(f"Crossroads-2T2P-v1: behaviour of trained agents by social tree ({len(report['seeds'])} seeds x "
                 f"{report['steps_per_run']:,} env steps; bars: mean, whiskers: 95% bootstrap over seeds, dots: seeds)",
                 fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)


def social_readme(report: Mapping[str, Any]) -> str:
    names = list(report["trees"])
    lines = ["# Crossroads social-tree study", "",
             f"{report['game']}, trees {', '.join(names)}; {report['scheme']}; seeds {report['seeds']}, "
             f"{report['steps_per_run']:,} env steps per run, {report['episodes_per_seed']} evaluation episodes per "
             f"seed; {report['seconds']:,} s in all. Values: mean over seeds [95% bootstrap interval over seeds].",
             "", "| measure | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for m in SOCIAL_MEASURES:
        cells = [f"{report['trees'][t][m]['mean']:.2f} [{report['trees'][t][m]['lower']:.2f}, "
                 f"{report['trees'][t][m]['upper']:.2f}]" for t in names]
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    lines += ["", "## The paper's claims at this budget", ""]
    for f in report["findings"]:
        verdict = "shown" if f["holds"] else f"not shown (intervals: {f['observed']})"
        lines.append(f"* {f['claim']}: **{verdict}** ({f['measure']}, {f['trees'][0]} vs {f['trees'][1]})")
    lines += _social_trend_lines(report)
    lines += ["", "## Measures", ""] + [f"* `{m}`: {text}" for m, text in SOCIAL_MEASURES.items()]
    lines += ["", "![measures](measures.png)", ""]
    if len(report.get("marks", [])) > 1:
        lines += ["![trend](trend.png)", ""]
    return "\n".join(lines)


def _social_trend_lines(report: Mapping[str, Any]) -> list[str]:
    """The README's trend with budget: each measure at every mark, and the claims at every mark
    (none for a report made before the study had marks, or with one mark only)."""
    marks = report.get("marks", [])
    if len(marks) < 2:
        return []
    names = list(report["trees"])
    lines = ["", "## Trend with budget", "",
             f"The same measures at each env-step mark of every run ({', '.join(f'{m:,}' for m in marks)}; a "
             "snapshot is taken at the first iteration past a mark), each mark's agents playing the same "
             f"{report['episodes_per_seed']} seeded episodes; the last mark is the table above."]
    if report["findings"]:
        lines += ["", "The paper's claims by mark (**shown**, or how the intervals compare):", "",
                  "| env steps | " + " | ".join(f"{f['measure']} ({f['trees'][0]} vs {f['trees'][1]})"
                                              for f in report["findings"]) + " |",
                  "|---|" + "---|" * len(report["findings"])]
        for mark, findings in zip(marks, report["findings_by_mark"]):
            lines.append(f"| {mark:,} | " + " | ".join("**shown**" if f["holds"] else f["observed"]
                                                      for f in findings) + " |")
    for m in SOCIAL_MEASURES:
        lines += ["", f"`{m}`:", "", "| env steps | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
        for k, mark in enumerate(marks):
            cells = [f"{report['trend'][t][m][k]['mean']:.2f} [{report['trend'][t][m][k]['lower']:.2f}, "
                     f"{report['trend'][t][m][k]['upper']:.2f}]" for t in names]
            lines.append(f"| {mark:,} | " + " | ".join(cells) + " |")
    return lines


def _social_trend_plot(report: Mapping[str, Any], path: Path) -> None:
    from arena_league.training.curves import pyplot, save_figure

    plt = pyplot()
    measures = list(SOCIAL_MEASURES)
    marks = report["marks"]
    fig, axes = plt.subplots(2, math.ceil(len(measures) / 2), figsize=(13, 6))
    for ax, m in zip(axes.flat, measures):
        for i, (tree, by_measure) in enumerate(report["trend"].items()):
            points = by_measure[m]
            ax.plot(marks, [p["mean"] for p in points], color=f"C{i}", marker="o", markersize=3, label=tree)
            ax.fill_between(marks, [p["lower"] for p in points], [p["upper"] for p in points], color=f"C{i}",
                            alpha=0.2)
        ax.set_xscale("log")
        ax.xaxis.set_minor_locator(plt.NullLocator())  # ticks at the marks say more, and lay out faster
        ax.set_xticks(marks, [f"{m / 1e6:.3g}M" if m >= 1e6 else f"{m / 1e3:.3g}k" for m in marks], fontsize=7)
        ax.set_title(m, fontsize=9)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    for ax in list(axes.flat)[len(measures):]:
        ax.axis("off")
    fig.suptitle(f"Crossroads-2T2P-v1: behaviour by env steps of training ({len(report['seeds'])} seeds; lines: mean, "
                 "bands: 95% bootstrap over seeds)", fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)


# --- the five baselines by population performance -------------------------------------------------

def _base_population(game_id: str, population: str) -> tuple[list[str], np.ndarray, dict[str, Any]]:
    """The frozen base population's member names, ratings and policies (loaded once; a built-in
    member, such as PushBox's tuned heuristics, is the agent its name says)."""
    from arena_league.league.population.build import member_policy
    from arena_league.league.population_index import indexed_populations, verified_population

    if population not in indexed_populations(game_id):
        raise ValueError(f"{game_id} ships no base population {population!r}, which this experiment ranks against; "
                         f"build one first (`arena-league population build {game_id}`, then `arena-league "
                         f"population index --write`)")
    folder = verified_population(game_id, population).folder  # raises naming the pull when it is not here
    manifest = json.loads((folder / "population.json").read_text())
    members = manifest["members"]
    names = [m["name"] for m in members]
    ratings = np.array([m["metadata"]["rating"] for m in members], dtype=np.float64)
    policies = {m["name"]: member_policy(folder, m, game_id) for m in members}  # built-in members too
    return names, ratings, policies


def _place(game_id: str, entrant: Any, names: list[str], ratings: np.ndarray, policies: Mapping[str, Any],
           budget: int, seed: int, first_match_id: int) -> dict[str, float]:
    """Adaptive placement of ``entrant`` (a policy) against the base; its rank and percentile."""
    from arena_league.matchmaking import play_matches
    from arena_league.matchmaking.selection import play_adaptive
    from arena_league.policies.threads import torch_threads
    from arena_league.rating import AdaptivePlacement

    chooser = AdaptivePlacement(ratings, budget=budget, target_half_width=0.0)
    agents = {**policies, "entrant": entrant}
    with torch_threads(1):
        play_adaptive("entrant", names, chooser, lambda specs: play_matches(specs, agents), game_id,
                      league_seed=seed, first_match_id=first_match_id, max_matches=budget + 1)
    p = chooser.placement
    return {"rank": int(p.rank), "rank_lower": int(p.rank_lower), "rank_upper": int(p.rank_upper),
            "percentile": float(p.percentile), "percentile_lower": float(p.percentile_lower),
            "percentile_upper": float(p.percentile_upper), "rating": float(p.rating), "matches": int(chooser.matches)}


class _TracedPlacement:
    """An :class:`~arena_league.rating.AdaptivePlacement` that keeps its rank half-width after every match."""

    def __init__(self, chooser: Any) -> None:
        self.chooser = chooser
        self.half_widths: list[float] = []

    def next_opponent(self) -> int:
        return self.chooser.next_opponent()

    def record(self, opponent: int, score: float, side: int = 0) -> None:
        self.chooser.record(opponent, score, side)
        self.half_widths.append(float(self.chooser.placement.rank_half_width))

    @property
    def done(self) -> bool:
        return self.chooser.done


def placement_budget(game_id: str, population: str = "base-v1", *, target: float = RANK_TARGET, members: int = 1,
                     max_budget: int = 300, seed: int = 0, simulated: int = 200) -> dict[str, Any]:
    """The placement budget at which an entrant in the middle of ``game_id``'s base population gets a
    rank interval of at most ``target`` places either side, measured two ways:

    * ``members``: the ``members`` base members rated nearest the population's median, each placed
      as the baselines experiment places a checkpoint (adaptive opponents, the whole base, a copy of
      itself included), match by match until its half-width is at most ``target`` (from the
      placement's minimum number of matches on) or ``max_budget`` matches; per member, the matches
      that took (None: not within ``max_budget``) and the half-width after each match;
    * ``simulated``: that many entrants of the median member's rating placed by simulation
      (:func:`~arena_league.rating.simulate_placement`, Bradley-Terry outcomes, no draws, no match
      played): the median matches and the share that reached ``target`` within ``max_budget``.
    """
    from arena_league.matchmaking import play_matches
    from arena_league.matchmaking.selection import play_adaptive
    from arena_league.policies.threads import torch_threads
    from arena_league.rating import AdaptivePlacement, simulate_placement

    if members < 1 or max_budget < 1 or simulated < 1 or not target > 0:
        raise ValueError(f"members, max_budget and simulated must be at least 1 and target above 0, got {members}, "
                         f"{max_budget}, {simulated} and {target}")
    names, ratings, base = _base_population(game_id, population)
    order = np.argsort(np.abs(ratings - np.median(ratings)), kind="stable")[:members]
    placed = []
    for k, index in enumerate(order):
        chooser = _TracedPlacement(AdaptivePlacement(ratings, budget=max_budget, target_half_width=target))
        agents = {**base, "entrant": base[names[index]]}
        started = time.perf_counter()
        with torch_threads(1):
            play_adaptive("entrant", names, chooser, lambda specs, agents=agents: play_matches(specs, agents),
                          game_id, league_seed=seed, first_match_id=(k + 1) * 100_000, max_matches=max_budget + 1)
        widths = chooser.half_widths
        reached = widths[-1] <= target and chooser.chooser.matches >= chooser.chooser.min_matches
        p = chooser.chooser.placement
        placed.append({"member": names[index], "rating": float(ratings[index]),
                       "rank_in_base": int(1 + (ratings > ratings[index]).sum()),
                       "matches_to_target": len(widths) if reached else None, "rank": int(p.rank),
                       "rank_lower": int(p.rank_lower), "rank_upper": int(p.rank_upper),
                       "half_width_by_match": widths, "seconds": round(time.perf_counter() - started, 1)})
    simulation = simulate_placement(ratings, np.full(simulated, ratings[order[0]]), target_half_width=target,
                                    budget=max_budget, seed=seed)
    return {"game": game_id, "population": population, "base_size": len(names), "target_half_width": target,
            "max_budget": max_budget, "seed": seed, "members": placed,
            "simulated": {"entrants": simulated, "rating": float(ratings[order[0]]),
                          "median_matches": simulation.median_matches,
                          "reached_share": float(simulation.reached.mean()),
                          "matches_90th_percentile": float(np.percentile(simulation.matches, 90))}}


def _finite(value: Any) -> float | None:
    """An iteration's episode return, or None when it has none (no episode finished: some trainers
    say None, CF's says NaN)."""
    return None if value is None or not math.isfinite(float(value)) else float(value)


def checkpoint_steps(steps: int, checkpoints: int, iteration_steps: int) -> list[int]:
    """``checkpoints`` log-spaced env-step marks ending at ``steps`` (distinct, at least one
    iteration apart where the budget allows)."""
    if checkpoints < 1:
        raise ValueError(f"checkpoints must be at least 1, got {checkpoints}")
    first = min(steps, max(iteration_steps, steps // 2 ** (checkpoints - 1)))
    marks = np.unique(np.geomspace(first, steps, checkpoints).round().astype(np.int64))
    return [int(m) for m in marks]


def ordering_flips(curves: Mapping[str, Sequence[float]]) -> float:
    """The share of (method pair, consecutive checkpoints) in which the pair's order flips."""
    methods = list(curves)
    values = np.array([curves[m] for m in methods], dtype=np.float64)
    if len(methods) < 2 or values.shape[1] < 2:
        return 0.0
    flips = total = 0
    for i in range(len(methods)):
        for j in range(i + 1, len(methods)):
            sign = np.sign(values[i] - values[j])
            flips += int((sign[1:] * sign[:-1] < 0).sum())
            total += len(sign) - 1
    return flips / total


@dataclass(frozen=True)
class Spread:
    """Where an experiment's training runs (and placements) go before the report is made from them:
    a process pool of ``processes`` on this machine (``backend="process"``) or the tasks of a Ray
    cluster at ``address`` (``"ray"``; default ``RAY_ADDRESS``, else a local instance of
    ``processes`` CPUs), each run one task of one CPU
    (:func:`arena_league.league.population.processes.run_tasks`). Every run writes its files under
    the report folder as it would here, and the report then reads them back, so a report is the
    same whatever trained it, and an experiment stopped anywhere resumes from its runs folder, on a
    cluster or here. The report folder must be on storage every node reads and writes."""

    backend: str = "process"
    processes: int = 1
    address: str | None = None

    def __post_init__(self) -> None:
        from arena_league.league.population.processes import EXECUTORS

        if self.backend not in EXECUTORS:
            raise ValueError(f"unknown backend {self.backend!r} for an experiment's runs; valid: "
                             f"{', '.join(EXECUTORS)}")
        if self.address is not None and self.backend != "ray":
            raise ValueError("a Ray address is for --backend ray; add it, or leave --address out")

    def run(self, tasks: Mapping[Any, tuple[Callable[..., Any], tuple[Any, ...]]],
            say: Callable[[str], None]) -> None:
        from arena_league.league.population.processes import run_tasks

        say(f"{len(tasks)} runs side by side ({self.backend}, {self.processes} processes)" if self.backend == "process"
            else f"{len(tasks)} runs as Ray tasks (cluster {self.address or 'RAY_ADDRESS or a local instance'})")
        run_tasks(tasks, lambda key, _: say(f"{', '.join(map(str, key))}: done"), backend=self.backend,
                  processes=self.processes, address=self.address)


def _baselines_run(method: str, game_id: str, seed: int, steps: int, marks: list[int], tree: Any,
                   max_cycles: int | None, folder: Path, names: list[str], ratings: np.ndarray,
                   base: Mapping[str, Any], budget: int, population: str) -> None:
    """One run of the baselines experiment, trained and its checkpoints placed, into ``folder``."""
    from arena_league.policies.threads import torch_threads

    with torch_threads(1):
        snapshots, *_ = _train_run(method, game_id, seed, steps, marks, tree, max_cycles, folder)
        _placements(game_id, _placed_learner(snapshots), names, ratings, base, budget, seed, population,
                    folder / f"placements-seed{seed}.json")


def _placed_learner(snapshots: list[Any]) -> list[Any]:
    """The snapshots of a run's first learner after step 0, by step: the ones placed."""
    first_learner = min(s.learner for s in snapshots)
    return sorted((s for s in snapshots if s.learner == first_learner and s.steps > 0), key=lambda s: s.steps)


def _train_run(method: str, game_id: str, seed: int, steps: int, marks: list[int], tree: Any,
               max_cycles: int | None, folder: Path) -> tuple[list[Any], list[dict[str, Any]], float | None, bool]:
    """Trains one run (or reads it back from ``folder``): its snapshots, its episode return per
    iteration, the seconds its training took (None when not known) and whether it trained now."""
    from arena_league.training.schemes import run_scheme

    started = time.perf_counter()
    history: list[dict[str, Any]] = []

    def record(trainer: Any, row: Mapping[str, Any]) -> None:
        history.append({"env_steps": int(row["env_steps"]), "episode_return": _finite(row.get("episode_return"))})

    # a run resumed from its checkpoint carries on with the curve it had
    record.checkpoint = lambda: list(history)  # type: ignore[attr-defined]
    record.resume = history.extend  # type: ignore[attr-defined]

    snapshots = run_scheme(method, game_id, steps=steps, seed=seed, snapshot_every=None, out_dir=folder,
                           callback=record, tree=tree, max_cycles=max_cycles, snapshot_at=marks)
    curve_file = folder / f"curve-seed{seed}.json"
    if history:
        seconds = round(time.perf_counter() - started, 1)
        curve_file.write_text(json.dumps({"history": history, "train_seconds": seconds}))
        return snapshots, history, seconds, True
    saved = json.loads(curve_file.read_text()) if curve_file.exists() else {"history": [], "train_seconds": None}
    return snapshots, saved["history"], saved["train_seconds"], False


def _placements(game_id: str, snapshots: list[Any], names: list[str], ratings: np.ndarray,
                base: Mapping[str, Any], budget: int, seed: int, population: str, path: Path) -> list[dict[str, Any]]:
    """Each snapshot placed against the base (kept in ``path``, and read back from it when the
    same snapshots were placed against the same base with the same budget)."""
    from arena_league.policies.families import TorchPolicy

    key = {"population": population, "budget": budget, "steps": [s.steps for s in snapshots]}
    saved = json.loads(path.read_text()) if path.exists() else {}
    if saved.get("key") == key:
        return saved["placements"]
    placements = [_place(game_id, TorchPolicy(snap.architecture, snap.params, name="entrant"), names, ratings, base,
                         budget, seed, first_match_id=(k + 1) * 100_000) for k, snap in enumerate(snapshots)]
    path.write_text(json.dumps({"key": key, "placements": placements}))
    return placements


def _methods_left_out(game_id: str, methods: Sequence[str]) -> dict[str, str]:
    """The methods of ``methods`` that cannot train ``game_id``, each with why: those whose trainer
    takes none of the game's action types (CF sums its critic over a seat's discrete actions)."""
    from arena_league.training.schemes import scheme_action_types

    offered = game_spec(game_id).rules.action_types
    left_out = {}
    for method in methods:
        trains = scheme_action_types(method)
        if not set(trains) & set(offered):
            left_out[method] = (f"{method.upper()} needs {' or '.join(trains)} actions and {game_id} has "
                                f"{' and '.join(offered)} ones only")
    return left_out


def baselines(game_id: str, out: str | Path, *, methods: Sequence[str] = BASELINES, seeds: Sequence[int] = (0, 1, 2),
              steps: int = 200_000, checkpoints: int = 6, budget: int = 40, population: str = "base-v1",
              max_cycles: int | None = None, reps: int = 2000,
              log: Callable[[str], None] | None = None, spread: Spread | None = None) -> dict[str, Any]:
    """Trains every method of ``methods`` on ``game_id`` (the paper's tree for it) for ``steps``
    env steps per seed, places the run's first learner against the game's frozen base population
    at log-spaced checkpoints, and writes ``report.json``, ``curves.png`` and ``README.md`` into
    ``out``; returns the report. With ``spread``, the runs are trained and placed first, side by
    side (:class:`Spread`)."""
    from arena_league.envs import example_trees

    say = _say(log)
    if game_id not in BASELINE_GAMES:
        raise ValueError(f"the baselines experiment runs on {' or '.join(BASELINE_GAMES)}, not {game_id!r}")
    seeds = _check_budget(seeds, steps, budget, "budget")
    methods = list(methods)
    unknown = [m for m in methods if m not in BASELINES]
    if unknown or not methods:
        raise ValueError(f"unknown method(s) {', '.join(unknown) or '(none given)'}; the paper's: {', '.join(BASELINES)}")
    left_out = _methods_left_out(game_id, methods)
    methods = [m for m in methods if m not in left_out]
    if not methods:
        raise ValueError(f"no method of those asked can train {game_id}: {'; '.join(left_out.values())}")
    for method, why in left_out.items():
        say(f"{method} left out: {why}")
    tree_name = BASELINE_GAMES[game_id]
    tree = example_trees(game_id)[tree_name] if tree_name else None
    started = time.perf_counter()
    names, ratings, base = _base_population(game_id, population)
    out = _report_folder(out)
    marks = checkpoint_steps(steps, checkpoints, 1024)
    if spread is not None:
        spread.run({(method, seed): (_baselines_run, (method, game_id, seed, steps, marks, tree, max_cycles,
                                                      out / "runs" / method, names, ratings, base, budget, population))
                    for method in methods for seed in seeds}, say)
    runs: dict[str, list[dict[str, Any]]] = {}
    for method in methods:
        runs[method] = []
        folder = out / "runs" / method
        for seed in seeds:
            run_started = time.perf_counter()
            say(f"{method}, seed {seed}: {steps:,} env steps, checkpoints at {marks}")
            snapshots, history, train_seconds, trained = _train_run(method, game_id, seed, steps, marks, tree,
                                                                    max_cycles, folder)
            say(f"{method}, seed {seed}: " + (f"trained in {train_seconds:.0f} s" if trained else
                                              f"read back from {folder}"))
            first_learner = min(s.learner for s in snapshots)
            ours = _placed_learner(snapshots)
            placements = _placements(game_id, ours, names, ratings, base, budget, seed, population,
                                     folder / f"placements-seed{seed}.json")
            points = []
            for snap, placed in zip(ours, placements):
                reward = [h["episode_return"] for h in history
                          if h["env_steps"] <= snap.steps and h["episode_return"] is not None]
                points.append({"env_steps": int(snap.steps), "episode_reward": reward[-1] if reward else None,
                               **placed})
            runs[method].append({"seed": seed, "learner": first_learner, "history": history, "checkpoints": points,
                                 "train_seconds": train_seconds,
                                 "seconds": round(time.perf_counter() - run_started, 1)})
            last = points[-1]
            say(f"{method}, seed {seed}: final rank {last['rank']} of {len(names) + 1}, percentile "
                f"{last['percentile']:.0f} ({last['percentile_lower']:.0f} .. {last['percentile_upper']:.0f})")
    report = _baselines_report(game_id, tree_name, population, len(names), seeds, steps, budget, marks, runs, reps)
    report["left_out"] = left_out
    report["seconds"] = round(time.perf_counter() - started, 1)
    report["max_cycles"] = max_cycles
    _write(out, report)
    _baselines_plot(report, out / "curves.png")
    (out / "README.md").write_text(baselines_readme(report))
    return report


def _baselines_report(game_id: str, tree_name: str | None, population: str, base_size: int, seeds: list[int],
                      steps: int, budget: int, marks: list[int], runs: Mapping[str, list[dict[str, Any]]],
                      reps: int) -> dict[str, Any]:
    final = {m: np.array([[r["checkpoints"][-1]["percentile"]] for r in rs]) for m, rs in runs.items()}
    rng = np.random.default_rng(0)  # one generator through every interval of the report
    summary = {}
    for method, scores in final.items():
        ci = stratified_bootstrap_ci(scores, iqm, reps=reps, level=LEVEL, rng=rng)
        summary[method] = {"iqm_final_percentile": float(ci.point), "lower": float(ci.lower), "upper": float(ci.upper),
                           "final_rank_mean": float(np.mean([r["checkpoints"][-1]["rank"] for r in runs[method]]))}

    def mean_curve(method: str, key: str) -> list[float | None]:
        """The mean over seeds at each checkpoint (None where no seed has a value, e.g. no episode
        had finished yet)."""
        rows = np.array([[np.nan if c[key] is None else c[key] for c in r["checkpoints"]] for r in runs[method]],
                        dtype=np.float64)
        seen = np.isfinite(rows).any(axis=0)
        sums = np.where(np.isfinite(rows), rows, 0.0).sum(axis=0)
        means = sums / np.maximum(np.isfinite(rows).sum(axis=0), 1)
        return [float(m) if ok else None for m, ok in zip(means, seen)]

    curves = {key: {m: mean_curve(m, key) for m in runs} for key in ("episode_reward", "percentile")}
    finite = {key: {m: c for m, c in per.items() if all(v is not None for v in c)} for key, per in curves.items()}
    noise = {key: {"ordering_flips": ordering_flips(per), "methods": list(per)} for key, per in finite.items()}
    report = {"game": game_id, "tree": tree_name or "default", "population": population, "base_size": base_size,
              "methods": list(runs), "seeds": seeds, "steps_per_run": int(steps), "placement_budget": int(budget),
              "checkpoints": marks, "level": LEVEL, "final": summary,
              "probability_of_improvement": probability_of_improvement_matrix(final),
              "noise": noise, "mean_curves": curves, "runs": runs}
    _baselines_spread(report)
    return report


def curve_noise(curves: Sequence[Sequence[float | None]]) -> float | None:
    """The noise SD of checkpoint curves around their own smoothed trend, pooled over the curves:
    ``sqrt(3/2)`` times the root mean square of ``v[t] - (v[t-1] + v[t] + v[t+1]) / 3`` over the
    interior checkpoints (a centred moving average over 3 checkpoints; the factor makes it the SD of
    independent noise about a trend straight over three checkpoints, in log steps as they are
    spaced). Triples with a missing value are skipped; None when no curve has one."""
    residuals: list[float] = []
    for curve in curves:
        v = np.array([np.nan if x is None else x for x in curve], dtype=np.float64)
        if len(v) >= 3:
            r = v[1:-1] - (v[:-2] + v[1:-1] + v[2:]) / 3.0
            residuals += [float(x) for x in r[np.isfinite(r)]]
    return float(math.sqrt(1.5 * np.mean(np.square(residuals)))) if residuals else None


def _rank_half_width(checkpoint: Mapping[str, Any]) -> float:
    """Half the width of a placement's rank interval, in places (older reports name its ends
    ``rank_best`` and ``rank_worst``)."""
    lower = checkpoint.get("rank_lower", checkpoint.get("rank_best"))
    upper = checkpoint.get("rank_upper", checkpoint.get("rank_worst"))
    return 0.5 * (float(upper) - float(lower))


def _baselines_spread(report: dict[str, Any]) -> None:
    """Adds to a baselines report what its runs' checkpoints give besides the ordering noise: each
    method's curve noise about its own trend (:func:`curve_noise`, per signal, and relative to the
    signal's range over the report) and the placements' rank half-widths by checkpoint (median
    over runs, and per method), against :data:`RANK_TARGET`. Reports written before these were
    measured get them from the data they hold."""
    runs = report["runs"]
    for key in ("episode_reward", "percentile"):
        per_run = {m: [[c[key] for c in r["checkpoints"]] for r in rs] for m, rs in runs.items()}
        values = [v for curves in per_run.values() for curve in curves for v in curve if v is not None]
        span = max(values) - min(values) if values else 0.0
        sd = {m: curve_noise(curves) for m, curves in per_run.items()}
        report["noise"][key]["curve_sd"] = sd
        report["noise"][key]["curve_sd_relative"] = {m: None if v is None or span == 0 else v / span
                                                     for m, v in sd.items()}
        report["noise"][key]["range"] = span
    report["noise"]["curve_trend"] = CURVE_TREND
    half = {m: np.array([[_rank_half_width(c) for c in r["checkpoints"]] for r in rs]) for m, rs in runs.items()}
    every = np.concatenate(list(half.values()), axis=0)
    median = [float(v) for v in np.median(every, axis=0)]
    report["rank_half_width"] = {
        "target": RANK_TARGET, "median": median, "met": [v <= RANK_TARGET for v in median],
        "env_steps": [int(c["env_steps"]) for c in next(iter(runs.values()))[0]["checkpoints"]],
        "by_method": {m: [float(v) for v in np.median(h, axis=0)] for m, h in half.items()}}


def _baselines_plot(report: Mapping[str, Any], path: Path) -> None:
    from arena_league.training.curves import pyplot, save_figure

    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    for i, (method, runs) in enumerate(report["runs"].items()):
        colour = f"C{i}"
        for r in runs:
            h = [(p["env_steps"], p["episode_return"]) for p in r["history"] if p["episode_return"] is not None]
            if h:
                top.plot(*zip(*h), color=colour, alpha=0.35, linewidth=0.8)
            c = r["checkpoints"]
            bottom.plot([p["env_steps"] for p in c], [p["percentile"] for p in c], color=colour, alpha=0.35,
                        linewidth=0.8)
        bottom.plot(report["checkpoints"][-len(report["mean_curves"]["percentile"][method]):],
                    report["mean_curves"]["percentile"][method], color=colour, linewidth=2.2, marker="o", label=method)
        top.plot([], [], color=colour, label=method)
    top.set_ylabel("episode reward (per iteration)")
    bottom.set_ylabel(f"percentile in {report['population']}")
    bottom.set_xlabel("env steps")
    bottom.set_ylim(-2, 102)
    for ax in (top, bottom):
        ax.set_xscale("log")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    top.set_title(f"{report['game']} ({report['tree']} tree): episode reward (above) and population performance "
                  f"(below), {len(report['seeds'])} seeds", fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)


def baselines_readme(report: Mapping[str, Any]) -> str:
    methods = report["methods"]
    lines = [f"# The five baselines on {report['game']} by population performance", "",
             f"Tree: {report['tree']}; methods {', '.join(methods)}; seeds {report['seeds']}; "
             f"{report['steps_per_run']:,} env steps per run; at checkpoints {report['checkpoints']} the run's first "
             f"learner is placed against {report['population']} ({report['base_size']} agents) with "
             f"{report['placement_budget']} adaptive matches; {report['seconds']:,} s in this call (runs and "
             f"placements kept under `runs/` from earlier calls are read back, not redone)."
             + "".join(f" Left out: {m}, {why}." for m, why in report.get("left_out", {}).items()), "",
             "| method | IQM of final percentile [95% CI] | mean final rank |", "|---|---|---|"]
    for m in methods:
        f = report["final"][m]
        lines.append(f"| {m} | {f['iqm_final_percentile']:.1f} [{f['lower']:.1f}, {f['upper']:.1f}] | "
                     f"{f['final_rank_mean']:.1f} of {report['base_size'] + 1} |")
    lines += ["", "Probability of improvement (row beats column, final percentile):", "",
              "| | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for a in methods:
        lines.append(f"| {a} | " + " | ".join(f"{report['probability_of_improvement'][a][b]:.2f}" for b in methods)
                     + " |")
    noise = report["noise"]
    lines += ["", "Ordering noise (share of method pairs whose order flips between consecutive checkpoints; "
              "lower is a steadier signal):", "",
              f"* episode reward: {noise['episode_reward']['ordering_flips']:.2f}",
              f"* population performance (percentile): {noise['percentile']['ordering_flips']:.2f}"]
    lines += _baselines_spread_lines(report)
    lines += ["", "![curves](curves.png)", ""]
    return "\n".join(lines)


def _baselines_spread_lines(report: Mapping[str, Any]) -> list[str]:
    """The README's curve noise about each method's trend and the placements' rank half-widths."""
    noise, methods = report["noise"], report["methods"]
    if "curve_sd" not in noise["percentile"]:
        return []

    def cell(key: str, m: str) -> str:
        sd, relative = noise[key]["curve_sd"].get(m), noise[key]["curve_sd_relative"].get(m)
        return "n/a" if sd is None else f"{sd:.2f} ({relative:.2f})"

    lines = ["", f"Curve noise about each method's own trend: the SD of a run's checkpoint curve about its "
             f"{noise['curve_trend']} (interior checkpoints, pooled over seeds; in brackets, relative to the "
             "signal's range over all runs and checkpoints, so the two signals compare; lower is steadier):", "",
             "| method | percentile SD (relative) | episode reward SD (relative) |", "|---|---|---|"]
    lines += [f"| {m} | {cell('percentile', m)} | {cell('episode_reward', m)} |" for m in methods]
    rank = report["rank_half_width"]
    met = sum(rank["met"])
    lines += ["", f"Placement precision: the rank interval's half-width (median over runs) at the checkpoints "
              f"{', '.join(f'{s:,}' for s in rank['env_steps'])}: "
              f"{', '.join(f'{v:.1f}' for v in rank['median'])} places; the target of at most "
              f"{rank['target']:.0f} places is met at {met} of {len(rank['median'])} checkpoints with "
              f"{report['placement_budget']} matches (near the population's ends an interval is cut short "
              "by the last place). `benchmarks/placement_budget.py` estimates the budget that meets it."]
    return lines
