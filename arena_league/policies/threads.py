"""Torch's compute-thread count, set for a block and restored after it.

Policy forwards in a league are many and tiny (a few hundred rows through a small MLP), and on
such work OpenMP's hand-offs between threads cost more than they save, so matches, validation
and training run on one thread. Torch's setting is process-wide: a library call that changed it
and left it changed would slow whatever the caller does next with large tensors, so every such
change goes through :func:`torch_threads`, which puts the caller's setting back.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import torch

__all__ = ["torch_threads"]


@contextmanager
def torch_threads(n: int = 1) -> Iterator[None]:
    """Run the block with torch on ``n`` intra-op threads, then restore the caller's count."""
    if n < 1:
        raise ValueError(f"a thread count is at least 1, got {n}")
    previous = torch.get_num_threads()
    if previous != n:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        if torch.get_num_threads() != previous:
            torch.set_num_threads(previous)
