"""Where matches run: in this process, in a local process pool, or on a Ray cluster.

All three play the same :class:`~arena_league.matchmaking.runner.LockstepRunner` over chunks of
match specs and return the same results: a match's outcome depends only on its spec and its agents
(see :mod:`arena_league.matchmaking.specs`), never on which worker played it or with which others.

* ``"inprocess"``: one runner per game in this process (agents may be loaded policies).
* ``"process"``: a ``concurrent.futures.ProcessPoolExecutor`` whose workers fork from a fork server
  (``forkserver`` start method) that imported the league's modules once, so no state of this
  process is inherited and later pools start at once; each worker loads the agents from their
  :class:`AgentRef` records once and plays chunks of specs.
* ``"ray"``: the same chunks as Ray tasks; ``ray.init(address=...)`` joins a cluster when an
  address is given (or ``RAY_ADDRESS`` is set), else starts a local instance with ``num_cpus``
  workers. Every node needs ``arena_league`` importable and the agents' artifacts at the same paths
  (a shared league home).

Results come back in the order of the specs.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from arena_league.matchmaking.agents import AgentRef, load_agents
from arena_league.matchmaking.runner import LockstepRunner, MatchRecording
from arena_league.matchmaking.specs import MatchResult, MatchSpec
from arena_league.policies.policy import Policy

__all__ = ["BACKENDS", "play_chunk", "play_matches"]

BACKENDS = ("inprocess", "process", "ray")

#: Policies loaded in this worker process, by their references (reused across chunks).
_WORKER_POLICIES: dict[tuple[AgentRef, ...], dict[str, Policy]] = {}


def play_chunk(game_id: str, agents: Mapping[str, AgentRef], specs: Sequence[MatchSpec], batch_size: int,
               env_kwargs: Mapping[str, Any] | None, recording: MatchRecording | None) -> list[MatchResult]:
    """Plays one chunk of specs of one game in this process (the unit of work of the process-pool
    and Ray backends); policies are loaded once per process and kept."""
    cache_key = tuple(sorted(set(agents.values()), key=lambda ref: (ref.key, ref.game_id, str(ref.action_type))))
    policies = _WORKER_POLICIES.get(cache_key)
    if policies is None:
        policies = load_agents({ref.key: ref for ref in agents.values()})
        _WORKER_POLICIES[cache_key] = policies
    seat_policies = {key: policies[ref.key] for key, ref in agents.items()}
    runner = LockstepRunner(game_id, seat_policies, batch_size=batch_size, env_kwargs=env_kwargs,
                            recording=recording)
    return runner.play(specs)


def _worker_init() -> None:
    # one compute thread per worker: the pool already uses every core
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("MKL_NUM_THREADS", "1")
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)


#: Modules the fork server imports once, so that every pool's workers start without importing them.
_PRELOAD = ["arena_league.matchmaking", "arena_league.policies.artifacts"]


def _process_context() -> multiprocessing.context.BaseContext:
    """A fork server that has imported the league's modules (torch included) once: its workers fork
    from it, without inheriting this process's threads or state, and start in milliseconds."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(_PRELOAD)
    return context


def play_matches(specs: Sequence[MatchSpec], agents: Mapping[str, AgentRef | Policy], *,
                 backend: str = "inprocess", batch_size: int = 64, workers: int | None = None,
                 chunk_size: int | None = None, ray_address: str | None = None,
                 env_kwargs: Mapping[str, Any] | None = None, recording: MatchRecording | None = None,
                 on_result: Callable[[MatchResult], None] | None = None) -> list[MatchResult]:
    """Plays ``specs`` and returns their results in the same order.

    Args:
        specs: the matches (several games may be mixed; each game is played by its own runner).
        agents: agent key (as named in the specs' seats) -> :class:`AgentRef`, or a loaded
            :class:`Policy` (in-process only).
        backend: ``"inprocess"``, ``"process"`` or ``"ray"``.
        batch_size: matches in flight per runner.
        workers: processes of the pool, or CPUs of a local Ray instance (default: all cores).
        chunk_size: specs per task (default: enough for about four tasks per worker, at least
            ``batch_size``).
        ray_address: the Ray cluster to join (``"auto"``, ``"ray://host:10001"``); default
            ``RAY_ADDRESS`` or a new local instance.
        env_kwargs: options of :func:`arena_league.envs.make` for every match.
        recording: opens a recorder per match (``arena_league.replay.ReplayRecording(directory)``
            writes one MCAP replay per match there); see :class:`MatchRecording`.
        on_result: called with each result as it arrives (in-process: as each match ends; other
            backends: as each chunk returns).
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; valid: {', '.join(BACKENDS)}")
    specs = list(specs)
    missing = sorted({key for spec in specs for key in spec.seats if key not in agents})
    if missing:
        raise KeyError(f"no agent for key(s) {missing[:10]}; give every agent key named in the specs an "
                       "AgentRef or a Policy")
    by_game: dict[str, list[int]] = {}
    for index, spec in enumerate(specs):
        by_game.setdefault(spec.game_id, []).append(index)
    results: list[MatchResult | None] = [None] * len(specs)

    if backend == "inprocess":
        policies = load_agents(agents)
        for game_id, indices in by_game.items():
            runner = LockstepRunner(game_id, {k: policies[k] for k in _keys_of(specs, indices)},
                                    batch_size=batch_size, env_kwargs=env_kwargs, recording=recording)
            for index, result in zip(indices, runner.play([specs[i] for i in indices], on_result)):
                results[index] = result
        return [r for r in results if r is not None]

    not_refs = sorted(k for k, a in agents.items() if not isinstance(a, AgentRef))
    if not_refs:
        raise TypeError(f"the {backend} backend loads agents in its workers from references; agent(s) "
                        f"{not_refs[:5]} are loaded policies. Pass AgentRef records (or use backend='inprocess')")
    n_workers = workers or os.cpu_count() or 1
    tasks = []  # (indices, args)
    for game_id, indices in by_game.items():
        size = chunk_size or max(batch_size, math.ceil(len(indices) / (4 * n_workers)))
        for start in range(0, len(indices), size):
            part = indices[start: start + size]
            refs = {k: agents[k] for k in _keys_of(specs, part)}
            tasks.append((part, (game_id, refs, [specs[i] for i in part], batch_size, env_kwargs, recording)))

    def collect(part: list[int], chunk_results: list[MatchResult]) -> None:
        for index, result in zip(part, chunk_results):
            results[index] = result
            if on_result is not None:
                on_result(result)

    if backend == "process":
        with ProcessPoolExecutor(max_workers=n_workers, mp_context=_process_context(),
                                 initializer=_worker_init) as pool:
            futures = [(part, pool.submit(play_chunk, *args)) for part, args in tasks]
            for part, future in futures:
                collect(part, future.result())
    else:
        remote = _ray_remote(ray_address, workers)
        import ray

        pending = {remote.remote(*args): part for part, args in tasks}
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                collect(pending.pop(ref), ray.get(ref))
    return [r for r in results if r is not None]


def _keys_of(specs: Sequence[MatchSpec], indices: Sequence[int]) -> list[str]:
    return sorted({key for i in indices for key in specs[i].seats})


def _ray_remote(address: str | None, num_cpus: int | None):
    try:
        import ray
    except ImportError as error:
        raise RuntimeError("the ray backend needs Ray: pip install 'arena-league[ray]'") from error
    if not ray.is_initialized():
        address = address or os.environ.get("RAY_ADDRESS")
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            # a local instance: its workers import arena_league from the same place as this process
            package_root = str(Path(__file__).resolve().parents[2])
            path = os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH", "")) if p)
            ray.init(num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False, log_to_driver=False,
                     runtime_env={"env_vars": {"PYTHONPATH": path, "OMP_NUM_THREADS": "1"}})
    return ray.remote(play_chunk)
