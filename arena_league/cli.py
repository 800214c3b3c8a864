"""The ``arena-league`` command: a thin layer over the library.

Every command that prints results takes ``--json`` (one JSON document on stdout; progress and logs
on stderr). Tables and progress bars are drawn with rich when stderr/stdout is a terminal.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

stdout = Console()
if not stdout.is_terminal and not os.environ.get("COLUMNS", "").isdigit():
    stdout = Console(width=160)  # piped or captured, no width given (COLUMNS): keep rows readable
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
    from arena_league.league import check_game, game_manual, game_rows, option_line

    wanted = None if args.game is None else check_game(args.game)
    rows = [row for row in game_rows() if wanted in (None, row["game_id"])]
    if wanted:
        rows[0]["manual"] = game_manual(wanted)
    if args.json:
        emit_json({"games": rows})
        return 0
    _print_table("arena-league games", ("game id", "teams x players", "actions", "obs", "default social tree"),
                 [(row["game_id"], f"{row['teams']} x {row['players_per_team']}",
                   "/".join(row["action_types"]) + (" (turns)" if row["turn_based"] else ""),
                   str(row["obs_dim"]), escape(tree_outline(row["default_tree"]))) for row in rows],
                 caption=None if wanted else "a game's options: arena-league games GAME_ID")
    if wanted:
        row = rows[0]
        stdout.print(f"{escape(row['summary'])}.", highlight=False)
        if row["options"]:
            stdout.print("Options (make(game_id, **options)):", highlight=False)
            for record in row["options"]:
                stdout.print(f"  {escape(option_line(record))}", highlight=False, soft_wrap=True)
        else:
            stdout.print("Options: none beyond the layout and action type.", highlight=False)
        stdout.print("", highlight=False)
        stdout.print(escape(row["manual"]), highlight=False, soft_wrap=True)
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

def _log(line: str) -> None:
    """What a command is about to do, for a person: on stderr, so that --json stays one document."""
    stderr.print(line, highlight=False, soft_wrap=True)


def _league(args: argparse.Namespace):
    from arena_league.league import open_home

    return open_home(args.home, args.db)


def _print_table(title: str, columns: tuple[str, ...], rows: list[tuple[str, ...]], caption: str | None = None
                 ) -> None:
    """A table of text cells on stdout; long cells fold rather than being cut."""
    table = Table(title=title, caption=caption)
    for column in columns:
        table.add_column(column, overflow="fold")
    for row in rows:
        table.add_row(*row)
    stdout.print(table)


def _print_record(title: str, record: dict[str, Any], keys: list[str] | None = None) -> None:
    table = Table(title=title, show_header=False)
    table.add_column("field", style="bold")
    table.add_column("value", overflow="fold")
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
        stdout.print(f"[{colour}]{result.agent}: {result.status}[/] ({escape(result.note)}, sha256 "
                     f"{result.digest[:12]}, {result.seconds:.1f} s)")
    if result.reason:
        stderr.print(f"[bold red]rejected:[/] {escape(result.reason)}; the validation log: "
                     f"`arena-league agent {result.agent}`", highlight=False)
    return 0 if result.status == "active" else 1


def cmd_rank(args: argparse.Namespace) -> int:
    from arena_league.league import LEAGUE_WIDE, describe_population, rank, resolve_agent

    if args.league_wide and args.population:
        raise CommandError("give --population NAME or --league-wide, not both")
    if (args.agent is None) == (args.members is None):
        raise CommandError("give one agent to rank, or --members NAME_OR_PATH ... for a population's averaged "
                           "ranking, not both")
    population = LEAGUE_WIDE if args.league_wide else args.population
    if args.members is not None and args.more is not None:
        raise CommandError("--more continues one agent's placement; leave it out with --members")
    if args.members is not None:
        return _rank_members(args, population)
    with _league(args) as league, progress_bar(f"ranking {args.agent}", args.more or args.budget) as update:
        report = rank(league, resolve_agent(league, args.agent, args.game), budget=args.budget,
                      population=population, seed=args.seed, target_half_width=args.half_width,
                      backend=args.backend, more=args.more, progress=update, log=_log)
        against = describe_population(league, report.game_id, report.base) if population != LEAGUE_WIDE else \
            f"{report.base} ({report.base_size} agents)"
    if args.json:
        emit_json(report.to_dict())
        return 0
    level = round(report.level * 100)
    seeds = ", ".join(report.seeds) or str(args.seed)
    stdout.print(f"[bold]{report.agent}[/] on {report.game_id} against {escape(against)}, {report.matches} "
                 f"{report.unit}:")
    if report.stored:
        stdout.print(f"  from the stored placement (job {report.job_id}, seed{'s' if len(report.seeds) > 1 else ''} "
                     f"{seeds}); --more N or another --seed to add evidence", highlight=False)
    elif report.played != report.matches:
        stdout.print(f"  {report.played} played now under seed {args.seed}, continuing the stored placement (seeds "
                     f"{seeds})", highlight=False)
    stdout.print(f"  rating      {report.rating:.0f}  ({level}% CI {report.lower:.0f} .. {report.upper:.0f})")
    stdout.print(f"  rank        {report.rank} of {report.base_size + 1}  ({level}% interval {report.rank_lower} .. "
                 f"{report.rank_upper})")
    stdout.print(f"  percentile  {report.percentile:.1f}  ({report.percentile_lower:.1f} .. "
                 f"{report.percentile_upper:.1f})")
    stdout.print(f"  Nash score  {report.nash_score:+.3f}  (mass {report.nash_mass:.3f})")
    if report.stop_reason:
        stdout.print(f"  stopped     {escape(report.stop_reason)}", highlight=False)
    if report.forfeits:
        stdout.print(f"  forfeits    {report.forfeits} (losses: its calls failed in the inference sandbox)")
    if report.suspended:
        stderr.print(f"[bold red]suspended:[/] {escape(report.suspended)}; see `arena-league agent {report.agent}`",
                     highlight=False)
    return 0


def _rank_members(args: argparse.Namespace, population: str | None) -> int:
    from arena_league.league.members import rank_members

    with _league(args) as league, progress_bar("ranking the members", args.budget) as update:
        report = rank_members(league, args.members, game_id=args.game, budget=args.budget, population=population,
                              seed=args.seed, target_half_width=args.half_width, backend=args.backend,
                              progress=update, log=_log)
    if args.json:
        emit_json(report.to_dict())
        return 0
    n = report.base_size + 1
    stdout.print(f"{len(report.members)} members on {report.game_id} against {report.base} ({report.base_size} "
                 f"agents), {report.matches} matches:")
    for row in report.members:
        stdout.print(f"  {row['agent']:<40} rank {row['rank']:>3} of {n} ({row['rank_lower']} .. {row['rank_upper']}), "
                     f"percentile {row['percentile']:.1f}", highlight=False)
    level = round(report.level * 100)
    stdout.print(f"  mean rank        {report.mean_rank:.1f} of {n}  ({level}% interval over members "
                 f"{report.mean_rank_lower:.1f} .. {report.mean_rank_upper:.1f})")
    stdout.print(f"  mean percentile  {report.mean_percentile:.1f}  ({report.mean_percentile_lower:.1f} .. "
                 f"{report.mean_percentile_upper:.1f})")
    return 0


def cmd_leaderboard(args: argparse.Namespace) -> int:
    from arena_league.league import leaderboard, render_terminal, write_html_report

    with _league(args) as league:
        board = leaderboard(league, args.game, args.method, population=args.population, rounds=args.rounds,
                            seed=args.seed, log=_log)
    if args.html:
        write_html_report(board, args.html)
        stderr.print(f"wrote {args.html}")
    if args.json:
        emit_json(board.to_dict())
    else:
        stdout.print(render_terminal(board, wide=args.wide))
    return 0


def cmd_evaluate(args: argparse.Namespace) -> int:
    from arena_league.league import evaluate, queue_evaluation, resolve_agent

    with _league(args) as league:
        if args.agents is not None:
            args.agents = [resolve_agent(league, name, args.game) for name in args.agents]
        if args.queue:
            job_id = queue_evaluation(league, args.game, args.agents, matches_per_pair=args.matches_per_pair,
                                      seed=args.seed, backend=args.backend, workers=args.workers, record=args.record,
                                      max_matches=args.max_matches)
            if args.json:
                emit_json({"queued": job_id})
            else:
                stdout.print(f"queued evaluation job {job_id}; run `arena-league worker` to play it")
            return 0
        with progress_bar(f"evaluating {args.game}", 1) as update:
            report = evaluate(league, args.game, args.agents, matches_per_pair=args.matches_per_pair, seed=args.seed,
                              backend=args.backend, workers=args.workers, record=args.record,
                              max_matches=args.max_matches, progress=update, log=_log)
    if args.json:
        emit_json(report.to_dict())
    else:
        rate = report.played / report.seconds if report.seconds else float("nan")
        stdout.print(f"{report.game_id}: played {report.played} matches ({report.stored} new) among "
                     f"{len(report.agents)} agents in {report.seconds:.1f} s ({rate:.0f} matches/s, "
                     f"{report.steps} env steps)")
        _print_forfeits(report.forfeits, report.suspended, report.skipped)
    return 0


def _print_forfeits(forfeits: dict[str, int], suspended: dict[str, str], skipped: int) -> None:
    """What a job's hostile or broken agents cost it, on stderr."""
    for name, count in forfeits.items():
        stderr.print(f"[bold yellow]forfeits:[/] {escape(name)} forfeited {count} match(es)", highlight=False)
    for name, reason in suspended.items():
        stderr.print(f"[bold red]suspended:[/] {escape(name)}: {escape(reason)}", highlight=False)
    if skipped:
        stderr.print(f"{skipped} match(es) were skipped: an agent in them was suspended", highlight=False)


def cmd_matches(args: argparse.Namespace) -> int:
    from arena_league.league import recent_matches

    with _league(args) as league:
        matches = recent_matches(league, args.game, agent=args.agent, limit=args.limit, server=args.server)
    if args.json:
        emit_json({"game_id": args.game, "matches": matches})
        return 0
    rows = [(str(m["id"]), m["result"], m["page"], m["replay"] or "-") for m in matches]
    caption = "a match without a replay records one with `arena-league replay ID --record`; seeds in --json" \
        if any(m["replay"] is None for m in matches) else "seeds in --json"
    _print_table(f"last {len(matches)} matches of {args.game}", ("match", "result", "page", "replay"),
                 [tuple(escape(cell) for cell in row) for row in rows], caption=caption)
    return 0


def cmd_worker(args: argparse.Namespace) -> int:
    import logging
    import signal

    from arena_league.league import run_worker, signal_stop

    def stop(signum: int, frame: object) -> None:
        signal_stop()
        raise KeyboardInterrupt  # the worker hands its job back to the queue

    signal.signal(signal.SIGTERM, stop)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s", stream=sys.stderr)
    with _league(args) as league:
        try:
            summary = run_worker(league, worker_id=args.worker_id, lease_seconds=args.lease,
                                 poll_seconds=args.poll, max_jobs=args.max_jobs, until_idle=args.until_idle,
                                 parent_pid=args.parent, backend=args.backend, address=args.address,
                                 workers=args.processes)
        except KeyboardInterrupt:
            stderr.print("worker stopped; a job it was running, if any, went back to the queue")
            return 130
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
        _print_table("schedules", ("name", "kind", "game", "every / cron", "next run", "enabled"),
                     [(r["name"], r["kind"], str(r["payload"].get("game_id")),
                       f"{r['interval_seconds']} s" if r["interval_seconds"] else str(r["cron"]), r["next_run_at"],
                       str(r["enabled"])) for r in rows])
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
    from arena_league.league import match_page, match_replay_file, replay_summary

    path, match = Path(args.file), None
    if path.exists() or path.suffix == ".mcap":
        if args.record:
            raise CommandError("--record is for a match id (e.g. `arena-league replay 265 --record`), not a file")
    else:
        with _league(args) as league:
            match, path = match_replay_file(league, args.file, record=args.record)
    document = replay_summary(path, gif=args.gif, fps=args.fps, every=args.every)
    if match is not None:  # the league's id, as `matches` and the web show it, before the file's own
        document = {"match": match, "page": match_page(match), **document}
    if args.gif:
        stderr.print(f"wrote {args.gif} ({document['gif']['frames']} frames)")
    if args.json:
        emit_json(document)
    else:
        skip = {"match_id"} if match is not None else set()
        _print_record(f"replay {path}" if match is None else f"replay of match {match}",
                      {k: v for k, v in document.items() if not isinstance(v, (dict, list)) and k not in skip})
    return 0


def cmd_population(args: argparse.Namespace) -> int:
    from arena_league.league import (
        check_game,
        export_population,
        import_population,
        list_populations,
        list_shipped,
    )

    if args.action == "pull":
        return _pull_population(args)
    if args.action == "index":
        return _population_index(args)
    if args.action == "list" and args.game is not None:
        check_game(args.game)
    with _league(args) as league:
        if args.action == "build":
            return _build_population(args, league)
        if args.action == "import":
            label = import_population(league, _required(args.folder, "the population folder"), name=args.name)
            if args.json:
                emit_json({"imported": label})
            else:
                stdout.print(f"imported population {label}")
            return 0
        if args.action == "export":
            path = export_population(league, _required(args.population, "--population NAME[:VERSION]"),
                                     _required(args.destination, "--destination FOLDER"), game_id=args.game)
            if args.json:
                emit_json({"exported": args.population, "path": str(path)})
            else:
                stdout.print(f"exported {args.population} to {path}")
            return 0
        rows = list_populations(league, args.game)
        shipped = list_shipped(league, args.game)
    if args.json:
        emit_json({"populations": rows, "shipped": shipped})
        return 0
    if rows:
        _print_table("populations in this league", ("population", "game", "members", "frozen"),
                     [(f"{r['name']}:{r['version']}", r["game_id"], str(r["members"]), str(r["frozen"])) for r in rows])
    else:
        stdout.print(f"no populations{' of ' + args.game if args.game else ''} in this league yet (a shipped one is "
                     "imported on first use, or with `arena-league population import FOLDER`)", highlight=False)
    _print_table("shipped with arena-league", ("population", "game", "members", "MB", "on this machine", "imported"),
                 [(r["name"], r["game_id"], str(r["members"]), f"{r['bytes'] / 1e6:.1f}",
                   escape(f"{r['where']} {r['path']}" if r["path"] else "not downloaded: `arena-league population "
                          f"pull {r['game_id']} {r['name']}`"), r["imported"] or "not yet") for r in shipped])
    return 0


def _pull_population(args: argparse.Namespace) -> int:
    from arena_league.league import pull_population

    reports = pull_population(args.game, args.what, every=args.every, mirror=args.mirror)
    if args.json:
        emit_json({"pulled": [r.to_dict() for r in reports]})
        return 0
    for r in reports:
        done = f"pulled {r.files} files ({r.bytes / 1e6:.1f} MB) from {r.url}" if r.fetched else \
            "already here, whole"
        stdout.print(f"{r.game_id} {r.name}: {done}; in {escape(r.path)}", highlight=False)
    return 0


def _population_index(args: argparse.Namespace) -> int:
    from arena_league.league import index_differences, write_index

    if args.write:
        index = write_index(url=args.url)
        if args.json:
            emit_json({"written": len(index["populations"]), "url": index["url"]})
        else:
            stdout.print(f"wrote the index of {len(index['populations'])} populations (files fetched from "
                         f"{index['url'] or 'a mirror only: no --url given'})", highlight=False)
        return 0
    if args.url is not None:
        raise CommandError("--url is written with --write: `arena-league population index --write --url URL`")
    differences = index_differences()
    if args.json:
        emit_json({"differences": differences})
    elif differences:
        for line in differences:
            stderr.print(line, highlight=False)
        stderr.print("the package's index disagrees with checkpoints/; rewrite it with "
                     "`arena-league population index --write`", highlight=False)
    else:
        stdout.print("the package's index agrees with checkpoints/")
    return 1 if differences else 0


def cmd_agents(args: argparse.Namespace) -> int:
    from arena_league.league import agent_rows, short_name

    with _league(args) as league:
        rows = agent_rows(league, args.game)
    if args.json:
        emit_json({"game_id": args.game, "agents": rows})
        return 0
    if not rows:
        stderr.print(f"no agents{' of ' + args.game if args.game else ''} in this league yet; submit one with "
                     "`arena-league submit PATH --game GAME --name NAME`, or run `arena-league quickstart`")
        return 0
    cells = []
    for r in rows:
        rating = "" if r["rating"] is None else f"{r['rating']:.0f}"
        note = r["reason"] if r["status"] in ("rejected", "suspended") else (r["rated_by"] or "")
        name = short_name(r["name"], args.game) if args.game else r["name"]
        cells.append((name, r["game_id"], r["kind"], r["status"], r["owner"] or "", rating, escape(note or "")))
    _print_table(f"agents of {args.game}" if args.game else "agents",
                 ("agent", "game", "kind", "status", "owner", "rating", "note"), cells)
    return 0


def cmd_agent(args: argparse.Namespace) -> int:
    from arena_league.league import agent_detail

    with _league(args) as league:
        detail = agent_detail(league, args.name, game_id=args.game)
    if args.json:
        emit_json(detail)
        return 0
    _print_record(f"agent {detail['name']}", {k: v for k, v in detail.items()
                                             if not isinstance(v, (dict, list)) and k != "validation_log"})
    if len(detail["versions"]) > 1:
        stdout.print("versions: " + ", ".join(f"{v['name']} ({v['status']})" for v in detail["versions"]),
                     highlight=False)
    for forfeit in detail["forfeits"][:5]:
        stdout.print(f"forfeited in match {forfeit['match']} (job {forfeit['job_id']}): it {escape(forfeit['reason'])}",
                     highlight=False)
    for placed in detail["placements"][:5]:
        stdout.print(f"placed against {placed.get('base')}: rating {placed.get('rating', float('nan')):.0f} "
                     f"({placed.get('lower', float('nan')):.0f} .. {placed.get('upper', float('nan')):.0f}), rank "
                     f"{placed.get('rank')} ({placed.get('rank_lower')}..{placed.get('rank_upper')}) of "
                     f"{int(placed.get('base_size', 0)) + 1}, {placed.get('matches')} matches")
    if detail["validation_log"]:
        stdout.print("validation log:", style="bold")
        stdout.print(escape(detail["validation_log"].rstrip()), highlight=False)
    return 0


def cmd_jobs(args: argparse.Namespace) -> int:
    from arena_league.league import cancel_job, job_detail, job_rows

    with _league(args) as league:
        if args.action == "list":
            rows = job_rows(league, status=args.status, limit=args.limit)
            if args.json:
                emit_json({"jobs": rows})
                return 0
            _print_table("jobs, newest first", ("id", "kind", "status", "game", "what", "created"),
                         [(str(r["id"]), r["kind"], r["status"], r["game_id"] or "", escape(r["what"]),
                           r["created_at"] or "") for r in rows])
            return 0
        job_id = _required(args.job, "a job id, e.g. `arena-league jobs " + args.action + " 12`")
        document = job_detail(league, job_id) if args.action == "show" else cancel_job(league, job_id)
    if args.json:
        emit_json(document)
    elif args.action == "cancel":
        stdout.print(f"job {document['id']} ({document['kind']}): {document['status']}")
    else:
        _print_record(f"job {document['id']}", {k: v for k, v in document.items() if not isinstance(v, (dict, list))})
    return 0


def cmd_settings(args: argparse.Namespace) -> int:
    from arena_league.league import league_settings, reset_setting, set_setting

    with _league(args) as league:
        if args.action == "set":
            value = set_setting(league, _required(args.key, "a setting's key"),
                                _required(args.value, "the value, e.g. `arena-league settings set KEY VALUE`"))
            document: dict[str, Any] = {"key": args.key, "value": value}
        elif args.action == "reset":
            document = {"key": args.key, "value": reset_setting(league, _required(args.key, "a setting's key"))}
        else:
            settings = league_settings(league)
            if args.json:
                emit_json({"settings": settings})
            else:
                _print_table("league settings", ("key", "value", "default", "what it bounds"),
                             [(key, f"{row['value']}{' *' if row['changed'] else ''}", str(row["default"]),
                               row["help"]) for key, row in settings.items()])
            return 0
    if args.json:
        emit_json(document)
    else:
        stdout.print(f"{document['key']} = {document['value']}")
    return 0


def cmd_reinstate(args: argparse.Namespace) -> int:
    from arena_league.league import reinstate_agent

    with _league(args) as league:
        document = reinstate_agent(league, args.name, args.game)
    if args.json:
        emit_json(document)
    else:
        stdout.print(f"{document['name']} is active again; it has forfeited {document['matches_forfeited']} "
                     "match(es), and its next forfeit suspends it again")
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    from arena_league.web import serve

    if args.no_worker and args.workers is not None:
        raise CommandError("give --workers N or --no-worker, not both")
    from arena_league.league import league_location

    workers = 0 if args.no_worker else (1 if args.workers is None else args.workers)

    def banner() -> None:  # once the port is ours: a port in use is one line, no banner
        stderr.print(f"serving the league at {league_location(args.home, args.db)} on http://{args.host}:{args.port} "
                     f"with {workers} job worker(s); Ctrl-C stops it", highlight=False, soft_wrap=True)

    serve(host=args.host, port=args.port, home=args.home, url=args.db, workers=workers, on_listening=banner)
    return 0


def cmd_token(args: argparse.Namespace) -> int:
    from arena_league.league import create_token, list_tokens, revoke_token

    with _league(args) as league:
        if args.action == "create":
            document = create_token(league, _required(args.target, "the token's OWNER"), admin=args.admin)
            if args.json:
                emit_json({"owner": document["owner"], "token": document["token"], "admin": document["admin"],
                           "id": document["id"]})
            else:
                stdout.print(document["token"], highlight=False, soft_wrap=True)
                stderr.print(f"token {document['id']} of {document['owner']}{' (admin)' if args.admin else ''}: shown "
                             "this once (the league keeps only its hash); send it as `Authorization: Bearer TOKEN`")
            return 0
        if args.action == "revoke":
            document = revoke_token(league, str(_required(args.target, "the token's id or OWNER")))
            if args.json:
                emit_json(document)
            else:
                stdout.print(f"revoked {document['revoked']} token(s) of {args.target}")
            return 0
        rows = list_tokens(league)
    if args.json:
        emit_json({"tokens": rows})
    else:
        _print_table("tokens", ("id", "owner", "admin", "starts", "created", "last used", "revoked"),
                     [(str(r["id"]), r["owner"], "yes" if r["admin"] else "", r["prefix"] + "...", r["created_at"],
                       r["last_used_at"] or "", r["revoked_at"] or "") for r in rows])
    return 0


def _required(value: Any, what: str) -> Any:
    if value is None:
        raise CommandError(f"this command needs {what}")
    return value


def _build_population(args: argparse.Namespace, league) -> int:
    from arena_league.league.population.build import build_population
    from arena_league.league.population.options import BuildOptions, command_line_options

    game = _required(args.game, "a game id, e.g. `arena-league population build Soccer-2T2P-v1`")

    def log(line: str) -> None:
        stderr.print(line, highlight=False)

    values = {option.field: getattr(args, option.field) for option in command_line_options()}
    if values["schemes"] == ["none"]:
        values["schemes"] = []
    report = build_population(game, BuildOptions(**values), league=league, log=log)
    document = report.to_dict()
    if args.json:
        emit_json(document)
    else:
        _print_record(f"population {document['name']} of {game}",
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
    """A whole league on the embedded default (see :mod:`arena_league.league.first_league`)."""
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
        against = report.population_origin if report.population_origin and ranked.base == report.population \
            else f"{ranked.base} ({ranked.base_size} agents)"
        stdout.print(f"[bold]{ranked.agent}[/] against {escape(against)}, {ranked.matches} matches:")
        stdout.print(f"  rating {ranked.rating:.0f} ({ranked.lower:.0f} .. {ranked.upper:.0f}), rank {ranked.rank} "
                     f"({ranked.rank_lower}..{ranked.rank_upper}) of {ranked.base_size + 1}, percentile "
                     f"{ranked.percentile:.0f} ({ranked.percentile_lower:.0f} .. {ranked.percentile_upper:.0f})")
    stdout.print(render_terminal(board))
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    from arena_league.league.train import runs_folder, train_entrant

    def log(line: str) -> None:
        if not args.json:
            stderr.print(line, highlight=False)

    out = args.out
    if out is None and args.report is None:
        out = runs_folder(args.home, args.game, args.scheme, args.seed)
    try:
        report = train_entrant(args.game, args.scheme, steps=args.steps, seed=args.seed, report_dir=args.report,
                               eval_every=args.eval_every, eval_matches=args.eval_matches, reference=args.reference,
                               snapshot_every=args.snapshot_every, out_dir=out, warm_start_steps=args.warm_start,
                               hidden=args.hidden, log=log, home=args.home,
                               eval_background=False if args.eval_inline else None,
                               checkpoint_seconds=args.checkpoint_seconds)
    except KeyboardInterrupt:
        where = out if out is not None else Path(args.report) / "snapshots"
        raise KeyboardInterrupt(f"training stopped; its last checkpoint is under {where}: the same command, run "
                                "again, resumes the run from there") from None
    document = report.as_dict()
    if args.json:
        emit_json(document)
        return 0
    last = report.evaluations[-1] if report.evaluations else {}
    trained = report.env_steps
    rounded = (f" ({args.steps} asked for, rounded up to whole iterations of {report.history[0]['env_steps']})"
               if trained != args.steps and report.history else "")
    performance = last.get("population_performance")
    stdout.print(f"{args.scheme} on {args.game}: {trained} env steps in {len(report.history)} iteration(s){rounded}, "
                 f"{len(report.snapshots)} snapshot(s); population performance "
                 f"{'-' if performance is None else f'{performance:.3f}'}")
    timing = report.timing
    if timing.get("evaluations"):
        where = (f"in {timing['eval_processes']} background process(es)" if timing["eval_background"]
                 else "between iterations")
        stdout.print(f"  evaluation: {timing['evaluations']} evaluation(s) played {where} in "
                     f"{timing['eval_seconds']:.1f} s; training waited {timing['eval_wait_seconds']:.1f} s for them, "
                     f"{100 * (timing['eval_share'] or 0.0):.0f}% of the run's {timing['seconds']:.1f} s")
    for name, path in report.plots.items():
        stdout.print(f"  {name}: {path}")
    for snapshot in report.snapshots[-3:]:
        stdout.print(f"  snapshot {snapshot.name}: {snapshot.path} (submit it with `arena-league submit`)")
    return 0


#: The paper's five baselines (``league.experiments.BASELINES``, named here so that building the
#: parser imports no training code).
_BASELINES = ("dppo", "sp", "pbt", "cc", "cf")


def cmd_experiment(args: argparse.Namespace) -> int:
    from arena_league.league import experiments

    def log(line: str) -> None:
        if not args.json:
            stderr.print(line, highlight=False)

    if args.address is not None and args.backend != "ray":
        raise CommandError("a Ray address is for --backend ray; add it, or leave --address out")
    spread = None if args.backend == "inprocess" else \
        experiments.Spread(args.backend, args.processes or 1, args.address)
    if args.readme_only:
        out = args.out or (f"experiments/{args.which}" if args.which == "crossroads-social" or args.game is None
                           else f"experiments/baselines-{args.game.split('-')[0].lower()}")
        report = experiments.rewrite_readme(out)
    elif args.which == "crossroads-social":
        if args.game is not None:
            raise CommandError("crossroads-social runs on Crossroads-2T2P-v1 and takes no GAME; leave it out")
        out = args.out or "experiments/crossroads-social"
        report = experiments.crossroads_social(out, seeds=args.seeds, steps=args.steps or 300_000,
                                               episodes=args.episodes, max_cycles=args.max_cycles,
                                               marks=args.marks, marks_at=args.marks_at, log=log, spread=spread)
    else:
        if args.game is None:
            raise CommandError(f"name the game: `arena-league experiment baselines GAME`, one of "
                               f"{', '.join(experiments.BASELINE_GAMES)}")
        out = args.out or f"experiments/baselines-{args.game.split('-')[0].lower()}"
        report = experiments.baselines(args.game, out, methods=args.methods, seeds=args.seeds,
                                       steps=args.steps or 150_000, checkpoints=args.checkpoints,
                                       budget=args.budget, max_cycles=args.max_cycles, log=log, spread=spread)
    if args.json:
        emit_json(report)
        return 0
    stdout.print((Path(out) / "README.md").read_text(), highlight=False, markup=False)
    stdout.print(f"report: {Path(out) / experiments.REPORT_FILE}")
    return 0


def cmd_gc(args: argparse.Namespace) -> int:
    from arena_league.league import collect_garbage

    with _league(args) as league:
        report = collect_garbage(league, dry_run=args.dry_run, min_age_s=args.min_age)
    if args.json:
        emit_json(report)
        return 0
    verb = "would remove" if args.dry_run else "removed"
    for entry in report["artifacts"]:
        stdout.print(f"{verb} artifact {entry['sha256'][:12]} ({entry['path']}, {entry['bytes']} bytes)",
                     highlight=False)
    for entry in report["incoming"] + report["uploads"] + report["previews"]:
        stdout.print(f"{verb} leftover {entry['path']} ({entry['bytes']} bytes)", highlight=False)
    count = len(report["artifacts"]) + len(report["incoming"]) + len(report["uploads"]) + len(report["previews"])
    stdout.print(f"{verb} {count} entries, {report['bytes']} bytes" if count else "nothing to remove",
                 highlight=False)
    return 0


# --- parser --------------------------------------------------------------------------------------

_BACKENDS = ("inprocess", "process", "ray")
_BACKEND_HELP = "where matches run: inprocess (default), a process pool, or Ray"


def _league_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--home", default=None, help="league home (default: $ARENA_LEAGUE_HOME or ~/.arena-league)")
    p.add_argument("--db", default=None, help="SQLAlchemy URL of the registry (default: $ARENA_LEAGUE_DB or "
                                              "the home's league.db)")
    _json_option(p)


def _json_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout (progress on stderr)")


def _build_options(p: argparse.ArgumentParser) -> None:
    """The options of ``population build``: the fields of the library's ``BuildOptions`` that the
    command takes, with their defaults and docs (none written here)."""
    from arena_league.league.population.options import command_line_options

    types: dict[str, Callable[[str], Any]] = {"positive": _positive_int, "non_negative": _non_negative_int,
                                              "seed": _seed, "text": str, "texts": str}
    for option in command_line_options():
        p.add_argument(option.flag, dest=option.field, type=types[option.kind], default=option.default,
                       nargs="+" if option.kind == "texts" else None, help=option.help,
                       metavar=option.metavar or option.flag.removeprefix("--").upper().replace("-", "_"))


def _seed_option(p: argparse.ArgumentParser, what: str = "the matches' seeds") -> None:
    p.add_argument("--seed", type=_seed, default=0, help=f"seed of {what} (default 0): same seed, same result")


def _evaluation_seed_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--seed", type=_seed, default=0,
                   help="seed of the matches (default 0), mixed with the job's id so that no two evaluations play "
                        "the same match: the same commands on the same league state play the same matches")


def build_parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False, allow_abbrev=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="on an error, show the full traceback")
    parser = argparse.ArgumentParser(
        prog="arena-league", allow_abbrev=False,
        description="A league for multi-agent RL agents: submit an agent, rank it against its game's base "
                    "population with intervals, read the leaderboard. Start with `arena-league quickstart`.")
    parser.add_argument("--debug", action="store_true", help="on an error, show the full traceback")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    parser.set_defaults(commands=sub.choices)

    def command(name: str, help_text: str) -> argparse.ArgumentParser:
        return sub.add_parser(name, help=help_text, description=help_text, parents=[common], allow_abbrev=False)

    p = command("games", "the game set, with default social trees; a game's options with its id")
    p.add_argument("game", nargs="?", default=None,
                   help="a game id, e.g. GoBang-2T1P-v1: that game alone, with its options")
    _json_option(p)
    p.set_defaults(func=cmd_games)

    p = command("verify", "verify every node of a game's social tree by paired sampling")
    p.add_argument("game", help="game id, e.g. Crossroads-2T2P-v1 (see `arena-league games`)")
    p.add_argument("--tree", help="a social tree spec file (YAML or JSON); default: the game's own")
    p.add_argument("--samples", type=_positive_int, default=64, help="paired episodes (default 64)")
    _seed_option(p, "the paired episodes")
    p.add_argument("--max-cycles", type=_positive_int, default=None, help="episode length (default: the game's)")
    p.add_argument("--action-type", choices=("discrete", "continuous"), default=None,
                   help="the game's action type (default: its first)")
    _json_option(p)
    p.set_defaults(func=cmd_verify)

    p = command("submit", "validate an agent (ONNX file or arena-policy folder) and register it")
    p.add_argument("path", help="an .onnx file (its .onnx.data beside it) or an arena-policy folder")
    p.add_argument("--game", required=True, help="the game id the agent plays (see `arena-league games`)")
    p.add_argument("--name", required=True, help="the agent's name in the league")
    p.add_argument("--owner", default=None, help="who submits it (shown in listings)")
    _league_options(p)
    p.set_defaults(func=cmd_submit)

    p = command("rank", "place an agent (or a population's members) against its game's base population")
    p.add_argument("agent", nargs="?", default=None, help="the agent's name (see `arena-league agents`)")
    p.add_argument("--members", nargs="+", default=None, metavar="NAME_OR_PATH",
                   help="rank every member instead and report their mean rank and percentile with intervals: agent "
                        "names, .onnx files, arena-policy folders, a population folder or a folder of agents")
    p.add_argument("--game", default=None, help="the agent's game, where its short name (e.g. random) is another "
                                                "game's too; --members given as files: their game (a population "
                                                "folder says it)")
    p.add_argument("--budget", type=_positive_int, default=200,
                   help="at most this many matches played now (default 200)")
    p.add_argument("--more", type=_positive_int, default=None, metavar="N",
                   help="play N more matches under --seed after the agent's stored placement against this base "
                        "(whatever its interval): its matches only grow")
    p.add_argument("--population", default=None,
                   help="the base population NAME[:VERSION] (default: the game's own: the newest frozen one, or "
                        "the shipped base-v1, imported on first use)")
    p.add_argument("--league-wide", action="store_true",
                   help="rank against every other active agent of the game instead (rated first by a round "
                        "robin that counts against --budget)")
    p.add_argument("--half-width", type=float, default=3.0,
                   help="stop early at this rank-interval half-width, in places (default 3)")
    p.add_argument("--seed", type=_seed, default=0,
                   help="seed of the placement's matches (default 0): they depend on the seed, the agent and the "
                        "base only, so the same seed gives the same placement in any league, and asking again with "
                        "a seed the stored placement holds returns it without playing. Another seed adds its "
                        "matches to the stored ones (at least 20, at most --budget, until the interval reaches "
                        "--half-width)")
    p.add_argument("--backend", choices=_BACKENDS, default="inprocess", help=_BACKEND_HELP)
    _league_options(p)
    p.set_defaults(func=cmd_rank)

    p = command("leaderboard", "a game's ratings: base members and placed entrants, with intervals")
    p.add_argument("game", help="the game id")
    p.add_argument("--method", choices=("bt", "elo", "openskill", "nash", "alpharank"), default="bt",
                   help="rating method (default bt: Bradley-Terry on the Elo scale)")
    p.add_argument("--population", default=None, help="rate only this population's members, NAME[:VERSION]")
    p.add_argument("--rounds", type=_positive_int, default=100, help="bootstrap rounds of the intervals (default 100)")
    _seed_option(p, "the bootstrap")
    p.add_argument("--html", default=None, help="also write a self-contained HTML report to this file")
    p.add_argument("--wide", action="store_true", help="every column that fits beside the agent column (the default table fits 80 columns)")
    _league_options(p)
    p.set_defaults(func=cmd_leaderboard)

    p = command("evaluate", "round robin among a game's agents (tops each pair up to N matches)")
    p.add_argument("game", help="the game id")
    p.add_argument("--agents", nargs="+", default=None, help="agent names (default: every active agent)")
    p.add_argument("--matches-per-pair", type=_positive_int, default=10,
                   help="bring every pair up to this many matches (default 10); pairs that have them play none")
    p.add_argument("--max-matches", type=_positive_int, default=None, help="play at most this many matches")
    _evaluation_seed_option(p)
    p.add_argument("--backend", choices=_BACKENDS, default="inprocess", help=_BACKEND_HELP)
    p.add_argument("--workers", type=_positive_int, default=None, help="processes or Ray CPUs (default: all cores)")
    p.add_argument("--record", action="store_true",
                   help="write one MCAP replay per match played now, under the home's replays/")
    p.add_argument("--queue", action="store_true", help="queue the job for `arena-league worker` instead")
    _league_options(p)
    p.set_defaults(func=cmd_evaluate)

    p = command("matches", "the latest stored matches of a game")
    p.add_argument("game", help="the game id")
    p.add_argument("--agent", default=None, help="only this agent's matches")
    p.add_argument("--limit", type=_positive_int, default=20, help="how many (default 20)")
    p.add_argument("--server", default=os.environ.get("ARENA_LEAGUE_URL"),
                   help="the web service's address, e.g. http://127.0.0.1:8000, to link each match's page in full "
                        "(default: $ARENA_LEAGUE_URL; without it, the page's path)")
    _league_options(p)
    p.set_defaults(func=cmd_matches)

    p = command("agents", "the league's agents: status, kind, owner, rating, why a rejected one was refused")
    p.add_argument("game", nargs="?", default=None, help="only this game's agents")
    _league_options(p)
    p.set_defaults(func=cmd_agents)

    p = command("agent", "one agent in full: validation log, populations, placements, recent matches")
    p.add_argument("name", help="the agent's name, or its short name on a board (random for random@GAME)")
    p.add_argument("--game", default=None, help="the agent's game, where its short name is another game's too")
    _league_options(p)
    p.set_defaults(func=cmd_agent)

    p = command("serve", "the league as a web service: pages, JSON API, uploads, replays (FastAPI on uvicorn)")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=_port, default=8000, help="port (default 8000)")
    p.add_argument("--workers", type=_non_negative_int, default=None,
                   help="job workers to run beside the server (default 1)")
    p.add_argument("--no-worker", action="store_true",
                   help="run no worker: jobs wait for `arena-league worker` processes started elsewhere")
    _league_options(p)
    p.set_defaults(func=cmd_serve)

    p = command("token", "bearer tokens of the web service: create OWNER [--admin], list, revoke ID|OWNER")
    p.add_argument("action", choices=("create", "list", "revoke"), nargs="?", default="list",
                   help="create a token (shown once), list them, or revoke one (by id) or an owner's")
    p.add_argument("target", nargs="?", default=None, help="create: the OWNER; revoke: the token's id or OWNER")
    p.add_argument("--admin", action="store_true", help="create: an administrator's token")
    _league_options(p)
    p.set_defaults(func=cmd_token)

    p = command("reinstate", "make a suspended agent active again (its next forfeit suspends it again)")
    p.add_argument("name", help="the suspended agent's name (or its short name on a board)")
    p.add_argument("--game", default=None, help="the agent's game, where its short name is another game's too")
    _league_options(p)
    p.set_defaults(func=cmd_reinstate)

    p = command("settings", "the league's settings (sandbox budgets, suspension): list, set KEY VALUE, reset KEY")
    p.add_argument("action", choices=("list", "set", "reset"), nargs="?", default="list",
                   help="list (default), set a value, or reset one to its default")
    p.add_argument("key", nargs="?", default=None, help="the setting, e.g. sandbox.call_seconds")
    p.add_argument("value", nargs="?", default=None, help="set: the new value")
    _league_options(p)
    p.set_defaults(func=cmd_settings)

    p = command("jobs", "queued, running and finished jobs: list, show ID, cancel ID")
    p.add_argument("action", choices=("list", "show", "cancel"), nargs="?", default="list",
                   help="list (default), show one job, or cancel a queued or running one")
    p.add_argument("job", nargs="?", type=_positive_int, default=None, help="the job id, for show and cancel")
    p.add_argument("--status", default=None, help="list: only jobs of this status (queued, running, done, failed, "
                                                  "cancelled)")
    p.add_argument("--limit", type=_positive_int, default=50, help="list: how many, newest first (default 50)")
    _league_options(p)
    p.set_defaults(func=cmd_jobs)

    p = command("worker", "run queued and scheduled jobs")
    p.add_argument("--worker-id", default=None, help="this worker's name in leases (default host:pid)")
    p.add_argument("--lease", type=float, default=60.0,
                   help="lease seconds (default 60): a crashed worker's job is retried after it")
    p.add_argument("--poll", type=float, default=1.0, help="seconds between looks at an empty queue (default 1)")
    p.add_argument("--max-jobs", type=_positive_int, default=None, help="stop after this many jobs")
    p.add_argument("--until-idle", action="store_true", help="stop when the queue is empty")
    p.add_argument("--parent", type=_positive_int, default=None, metavar="PID",
                   help="stop, handing the running job back, when process PID ends (serve starts its workers so)")
    p.add_argument("--backend", choices=("inprocess", "process", "ray"), default="inprocess",
                   help="where the jobs' matches are played: here (default: as each job asks), a process pool, "
                        "or the tasks of a Ray cluster")
    p.add_argument("--address", default=None, metavar="ADDR",
                   help="--backend ray: the cluster to join (default RAY_ADDRESS, else a local Ray instance)")
    p.add_argument("--processes", type=_positive_int, default=None, metavar="N",
                   help="--backend process: worker processes (default: every core); ray: CPUs of a local instance")
    _league_options(p)
    p.set_defaults(func=cmd_worker)

    p = command("schedule", "recurring evaluations: add, list, remove")
    p.add_argument("action", choices=("add", "list", "remove"), help="what to do")
    p.add_argument("name", nargs="?", default=None, help="the schedule's name (add, remove)")
    p.add_argument("--game", default=None, help="add: the game to evaluate")
    p.add_argument("--every", type=_positive_int, default=None, help="add: interval in seconds")
    p.add_argument("--cron", default=None, help="add: cron expression, 5 fields, UTC")
    p.add_argument("--matches-per-pair", type=_positive_int, default=10,
                   help="add: bring every pair up to this many matches (default 10)")
    _evaluation_seed_option(p)
    p.add_argument("--backend", choices=_BACKENDS, default="inprocess", help=_BACKEND_HELP)
    _league_options(p)
    p.set_defaults(func=cmd_schedule)

    p = command("scheduler", "queue due scheduled jobs: run (a loop) or tick (once, for cron)")
    p.add_argument("action", choices=("run", "tick"), help="run a loop, or tick once")
    p.add_argument("--poll", type=float, default=30.0, help="run: seconds between ticks (default 30)")
    p.add_argument("--max-ticks", type=_positive_int, default=None, help="run: stop after this many ticks")
    _league_options(p)
    p.set_defaults(func=cmd_scheduler)

    p = command("replay", "summarise a match's MCAP replay; export a GIF of its top-down view")
    p.add_argument("file", help="a match id (as `arena-league matches GAME` and its page show it, e.g. 265) or an "
                                ".mcap replay file")
    p.add_argument("--record", action="store_true",
                   help="a match without a replay: play it again here and record it first (it ends as stored)")
    p.add_argument("--gif", default=None, help="also write the top-down view as an animated GIF here")
    p.add_argument("--fps", type=float, default=10.0, help="GIF frames per second (default 10)")
    p.add_argument("--every", type=_positive_int, default=1, help="keep one frame in N (default 1)")
    _league_options(p)
    p.set_defaults(func=cmd_replay)

    p = command("population", "populations: list, build GAME, import FOLDER, export, pull GAME [NAME], index")
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION",
                               help="list, build, import, export, pull or index (each has its own --help)")
    p.set_defaults(func=cmd_population, actions=actions.choices)

    def action(name: str, help_text: str) -> argparse.ArgumentParser:
        return actions.add_parser(name, help=help_text, description=help_text, parents=[common], allow_abbrev=False)

    a = action("list", "the populations in this league and those shipped with arena-league, and where each is")
    a.add_argument("--game", default=None, help="only this game's")
    _league_options(a)

    a = action("build", "train, rate, select and freeze a base population of a game (resumable)")
    a.add_argument("game", nargs="?", default=None, help="the game id, e.g. Soccer-2T2P-v1")
    _build_options(a)
    _league_options(a)

    a = action("import", "import a frozen population folder into this league")
    a.add_argument("folder", nargs="?", default=None, help="the population folder, e.g. checkpoints/GAME/base-v1")
    a.add_argument("--name", default=None, help="the population's name in the league (default: the folder's own)")
    _league_options(a)

    a = action("export", "write a population of this league to a new folder")
    a.add_argument("--population", default=None, help="the population, NAME[:VERSION]")
    a.add_argument("--destination", default=None, help="a new folder")
    a.add_argument("--game", default=None, help="the population's game, where its name is another game's too")
    _league_options(a)

    a = action("pull", "fetch a shipped population into the cache, each file checked as it streams")
    a.add_argument("game", nargs="?", default=None, help="the game id (without one: with --all, every one shipped)")
    a.add_argument("what", nargs="?", default=None, metavar="NAME",
                   help="the shipped population (default: the game's newest)")
    a.add_argument("--all", dest="every", action="store_true",
                   help="every population shipped for the game (without a game: every one shipped)")
    a.add_argument("--mirror", default=None, metavar="URL",
                   help="a copy of checkpoints/ to fetch from (http://, https://, file:// or a folder; default "
                        "$ARENA_LEAGUE_POPULATION_MIRROR, else the URL the index names)")
    _json_option(a)

    a = action("index", "check the package's index of shipped populations against checkpoints/, or rewrite it")
    a.add_argument("--write", action="store_true", help="rewrite the index from checkpoints/")
    a.add_argument("--url", default=None, help="with --write: the base URL the files are fetched from")
    _json_option(a)

    p = command("gc", "remove artifact files no agent references, leftovers of interrupted writes and stale uploads")
    p.add_argument("--dry-run", action="store_true", help="only list what would be removed")
    p.add_argument("--min-age", type=float, default=3600.0, metavar="SECONDS",
                   help="leave files modified in the last SECONDS, which a running submission may be storing "
                        "(default 3600; 0 removes everything unreferenced now)")
    _league_options(p)
    p.set_defaults(func=cmd_gc)

    p = command("play", "play against a base population in the terminal (human ranking)")
    p.add_argument("game", help="the game id")
    p.add_argument("--against", default=None,
                   help="the base population NAME[:VERSION] (default: the one rank uses, the game's newest frozen "
                        "one, or the newest shipped, imported on first use)")
    p.add_argument("--player", default="human", help="your name; your results are kept as <name>@GAME")
    p.add_argument("--matches", type=_positive_int, default=None, help="stop after this many matches")
    _seed_option(p)
    p.add_argument("--pictures", default=None, help="physics games: save the top-down picture of each step here")
    _league_options(p)
    p.set_defaults(func=cmd_play)

    p = command("train", "train agents with a scheme (ppo, dppo, sp, pbt, cc, cf); plot the curves")
    p.add_argument("game", help="the game id")
    p.add_argument("--scheme", default="sp", help="ppo, dppo, sp, pbt, cc or cf (default sp)")
    p.add_argument("--steps", type=_positive_int, default=100_000, help="env steps (default 100000)")
    _seed_option(p, "the run")
    p.add_argument("--report", default=None, help="write episode_reward.png, population_performance.png and "
                                                  "curves.json here")
    p.add_argument("--eval-every", type=_positive_int, default=10, help="iterations between evaluations (default 10)")
    p.add_argument("--eval-matches", type=_positive_int, default=20,
                   help="matches per reference agent at each evaluation (default 20)")
    p.add_argument("--eval-inline", action="store_true",
                   help="play the evaluations between iterations (default: in a background process while "
                        "training goes on, on a machine with more than one core)")
    p.add_argument("--reference", nargs="+", default=None,
                   help="the fixed reference population (default scripted:random scripted:heuristic)")
    p.add_argument("--snapshot-every", type=_positive_int, default=None, help="env steps between snapshots")
    p.add_argument("--out", default=None, help="where snapshots (arena-policy folders) go (default: REPORT/snapshots "
                                               "with --report, else a new runs/<game>-<scheme>-seed<N>-<k>/ of the "
                                               "league home)")
    p.add_argument("--home", default=None, help="league home whose runs/ takes the snapshots (default: "
                                                "$ARENA_LEAGUE_HOME or ~/.arena-league)")
    p.add_argument("--warm-start", type=_positive_int, default=None, metavar="STEPS",
                   help="first imitate the game's heuristic (DAgger) for this many env steps")
    p.add_argument("--hidden", type=_positive_int, nargs="+", default=None, help="actor hidden widths (default 64 64)")
    p.add_argument("--checkpoint-seconds", type=_non_negative_float, default=None, metavar="SECONDS",
                   help="wall time between checkpoints of the unfinished run (default 120; 0: every iteration); "
                        "the same command, run again after a stop, resumes the run bit for bit")
    _json_option(p)
    p.set_defaults(func=cmd_train)

    p = command("experiment", "the Arena paper's experiments: crossroads-social, baselines GAME")
    p.add_argument("which", choices=("crossroads-social", "baselines"), help="which experiment")
    p.add_argument("game", nargs="?", default=None,
                   help="baselines: Crossroads-2T2P-v1 (blocking tree) or PushBox-2T2P-v1")
    p.add_argument("--seeds", type=_non_negative_int, nargs="+", default=[0, 1, 2], help="training seeds (default 0 1 2)")
    p.add_argument("--steps", type=_positive_int, default=None,
                   help="env steps per run (default 300000 for crossroads-social, 150000 for baselines)")
    p.add_argument("--episodes", type=_positive_int, default=50,
                   help="crossroads-social: evaluation episodes per seed (default 50)")
    p.add_argument("--marks", type=_positive_int, default=5,
                   help="crossroads-social: log-spaced env-step marks, ending at --steps, at which the agents "
                        "are evaluated (default 5)")
    p.add_argument("--marks-at", type=_positive_int, nargs="+", default=None, metavar="STEPS",
                   help="crossroads-social: these marks instead (--steps is added as the last)")
    p.add_argument("--methods", nargs="+", default=list(_BASELINES), choices=_BASELINES,
                   help="baselines: the methods (default all five)")
    p.add_argument("--checkpoints", type=_positive_int, default=6,
                   help="baselines: log-spaced checkpoints placed against the base population (default 6)")
    p.add_argument("--budget", type=_positive_int, default=40,
                   help="baselines: placement matches per checkpoint (default 40)")
    p.add_argument("--max-cycles", type=_positive_int, default=None, help="training episodes' length cap")
    p.add_argument("--out", default=None, help="the report folder (default experiments/<experiment>)")
    p.add_argument("--readme-only", action="store_true",
                   help="write the folder's README.md again from its report.json, training and playing nothing")
    p.add_argument("--backend", choices=("inprocess", "process", "ray"), default="inprocess",
                   help="where the runs train (and are placed) before the report: here one after the other "
                        "(default), side by side in --processes processes, or as the tasks of a Ray cluster")
    p.add_argument("--processes", type=_positive_int, default=None, metavar="N",
                   help="--backend process: worker processes; ray: CPUs of a local instance (default 1)")
    p.add_argument("--address", default=None, metavar="ADDR",
                   help="--backend ray: the cluster to join (default RAY_ADDRESS, else a local Ray instance)")
    _json_option(p)
    p.set_defaults(func=cmd_experiment)

    p = command("quickstart", "a league end to end: agents, round robin, ranking, leaderboard")
    p.add_argument("--game", default="Crossroads-2T2P-v1", help="the game (default Crossroads-2T2P-v1)")
    p.add_argument("--matches-per-pair", type=_positive_int, default=10,
                   help="round robin matches per pair of scripted agents (default 10)")
    p.add_argument("--budget", type=_positive_int, default=40, help="ranking matches of the example (default 40)")
    _seed_option(p)
    p.add_argument("--no-base", dest="base", action="store_false",
                   help="leave the game's shipped base population out (scripted agents only)")
    _league_options(p)
    p.set_defaults(func=cmd_quickstart)
    return parser


def _user_errors() -> tuple[type[BaseException], ...]:
    """Exceptions that describe the user's input (with the fix): printed as one line, exit 2."""
    from arena_league.league import USER_ERRORS

    return (CommandError, *USER_ERRORS)


def _int_at_least(minimum: int, requirement: str, maximum: int | None = None) -> Callable[[str], int]:
    """An argparse type: an integer of at least ``minimum`` (and at most ``maximum``), refused as
    ``must be <requirement>``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum or (maximum is not None and value > maximum):
            raise argparse.ArgumentTypeError(f"must be {requirement}, not {value}")
        return value

    return parse


def _non_negative_float(text: str) -> float:
    """An argparse type: a finite number of at least 0, refused as one line."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.0 <= value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a number of seconds, 0 or more, not {text}")
    return value


_positive_int = _int_at_least(1, "a positive integer")
_non_negative_int = _int_at_least(0, "0 or more")
_port = _int_at_least(1, "a port number from 1 to 65535", 65535)
#: Seeds as the web takes them: 0 to 2**31.
_seed = _int_at_least(0, "a whole number from 0 to 2147483648", 2**31)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line parsed; an unknown option is refused by its subcommand, with that
    subcommand's usage and the closest options it does have."""
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        from arena_league.league import did_you_mean

        command = args.commands[args.command]
        siblings = getattr(args, "actions", None) or {}
        if siblings:  # a command with actions (population): the action refuses, naming the one an option is for
            command = siblings[args.action]
            _refuse_another_actions_option(f"{args.command} {args.action}", command, unknown, {
                f"{args.command} {name}": parser for name, parser in siblings.items() if name != args.action})
        options = _option_strings(command)
        hints = "".join(did_you_mean(u.split("=")[0], options) for u in unknown if u.startswith("-"))
        command.error(f"unrecognized arguments: {' '.join(unknown)}.{hints}")
    return args


def _option_strings(parser: argparse.ArgumentParser) -> list[str]:
    return [o for action in parser._actions for o in action.option_strings]


def _refuse_another_actions_option(name: str, parser: argparse.ArgumentParser, unknown: list[str],
                                   others: dict[str, argparse.ArgumentParser]) -> None:
    """Exit with one line when an unknown option of ``parser`` (action ``name``) is one of
    another action's, or when words are left over that the action takes no place for."""
    for word in unknown:
        flag = word.split("=")[0]
        owners = [other for other, p in others.items() if flag in _option_strings(p)]
        if flag.startswith("-") and owners:
            parser.exit(2, f"arena-league {name}: error: {flag} is for `{'`, `'.join(owners)}`, not "
                           f"`{name}`; see `arena-league {name} --help`\n")
    words = [w for w in unknown if not w.startswith("-")]
    if words and len(words) == len(unknown):
        takes = [a.metavar or a.dest for a in parser._actions if not a.option_strings and a.dest != "help"]
        parser.exit(2, f"arena-league {name}: error: it takes {' '.join(takes).upper() or 'no argument'}; "
                       f"{' '.join(words)!r} is more than that\n")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    debug = getattr(args, "debug", False)
    try:
        return args.func(args)
    except KeyboardInterrupt as exc:
        if debug:
            raise
        stderr.print(f"[bold red]interrupted:[/] {escape(str(exc))}" if str(exc) else
                     "[bold red]interrupted:[/] the job this command was running is cancelled (nothing half-done "
                     "is left queued); matches already played stay stored. See `arena-league jobs list`.",
                     highlight=False, soft_wrap=True)
        return 130
    except _user_errors() as exc:
        if debug:
            raise
        return _fail(args, str(exc), type(exc).__name__, 2)
    except Exception as exc:  # a bug, not the user's input: one line, and the way to the traceback
        if debug:
            raise
        from arena_league.league.errors import disk_full_error

        full = disk_full_error(exc, str(getattr(exc, "filename", None) or "the league home"))
        if full is not None:  # a full disk is the machine's state, not a bug: named, with the fix
            return _fail(args, str(full), type(full).__name__, 2)
        return _fail(args, f"internal error ({type(exc).__name__}: {exc}); run again with --debug for the "
                           "traceback and report it", type(exc).__name__, 1)


def _fail(args: argparse.Namespace, message: str, kind: str, code: int) -> int:
    if getattr(args, "json", False):
        emit_json({"error": message, "kind": kind})
    stderr.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    return code


if __name__ == "__main__":
    sys.exit(main())
