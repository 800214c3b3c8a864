"""The inference sandbox: submitted agents run in a child process, bounded in memory and in time.

An ONNX graph can loop for 10^15 iterations, allocate a 12 GB tensor, or behave only once the
batch passes some size; a league worker that ran it in its own process would hang, or be killed
with every match it holds. So the forwards of submitted agents run in an :class:`InferenceSandbox`:
one child process per worker (per process that plays matches), holding every submitted agent that
process plays, with

* an address-space limit (``RLIMIT_AS``): the child's size when it starts plus
  :attr:`SandboxLimits.memory_mib`; an allocation past it fails inside the child only;
* a wall-clock budget per call (:attr:`SandboxLimits.call_seconds`, one policy's forward over all
  the seats it holds in one step) and per agent loaded (:attr:`SandboxLimits.load_seconds`);
  the child marks which call it is running in shared memory, so the parent knows whom to blame
  when it kills a child that ran over.

A call over budget, a crash, an allocation failure or an error fails that agent's call only: the
sandbox answers every other call of the step, restarting the child (and reloading its agents)
when it had to die, and reports the agent and the reason. What a failure means is the caller's
business: the match engine makes the agent forfeit the matches it has in flight, validation
rejects it. Agents of one architecture are stacked into one forward in the child as in the engine
(:func:`~arena_league.policies.families.stack_policies`); when such a stacked call fails, the
sandbox runs its members one by one to find the agent at fault, so no innocent agent forfeits.

The sandbox never hands an agent more rows in one call than :func:`largest_batch` of its game:
the size validation probes at, so an agent that passed validation never sees a batch it was not
tried on. Calls are split to that size when the engine's batch is larger.

The child is forked from the multiprocessing fork server (which has the policy modules imported),
dies with its parent (``PR_SET_PDEATHSIG``), ignores Ctrl-C (the parent handles it), and computes
exactly as the parent would: the same policies on the same inputs give the same outputs, so a
match's result does not depend on whether its agents were sandboxed.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import multiprocessing
import os
import re
import signal
import sys
import time
import types
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from arena_league.policies import errors as artifact_errors
from arena_league.policies.policy import ActionSpec, Policy, invalid_actions, valid_actions_text

__all__ = [
    "ENGINE_BATCH_MATCHES",
    "FORKSERVER_PRELOAD",
    "AgentSource",
    "ForfeitError",
    "GroupCall",
    "GroupOutcome",
    "InferenceSandbox",
    "SandboxLimits",
    "SandboxedPolicy",
    "largest_batch",
    "process_sandbox",
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

    def __post_init__(self) -> None:
        for name in ("memory_mib", "agent_memory_mib"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 16:
                raise ValueError(f"{name} must be a whole number of MiB, at least 16, not {value!r}")
        for name in ("call_seconds", "load_seconds"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= 3600:
                raise ValueError(f"{name} must be a number of seconds in (0, 3600], not {value!r}")


def largest_batch(game_id: str) -> int:
    """The most rows one policy call gets in ``game_id``: every seat of every match the engine keeps
    in flight (an agent playing itself, as in its validation match, holds them all)."""
    from arena_league.envs import game_spec

    spec = game_spec(game_id)
    return ENGINE_BATCH_MATCHES * spec.n_teams * spec.players_per_team


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


@dataclass
class GroupCall:
    """One batched call of a group of agents (see :meth:`InferenceSandbox.act_many`): ``owners[i]``
    is the position in the group of the agent playing row ``i``."""

    group: int
    obs: np.ndarray
    uniforms: np.ndarray
    owners: np.ndarray
    mask: np.ndarray | None = None
    state: np.ndarray | None = None


@dataclass
class GroupOutcome:
    """The answer to a :class:`GroupCall`: actions and next state for every row, and the agents (by
    position in the group) whose call failed, with the reason; their rows hold zeros."""

    actions: np.ndarray
    next_state: np.ndarray | None
    failures: dict[int, str] = field(default_factory=dict)


class SandboxedPolicy(Policy):
    """A handle on an agent loaded in a sandbox: a :class:`Policy` whose calls go to the child.

    The match engine batches the calls of every sandboxed agent of a step into one message
    (:meth:`InferenceSandbox.act_many`); called on its own, :meth:`act` raises :class:`ForfeitError`
    when the call fails. An agent that could not be loaded has ``broken`` set (the reason) and fails
    every call."""

    def __init__(self, sandbox: InferenceSandbox, key: str, group: int, position: int, spec: ActionSpec,
                 recurrent: bool, state_shape: tuple[int, ...], name: str, info: Any = None,
                 broken: str | None = None) -> None:
        self.sandbox = sandbox
        self.key = key
        self.group = group
        self.position = position
        self.spec = spec
        self.recurrent = recurrent
        self.state_shape = state_shape
        self.name = name
        self.info = info
        self.broken = broken

    def initial_state(self, n: int) -> np.ndarray | None:
        return np.zeros((n, *self.state_shape), dtype=np.float32) if self.recurrent else None

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        call = GroupCall(self.group, obs, uniforms, np.full(len(obs), self.position, dtype=np.int64), mask, state)
        outcome = self.sandbox.act_many([call])[0]
        if outcome.failures:
            raise ForfeitError(self.key, outcome.failures[self.position])
        return outcome.actions, outcome.next_state

    def forward(self, obs: np.ndarray, state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """The agent's raw outputs (``logits`` or ``action``) and next state, computed in the child."""
        return self.sandbox.forward(self.key, obs, state)

    def measure(self, obs: np.ndarray, state: np.ndarray | None = None, repeats: int = 3) -> dict[str, Any]:
        """Measured in the child: ``seconds`` of each of ``repeats`` forwards over ``obs``, the memory
        the agent holds at their peak since before it was loaded (``peak_mib``: its weights, what its
        earlier calls left allocated, these forwards) and what these forwards added (``forward_mib``);
        raises :class:`ForfeitError` on failure."""
        return self.sandbox.measure(self.key, obs, state, repeats)


class _ChildDied(Exception):
    def __init__(self, index: int | None, reason: str) -> None:
        super().__init__(reason)
        self.index = index
        self.reason = reason


@dataclass
class _Piece:
    """Rows of one group call that go to one child unit (a chunk of at most the game's largest batch)."""

    call: int
    rows: np.ndarray
    unit: int
    owners: np.ndarray  # owners within the child unit


class InferenceSandbox:
    """A child process that loads agents and answers their calls within :class:`SandboxLimits`
    (see the module docstring). Not thread-safe: one caller at a time."""

    def __init__(self, limits: SandboxLimits | None = None) -> None:
        self.limits = limits or SandboxLimits()
        self._process: Any = None
        self._conn: Any = None
        self._progress: Any = None
        self._sources: dict[str, AgentSource] = {}
        self._proxies: dict[str, SandboxedPolicy] = {}
        self._groups: list[list[str]] = []
        self._place: dict[str, tuple[int, int]] = {}  # agent -> (child unit, owner) in the running child
        self._units: list[list[str]] = []  # the running child's units, as agent keys
        self._split: set[str] = set()  # agents the child must not stack (a stacked call of theirs failed)
        self._broken: dict[str, str] = {}  # agents that cannot be loaded, with the reason
        self._load_mib: dict[str, float] = {}
        # per group, the running child's unit and owner of each member (numpy, for routing rows)
        self._group_unit: list[np.ndarray] = []
        self._group_owner: list[np.ndarray] = []
        #: Children started so far (the first, and one after each death).
        self.starts = 0

    # --- loading --------------------------------------------------------------------------------
    def load(self, agents: Mapping[str, AgentSource]) -> dict[str, SandboxedPolicy]:
        """Make the child hold exactly ``agents`` (key -> source) and return a handle per key.

        Loading the same set again returns the same handles at once; another set replaces the
        child's agents (handles of the previous set must not be used again). An agent that fails to
        load (an error, its memory or time budget) gets a handle with ``broken`` set; the others
        load as usual."""
        agents = dict(agents)
        if agents == self._sources and self._proxies:
            return dict(self._proxies)
        self._sources, self._split, self._broken, self._proxies = agents, set(), {}, {}
        infos = self._load_sources()
        self._groups = [list(unit) for unit in self._units] + [[key] for key in agents if key in self._broken]
        self._route()
        for g, members in enumerate(self._groups):
            for position, key in enumerate(members):
                source = agents[key]
                if key in self._broken:
                    spec = _game_spec(source)
                    self._proxies[key] = SandboxedPolicy(self, key, g, position, spec, False, (), key,
                                                         broken=self._broken[key])
                else:
                    info = infos[key]
                    self._proxies[key] = SandboxedPolicy(self, key, g, position, info["spec"], info["recurrent"],
                                                         tuple(info["state_shape"]), info["name"], info["info"])
        return dict(self._proxies)

    def load_one(self, source: AgentSource, key: str = "candidate") -> SandboxedPolicy:
        """Load a single agent (validation); raises the artifact's own error (``ArtifactError``) when
        it cannot be read, and :class:`ForfeitError` when loading runs out of time or memory."""
        self._sources, self._split, self._broken, self._proxies = {key: source}, set(), {}, {}
        try:
            infos = self._load_sources(raise_errors=True)
        except BaseException:
            self._sources = {}
            raise
        if key in self._broken:
            reason = self._broken[key]
            self._sources = {}
            raise ForfeitError(key, reason)
        info = infos[key]
        self._groups = [[key]]
        self._route()
        proxy = SandboxedPolicy(self, key, 0, 0, info["spec"], info["recurrent"], tuple(info["state_shape"]),
                                info["name"], info["info"])
        self._proxies = {key: proxy}
        return proxy

    def memory_of(self, key: str) -> float:
        """MiB the agent ``key`` added to the child when it was loaded."""
        return self._load_mib.get(key, 0.0)

    # --- calls ----------------------------------------------------------------------------------
    def act_many(self, calls: Sequence[GroupCall]) -> list[GroupOutcome]:
        """Answer one step's calls, one per group, in one message to the child (see the module
        docstring for what happens when a call fails)."""
        outcomes = [self._empty_outcome(call) for call in calls]
        failed: dict[str, str] = {}
        for _ in range(len(self._sources) + 2):  # each round retires an agent or splits a unit
            self._ensure_child()
            pieces = self._pieces(calls, failed)
            if not pieces:
                break
            message = ("act", [(p.unit, calls[p.call].obs[p.rows], calls[p.call].uniforms[p.rows], p.owners,
                                None if calls[p.call].mask is None else calls[p.call].mask[p.rows],
                                None if calls[p.call].state is None else calls[p.call].state[p.rows])
                               for p in pieces])
            try:
                answers = self._request(message, self.limits.call_seconds,
                                        [f"a call of {len(p.rows)} rows" for p in pieces])
            except _ChildDied as death:
                self._blame(pieces, death, failed)
                continue
            for piece, (actions, next_state, errors) in zip(pieces, answers):
                outcome = outcomes[piece.call]
                if actions is not None:
                    outcome.actions[piece.rows] = actions
                if outcome.next_state is not None and next_state is not None:
                    outcome.next_state[piece.rows] = next_state
                for owner, reason in errors.items():
                    failed.setdefault(self._units[piece.unit][owner], reason)
            break
        for call, outcome in zip(calls, outcomes):
            group = self._groups[call.group]
            for position in np.unique(call.owners).tolist():
                reason = failed.get(group[position]) or self._broken.get(group[position])
                if reason is not None:
                    outcome.failures[position] = reason
        return outcomes

    def forward(self, key: str, obs: np.ndarray, state: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray | None]:
        """Raw outputs of agent ``key`` (see :meth:`SandboxedPolicy.forward`)."""
        self._require_loaded(key)
        try:
            return self._answer(self._request(("forward", key, obs, state), self.limits.call_seconds, "a forward"),
                                key)
        except _ChildDied as death:
            raise ForfeitError(key, death.reason) from None

    def measure(self, key: str, obs: np.ndarray, state: np.ndarray | None, repeats: int) -> dict[str, Any]:
        """See :meth:`SandboxedPolicy.measure`."""
        self._require_loaded(key)
        try:
            return self._answer(self._request(("measure", key, obs, state, int(repeats)), self.limits.call_seconds,
                                              f"a forward of {len(obs)} rows"), key)
        except _ChildDied as death:
            raise ForfeitError(key, death.reason) from None

    def close(self) -> None:
        """Stop the child (its agents are gone; :meth:`load` starts a new one)."""
        self._stop_child()
        self._sources, self._proxies, self._groups = {}, {}, []

    def __enter__(self) -> InferenceSandbox:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- internals ------------------------------------------------------------------------------
    def _require_loaded(self, key: str) -> None:
        if key in self._broken:
            raise ForfeitError(key, self._broken[key])
        if key not in self._sources:
            raise KeyError(f"agent {key!r} is not loaded in this sandbox")

    @staticmethod
    def _answer(reply: Any, key: str) -> Any:
        status, value = reply
        if status == "error":
            raise ForfeitError(key, value)
        return value

    def _empty_outcome(self, call: GroupCall) -> GroupOutcome:
        proxy = self._proxies[self._groups[call.group][0]]
        n = len(call.obs)
        if proxy.spec.action_type == "discrete":
            actions = np.zeros(n, dtype=np.int64)
        else:
            actions = np.zeros((n, proxy.spec.act_dim), dtype=np.float32)
        state = np.zeros((n, *proxy.state_shape), dtype=np.float32) if proxy.recurrent else None
        return GroupOutcome(actions, state)

    def _pieces(self, calls: Sequence[GroupCall], failed: Mapping[str, str]) -> list[_Piece]:
        """The child calls that answer ``calls``: rows split by child unit, then into chunks of at
        most the game's largest batch; rows of failed and broken agents are left out."""
        pieces = []
        for index, call in enumerate(calls):
            group = self._groups[call.group]
            owners = np.asarray(call.owners, dtype=np.int64)
            units = self._group_unit[call.group][owners]
            keep = units >= 0
            if failed:
                keep &= ~np.asarray([key in failed for key in group], dtype=bool)[owners]
            child_owners = self._group_owner[call.group][owners]
            for unit in np.unique(units[keep]).tolist():
                rows = np.flatnonzero(keep & (units == unit))
                limit = _largest_batch(self._sources[self._units[unit][0]].game_id)
                for start in range(0, len(rows), limit):
                    part = rows[start: start + limit]
                    pieces.append(_Piece(index, part, unit, child_owners[part]))
        return pieces

    def _blame(self, pieces: list[_Piece], death: _ChildDied, failed: dict[str, str]) -> None:
        """The child died during ``pieces[death.index]``: blame its agent, or, for a stacked unit,
        have its members run apart from now on so the next try finds the one at fault."""
        if death.index is None or not 0 <= death.index < len(pieces):
            raise RuntimeError(f"the inference sandbox died outside any agent's call ({death.reason})")
        unit_members = self._units[pieces[death.index].unit]
        if len(unit_members) > 1:
            self._split.update(unit_members)
        else:
            failed.setdefault(unit_members[0], death.reason)

    def _ensure_child(self) -> None:
        """After a death: a new child with the same agents."""
        if self._process is None and self._sources:
            self._load_sources()

    def _spawn(self) -> None:
        context = _process_context()
        parent_end, child_end = context.Pipe()
        self._progress = context.RawArray("d", 2)
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
                infos, errors, units = self._request(("load", [(k, self._sources[k]) for k in keys],
                                                      sorted(self._split)), self.limits.load_seconds, "loading")
            except _ChildDied as death:
                if death.index is None:
                    raise RuntimeError(f"the inference sandbox could not start ({death.reason})") from None
                self._broken[keys[death.index]] = f"could not be loaded: {death.reason}"
                continue
            for key, (kind, text) in errors.items():
                error = getattr(artifact_errors, kind, None)
                if raise_errors and isinstance(error, type) and issubclass(error, artifact_errors.ArtifactError):
                    self._stop_child()
                    raise error(text)
                self._broken[key] = f"could not be loaded: {text}"
            self._units = [list(unit) for unit in units]
            self._place = {key: (u, o) for u, unit in enumerate(self._units) for o, key in enumerate(unit)}
            self._load_mib.update({key: info["load_mib"] for key, info in infos.items()})
            self._route()
            return infos

    def _route(self) -> None:
        """Each group member's unit and owner in the running child (-1: not loaded)."""
        self._group_unit = [np.asarray([self._place.get(k, (-1, -1))[0] for k in g], dtype=np.int64)
                            for g in self._groups]
        self._group_owner = [np.asarray([self._place.get(k, (-1, -1))[1] for k in g], dtype=np.int64)
                             for g in self._groups]

    def _request(self, message: tuple, budget: float, what: str | list[str]) -> Any:
        """Send ``message`` and wait for the answer, killing the child when the item it is working on
        runs past ``budget`` seconds; raises :class:`_ChildDied` naming the item (``what`` says what
        the items are, for the reason)."""
        process, conn, progress = self._process, self._conn, self._progress
        progress[0], progress[1] = -1.0, 0.0
        try:
            conn.send(message)
        except (BrokenPipeError, ConnectionResetError, OSError):
            raise self._died(None, self._exit_reason(process)) from None
        while True:
            try:
                if conn.poll(_POLL_SECONDS):
                    return conn.recv()
            except (EOFError, ConnectionResetError, OSError):
                raise self._died(_item(progress), self._exit_reason(process)) from None
            started = progress[1]
            if started and time.monotonic() - started > budget:
                index = _item(progress)
                process.kill()
                process.join()
                item = what if isinstance(what, str) else what[index] if index is not None else "a call"
                raise self._died(index, f"ran past its {budget:g} s budget for {item} (stopped)")
            if not process.is_alive():
                raise self._died(_item(progress), self._exit_reason(process))

    def _died(self, index: int | None, reason: str) -> _ChildDied:
        self._stop_child()
        return _ChildDied(index, reason)

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
        self._process = self._conn = None  # the units and routes of the dead child stay until the next start
        if conn is not None:
            with contextlib.suppress(OSError):
                conn.close()
        if process is not None:
            if process.is_alive():
                process.kill()
            process.join()


@functools.lru_cache(maxsize=64)
def _largest_batch(game_id: str) -> int:
    return largest_batch(game_id)


def _item(progress: Any) -> int | None:
    index = int(progress[0])
    return None if index < 0 else index


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


def _process_context() -> Any:
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(FORKSERVER_PRELOAD)
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
    """The child's side: loaded agents, their units, and the operations the parent asks for."""

    def __init__(self, progress: Any) -> None:
        self.progress = progress
        self.policies: dict[str, Policy] = {}
        self.units: list[Any] = []
        self.unit_keys: list[list[str]] = []
        self.baseline: dict[str, int] = {}  # agent -> the child's resident KiB before it was loaded

    def _start(self, index: int) -> None:
        self.progress[0] = float(index)
        self.progress[1] = time.monotonic()

    def load(self, items: list[tuple[str, AgentSource]], split: list[str]) -> tuple[str, Any]:
        from arena_league.policies.artifacts import load_agent
        from arena_league.policies.families import PolicyGroup, stack_policies
        from arena_league.policies.spaces import game_action_spec

        self.policies, self.units, self.unit_keys = {}, [], []  # the agents held before go first
        infos: dict[str, dict[str, Any]] = {}
        errors: dict[str, tuple[str, str]] = {}
        for index, (key, source) in enumerate(items):
            self._start(index)
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
        self.progress[1] = 0.0
        keys = list(self.policies)
        apart = set(split)
        stackable = [k for k in keys if k not in apart]
        self.units, self.unit_keys = [], []
        for group in stack_policies([self.policies[k] for k in stackable]):
            self.units.append(group)
            self.unit_keys.append([stackable[m] for m in group.members])
        for key in keys:
            if key in apart:
                self.units.append(PolicyGroup(self.policies[key], (0,)))
                self.unit_keys.append([key])
        return infos, errors, self.unit_keys

    def act(self, calls: list[tuple]) -> list[tuple]:
        answers = []
        for index, (unit, obs, uniforms, owners, mask, state) in enumerate(calls):
            self._start(index)
            group = self.units[unit]
            try:
                actions, next_state = group.act(obs, uniforms, owners, mask, state)
            except Exception as error:
                answers.append(self._act_apart(unit, obs, uniforms, owners, mask, state, error))
                continue
            answers.append(self._checked(group, np.asarray(actions), next_state, owners))
        self.progress[1] = 0.0
        return answers

    @staticmethod
    def _checked(group: Any, actions: np.ndarray, next_state: Any, owners: np.ndarray) -> tuple:
        """The answer to a call, with the owners of invalid actions or states named as failed."""
        spec = group.policy.spec
        n = len(owners)
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

    def _act_apart(self, unit: int, obs, uniforms, owners, mask, state, error: Exception) -> tuple:
        """A failed call of a stacked unit, run member by member to find the failing members."""
        from arena_league.policies.families import PolicyGroup

        group = self.units[unit]
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

    def forward(self, key: str, obs: np.ndarray, state: np.ndarray | None) -> tuple[str, Any]:
        self._start(0)
        try:
            out, next_state = self._forward(key, obs, state)
        except Exception as error:
            return "error", _one_line(error)
        finally:
            self.progress[1] = 0.0
        return "ok", (out, next_state)

    def _forward(self, key: str, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, Any]:
        policy = self.policies[key]
        forward = getattr(policy, "forward", None)
        if forward is not None:
            out, next_state = forward(obs, state)
            return np.asarray(out, dtype=np.float64), next_state
        uniforms = np.full((obs.shape[0], policy.spec.uniforms_per_seat), 0.5)
        actions, next_state = policy.act(obs, uniforms, None, state)
        return np.asarray(actions, dtype=np.float64).reshape(obs.shape[0], -1), next_state

    def measure(self, key: str, obs: np.ndarray, state: np.ndarray | None, repeats: int) -> tuple[str, Any]:
        seconds = []
        exact = _reset_peak()
        before = _status_kib("VmRSS")
        try:
            for index in range(repeats):
                self._start(index)
                tick = time.perf_counter()
                self._forward(key, obs, state)
                seconds.append(time.perf_counter() - tick)
        except Exception as error:
            return "error", _one_line(error)
        finally:
            self.progress[1] = 0.0
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


def _child_main(conn: Any, progress: Any, limits: SandboxLimits) -> None:
    _confine(limits)
    import onnxruntime
    import torch

    torch.set_num_threads(1)
    onnxruntime.set_default_logger_severity(4)  # failures come back as reasons, not as log lines
    _warm_onnxruntime()
    child = _Child(progress)
    operations = {"load": child.load, "act": child.act, "forward": child.forward, "measure": child.measure}
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        try:
            reply = operations[message[0]](*message[1:])
        except MemoryError as error:  # outside any agent's own call: still answer, and name it
            reply = ("error", _one_line(error))
        try:
            conn.send(reply)
        except (BrokenPipeError, OSError):
            return
