"""The test helpers that run on a Ray cluster's nodes, and the two-node cluster the tests join
(:func:`arena_league.matchmaking.cluster.local_cluster`, with this folder importable on its nodes)."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from arena_league.matchmaking.cluster import LocalCluster, local_cluster, ray_executable

__all__ = ["JOB_EXCLUDES", "LocalCluster", "NodeRecording", "count_setup", "fail", "ray_cluster", "ray_executable", "where_and_setups"]


#: What a Ray job sent from the checkout leaves behind: the shipped populations and experiments' files
#: (Ray refuses a working folder over 100 MiB) and git's own.
JOB_EXCLUDES = ["/checkpoints/", "/experiments/", "/.git"]


@contextmanager
def ray_cluster(log_dir: Path, dashboard: bool = False) -> Iterator[LocalCluster]:
    """A head and a worker node of one CPU each, whose workers import these helpers too (and the
    head's dashboard, for ``ray job submit``, with ``dashboard``)."""
    with local_cluster(log_dir, nodes=2, python_path=[Path(__file__).resolve().parent],
                       dashboard=dashboard) as cluster:
        yield cluster


#: Times this process ran :func:`count_setup`, by its argument (the tasks of the executor's tests).
SETUPS: dict[str, int] = {}


def count_setup(label: str) -> None:
    """An executor's initializer: counts its runs in this worker process."""
    SETUPS[label] = SETUPS.get(label, 0) + 1


def where_and_setups(label: str, seconds: float) -> tuple[str, int, int]:
    """An executor's task: (its Ray node id, its pid, the runs of ``count_setup(label)`` here),
    after ``seconds`` of sleep (so that the tasks overlap and spread over the nodes)."""
    import ray

    time.sleep(seconds)
    return ray.get_runtime_context().get_node_id(), os.getpid(), SETUPS.get(label, 0)


def fail(message: str, seconds: float = 0.0) -> None:
    """An executor's task that fails after ``seconds``."""
    time.sleep(seconds)
    raise ValueError(message)


class NodeRecording:
    """A match recording that records only where the match was played: its result's
    ``replay_path`` is the Ray node id of the worker that played it."""

    def __call__(self, spec, env, env_kwargs) -> NodeRecording:
        return self

    def before_step(self, obs, actions, acting) -> None:
        pass

    def after_step(self, rewards) -> None:
        pass

    def close(self, result) -> str:
        import ray

        return ray.get_runtime_context().get_node_id()

    def abort(self) -> None:
        pass
