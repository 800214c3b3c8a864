"""The ``arena-league`` command: a thin layer over the library.

Every command that prints results takes ``--json`` (one JSON document on stdout; progress and logs
on stderr). Tables and progress bars are drawn with rich when stderr/stdout is a terminal.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

stdout = Console()
if not stdout.is_terminal:  # piped or captured: no terminal width to fit, keep rows readable
    stdout = Console(width=160)
stderr = Console(stderr=True)


class CommandError(Exception):
    """A user-facing failure: printed as one line naming the problem and the fix, exit code 2."""


def emit_json(document: Any) -> None:
    sys.stdout.write(json.dumps(document, indent=2, sort_keys=False, default=_json_default) + "\n")
    sys.stdout.flush()


def _json_default(value: Any) -> Any:
    import numpy as np

    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} as JSON")


@contextmanager
def progress_bar(description: str, total: int) -> Iterator[Callable[[int, int], None]]:
    """A rich progress bar on stderr when it is a terminal; a no-op otherwise."""
    if not stderr.is_terminal:
        yield lambda done, total_: None
        return
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=stderr, transient=True) as bar:
        task = bar.add_task(description, total=total)
        yield lambda done, total_: bar.update(task, completed=done, total=total_)


# --- commands ------------------------------------------------------------------------------------

def cmd_games(args: argparse.Namespace) -> int:
    from arena_league.league import game_rows

    rows = game_rows()
    if args.json:
        emit_json({"games": rows})
        return 0
    table = Table(title="arena-league games")
    for column in ("game id", "teams x players", "actions", "obs", "default social tree"):
        table.add_column(column)
    for row in rows:
        table.add_row(row["game_id"], f"{row['teams']} x {row['players_per_team']}",
                      "/".join(row["action_types"]) + (" (turns)" if row["turn_based"] else ""),
                      str(row["obs_dim"]), escape(tree_outline(row["default_tree"])))
    stdout.print(table)
    return 0


def tree_outline(spec: Any) -> str:
    """A one-line outline of a tree spec: ``CP:ranking x100 [NL:none [IS:target, IS:target], ...]``."""
    if isinstance(spec, str):
        return spec
    if "agent" in spec and "scheme" not in spec:
        return str(spec["agent"])
    scale = spec.get("scale", 1)
    head = f"{spec.get('scheme')}:{spec.get('reward', 'none')}" + (f" x{scale:g}" if scale != 1 else "")
    children = spec.get("children")
    if not children:
        return head
    inner = [tree_outline(c) for c in children]
    if len(set(inner)) == 1 and len(inner) > 2:
        return f"{head} [{len(inner)} x {inner[0]}]"
    return f"{head} [{', '.join(inner)}]"


def cmd_verify(args: argparse.Namespace) -> int:
    from arena_league.league import verify_social_tree

    with progress_bar(f"verifying {args.game}", args.samples) as update:
        report = verify_social_tree(args.game, tree=args.tree, samples=args.samples, seed=args.seed,
                        max_cycles=args.max_cycles, action_type=args.action_type, progress=update)
    if args.json:
        emit_json(report.to_dict())
    else:
        table = Table(title=f"social tree of {args.game}: {args.samples} paired samples, seed {args.seed}")
        for column in ("node", "reward", "declared", "verified", "learnable", "child signs (slope)"):
            table.add_column(column)
        for node in report.nodes:
            signs = ", ".join(f"{k}:{v['slope']:+.2f}" for k, v in node.child_signs.items()) or "-"
            status = f"[green]{node.verified}[/]" if node.ok else f"[bold red]{node.verified}[/]"
            table.add_row(node.path, node.reward, node.declared, status, f"{node.learnable_share:.0%}", signs)
        stdout.print(table)
        stdout.print("[green]every node verifies as declared[/]" if report.ok
                     else "[bold red]some nodes do not behave as their declared scheme[/]")
    return 0 if report.ok else 1



# --- league commands -----------------------------------------------------------------------------

def _league(args: argparse.Namespace):
    from arena_league.league import open_home

    return open_home(args.home, args.db)


def _print_record(title: str, record: dict[str, Any], keys: list[str] | None = None) -> None:
    table = Table(title=title, show_header=False)
    table.add_column("field", style="bold")
    table.add_column("value")
    for key in keys or list(record):
        value = record.get(key)
        if isinstance(value, float):
            value = f"{value:.4g}"
        table.add_row(key, str(value))
    stdout.print(table)


def cmd_submit(args: argparse.Namespace) -> int:
    from arena_league.league import submit

    with _league(args) as league:
        result = submit(league, args.path, args.game, args.name, owner=args.owner)
    if args.json:
        emit_json(result.to_dict())
    else:
        colour = "green" if result.status == "active" else "bold red"
        note = "registered" if result.created else "already registered (same bytes)"
        stdout.print(f"[{colour}]{result.agent}: {result.status}[/] ({note}, sha256 {result.digest[:12]}, "
                     f"{result.seconds:.1f} s)")
        if result.reason:
            stdout.print(f"reason: {result.reason}")
    return 0 if result.status == "active" else 1


def cmd_rank(args: argparse.Namespace) -> int:
    from arena_league.league import rank

    with _league(args) as league, progress_bar(f"ranking {args.agent}", args.budget) as update:
        report = rank(league, args.agent, budget=args.budget, population=args.population, seed=args.seed,
                      target_half_width=args.half_width, backend=args.backend, progress=update)
    if args.json:
        emit_json(report.to_dict())
        return 0
    level = round(report.level * 100)
    stdout.print(f"[bold]{report.agent}[/] on {report.game_id} against {report.base} ({report.base_size} agents), "
                 f"{report.matches} matches:")
    stdout.print(f"  rating      {report.rating:.0f}  ({level}% CI {report.lower:.0f} .. {report.upper:.0f})")
    stdout.print(f"  rank        {report.rank} of {report.base_size + 1}  ({level}% interval {report.rank_best} .. "
                 f"{report.rank_worst})")
    stdout.print(f"  percentile  {report.percentile:.1f}  ({report.percentile_lower:.1f} .. "
                 f"{report.percentile_upper:.1f})")
    stdout.print(f"  Nash score  {report.nash_score:+.3f}  (mass {report.nash_mass:.3f})")
    return 0


def cmd_leaderboard(args: argparse.Namespace) -> int:
    from arena_league.league import leaderboard, render_terminal, write_html_report

    with _league(args) as league:
        board = leaderboard(league, args.game, args.method, population=args.population, rounds=args.rounds,
                            seed=args.seed)
    if args.html:
        write_html_report(board, args.html)
        stderr.print(f"wrote {args.html}")
    if args.json:
        emit_json(board.to_dict())
    else:
        stdout.print(render_terminal(board))
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    from arena_league.league import evaluate, queue_evaluation

    with _league(args) as league:
        if args.queue:
            job_id = queue_evaluation(league, args.game, args.agents, matches_per_pair=args.matches_per_pair,
                                      seed=args.seed, backend=args.backend, workers=args.workers, record=args.record)
            if args.json:
                emit_json({"queued": job_id})
            else:
                stdout.print(f"queued evaluation job {job_id}; run `arena-league worker` to play it")
            return 0
        with progress_bar(f"evaluating {args.game}", 1) as update:
            report = evaluate(league, args.game, args.agents, matches_per_pair=args.matches_per_pair, seed=args.seed,
                              backend=args.backend, workers=args.workers, record=args.record, progress=update)
    if args.json:
        emit_json(report.to_dict())
    else:
        rate = report.played / report.seconds if report.seconds else float("nan")
        stdout.print(f"{report.game_id}: played {report.played} matches ({report.stored} new) among "
                     f"{len(report.agents)} agents in {report.seconds:.1f} s ({rate:.0f} matches/s, "
                     f"{report.steps} env steps)")
    return 0


def cmd_matches(args: argparse.Namespace) -> int:
    from arena_league.league import recent_matches

    with _league(args) as league:
        matches = recent_matches(league, args.game, agent=args.agent, limit=args.limit)
    if args.json:
        emit_json({"game_id": args.game, "matches": matches})
        return 0
    table = Table(title=f"last {len(matches)} matches of {args.game}")
    for column in ("match", "seed", "result", "replay"):
        table.add_column(column)
    for m in matches:
        teams: dict[int, list[str]] = {}
        for seat in m["seats"]:
            teams.setdefault(seat["team"], [])
            if seat["agent"] not in teams[seat["team"]]:
                teams[seat["team"]].append(f"{seat['agent']} ({seat['outcome']})")
        table.add_row(m["match_key"], str(m["seed"])[:10], " vs ".join("+".join(v) for v in teams.values()),
                      m["replay"] or "")
    stdout.print(table)
    return 0


def cmd_worker(args: argparse.Namespace) -> int:
    import logging

    from arena_league.league import run_worker

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s", stream=sys.stderr)
    with _league(args) as league:
        summary = run_worker(league, worker_id=args.worker_id, lease_seconds=args.lease, poll_seconds=args.poll,
                             max_jobs=args.max_jobs, until_idle=args.until_idle)
    if args.json:
        emit_json(summary.to_dict())
    else:
        stderr.print(f"worker stopped: {summary.to_dict()}")
    return 0 if summary.failed == 0 else 1


def cmd_schedule(args: argparse.Namespace) -> int:
    from arena_league.league import add_evaluation_schedule, list_schedules, remove_schedule

    with _league(args) as league:
        if args.action == "add":
            row = add_evaluation_schedule(league, args.name, args.game, every=args.every, cron=args.cron,
                                          matches_per_pair=args.matches_per_pair, seed=args.seed,
                                          backend=args.backend)
            if args.json:
                emit_json(row)
            else:
                stdout.print(f"schedule {row['name']}: evaluate {args.game}, next run {row['next_run_at']}")
            return 0
        if args.action == "remove":
            remove_schedule(league, args.name)
            if args.json:
                emit_json({"removed": args.name})
            return 0
        rows = list_schedules(league)
    if args.json:
        emit_json({"schedules": rows})
    else:
        table = Table(title="schedules")
        for column in ("name", "kind", "game", "every / cron", "next run", "enabled"):
            table.add_column(column)
        for r in rows:
            table.add_row(r["name"], r["kind"], str(r["payload"].get("game_id")),
                          f"{r['interval_seconds']} s" if r["interval_seconds"] else str(r["cron"]),
                          r["next_run_at"], str(r["enabled"]))
        stdout.print(table)
    return 0


def cmd_scheduler(args: argparse.Namespace) -> int:
    from arena_league.league import run_scheduler, tick

    with _league(args) as league:
        if args.action == "tick":
            jobs = tick(league)
            if args.json:
                emit_json({"queued": jobs})
            else:
                stdout.print(f"queued {len(jobs)} job(s): {jobs}")
            return 0
        ticks = run_scheduler(league, poll_seconds=args.poll, max_ticks=args.max_ticks)
    if args.json:
        emit_json({"ticks": ticks})
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    from arena_league.league import replay_summary

    document = replay_summary(args.file, gif=args.gif, fps=args.fps, every=args.every)
    if args.gif:
        stderr.print(f"wrote {args.gif} ({document['gif']['frames']} frames)")
    if args.json:
        emit_json(document)
    else:
        _print_record(f"replay {args.file}", {k: v for k, v in document.items() if not isinstance(v, (dict, list))})
    return 0


def cmd_population(args: argparse.Namespace) -> int:
    from arena_league.league import export_population, import_population, list_populations

    with _league(args) as league:
        if args.action == "build":
            return _build_population(args, league)
        if args.action == "import":
            label = import_population(league, _required(args.target, "the population folder"), name=args.name)
            if args.json:
                emit_json({"imported": label})
            else:
                stdout.print(f"imported population {label}")
            return 0
        if args.action == "export":
            path = export_population(league, _required(args.population, "--population NAME[:VERSION]"),
                                     _required(args.destination, "--destination FOLDER"))
            if args.json:
                emit_json({"exported": args.population, "path": str(path)})
            else:
                stdout.print(f"exported {args.population} to {path}")
            return 0
        rows = list_populations(league, args.game)
    if args.json:
        emit_json({"populations": rows})
    else:
        table = Table(title="populations")
        for column in ("population", "game", "members", "frozen"):
            table.add_column(column)
        for r in rows:
            table.add_row(f"{r['name']}:{r['version']}", r["game_id"], str(r["members"]), str(r["frozen"]))
        stdout.print(table)
    return 0


def _required(value: Any, what: str) -> Any:
    if value is None:
        raise CommandError(f"this command needs {what}")
    return value


def _build_population(args: argparse.Namespace, league) -> int:
    from arena_league.league.population.build import build_population

    game = _required(args.target, "a game id, e.g. `arena-league population build Soccer-2T2P-v1`")

    def log(line: str) -> None:
        stderr.print(line, highlight=False)

    report = build_population(game, size=args.size, name=args.name or "base-v1", schemes=args.schemes,
                              steps_per_scheme=args.steps, runs_per_scheme=args.runs,
                              warm_runs_per_scheme=args.warm_runs, seed=args.seed, work_dir=args.work_dir,
                              out_dir=args.out_dir, league=league, log=log)
    document = report.to_dict()
    if args.json:
        emit_json(document)
    else:
        _print_record(f"population {document.get('name', args.name)} of {game}",
                      {k: v for k, v in document.items() if not isinstance(v, (dict, list))})
    return 0


def cmd_play(args: argparse.Namespace) -> int:
    from arena_league.league.human import play_human

    with _league(args) as league:
        session = play_human(args.game, args.against, league, player=args.player, seed=args.seed,
                             matches=args.matches, picture_dir=args.pictures)
    if args.json:
        emit_json(session.to_dict() if hasattr(session, "to_dict") else {"player": args.player})
    return 0


def cmd_quickstart(args: argparse.Namespace) -> int:
    """A whole league on the embedded default (see :mod:`arena_league.league.quickstart`)."""
    from arena_league.league import quickstart, render_terminal

    def log(line: str) -> None:
        stderr.print(line, highlight=False)

    with _league(args) as league, ExitStack() as bars:

        def stage_progress(stage: str, total: int) -> Callable[[int, int], None]:
            bars.close()  # one live bar at a time: the last stage's ends here
            return bars.enter_context(progress_bar(stage, total))

        report = quickstart(league, args.game, matches_per_pair=args.matches_per_pair, budget=args.budget,
                            seed=args.seed, base=args.base, log=log, stage_progress=stage_progress)
    if args.json:
        emit_json(report.to_dict())
        return 0
    ranked, board = report.ranked, report.board
    if ranked:
        stdout.print(f"[bold]{ranked.agent}[/] against {ranked.base} ({ranked.base_size} agents, {ranked.matches} "
                     f"matches): rating {ranked.rating:.0f} ({ranked.lower:.0f} .. {ranked.upper:.0f}), "
                     f"rank {ranked.rank} ({ranked.rank_best}..{ranked.rank_worst}) of {ranked.base_size + 1}, "
                     f"percentile {ranked.percentile:.0f} ({ranked.percentile_lower:.0f} .. "
                     f"{ranked.percentile_upper:.0f}), Nash score {ranked.nash_score:+.2f}")
    unrated = len(board.rows) - len(board.rated_rows)
    stdout.print(render_terminal(dataclasses.replace(board, rows=board.rated_rows)))
    if unrated:
        stdout.print(f"({unrated} agents without matches in this league are not shown: base members keep the "
                     "ratings of their build in the population manifest; `arena-league leaderboard` lists all)")
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    from arena_league.league.train import train_entrant

    def log(line: str) -> None:
        if not args.json:
            stderr.print(line, highlight=False)

    report = train_entrant(args.game, args.scheme, steps=args.steps, seed=args.seed, report_dir=args.report,
                           eval_every=args.eval_every, eval_matches=args.eval_matches, reference=args.reference,
                           snapshot_every=args.snapshot_every, out_dir=args.out, warm_start_steps=args.warm_start,
                           hidden=args.hidden, log=log)
    document = report.as_dict()
    if args.json:
        emit_json(document)
        return 0
    last = report.evaluations[-1] if report.evaluations else {}
    stdout.print(f"{args.scheme} on {args.game}: {args.steps} env steps, {len(report.snapshots)} snapshot(s); "
                 f"population performance {last.get('population_performance', float('nan')):.3f}")
    for name, path in report.plots.items():
        stdout.print(f"  {name}: {path}")
    for snapshot in report.snapshots[-3:]:
        stdout.print(f"  snapshot {snapshot.name}: {snapshot.path} (submit it with `arena-league submit`)")
    return 0


# --- parser --------------------------------------------------------------------------------------

def _league_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--home", default=None, help="league home (default: $ARENA_LEAGUE_HOME or ~/.arena-league)")
    p.add_argument("--db", default=None, help="SQLAlchemy URL of the registry (default: $ARENA_LEAGUE_DB or "
                                              "the home's league.db)")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")

def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="arena-league", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("games", help="the game set, with default social trees")
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(func=cmd_games)

    p = sub.add_parser("verify", help="verify every node of a game's social tree by paired sampling")
    p.add_argument("game", help="game id, e.g. Crossroads-2T2P-v1 (see `arena-league games`)")
    p.add_argument("--tree", help="a social tree spec file (YAML or JSON); default: the game's own")
    p.add_argument("--samples", type=_positive_int, default=64, help="paired episodes (default 64)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-cycles", type=_positive_int, default=None)
    p.add_argument("--action-type", choices=("discrete", "continuous"), default=None)
    p.add_argument("--json", action="store_true", help="one JSON document on stdout")
    p.set_defaults(func=cmd_verify)

    p = sub.add_parser("submit", help="validate an agent (ONNX file or arena-policy folder) and register it")
    p.add_argument("path")
    p.add_argument("--game", required=True)
    p.add_argument("--name", required=True)
    p.add_argument("--owner", default=None)
    _league_options(p)
    p.set_defaults(func=cmd_submit)

    p = sub.add_parser("rank", help="place an agent against its game's base population")
    p.add_argument("agent")
    p.add_argument("--budget", type=_positive_int, default=200, help="at most this many matches (default 200)")
    p.add_argument("--population", default=None, help="base population NAME[:VERSION] (default: all active agents)")
    p.add_argument("--half-width", type=float, default=3.0, help="stop at this rank-interval half-width (places)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--backend", choices=("inprocess", "process", "ray"), default="inprocess")
    _league_options(p)
    p.set_defaults(func=cmd_rank)

    p = sub.add_parser("leaderboard", help="ratings of a game's agents from the stored matches")
    p.add_argument("game")
    p.add_argument("--method", choices=("bt", "elo", "openskill", "nash", "alpharank"), default="bt")
    p.add_argument("--population", default=None)
    p.add_argument("--rounds", type=_positive_int, default=100, help="bootstrap rounds (default 100)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--html", default=None, help="also write a self-contained HTML report here")
    _league_options(p)
    p.set_defaults(func=cmd_leaderboard)

    p = sub.add_parser("evaluate", help="round robin among a game's agents (fills its payoff table)")
    p.add_argument("game")
    p.add_argument("--agents", nargs="+", default=None, help="agent names (default: every active agent)")
    p.add_argument("--matches-per-pair", type=_positive_int, default=10)
    p.add_argument("--seed", type=int, default=0, help="league seed of the matches' seeds")
    p.add_argument("--backend", choices=("inprocess", "process", "ray"), default="inprocess")
    p.add_argument("--workers", type=_positive_int, default=None)
    p.add_argument("--record", action="store_true", help="write one MCAP replay per match under the home")
    p.add_argument("--queue", action="store_true", help="queue the job for `arena-league worker` instead")
    _league_options(p)
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("matches", help="the latest stored matches of a game")
    p.add_argument("game")
    p.add_argument("--agent", default=None)
    p.add_argument("--limit", type=_positive_int, default=20)
    _league_options(p)
    p.set_defaults(func=cmd_matches)

    p = sub.add_parser("worker", help="run queued and scheduled jobs")
    p.add_argument("--worker-id", default=None)
    p.add_argument("--lease", type=float, default=60.0, help="lease seconds (a crashed worker's job is retried after)")
    p.add_argument("--poll", type=float, default=1.0)
    p.add_argument("--max-jobs", type=_positive_int, default=None)
    p.add_argument("--until-idle", action="store_true", help="stop when the queue is empty")
    _league_options(p)
    p.set_defaults(func=cmd_worker)

    p = sub.add_parser("schedule", help="recurring evaluations: add, list, remove")
    p.add_argument("action", choices=("add", "list", "remove"))
    p.add_argument("name", nargs="?", default=None)
    p.add_argument("--game", default=None)
    p.add_argument("--every", type=_positive_int, default=None, help="interval in seconds")
    p.add_argument("--cron", default=None, help="cron expression, 5 fields, UTC")
    p.add_argument("--matches-per-pair", type=_positive_int, default=10)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--backend", choices=("inprocess", "process", "ray"), default="inprocess")
    _league_options(p)
    p.set_defaults(func=cmd_schedule)

    p = sub.add_parser("scheduler", help="queue due scheduled jobs: run (a loop) or tick (once, for cron)")
    p.add_argument("action", choices=("run", "tick"))
    p.add_argument("--poll", type=float, default=30.0)
    p.add_argument("--max-ticks", type=_positive_int, default=None)
    _league_options(p)
    p.set_defaults(func=cmd_scheduler)

    p = sub.add_parser("replay", help="summarise an MCAP match replay; export a GIF of its top-down view")
    p.add_argument("file")
    p.add_argument("--gif", default=None)
    p.add_argument("--fps", type=float, default=10.0)
    p.add_argument("--every", type=_positive_int, default=1, help="keep one frame in N")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_replay)

    p = sub.add_parser("population", help="populations: list, build GAME, import FOLDER, export")
    p.add_argument("action", choices=("list", "build", "import", "export"))
    p.add_argument("target", nargs="?", default=None, help="build: the game id; import: the population folder")
    p.add_argument("--game", default=None, help="list: only this game's populations")
    p.add_argument("--name", default=None, help="build / import: the population's name (default base-v1)")
    p.add_argument("--size", type=_positive_int, default=100, help="build: members (default 100)")
    p.add_argument("--schemes", nargs="+", default=None, help="build: training schemes (default per game)")
    p.add_argument("--steps", type=_positive_int, default=None, help="build: env steps per scheme run")
    p.add_argument("--runs", type=_positive_int, default=1, help="build: runs (seeds) of each scheme from scratch")
    p.add_argument("--warm-runs", type=_non_negative_int, default=None,
                   help="build: more runs of each scheme that first imitate the game's heuristic (default per game)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--work-dir", default=None, help="build: runs and matches (a rerun resumes from here)")
    p.add_argument("--out-dir", default=None, help="build: the frozen population (default checkpoints/GAME/NAME)")
    p.add_argument("--population", default=None, help="export: NAME[:VERSION]")
    p.add_argument("--destination", default=None, help="export: a new folder")
    _league_options(p)
    p.set_defaults(func=cmd_population)

    p = sub.add_parser("play", help="play against a base population in the terminal (human ranking)")
    p.add_argument("game")
    p.add_argument("--against", default="base-v1", help="the base population NAME[:VERSION]")
    p.add_argument("--player", default="human", help="your name; your results are kept as <name>@GAME")
    p.add_argument("--matches", type=_positive_int, default=None, help="stop after this many matches")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--pictures", default=None, help="physics games: save the top-down picture of each step here")
    _league_options(p)
    p.set_defaults(func=cmd_play)

    p = sub.add_parser("train", help="train agents with a scheme (ppo, dppo, sp, pbt, cc, cf); plot the curves")
    p.add_argument("game")
    p.add_argument("--scheme", default="sp", help="ppo, dppo, sp, pbt, cc or cf (default sp)")
    p.add_argument("--steps", type=_positive_int, default=100_000, help="env steps (default 100000)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--report", default=None, help="write episode_reward.png, population_performance.png and "
                                                  "curves.json here")
    p.add_argument("--eval-every", type=_positive_int, default=10, help="iterations between evaluations")
    p.add_argument("--eval-matches", type=_positive_int, default=20, help="matches per reference agent")
    p.add_argument("--reference", nargs="+", default=None,
                   help="the fixed reference population (default scripted:random scripted:heuristic)")
    p.add_argument("--snapshot-every", type=_positive_int, default=None, help="env steps between snapshots")
    p.add_argument("--out", default=None, help="where snapshots (arena-policy folders) go")
    p.add_argument("--warm-start", type=_positive_int, default=None, metavar="STEPS",
                   help="first imitate the game's heuristic (DAgger) for this many env steps")
    p.add_argument("--hidden", type=_positive_int, nargs="+", default=None, help="actor hidden widths (default 64 64)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("quickstart", help="a league end to end: agents, round robin, ranking, leaderboard")
    p.add_argument("--game", default="Crossroads-2T2P-v1")
    p.add_argument("--matches-per-pair", type=_positive_int, default=10)
    p.add_argument("--budget", type=_positive_int, default=40)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-base", dest="base", action="store_false",
                   help="leave the game's shipped base population out (scripted agents only)")
    _league_options(p)
    p.set_defaults(func=cmd_quickstart)
    return parser


def _user_errors() -> tuple[type[BaseException], ...]:
    """Exceptions that describe the user's input (with the fix): printed as one line, exit 2."""
    from arena_league.league import USER_ERRORS

    return (CommandError, *USER_ERRORS)


def _int_at_least(minimum: int, requirement: str) -> Callable[[str], int]:
    """An argparse type: an integer of at least ``minimum``, refused as ``must be <requirement>``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be {requirement}, not {value}")
        return value

    return parse


_positive_int = _int_at_least(1, "a positive integer")
_non_negative_int = _int_at_least(0, "0 or more")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except _user_errors() as exc:
        message = str(exc)
        if getattr(args, "json", False):
            emit_json({"error": message, "kind": type(exc).__name__})
        stderr.print(f"[bold red]error:[/] {message}", highlight=False)
        return 2


if __name__ == "__main__":
    sys.exit(main())
