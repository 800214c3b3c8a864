"""The inference sandbox: submitted agents run in a child process, bounded in memory and in time.

An ONNX graph can loop for 10^15 iterations, allocate a 12 GB tensor, or behave only once the
batch passes some size; a league worker that ran it in its own process would hang, or be killed
with every match it holds. So submitted agents run in an :class:`InferenceSandbox`: one child
process per worker (per process that plays matches), holding every agent that process plays, with

* an address-space limit (``RLIMIT_AS``): the child's size when it starts plus
  :attr:`SandboxLimits.memory_mib`; an allocation past it fails inside the child only;
* a wall-clock budget per call (:attr:`SandboxLimits.call_seconds`: one policy's forward over all
  the seats it holds in one step) and per agent loaded (:attr:`SandboxLimits.load_seconds`).
  The child marks the call it is in (an index and its start time, in shared memory); the parent
  watches the mark and kills the child when a call runs over, and then knows whom to blame;
* a budget per match, in the manner of Kaggle's simulations: each step an agent may take
  :attr:`SandboxLimits.step_seconds`, and what it takes beyond that is drawn from a bank of
  :attr:`SandboxLimits.overage_seconds` per match; an agent whose bank runs dry forfeits that
  match (the runner keeps the banks, see :class:`~arena_league.matchmaking.runner.StepBudget`).

The child serves two kinds of work. Validation asks it for single forwards of one agent
(:class:`SandboxedPolicy`: ``act``, ``forward``, ``measure`` of time and memory); a failure comes
back as a :class:`ForfeitError` with the reason. Play runs a whole task in it
(:meth:`InferenceSandbox.run`): the match engine's lockstep loop, every unit call going through
:meth:`_Child.guarded`, which turns an agent's error, invalid actions or non-finite state into a
failure of that agent instead of an exception, and runs a failed stacked call (agents of one
architecture computed together) member by member so that only the agent at fault fails. A task
streams messages back (results as matches end); when the child dies or is stopped,
:class:`SandboxDied` names the marked call, and the next request starts a new child with the
same agents (:mod:`arena_league.matchmaking.sandboxed` replays what was in flight).

A guarded call of a submitted agent has exactly one of the sizes validation times
(:func:`timed_batch_sizes`: powers of two up to :func:`largest_batch`, and that one): a call of
more rows than the largest goes in chunks, and one of fewer is padded with copies of its last row
up to the next timed size (:func:`padded_rows`), so an agent that passed validation never sees a
batch it was not timed on.

The child is forked from the multiprocessing fork server (which has the policy modules imported),
dies with its parent (``PR_SET_PDEATHSIG``), ignores Ctrl-C (the parent handles it), and computes
exactly as the parent would: the same policies on the same inputs give the same outputs, so a
match's result does not depend on whether its agents were sandboxed.
"""

from __future__ import annotations

import atexit
import contextlib
import multiprocessing
import os
import re
import signal
import sys
import time
import traceback
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from arena_league.policies import errors as artifact_errors
from arena_league.policies.policy import ActionSpec, Policy, invalid_actions, raw_outputs, valid_actions_text

__all__ = [
    "ENGINE_BATCH_MATCHES",
    "FORKSERVER_PRELOAD",
    "AgentSource",
    "ForfeitError",
    "InferenceSandbox",
    "SandboxDied",
    "SandboxFailedError",
    "SandboxLimits",
    "SandboxedPolicy",
    "largest_batch",
    "padded_rows",
    "process_context",
    "process_sandbox",
    "timed_batch_sizes",
]

MiB = 1024 * 1024
#: Matches the league's engine keeps in flight (``play_matches``' default batch).
ENGINE_BATCH_MATCHES = 64
#: Modules the fork server imports once, so that sandbox children (and process-pool workers) start
#: in milliseconds with torch and onnxruntime already loaded.
FORKSERVER_PRELOAD = ["arena_league.policies.artifacts", "arena_league.policies.sandbox"]
#: How often the parent looks at the child while it waits for an answer (an answer wakes it at once).
_POLL_SECONDS = 0.02
_PR_SET_PDEATHSIG = 1


@dataclass(frozen=True)
class SandboxLimits:
    """The budgets of a sandbox child and of the agents in it (league settings, see the command's
    ``arena-league settings``)."""

    #: Address space the child may add to what it has when it starts (the runtime: torch, onnxruntime).
    memory_mib: int = 2048
    #: Wall-clock seconds one policy call may take (one agent's forward over all its seats of a step).
    call_seconds: float = 2.0
    #: Wall-clock seconds loading one agent may take (parsing, building the onnxruntime session).
    load_seconds: float = 30.0
    #: Validation: the most memory an agent may add, loaded and computing its largest batch.
    agent_memory_mib: int = 512
    #: Wall-clock seconds an agent may take each step of a match without drawing on its overage bank
    #: (the base populations' forwards take about a millisecond at the largest batch).
    step_seconds: float = 0.25
    #: Seconds over ``step_seconds`` an agent may spend in all of one match; past them it forfeits it.
    overage_seconds: float = 30.0

    def __post_init__(self) -> None:
        for name in ("memory_mib", "agent_memory_mib"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 16:
                raise ValueError(f"{name} must be a whole number of MiB, at least 16, not {value!r}")
        for name in ("call_seconds", "load_seconds", "step_seconds"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= 3600:
                raise ValueError(f"{name} must be a number of seconds in (0, 3600], not {value!r}")
        value = self.overage_seconds
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0 <= value <= 86400:
            raise ValueError(f"overage_seconds must be a number of seconds in [0, 86400], not {value!r}")


def largest_batch(game_id: str) -> int:
    """The most rows one policy call gets in ``game_id``: every seat of every match the engine keeps
    in flight (an agent playing itself, as in its validation match, holds them all)."""
    from arena_league.envs import game_spec

    spec = game_spec(game_id)
    return ENGINE_BATCH_MATCHES * spec.n_teams * spec.players_per_team


def timed_batch_sizes(largest: int) -> list[int]:
    """The call sizes validation times an agent at, for a game whose largest call has ``largest``
    rows: the powers of two below it, and itself. A few sizes rather than every one, because a slow
    agent would make timing each of hundreds of sizes take minutes."""
    sizes = []
    size = 1
    while size < largest:
        sizes.append(size)
        size *= 2
    return [*sizes, largest]


def padded_rows(rows: int, largest: int) -> int:
    """The size a call of ``rows`` rows (at most ``largest``) is padded to: the smallest of
    :func:`timed_batch_sizes` that holds it."""
    return min(largest, 1 << max(0, rows - 1).bit_length())


@dataclass(frozen=True)
class AgentSource:
    """What the child loads for one agent: an artifact path, ``scripted:<name>``, or an artifact
    already read (:class:`~arena_league.policies.artifacts.AgentArtifact`, sent as bytes)."""

    source: Any
    game_id: str
    action_type: str | None = None
    #: The artifact limits to load it under (None: the defaults).
    limits: Any = None


class ForfeitError(RuntimeError):
    """A sandboxed agent's call failed (over its time or memory budget, a crash, an error, invalid
    output); ``reason`` says which, in one line."""

    def __init__(self, agent: str, reason: str) -> None:
        super().__init__(f"agent {agent} {reason}")
        self.agent = agent
        self.reason = reason


class SandboxDied(Exception):
    """The child died (or was stopped) while in call ``index`` (the item of a request, or the unit
    call a task marked), at the task's step ``step``; ``reason`` says how, in one line."""

    def __init__(self, index: int | None, reason: str, step: int = 0) -> None:
        super().__init__(reason)
        self.index = index
        self.reason = reason
        self.step = step


class SandboxFailedError(RuntimeError):
    """An operation failed in the child outside any agent's call (a bug, or the runtime itself out
    of memory); the message ends with the child's traceback."""

    def __init__(self, child_traceback: str) -> None:
        last = child_traceback.strip().splitlines()[-1] if child_traceback.strip() else "no traceback"
        super().__init__(f"the inference sandbox failed outside any agent's call: {last}\n{child_traceback}")


@dataclass
class _Emitted:
    """A message a task in the child sends while it runs (see :meth:`InferenceSandbox.run`)."""

    payload: Any


@dataclass
class _Failed:
    """The child's answer when an operation raised outside any agent's call: its traceback."""

    traceback: str


class SandboxedPolicy(Policy):
    """A handle on an agent loaded in a sandbox: a :class:`Policy` whose calls go to the child, one
    request each (validation's probes and match). A failed call raises :class:`ForfeitError`; an
    agent that could not be loaded has ``broken`` set (the reason) and fails every call."""

    def __init__(self, sandbox: InferenceSandbox, key: str, spec: ActionSpec, recurrent: bool = False,
                 state_shape: tuple[int, ...] = (), name: str = "", info: Any = None,
                 broken: str | None = None) -> None:
        self.sandbox = sandbox
        self.key = key
        self.spec = spec
        self.recurrent = recurrent
        self.state_shape = state_shape
        self.name = name or key
        self.info = info
        self.broken = broken

    def initial_state(self, n: int) -> np.ndarray | None:
        return np.zeros((n, *self.state_shape), dtype=np.float32) if self.recurrent else None

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        return self.sandbox.call(self.key, "act", obs, uniforms, mask, state)

    def forward(self, obs: np.ndarray, state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """The agent's raw outputs (``logits`` or ``action``) and next state, computed in the child."""
        return self.sandbox.call(self.key, "forward", obs, state)

    def measure(self, obs: np.ndarray, state: np.ndarray | None = None, repeats: int = 3) -> dict[str, Any]:
        """Measured in the child: ``seconds`` of each of ``repeats`` forwards over ``obs``, the memory
        the agent holds at their peak since before it was loaded (``peak_mib``: its weights, what its
        earlier calls left allocated, these forwards) and what these forwards added (``forward_mib``);
        raises :class:`ForfeitError` on failure."""
        return self.sandbox.call(self.key, "measure", obs, state, repeats)


class InferenceSandbox:
    """A child process that loads agents and runs their calls within :class:`SandboxLimits` (see
    the module docstring). Not thread-safe: one caller at a time."""

    def __init__(self, limits: SandboxLimits | None = None) -> None:
        self.limits = limits or SandboxLimits()
        self._process: Any = None
        self._conn: Any = None
        self._progress: Any = None
        self._sources: dict[str, AgentSource] = {}
        self._proxies: dict[str, SandboxedPolicy] = {}
        self._broken: dict[str, str] = {}  # agents that cannot be loaded, with the reason
        self._load_mib: dict[str, float] = {}
        #: Children started so far (the first, and one after each death).
        self.starts = 0

    # --- loading --------------------------------------------------------------------------------
    def load(self, agents: Mapping[str, AgentSource]) -> dict[str, SandboxedPolicy]:
        """Make the child hold exactly ``agents`` (key -> source) and return a handle per key.

        Loading the same set again returns the same handles at once; another set replaces the
        child's agents. An agent that fails to load (an error, its memory or time budget) gets a
        handle with ``broken`` set; the others load as usual."""
        agents = dict(agents)
        if agents == self._sources and self._proxies:
            return dict(self._proxies)
        self._sources, self._broken, self._proxies = agents, {}, {}
        self._proxies = self._handles(self._load_sources())
        return dict(self._proxies)

    def load_one(self, source: AgentSource, key: str = "candidate") -> SandboxedPolicy:
        """Load a single agent (validation); raises the artifact's own error (``ArtifactError``) when
        it cannot be read, and :class:`ForfeitError` when loading runs out of time or memory."""
        self._sources, self._broken, self._proxies = {key: source}, {}, {}
        try:
            infos = self._load_sources(raise_errors=True)
            if key in self._broken:
                raise ForfeitError(key, self._broken[key])
        except BaseException:
            self._sources = {}
            raise
        self._proxies = self._handles(infos)
        return self._proxies[key]

    def _handles(self, infos: Mapping[str, Any]) -> dict[str, SandboxedPolicy]:
        """A handle per loaded source, from what the child said of each (broken ones with the reason)."""
        handles = {}
        for key, source in self._sources.items():
            if key in self._broken:
                handles[key] = SandboxedPolicy(self, key, _game_spec(source), broken=self._broken[key])
            else:
                info = infos[key]
                handles[key] = SandboxedPolicy(self, key, info["spec"], info["recurrent"],
                                               tuple(info["state_shape"]), info["name"], info["info"])
        return handles

    def memory_of(self, key: str) -> float:
        """MiB the agent ``key`` added to the child when it was loaded."""
        return self._load_mib.get(key, 0.0)

    # --- calls ----------------------------------------------------------------------------------
    def call(self, key: str, operation: str, *args: Any, what: str = "a forward") -> Any:
        """One operation (``act``, ``forward``, ``measure``) of agent ``key`` in the child, within the
        budget per call; raises :class:`ForfeitError` when it fails."""
        if key in self._broken:
            raise ForfeitError(key, self._broken[key])
        if key not in self._sources:
            raise KeyError(f"agent {key!r} is not loaded in this sandbox")
        self._ensure_child()
        try:
            status, value = self._request(("call", key, operation, *args), self.limits.call_seconds, what)
        except SandboxDied as death:
            raise ForfeitError(key, death.reason) from None
        if status == "error":
            raise ForfeitError(key, value)
        return value

    def run(self, task: Callable[..., Any], args: tuple, *, on_message: Callable[[Any], None] | None = None,
            on_tick: Callable[[], None] | None = None, what: str = "a call") -> Any:
        """Run ``task(child, emit, *args)`` in the child, with the agents :meth:`load` gave it, and
        return what it returns. ``task`` (a module-level function, sent by reference) calls its
        agents through ``child.guarded(...)``, which marks each call so that one over the budget is
        stopped, and may ``emit(payload)`` messages, which reach ``on_message`` as they come;
        ``child.tick()`` advances the step counter, which calls ``on_tick`` here (a sign of
        progress). Raises :class:`SandboxDied` when the child dies or is stopped (the next request
        starts a new one with the same agents), :class:`SandboxFailedError` when the task raises."""
        self._ensure_child()
        return self._request(("run", task, args), self.limits.call_seconds, what, on_message, on_tick)

    def close(self) -> None:
        """Stop the child (its agents are gone; :meth:`load` starts a new one)."""
        self._stop_child()
        self._sources, self._proxies = {}, {}

    def __enter__(self) -> InferenceSandbox:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- the child's life -----------------------------------------------------------------------
    def _ensure_child(self) -> None:
        """After a death: a new child with the same agents."""
        if self._process is None and self._sources:
            self._load_sources()

    def _spawn(self) -> None:
        context = process_context()
        parent_end, child_end = context.Pipe()
        # the marked call, when it started, the task's step, the marked call's rows
        self._progress = context.RawArray("d", 4)
        process = context.Process(target=_child_main, args=(child_end, self._progress, self.limits),
                                  name="arena-league-sandbox", daemon=True)
        try:
            with _without_main_module():
                process.start()
        finally:
            child_end.close()
        self._process, self._conn = process, parent_end
        self.starts += 1

    def _load_sources(self, raise_errors: bool = False) -> dict[str, dict[str, Any]]:
        """Have the child (started if none runs) hold every source not known to be broken, in place of
        what it held; returns what was loaded. An agent whose loading kills the child is broken and
        the rest load into a new one. With ``raise_errors``, an agent's own artifact error is raised
        (validation)."""
        while True:
            if self._process is None:
                self._spawn()
            keys = [k for k in self._sources if k not in self._broken]
            try:
                infos, errors = self._request(("load", [(k, self._sources[k]) for k in keys]),
                                              self.limits.load_seconds, "loading")
            except SandboxDied as death:
                if death.index is None:
                    raise RuntimeError(f"the inference sandbox could not start ({death.reason})") from None
                self._broken[keys[death.index]] = f"could not be loaded: {death.reason}"
                continue
            for key, (kind, text) in errors.items():
                error = artifact_errors.artifact_error_class(kind)
                if raise_errors and error is not None:
                    raise error(text)
                self._broken[key] = f"could not be loaded: {text}"
            self._load_mib.update({key: info["load_mib"] for key, info in infos.items()})
            return infos

    def _request(self, message: tuple, budget: float, what: str,
                 on_message: Callable[[Any], None] | None = None, on_tick: Callable[[], None] | None = None) -> Any:
        """Send ``message`` and wait for the answer, killing the child when the call it marked runs
        past ``budget`` seconds (``what`` names such a call in the reason); raises
        :class:`SandboxDied`. Messages a task emits meanwhile go to ``on_message``; ``on_tick`` is
        called whenever the task's step counter has moved since the last look."""
        process, conn, progress = self._process, self._conn, self._progress
        progress[0], progress[1], progress[2], progress[3] = -1.0, 0.0, 0.0, 0.0
        try:
            conn.send(message)
        except (BrokenPipeError, ConnectionResetError, OSError):
            raise self._died(self._exit_reason(process)) from None
        seen = 0.0
        while True:
            try:
                while conn.poll(_POLL_SECONDS):
                    reply = conn.recv()
                    if isinstance(reply, _Failed):
                        raise SandboxFailedError(reply.traceback)
                    if not isinstance(reply, _Emitted):
                        return reply
                    if on_message is not None:
                        on_message(reply.payload)
            except (EOFError, ConnectionResetError, OSError):
                raise self._died(self._exit_reason(process)) from None
            if on_tick is not None and progress[2] != seen:
                seen = progress[2]
                on_tick()
            started = progress[1]
            if started and time.monotonic() - started > budget:
                process.kill()
                rows = int(progress[3])
                raise self._died(f"ran past its {budget:g} s budget for {what}{f' of {rows} rows' if rows else ''} "
                                 "(stopped)")
            if not process.is_alive():
                raise self._died(self._exit_reason(process))

    def _died(self, reason: str) -> SandboxDied:
        progress = self._progress
        index = int(progress[0])
        death = SandboxDied(None if index < 0 else index, reason, int(progress[2]))
        self._stop_child()
        return death

    def _exit_reason(self, process: Any) -> str:
        process.join(timeout=5)
        code = process.exitcode
        limit = f"the sandbox's {self.limits.memory_mib} MiB"
        if code is None:
            return "stopped answering"
        if code == -signal.SIGKILL:
            return f"was killed (SIGKILL: the system ran out of memory or an outside limit struck; {limit})"
        if code == -signal.SIGABRT:
            return f"aborted (SIGABRT, typically an allocation past {limit} in native code)"
        if code < 0:
            name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else str(-code)
            return f"crashed (signal {name})"
        return f"made the sandbox exit (code {code})"

    def _stop_child(self) -> None:
        process, conn = self._process, self._conn
        self._process = self._conn = None
        if conn is not None:
            with contextlib.suppress(OSError):
                conn.close()
        if process is not None:
            if process.is_alive():
                process.kill()
            process.join()


def _game_spec(source: AgentSource) -> ActionSpec:
    from arena_league.policies.spaces import game_action_spec

    return game_action_spec(source.game_id, source.action_type)


@contextlib.contextmanager
def _without_main_module() -> Any:
    """Start a child without it re-running the caller's main module: multiprocessing's fork server
    imports ``__main__`` again in every child it makes (so that objects defined there unpickle),
    which runs an unguarded script's top level a second time and fails outright for code read from
    stdin or ``-c``. The sandbox child needs nothing from ``__main__``, so while it starts, the main
    module is an empty one, which the child does not import."""
    main = sys.modules.get("__main__")
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        if main is not None:
            sys.modules["__main__"] = main


def process_context(preload: Sequence[str] = FORKSERVER_PRELOAD) -> Any:
    """The forkserver context, its server importing ``preload`` once when it starts (a process has
    one fork server: the first start decides what it preloads)."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(preload))
    return context


# --- one sandbox per process ---------------------------------------------------------------------

#: This process's sandbox, under the key "sandbox" (one per process: a worker's one child).
_PROCESS_SANDBOX: dict[str, InferenceSandbox] = {}


def process_sandbox(limits: SandboxLimits | None = None) -> InferenceSandbox:
    """This process's sandbox, started with ``limits`` or restarted when they changed; closed when
    the process exits."""
    limits = limits or SandboxLimits()
    current = _PROCESS_SANDBOX.get("sandbox")
    if current is not None and current.limits != limits:
        current.close()
        current = None
    if current is None:
        current = _PROCESS_SANDBOX["sandbox"] = InferenceSandbox(limits)
        atexit.register(current.close)
    return current


# --- the child -----------------------------------------------------------------------------------

def _status_kib(field_name: str) -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field_name + ":"):
                return int(line.split()[1])
    return 0


def _reset_peak() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as refs:
            refs.write("5")
        return True
    except OSError:
        return False


def _confine(limits: SandboxLimits) -> None:
    """Die with the parent, leave Ctrl-C to it, no core files, and the address-space limit."""
    import resource

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        import ctypes

        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        if os.getppid() == 1:  # the parent is already gone
            os._exit(0)
    with contextlib.suppress(ValueError, OSError):
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    size = _status_kib("VmSize") * 1024 if sys.platform.startswith("linux") else 0
    if size:
        _, hard = resource.getrlimit(resource.RLIMIT_AS)
        limit = size + limits.memory_mib * MiB
        if hard != resource.RLIM_INFINITY:
            limit = min(limit, hard)
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


_ORT_STATUS = re.compile(r"running (\w+) node.*?Status Message: (?:\S+:\d+ [^(]*\([^)]*\) )?(.*)$", re.DOTALL)


def _one_line(error: BaseException) -> str:
    """Why an agent's call failed, in one line: onnxruntime's status without its C++ signature, a
    policy's own complaint as it is."""
    text = " ".join(str(error).split())
    found = _ORT_STATUS.search(text)
    if found:
        text = f"onnxruntime failed in a {found.group(1)} node: {found.group(2)}"
    text = text[:400]
    if isinstance(error, MemoryError) or "alloc" in text.lower():
        return f"ran out of memory ({text or type(error).__name__})"
    if type(error).__name__ == "PolicyOutputError":
        return text.split(" ", 1)[1] if " output " in text else text  # drop the policy's name
    return f"failed: {text}" if found else f"failed: {type(error).__name__}: {text}"


class _Child:
    """The child's side: the loaded agents and the operations the parent asks for."""

    def __init__(self, progress: Any, emit: Callable[[Any], None] | None = None) -> None:
        self.progress = progress
        self.emit = emit or (lambda payload: None)
        self.policies: dict[str, Policy] = {}
        self.baseline: dict[str, int] = {}  # agent -> the child's resident KiB before it was loaded

    def _mark(self, index: int, rows: int = 0, timed: bool = True) -> None:
        self.progress[0] = float(index)
        self.progress[3] = float(rows)
        self.progress[1] = time.monotonic() if timed else 0.0

    def _unmark(self) -> None:
        self.progress[1] = 0.0

    def tick(self) -> None:
        """A task's step is done (the parent sees the counter move: progress)."""
        self.progress[2] += 1.0

    def load(self, items: list[tuple[str, AgentSource]]) -> tuple[dict[str, Any], dict[str, tuple[str, str]]]:
        from arena_league.policies.artifacts import load_agent
        from arena_league.policies.spaces import game_action_spec

        self.policies = {}  # the agents held before go first
        infos: dict[str, dict[str, Any]] = {}
        errors: dict[str, tuple[str, str]] = {}
        for index, (key, source) in enumerate(items):
            self._mark(index)
            with contextlib.suppress(Exception):  # the game's modules belong to the runtime, not to the agent
                game_action_spec(source.game_id, source.action_type)
            _reset_peak()
            before = _status_kib("VmRSS")
            try:
                loaded = load_agent(source.source, source.game_id, action_type=source.action_type,
                                    **({"limits": source.limits} if source.limits is not None else {}))
            except Exception as error:
                text = str(error) if isinstance(error, artifact_errors.ArtifactError) else _one_line(error)
                errors[key] = (type(error).__name__, text)
                continue
            self.policies[key] = loaded.policy
            self.baseline[key] = before
            policy = loaded.policy
            infos[key] = {"spec": policy.spec, "recurrent": bool(policy.recurrent),
                          "state_shape": tuple(loaded.info.state_shape), "name": policy.name, "info": loaded.info,
                          "load_mib": max(0, _status_kib("VmHWM") - before) / 1024}
        self._unmark()
        return infos, errors

    def run(self, task: Callable[..., Any], args: tuple) -> Any:
        return task(self, self.emit, *args)

    def call(self, key: str, operation: str, *args: Any) -> tuple[str, Any]:
        """One operation of one agent (see :meth:`InferenceSandbox.call`): ``("ok", value)`` or
        ``("error", reason)``."""
        if operation == "measure":
            return self.measure(key, *args)
        self._mark(0, len(args[0]))
        try:
            if operation == "forward":
                return "ok", self._forward(key, *args)
            from arena_league.policies.families import PolicyGroup

            obs, uniforms, mask, state = args
            policy = self.policies[key]
            actions, next_state, failures = self._checked(PolicyGroup(policy, (0,)), *policy.act(
                obs, uniforms, mask, state), np.zeros(len(obs), np.int64))
            return ("error", failures[0]) if failures else ("ok", (actions, next_state))
        except Exception as error:
            return "error", _one_line(error)
        finally:
            self._unmark()

    def guarded(self, index: int, group: Any, obs: np.ndarray, uniforms: np.ndarray, owners: np.ndarray,
                mask: np.ndarray | None, state: np.ndarray | None, *, limit: int | None = None, timed: bool = True
                ) -> tuple[Any, Any, dict[int, str]]:
        """One call of ``group`` (a stacked or single policy unit: ``.policy``, ``.stacked``,
        ``.act(obs, uniforms, owners, mask, state)``), marked as call ``index`` while it runs, in
        chunks of at most ``limit`` rows: ``(actions, next_state, failures)``, where failures names
        the owners (positions in the unit) whose call failed (an error, invalid actions or state)
        and why; their rows are not valid. An untimed call (``timed=False``: a unit of trusted
        agents only) is marked but not held to the call budget; a timed one of fewer rows than
        ``limit`` is padded up to the next size validation timed (:func:`padded_rows`)."""
        n = len(obs)
        if limit is not None and n > limit:
            parts = [self.guarded(index, group, obs[i: i + limit], uniforms[i: i + limit], owners[i: i + limit],
                                  None if mask is None else mask[i: i + limit],
                                  None if state is None else state[i: i + limit], limit=limit, timed=timed)
                     for i in range(0, n, limit)]
            return _joined(parts, n)
        size = padded_rows(n, limit) if limit is not None and timed and n else n
        if size > n:
            # copies of the last row: the agent computes rows apart (validation checks), so they change nothing
            def pad(array: Any) -> Any:
                return None if array is None else np.concatenate([array, np.repeat(array[-1:], size - n, axis=0)])

            actions, next_state, failures = self.guarded(index, group, pad(obs), pad(uniforms), pad(owners),
                                                         pad(mask), pad(state), limit=limit, timed=timed)
            return (None if actions is None else actions[:n],
                    None if next_state is None else np.asarray(next_state)[:n], failures)
        self._mark(index, n, timed)
        try:
            actions, next_state = group.act(obs, uniforms, owners, mask, state)
        except Exception as error:
            answer = self._act_apart(group, obs, uniforms, owners, mask, state, error)
        else:
            answer = self._checked(group, np.asarray(actions), next_state, owners)
        self._unmark()
        return answer

    @staticmethod
    def _checked(group: Any, actions: Any, next_state: Any, owners: np.ndarray) -> tuple:
        """The answer to a call, with the owners of invalid actions or states named as failed."""
        spec = group.policy.spec
        n = len(owners)
        actions = np.asarray(actions)
        problem, bad = invalid_actions(spec, actions, n)
        errors: dict[int, str] = {}
        if problem is None and group.policy.recurrent:
            state = None if next_state is None else np.asarray(next_state)
            shape = (n, *group.policy.initial_state(1).shape[1:])
            if state is None or state.shape != shape:
                problem = f"returned a recurrent state of shape {None if state is None else state.shape}, not {shape}"
            elif not np.isfinite(state).all():
                problem, bad = None, np.flatnonzero(~np.isfinite(state.reshape(n, -1)).all(axis=1))
                for owner in np.unique(owners[bad]).tolist():
                    errors[owner] = "returned a recurrent state holding NaN or infinite values"
        if problem is not None:
            return None, None, dict.fromkeys(np.unique(owners).tolist(), problem)
        for row in bad.tolist():
            errors.setdefault(int(owners[row]), f"returned the invalid action {actions[row].tolist()}; valid: "
                                                f"{valid_actions_text(spec)}")
        return actions, next_state, errors

    def _act_apart(self, group: Any, obs, uniforms, owners, mask, state, error: Exception) -> tuple:
        """A failed call of a stacked group, run member by member to find the failing members."""
        from arena_league.policies.families import PolicyGroup

        if not group.stacked:
            return None, None, {0: _one_line(error)}
        actions: Any = None
        next_state: Any = None
        errors: dict[int, str] = {}
        for owner in np.unique(owners).tolist():
            rows = np.flatnonzero(owners == owner)
            member = PolicyGroup(group.policy.member(owner), (0,))
            try:
                part, part_state = member.act(obs[rows], uniforms[rows], np.zeros(len(rows), np.int64),
                                              None if mask is None else mask[rows],
                                              None if state is None else state[rows])
            except Exception as member_error:
                errors[owner] = _one_line(member_error)
                continue
            part, part_state, problems = self._checked(member, np.asarray(part), part_state,
                                                       np.zeros(len(rows), np.int64))
            if problems:
                errors[owner] = problems[0]
                continue
            if actions is None:
                actions = np.zeros((len(obs), *part.shape[1:]), dtype=part.dtype)
            actions[rows] = part
            if part_state is not None:
                if next_state is None:
                    next_state = np.zeros((len(obs), *np.shape(part_state)[1:]), dtype=np.float32)
                next_state[rows] = part_state
        return actions, next_state, errors

    def _forward(self, key: str, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, Any]:
        return raw_outputs(self.policies[key], obs, state)

    def measure(self, key: str, obs: np.ndarray, state: np.ndarray | None, repeats: int) -> tuple[str, Any]:
        seconds = []
        exact = _reset_peak()
        before = _status_kib("VmRSS")
        try:
            for index in range(repeats):
                self._mark(index, len(obs))
                tick = time.perf_counter()
                self._forward(key, obs, state)
                seconds.append(time.perf_counter() - tick)
        except Exception as error:
            return "error", _one_line(error)
        finally:
            self._unmark()
        peak = _status_kib("VmHWM") if exact else _status_kib("VmRSS")
        # memory the agent holds since before it was loaded, at the forwards' peak (what earlier calls
        # left in onnxruntime's arena included), and what these forwards added
        return "ok", {"seconds": seconds, "peak_mib": max(0, peak - self.baseline.get(key, before)) / 1024,
                      "forward_mib": max(0, peak - before) / 1024}


def _warm_onnxruntime() -> None:
    """Run a one-node model once, so that onnxruntime's environment (tens of MiB, made on the first
    session) belongs to the child's runtime, not to the first agent it loads."""
    import onnxruntime
    from onnx import TensorProto, helper

    value = helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])
    output = helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])
    graph = helper.make_graph([helper.make_node("Identity", ["x"], ["y"])], "warm", [value], [output])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    from arena_league.policies.onnx_policy import session_options

    session = onnxruntime.InferenceSession(model.SerializeToString(),
                                           session_options(), providers=["CPUExecutionProvider"])
    session.run(None, {"x": np.zeros(1, np.float32)})


def _joined(parts: list[tuple[Any, Any, dict[int, str]]], n: int) -> tuple[Any, Any, dict[int, str]]:
    """The answers of consecutive chunks of one call, as one answer of ``n`` rows."""
    failures: dict[int, str] = {}
    for _, _, errors in parts:
        for owner, reason in errors.items():
            failures.setdefault(owner, reason)
    if any(actions is None for actions, _, _ in parts):
        return None, None, failures
    actions = np.concatenate([actions for actions, _, _ in parts])
    states = [state for _, state, _ in parts]
    return actions, (None if any(s is None for s in states) else np.concatenate(states)), failures


def _child_main(conn: Any, progress: Any, limits: SandboxLimits) -> None:
    _confine(limits)
    import onnxruntime
    import torch

    torch.set_num_threads(1)
    onnxruntime.set_default_logger_severity(4)  # failures come back as reasons, not as log lines
    _warm_onnxruntime()
    child = _Child(progress, lambda payload: conn.send(_Emitted(payload)))
    operations = {"load": child.load, "call": child.call, "run": child.run}
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        try:
            reply = operations[message[0]](*message[1:])
        except Exception:  # outside any agent's own call: a bug, or the runtime out of memory
            reply = _Failed(traceback.format_exc())
        try:
            conn.send(reply)
        except (BrokenPipeError, OSError):
            return
