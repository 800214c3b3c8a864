"""The ``arena-league`` command: a thin layer over the library.

Every command that prints results takes ``--json`` (one JSON document on stdout; progress and logs
on stderr). Tables and progress bars are drawn with rich when stderr/stdout is a terminal.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

stdout = Console()
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
    from arena_league.envs import default_tree, game_spec, list_games, make_rules

    rows = []
    for game_id in list_games():
        spec = game_spec(game_id)
        rules = make_rules(game_id)
        rows.append({
            "game_id": game_id,
            "teams": spec.n_teams,
            "players_per_team": spec.players_per_team,
            "action_types": list(spec.rules.action_types),
            "turn_based": spec.rules.turn_based,
            "obs_dim": rules.obs_dim,
            "max_cycles": spec.rules.default_max_cycles,
            "summary": spec.rules.summary,
            "default_tree": default_tree(game_id),
        })
    if args.json:
        emit_json({"games": rows})
        return 0
    table = Table(title="arena-league games")
    for column in ("game id", "teams x players", "actions", "obs", "default social tree"):
        table.add_column(column)
    for row in rows:
        table.add_row(row["game_id"], f"{row['teams']} x {row['players_per_team']}",
                      "/".join(row["action_types"]) + (" (turns)" if row["turn_based"] else ""),
                      str(row["obs_dim"]), tree_outline(row["default_tree"]))
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
    from arena_league.envs.social.verify import verify

    with progress_bar(f"verifying {args.game}", args.samples) as update:
        report = verify(args.game, tree=args.tree, samples=args.samples, seed=args.seed,
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


# --- parser --------------------------------------------------------------------------------------

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
    return parser


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, not {value}")
    return value


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (CommandError, ValueError, FileNotFoundError) as exc:
        message = str(exc)
        if getattr(args, "json", False):
            emit_json({"error": message, "kind": type(exc).__name__})
        stderr.print(f"[bold red]error:[/] {message}", highlight=False)
        return 2


if __name__ == "__main__":
    sys.exit(main())
