"""A stored match replay as the front ends show it: its summary, and its top-down view as a GIF."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

from arena_league.replay import export_gif, read_replay

__all__ = ["replay_summary"]


def replay_summary(path: str | Path, *, gif: str | Path | None = None, fps: float = 10.0,
                   every: int = 1) -> dict[str, Any]:
    """What the MCAP replay at ``path`` holds (game, match, seats, steps, outcome, events); with
    ``gif``, also writes its top-down view there (one frame in ``every``) and says so under ``"gif"``."""
    document = asdict(read_replay(path))
    if gif is not None:
        frames = export_gif(path, gif, fps=fps, every=every)
        document["gif"] = {"path": str(gif), "frames": frames}
    return document
