"""Base-population build: train with several schemes, play a round robin, select, rate and freeze.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) ships, for each game, 100 agents that different training schemes produce,
as the base population new agents are ranked against. :func:`build_population` makes one, as its
:class:`BuildOptions` say:

1. **train**: each scheme (``sp``, ``pbt``, ``dppo``, plus ``cc`` for team games, by default) runs
   once through :func:`arena_league.training.run_scheme`, saving every learner every
   ``steps / snapshots`` env steps, so that each run leaves a ladder of snapshots from weak
   (early) to strong (late);
2. **candidates**: every snapshot (evenly thinned per learner down to ``max_candidates``), the
   members of an earlier population (``base``: a ``base-v2`` keeps what ``base-v1`` holds) and
   built-in agents (``scripted``: search agents at several budgets or tuned heuristics, the top rungs where training
   cannot reach above the heuristic), plus the built-in ``scripted:random`` and
   ``scripted:heuristic`` agents as references;
3. **round robin**: every pair of candidates meets ``matches_per_pair`` times, seats balanced,
   on the batched match engine (torch agents of one architecture stacked into one forward);
4. **rate**: Bradley-Terry over the round robin (Elo scale);
5. **select**: ``size`` candidates spanning the rating range from just above the random agent to
   the strongest, differing in whom they beat (:mod:`arena_league.league.population.selection`);
6. **figures**: the members' ratings with bootstrap intervals (over the matches among members
   and the scripted references), the Bradley-Terry spread, the best member against the worst
   (``verify_matches`` extra matches), the best member against the heuristic (as many; the
   population's headroom, :data:`HEADROOM`), the random agent's rank, the schemes present, the
   effective diversity, each checked against the issue's criteria (:data:`CRITERIA`);
7. **freeze**: ``out_dir`` (default ``checkpoints/<game>/<name>/``) gets ``population.json``
   (readable by :func:`arena_league.league.populations.import_population`), one arena-policy
   folder per member under ``agents/``, one stacked safetensors bundle per architecture (every
   member's weights as ``[P, ...]`` tensors, :func:`load_bundles`) and a ``README.md``;
8. **register** (when a league is given): the population is imported, frozen, with its members'
   ratings, so that ``league.service.rank`` places entrants against it.

Resumable: everything lands in ``work_dir`` as it is made: a finished training run leaves its
``run.json`` (``run_scheme`` reads it back instead of training again), and the round robin is
played in chunks of ``CHUNK_MATCHES`` matches, each saved once played, under a folder named after
the candidates and the schedule. A build interrupted at any stage and started again with the same
arguments redoes only what was not saved; its report says what was reused.

Where the work runs (``backend``): training runs and round-robin chunks side by side in
``processes`` worker processes here, or each as a Ray task on a cluster (``backend="ray"``,
``ray_address``; see :mod:`.processes`). Either way the chunks are saved by this process into
``work_dir`` (the training runs save theirs where they run: on Ray, ``work_dir`` must be on storage
every node reads and writes), a build resumes from its work folder on either backend, and the same
seed gives the same population: every run and every match depends only on its seed.

Layout of a frozen population::

    population.json        name, version, game_id, provenance (build, figures, criteria), bundles, members
    README.md              provenance and figures for people
    mlp-0.safetensors      stacked bundle: tensor <param> of shape [P, ...], header metadata naming members
    agents/<member>/       manifest.json + weights.safetensors (an arena-policy folder per member)

A built-in member (a search agent) has no artifact: its entry names the agent (``kind`` ``scripted``,
``agent_metadata.scripted``) and its budget, and :func:`member_policy` loads any member.

The stages live in their own modules, this one runs them in order: :mod:`.options` (the build's
options, read by the command too), :mod:`.recipes`, :mod:`.runs` (training), :mod:`.round_robin`,
:mod:`.figures` (rating, selection and figures; the rule itself in :mod:`.selection`),
:mod:`.freeze` and :mod:`.readme`, :mod:`.loading` (a frozen population's bundles and members),
:mod:`.candidates` (an earlier population's members and built-in agents as candidates) and
:mod:`.records` (what the stages pass on).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from arena_league.league.population.candidates import (
    base_candidates,
    base_manifest,
    origin_of,
    scripted_names,
    scripted_scheme,
)
from arena_league.league.population.figures import member_records, population_figures, rate_and_select
from arena_league.league.population.freeze import (
    BUNDLE_FORMAT,
    FORMAT_VERSION,
    POPULATION_FORMAT,
    build_id_of,
    freeze,
    register,
)
from arena_league.league.population.loading import load_bundles, member_policy
from arena_league.league.population.options import STAGES, BuildOptions, BuildProgress
from arena_league.league.population.readme import population_readme
from arena_league.league.population.recipes import (
    DEFAULT_FLOOR_MARGIN,
    DEFAULT_SCHEMES,
    RECIPES,
    TEAM_SCHEMES,
    TOP_RUN_SEEDS,
    Recipe,
    default_schemes,
    recipe_for,
)
from arena_league.league.population.records import (
    CRITERIA,
    HEADROOM,
    PAIRED_CRITERIA,
    REFERENCES,
    SCRIPTED_SCHEME,
    TUNED_SCHEME,
    BuildReport,
    Candidate,
    MemberRecord,
    PopulationFigures,
    check_criteria,
    criteria_for,
    member_name,
)
from arena_league.league.population.round_robin import (
    CHUNK_MATCHES,
    Schedule,
    best_against_heuristic,
    play_seatings,
    round_robin_policies,
)
from arena_league.league.population.runs import checked_top_runs, plan_training, thin, train

__all__ = [
    "BUNDLE_FORMAT",
    "CHUNK_MATCHES",
    "CRITERIA",
    "DEFAULT_FLOOR_MARGIN",
    "DEFAULT_SCHEMES",
    "FORMAT_VERSION",
    "HEADROOM",
    "PAIRED_CRITERIA",
    "POPULATION_FORMAT",
    "RECIPES",
    "SCRIPTED_SCHEME",
    "STAGES",
    "TEAM_SCHEMES",
    "TOP_RUN_SEEDS",
    "TUNED_SCHEME",
    "BuildOptions",
    "BuildProgress",
    "BuildReport",
    "Candidate",
    "MemberRecord",
    "PopulationFigures",
    "Recipe",
    "best_against_heuristic",
    "build_population",
    "check_criteria",
    "criteria_for",
    "default_schemes",
    "load_bundles",
    "member_name",
    "member_policy",
    "play_seatings",
    "population_readme",
    "recipe_for",
]


def build_population(game_id: str, options: BuildOptions | None = None, *, league: Any = None,
                     progress: BuildProgress | None = None, log: Callable[[str], None] | None = None,
                     **fields: Any) -> BuildReport:
    """Train, rate, select and freeze a base population of ``game_id`` (see the module docstring).

    Args:
        game_id: a two-team game of :func:`arena_league.envs.list_games`.
        options: how to build (:class:`BuildOptions`: every field with its default and meaning).
        league: a :class:`arena_league.registry.League`: register the population there, frozen.
        progress: called as ``progress(stage, done, total)``.
        log: called with a line per build step.
        **fields: fields of :class:`BuildOptions` over ``options`` (``size=8, seed=3``), as the
            shipped populations' READMEs give their rebuilds.
    """
    from arena_league.envs import game_spec

    options = (options or BuildOptions()).replaced(fields)
    started = time.perf_counter()
    spec = game_spec(game_id)
    if spec.n_teams != 2:
        raise ValueError(f"{game_id} has {spec.n_teams} teams; base populations are rated by two-team matches. "
                         f"Build one for a two-team layout such as {spec.rules.name}-2T{spec.players_per_team}P-v1")
    options.check()
    recipe = recipe_for(game_id)
    schemes = list(options.schemes) if options.schemes is not None else list(default_schemes(game_id))
    top = checked_top_runs(recipe.top_runs if options.top_runs is None else options.top_runs)
    base = options.base
    if (not schemes and base is None and not options.scripted and not top) or len(set(schemes)) != len(schemes):
        raise ValueError(f"schemes must be distinct scheme names (none only with a base, scripted members or top runs), "
                         f"got {schemes!r}")
    manifest = base_manifest(Path(base), game_id) if base is not None else None
    scripted = scripted_names(game_id, options.scripted)
    if options.retire and manifest is None:
        raise ValueError("retire names members of a base population; give the base too (--base FOLDER, e.g. "
                         "checkpoints/<game>/base-v1)")
    extra = base_candidates(Path(base), manifest, options.retire) if manifest is not None and base is not None else []
    extra += [Candidate(n, scripted_scheme(n), 0, 0, n, None, {}, None, n) for n in scripted]
    plan = plan_training(game_id, options, recipe, schemes, top)
    name = options.name
    work = Path(options.work_dir) if options.work_dir is not None else Path("runs") / "population" / game_id / name
    out = Path(options.out_dir) if options.out_dir is not None else Path("checkpoints") / game_id / name
    say = log or (lambda line: None)
    report = BuildReport(game_id=game_id, name=name, out_dir=None, work_dir=str(work), schemes=schemes,
                         steps_per_scheme=plan.steps, seed=options.seed, candidates=0, members=[], figures=None,
                         criteria={}, passed=False, trained=[], reused_runs=[], matches_played=0, matches_reused=0,
                         stage="")
    work.mkdir(parents=True, exist_ok=True)

    # 1. train every run (a finished run is read back)
    clock = time.perf_counter()
    snapshots = train(game_id, plan, options.seed, work, options.processes, report, progress, say, options.backend,
                      options.ray_address)
    if _stage_done(report, "train", clock, options):
        return report

    # 2-3. candidates and the round robin
    clock = time.perf_counter()
    candidates = thin(snapshots, options.max_candidates)
    clash = sorted({c.key for c in candidates} & {c.key for c in extra})
    if clash:
        raise ValueError(f"trained snapshots and the base's members share keys ({', '.join(clash[:3])}); train "
                         "with another seed or build from another base")
    candidates += extra
    report.candidates = len(candidates)
    if len(candidates) < options.size:
        say(f"only {len(candidates)} snapshots for {options.size} members: every candidate will be a member; "
            "train longer or take more snapshots for a choice")
    keys = [c.key for c in candidates] + list(REFERENCES)
    schedule = Schedule(game_id, keys, options.matches_per_pair, options.seed)
    policies = round_robin_policies(game_id, candidates)
    table = schedule.play(work, policies, options.batch_size, report, progress, say, processes=options.processes,
                          candidates=candidates, backend=options.backend, address=options.ray_address)
    if _stage_done(report, "round_robin", clock, options):
        return report

    # 4-5. rate and select
    clock = time.perf_counter()
    margin = float(recipe.floor_margin if options.floor_margin is None else options.floor_margin)
    selection = rate_and_select(table, keys, len(candidates), options.size, margin, say)
    report.seconds["select"] = round(time.perf_counter() - clock, 1)

    # 6. figures over the members and the references
    clock = time.perf_counter()
    members = [candidates[i] for i in selection.chosen]
    figures, member_ratings = population_figures(game_id, members, keys, selection.counts, policies, options.seed,
                                                 options.bootstrap_rounds, options.verify_matches, options.batch_size,
                                                 work, schedule.digest, report)
    report.figures = figures
    report.criteria = check_criteria(figures, game_id)
    report.passed = all(report.criteria.values())
    say(f"figures: spread {figures.spread:.0f} Elo, best beats worst {figures.best_vs_worst_win_rate:.3f}, "
        f"random rank {figures.random_rank}/{figures.size + 1}, schemes {figures.schemes}; "
        f"criteria {'met' if report.passed else 'NOT met'}: {report.criteria}")
    report.members = member_records(name, game_id, members, member_ratings)
    report.seconds["figures"] = round(time.perf_counter() - clock, 1)
    report.stage = "select"
    if options.stop_after == "select":
        return report

    # 7. freeze
    clock = time.perf_counter()
    warm_build = plan.warm_build()
    origin = origin_of(base, manifest, scripted, top, options.retire)
    build_id = build_id_of(game_id, name, schemes, plan.steps, options.seed, plan.snapshots, options.size,
                           options.matches_per_pair, schedule.digest, plan.runs_per_scheme, warm_build, origin, margin)
    freeze(out, report, members, build_id, options, recipe, plan, origin, margin)
    report.out_dir = str(out)
    report.seconds["freeze"] = round(time.perf_counter() - clock, 1)
    report.stage = "freeze"
    say(f"froze {len(members)} members in {out}")
    if options.stop_after == "freeze" or league is None:
        report.seconds["total"] = round(time.perf_counter() - started, 1)
        return report

    # 8. register
    report.population = register(league, out, name, [m.name for m in report.members])
    report.stage = "register"
    say(f"registered {report.population} (frozen)")
    report.seconds["total"] = round(time.perf_counter() - started, 1)
    return report


def _stage_done(report: BuildReport, stage: str, clock: float, options: BuildOptions) -> bool:
    """Record ``stage`` as done, with its seconds; whether the build stops after it."""
    report.seconds[stage] = round(time.perf_counter() - clock, 1)
    report.stage = stage
    return options.stop_after == stage
