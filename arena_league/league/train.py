"""Training an entrant: one scheme on one game, with its reward and population-performance curves.

The front ends' entry to :func:`arena_league.training.curves.train`: options a person gives by name
(a warm start's imitation steps, the actor's hidden widths) become the trainer's overrides here.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["runs_folder", "train_entrant"]


def runs_folder(home: str | Path | None, game_id: str, scheme: str, seed: int) -> Path:
    """The folder of a run's snapshots under the league home: ``runs/<game>-<scheme>-seed<N>-<k>``,
    ``k`` the first number not taken (no clock, so the same runs get the same folders), except that
    the newest such folder is taken again while its run is unfinished (it holds a checkpoint and no
    run record): the same command, started again after a stop, resumes its run."""
    from arena_league.registry import league_home
    from arena_league.training.schemes import CHECKPOINT_FILE, RUN_RECORD

    runs = league_home(home) / "runs"
    k = 1
    while (runs / f"{game_id}-{scheme}-seed{seed}-{k}").exists():
        k += 1
    if k > 1:
        newest = runs / f"{game_id}-{scheme}-seed{seed}-{k - 1}"
        run = newest / f"{scheme}-seed{seed}"
        if (run / CHECKPOINT_FILE).exists() and not (run / RUN_RECORD).exists():
            return newest
    return runs / f"{game_id}-{scheme}-seed{seed}-{k}"


def train_entrant(game_id: str, scheme: str = "sp", *, steps: int = 100_000, seed: int = 0,
                  report_dir: str | Path | None = None, eval_every: int = 10, eval_matches: int = 20,
                  reference: Sequence[str] | None = None, snapshot_every: int | None = None,
                  out_dir: str | Path | None = None, warm_start_steps: int | None = None,
                  hidden: Sequence[int] | None = None, log: Callable[[str], None] | None = None,
                  home: str | Path | None = None, eval_background: bool | None = None,
                  checkpoint_seconds: float | None = None) -> Any:
    """Train ``game_id`` with ``scheme`` for ``steps`` env steps (rounded up to whole iterations:
    the report's ``env_steps`` says how many were trained); snapshots go to ``out_dir`` (default
    ``report_dir/snapshots``, else a new :func:`runs_folder` of the league ``home``; submit them
    with ``arena-league submit``), plots and ``curves.json`` to ``report_dir``. With
    ``warm_start_steps`` the learners first imitate the game's heuristic (DAgger) for that many env
    steps; ``hidden`` sets the actor's hidden widths; ``reference`` is the fixed population of the
    performance curve (default: the scripted random and heuristic agents); ``eval_background``:
    whether its evaluations play in a background process while training goes on (default: when
    this process may run on more than one core); ``checkpoint_seconds``: wall time between two
    checkpoints of the unfinished run (default :data:`~arena_league.training.schemes.CHECKPOINT_SECONDS`;
    0: every iteration), from which the same call, made again after a stop, resumes it bit for bit.
    Returns the training report."""
    from arena_league.training.curves import DEFAULT_REFERENCE, train  # matplotlib: imported on first use

    overrides: dict[str, Any] = {}
    if warm_start_steps:
        overrides["warm_start"] = {"steps": int(warm_start_steps)}
    if hidden:
        overrides["hidden"] = tuple(int(h) for h in hidden)
    if checkpoint_seconds is not None:
        overrides["checkpoint_seconds"] = float(checkpoint_seconds)
    if out_dir is None and report_dir is None:
        out_dir = runs_folder(home, game_id, scheme, seed)
    return train(game_id, scheme, steps=steps, seed=seed, report_dir=report_dir, eval_every=eval_every,
                 eval_matches=eval_matches, reference=tuple(reference or DEFAULT_REFERENCE),
                 snapshot_every=snapshot_every, out_dir=out_dir, log=log, eval_background=eval_background,
                 **overrides)
