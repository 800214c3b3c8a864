"""Worker processes of a population build: training runs and round-robin chunks side by side."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any


def in_processes(processes: int, tasks: Mapping[Any, tuple[Callable[..., Any], tuple[Any, ...]]],
                  done: Callable[[Any, Any], None], initializer: Callable[..., None] | None = None,
                  initargs: tuple[Any, ...] = ()) -> None:
    """Run ``tasks`` (key: (function, arguments)) in at most ``processes`` spawned worker processes,
    in their order, calling ``done(key, result)`` here as each finishes. A task that fails fails
    here, as it would in this process; then, or when ``done`` raises (an interrupt, a deadline),
    the workers are ended at once: nothing already saved is lost, the rest is not played out."""
    from multiprocessing import get_context

    pool = get_context("spawn").Pool(min(processes, len(tasks)), initializer, initargs)
    try:
        for key, result in pool.imap_unordered(call, [(key, *task) for key, task in tasks.items()]):
            done(key, result)
    except BaseException:
        pool.terminate()
        raise
    finally:
        pool.close()
        pool.join()


def call(task: tuple[Any, Callable[..., Any], tuple[Any, ...]]) -> tuple[Any, Any]:
    """Run one task of :func:`in_processes` in a worker: its key and its result."""
    key, function, arguments = task
    return key, function(*arguments)
