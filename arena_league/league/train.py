"""Training an entrant: one scheme on one game, with its reward and population-performance curves.

The front ends' entry to :func:`arena_league.training.curves.train`: options a person gives by name
(a warm start's imitation steps, the actor's hidden widths) become the trainer's overrides here.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["train_entrant"]


def train_entrant(game_id: str, scheme: str = "sp", *, steps: int = 100_000, seed: int = 0,
                  report_dir: str | Path | None = None, eval_every: int = 10, eval_matches: int = 20,
                  reference: Sequence[str] | None = None, snapshot_every: int | None = None,
                  out_dir: str | Path | None = None, warm_start_steps: int | None = None,
                  hidden: Sequence[int] | None = None, log: Callable[[str], None] | None = None) -> Any:
    """Train ``game_id`` with ``scheme`` for ``steps`` env steps; snapshots go to ``out_dir`` (submit
    them with ``arena-league submit``), plots and ``curves.json`` to ``report_dir``. With
    ``warm_start_steps`` the learners first imitate the game's heuristic (DAgger) for that many env
    steps; ``hidden`` sets the actor's hidden widths; ``reference`` is the fixed population of the
    performance curve (default: the scripted random and heuristic agents). Returns the training report."""
    from arena_league.training.curves import DEFAULT_REFERENCE, train  # matplotlib: imported on first use

    overrides: dict[str, Any] = {}
    if warm_start_steps:
        overrides["warm_start"] = {"steps": int(warm_start_steps)}
    if hidden:
        overrides["hidden"] = tuple(int(h) for h in hidden)
    return train(game_id, scheme, steps=steps, seed=seed, report_dir=report_dir, eval_every=eval_every,
                 eval_matches=eval_matches, reference=tuple(reference or DEFAULT_REFERENCE),
                 snapshot_every=snapshot_every, out_dir=out_dir, log=log, **overrides)
