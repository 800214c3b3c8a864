"""Where a population build's tasks run: training runs and round-robin chunks side by side, in
spawned worker processes on this machine or as Ray tasks on a cluster.

:func:`run_tasks` takes the tasks (key: (function, arguments)) and calls ``done(key, result)`` here
as each finishes, in the order they finish, whichever the backend:

* ``"process"``: a pool of ``processes`` spawned worker processes, each running ``initializer``
  once as it starts.
* ``"ray"``: one Ray task per task, each asking for its ``num_cpus``, on the cluster
  :func:`arena_league.matchmaking.cluster.join_ray` joins (``address``, or a local instance of
  ``processes`` CPUs). ``initializer(*initargs)`` runs once per Ray worker process, before its
  first task: the pair is put in Ray's object store once and each worker keeps, by the object's
  id, whether it ran it. Plain tasks rather than a Ray actor per CPU, so that Ray places each task
  by its own CPU request on any node with room and cancels it alone.

A task that fails fails the call, as it would in this process; then, or when ``done`` raises (an
interrupt, a deadline), the remaining tasks are ended at once: nothing ``done`` already saved is
lost, the rest is not played out. On Ray a cancel that reaches a task between its dispatch to a
worker and its start can be lost (Ray 2.60); such a task runs to its end, and what it writes
(a training run's folder) is what a resumed build reads back.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["EXECUTORS", "run_tasks"]

#: The backends of :func:`run_tasks`.
EXECUTORS = ("process", "ray")

Tasks = Mapping[Any, tuple[Callable[..., Any], tuple[Any, ...]]]


def run_tasks(tasks: Tasks, done: Callable[[Any, Any], None], *, backend: str = "process", processes: int = 1,
              address: str | None = None, num_cpus: float | Mapping[Any, float] = 1,
              initializer: Callable[..., None] | None = None, initargs: tuple[Any, ...] = ()) -> None:
    """Run ``tasks`` (key: (function, arguments)) and call ``done(key, result)`` here as each
    finishes (see the module docstring).

    Args:
        tasks: the tasks, started in their order.
        done: called in this process with each task's key and result, in the order they finish.
        backend: ``"process"`` (a spawned process pool) or ``"ray"``.
        processes: worker processes of the pool, or CPUs of a local Ray instance.
        address: the Ray cluster to join (default ``RAY_ADDRESS``, else a local instance).
        num_cpus: the CPUs each Ray task asks for, one number or one per key (default 1).
        initializer: run with ``initargs`` once in each worker process before its first task.
    """
    if backend not in EXECUTORS:
        raise ValueError(f"unknown backend {backend!r}; valid: {', '.join(EXECUTORS)}")
    if not tasks:
        return
    if backend == "process":
        _in_pool(processes, tasks, done, initializer, initargs)
    else:
        _on_ray(tasks, done, processes, address, num_cpus, initializer, initargs)


def _in_pool(processes: int, tasks: Tasks, done: Callable[[Any, Any], None],
             initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
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
    """Run one task of the process pool in a worker: its key and its result."""
    key, function, arguments = task
    return key, function(*arguments)


def _on_ray(tasks: Tasks, done: Callable[[Any, Any], None], processes: int, address: str | None,
            num_cpus: float | Mapping[Any, float], initializer: Callable[..., None] | None,
            initargs: tuple[Any, ...]) -> None:
    from arena_league.matchmaking.cluster import join_ray

    ray = join_ray(address, processes)
    # wrapped in a list, the reference reaches the worker unresolved: only its first task reads it
    setup = [ray.put((initializer, initargs))] if initializer is not None else None
    remote = ray.remote(_call_on_ray)
    pending: dict[Any, Any] = {}
    try:
        for key, (function, arguments) in tasks.items():
            cpus = num_cpus[key] if isinstance(num_cpus, Mapping) else num_cpus
            pending[remote.options(num_cpus=cpus).remote(function, arguments, setup)] = key
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                key = pending.pop(ref)
                done(key, ray.get(ref))
    except BaseException:
        for ref in pending:  # once each: Ray 2.60 aborts a driver that cancels a finishing task again
            ray.cancel(ref, force=True)
        raise


#: The setups (object ids of initializer and arguments) this Ray worker process has run.
_SETUPS_RUN: set[str] = set()


def _call_on_ray(function: Callable[..., Any], arguments: tuple[Any, ...], setup: list[Any] | None) -> Any:
    """One task on a Ray worker: the setup first if this process has not run it, then the task."""
    if setup is not None:
        (ref,) = setup
        if ref.hex() not in _SETUPS_RUN:
            import ray

            initializer, initargs = ray.get(ref)
            initializer(*initargs)
            _SETUPS_RUN.add(ref.hex())
    return function(*arguments)
