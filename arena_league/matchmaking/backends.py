"""Where matches run: in this process, in a local process pool, or on a Ray cluster.

All three play the same :class:`~arena_league.matchmaking.runner.LockstepRunner` over chunks of
match specs and return the same results: a match's outcome depends only on its spec and its agents
(see :mod:`arena_league.matchmaking.specs`), never on which worker played it or with which others.

* ``"inprocess"``: one runner per game in this process (agents may be loaded policies).
* ``"process"``: a ``concurrent.futures.ProcessPoolExecutor`` whose workers fork from a fork server
  (``forkserver`` start method) that imported the league's modules once, so no state of this
  process is inherited and later pools start at once; each worker loads the agents from their
  :class:`AgentRef` records once and plays chunks of specs.
* ``"ray"``: the same chunks as Ray tasks; :func:`arena_league.matchmaking.cluster.join_ray` joins
  a cluster when an address is given (or ``RAY_ADDRESS`` is set), else starts a local instance with
  ``workers`` CPUs (its module docstring names the variables that pin the node address and carry
  the token). Every node needs ``arena_league`` importable and the agents' artifacts at the same
  paths (a shared league home).

Results come back in the order of the specs. Sandboxed agent references (submitted agents) load
into each worker process's own inference sandbox (:mod:`arena_league.policies.sandbox`): one child
process per worker, with the memory and time budgets of ``sandbox_limits``.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import sys
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

from arena_league.matchmaking.agents import AgentRef, load_agents
from arena_league.matchmaking.cluster import join_ray
from arena_league.matchmaking.runner import LockstepRunner, MatchRecording
from arena_league.matchmaking.sandboxed import play_in_sandbox
from arena_league.matchmaking.specs import MatchResult, MatchSpec
from arena_league.policies.policy import Policy
from arena_league.policies.sandbox import (
    ENGINE_BATCH_MATCHES,
    FORKSERVER_PRELOAD,
    SandboxLimits,
    process_context,
)

__all__ = ["BACKENDS", "play_chunk", "play_matches"]

BACKENDS = ("inprocess", "process", "ray")
#: How often the process-pool backend looks at its workers' step counter while it waits.
_HEARTBEAT_SECONDS = 1.0

#: Policies loaded in this worker process, by their references (reused across chunks).
_WORKER_POLICIES: dict[tuple[AgentRef, ...], dict[str, Policy]] = {}


def play_chunk(game_id: str, agents: Mapping[str, AgentRef], specs: Sequence[MatchSpec], batch_size: int,
               env_kwargs: Mapping[str, Any] | None, recording: MatchRecording | None,
               sandbox_limits: SandboxLimits | None = None, forfeit_limit: int | Mapping[str, int] | None = None,
               deadline: float | None = None) -> list[MatchResult]:
    """Plays one chunk of specs of one game in this process (the unit of work of the process-pool
    and Ray backends); in-process policies are loaded once per process and kept, sandboxed ones
    live in the process's sandbox (which keeps the same set loaded from chunk to chunk)."""
    if any(ref.sandboxed for ref in agents.values()):
        return play_in_sandbox(game_id, specs, agents, batch_size=batch_size, env_kwargs=env_kwargs,
                               recording=recording, forfeit_limit=forfeit_limit, heartbeat=_pool_heartbeat(),
                               sandbox_limits=sandbox_limits, deadline=deadline)
    refs = set(agents.values())
    cache_key = tuple(sorted(refs, key=lambda ref: (ref.key, ref.game_id, str(ref.action_type))))
    policies = _WORKER_POLICIES.get(cache_key)
    if policies is None:
        policies = load_agents({ref.key: ref for ref in refs})
        _WORKER_POLICIES[cache_key] = policies
    seat_policies = {key: policies[ref.key] for key, ref in agents.items()}
    runner = LockstepRunner(game_id, seat_policies, batch_size=batch_size, env_kwargs=env_kwargs,
                            recording=recording)
    return runner.play(specs, forfeit_limit=forfeit_limit, heartbeat=_pool_heartbeat(), deadline=deadline)


def _pool_heartbeat() -> Callable[[], None] | None:
    """In a process-pool worker, a heartbeat that counts steps where the parent can see them."""
    if not _WORKER_HEARTBEAT:
        return None
    counter = _WORKER_HEARTBEAT[0]

    def heartbeat() -> None:
        counter.value += 1
    return heartbeat


#: A process-pool worker's step counter, shared with the parent (a sign of progress for its lease).
_WORKER_HEARTBEAT: list[Any] = []


def _worker_init(counter: Any = None) -> None:
    if counter is not None:
        _WORKER_HEARTBEAT[:] = [counter]
    # one compute thread per worker: the pool already uses every core
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("MKL_NUM_THREADS", "1")
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)


#: Modules the fork server imports once, so that every pool's workers (and every sandbox child)
#: start without importing them.
_PRELOAD = [*FORKSERVER_PRELOAD, "arena_league.matchmaking"]


def _process_context() -> multiprocessing.context.BaseContext:
    """A fork server that has imported the league's modules (torch included) once: its workers fork
    from it, without inheriting this process's threads or state, and start in milliseconds."""
    return process_context(_PRELOAD)


def play_matches(specs: Sequence[MatchSpec], agents: Mapping[str, AgentRef | Policy], *,
                 backend: str = "inprocess", batch_size: int = ENGINE_BATCH_MATCHES, workers: int | None = None,
                 chunk_size: int | None = None, ray_address: str | None = None,
                 env_kwargs: Mapping[str, Any] | None = None, recording: MatchRecording | None = None,
                 on_result: Callable[[MatchResult], None] | None = None,
                 sandbox_limits: SandboxLimits | None = None, forfeit_limit: int | Mapping[str, int] | None = None,
                 heartbeat: Callable[[], None] | None = None, deadline: float | None = None) -> list[MatchResult]:
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
        sandbox_limits: the budgets of the inference sandbox that sandboxed references load into
            (one per process; see :mod:`arena_league.policies.sandbox`).
        forfeit_limit: matches an agent (by key, or every agent) may forfeit before the specs that
            name it are skipped (see :meth:`LockstepRunner.play`); with several workers each counts
            its own. Skipped specs have no result, so fewer results than specs may come back.
        heartbeat: called whenever play makes progress (in-process: every step; the process pool:
            when its workers stepped since the last look; Ray: as each chunk returns).
        deadline: a ``time.time()`` past which play stops; the matches not finished by then have no
            result (a job's wall-time bound).
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
        for game_id, indices in by_game.items():
            keys = _keys_of(specs, indices)
            game_specs = [specs[i] for i in indices]
            if all(isinstance(agents[k], AgentRef) for k in keys) and any(agents[k].sandboxed for k in keys):
                # submitted agents: the whole game's lockstep loop runs in the sandbox's child
                played = play_in_sandbox(game_id, game_specs, {k: agents[k] for k in keys}, batch_size=batch_size,
                                         env_kwargs=env_kwargs, recording=recording, forfeit_limit=forfeit_limit,
                                         on_result=on_result, heartbeat=heartbeat, sandbox_limits=sandbox_limits,
                                         deadline=deadline)
            else:
                policies = load_agents({k: agents[k] for k in keys}, sandbox_limits)
                runner = LockstepRunner(game_id, policies, batch_size=batch_size, env_kwargs=env_kwargs,
                                        recording=recording)
                played = runner.play(game_specs, on_result, forfeit_limit=forfeit_limit, heartbeat=heartbeat,
                                     deadline=deadline)
            _place(results, played, specs, indices)
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
            tasks.append((part, (game_id, refs, [specs[i] for i in part], batch_size, env_kwargs, recording,
                                 sandbox_limits, forfeit_limit, deadline)))

    def collect(part: list[int], chunk_results: list[MatchResult]) -> None:
        _place(results, chunk_results, specs, part)
        for result in chunk_results:
            if on_result is not None:
                on_result(result)
        if heartbeat is not None:
            heartbeat()

    if backend == "process":
        context = _process_context()
        counter = context.RawValue("Q", 0)
        with ProcessPoolExecutor(max_workers=n_workers, mp_context=context, initializer=_worker_init,
                                 initargs=(counter,)) as pool:
            futures = {pool.submit(play_chunk, *args): part for part, args in tasks}
            seen = 0
            while futures:
                done, _ = wait(list(futures), timeout=_HEARTBEAT_SECONDS, return_when=FIRST_COMPLETED)
                for future in done:
                    collect(futures.pop(future), future.result())
                if heartbeat is not None and counter.value != seen:
                    seen = counter.value
                    heartbeat()
    else:
        remote = _ray_remote(ray_address, workers)
        import ray

        pending = {remote.remote(*args): part for part, args in tasks}
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                collect(pending.pop(ref), ray.get(ref))
    return [r for r in results if r is not None]


def _place(results: list[MatchResult | None], played: list[MatchResult], specs: Sequence[MatchSpec],
           indices: Sequence[int]) -> None:
    """Put the results of ``specs[indices]`` (in that order, skipped specs left out) in their places."""
    remaining = iter(played)
    result = next(remaining, None)
    for index in indices:
        if result is not None and result.spec == specs[index]:
            results[index] = result
            result = next(remaining, None)


def _keys_of(specs: Sequence[MatchSpec], indices: Sequence[int]) -> list[str]:
    return sorted({key for i in indices for key in specs[i].seats})


def _ray_remote(address: str | None, num_cpus: int | None):
    """:func:`play_chunk` as a Ray remote function, Ray joined (:func:`join_ray`) first."""
    return join_ray(address, num_cpus).remote(play_chunk)
