"""Agent references: a small, picklable name for an agent that any process can load.

The process-pool and Ray backends never ship torch objects between processes: each worker gets
:class:`AgentRef` records (a few strings) and loads the policies itself through
:mod:`arena_league.policies`, once per worker process. A reference names

* ``scripted``: a built-in agent by name (``random``, ``heuristic``);
* ``onnx``: an ONNX file in the league's I/O convention (:mod:`arena_league.policies.onnx_policy`);
* ``arena-policy``: an ``arena-policy`` folder (``manifest.json`` + ``weights.safetensors``).

Its text form is ``<kind>:<name or path>`` (``scripted:heuristic``, ``onnx:/league/ab12.onnx``).

A reference marked ``sandboxed`` (the league marks every submitted agent so) computes in the
process's :class:`~arena_league.policies.sandbox.InferenceSandbox`, a child process with memory
and time budgets: ``play_matches`` plays the matches of such agents inside it
(:mod:`arena_league.matchmaking.sandboxed`), and :func:`load_agents` gives a handle whose every
call goes there. The others load in the process itself.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from arena_league.policies.policy import Policy
from arena_league.policies.sandbox import AgentSource, SandboxLimits

__all__ = ["AGENT_KINDS", "AgentRef", "load_agents"]

#: Kinds of agent a reference can name.
AGENT_KINDS = ("scripted", "onnx", "arena-policy")


@dataclass(frozen=True)
class AgentRef:
    """A loadable name of one agent for one game (see the module docstring)."""

    kind: str
    name: str
    """The scripted agent's name, or the artifact's path."""
    game_id: str
    action_type: str | None = None
    """The game's action variant the agent plays (None: the game's default)."""
    sandboxed: bool = False
    """Load and run the agent in the process's inference sandbox (see the module docstring)."""

    def __post_init__(self) -> None:
        if self.kind not in AGENT_KINDS:
            raise ValueError(f"unknown agent kind {self.kind!r}; valid: {', '.join(AGENT_KINDS)}")
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"an agent reference needs a name or path, got {self.name!r}")

    @classmethod
    def parse(cls, text: str, game_id: str, action_type: str | None = None, sandboxed: bool = False) -> AgentRef:
        """From the text form ``<kind>:<name or path>``, e.g. ``scripted:random``."""
        kind, sep, name = text.partition(":")
        if not sep or kind not in AGENT_KINDS:
            raise ValueError(f"agent reference {text!r} is not '<kind>:<name or path>' with kind one of "
                             f"{', '.join(AGENT_KINDS)} (e.g. 'scripted:heuristic', 'onnx:agent.onnx')")
        return cls(kind, name, game_id, action_type, sandboxed)

    @property
    def key(self) -> str:
        """The text form, ``<kind>:<name or path>``."""
        return f"{self.kind}:{self.name}"

    def load(self, sandbox_limits: SandboxLimits | None = None) -> Policy:
        """The agent's :class:`Policy`, loaded through :mod:`arena_league.policies` (artifacts are
        read safely: no pickle, TorchScript or .pt2; spaces are checked against the game). A
        sandboxed reference loads alone into the process's sandbox; load several at once with
        :func:`load_agents`."""
        if self.sandboxed:
            return load_agents({self.key: self}, sandbox_limits)[self.key]
        if self.kind == "scripted":
            from arena_league.policies.scripted import scripted_policy

            return scripted_policy(self.name, self.game_id, self.action_type)
        return _load_artifact(self)

    def sandbox_source(self) -> AgentSource:
        """What the inference sandbox loads for this reference (a scripted agent by its key, an
        artifact by its path)."""
        return AgentSource(self.name if self.kind != "scripted" else self.key, self.game_id, self.action_type)

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "name": self.name, "game_id": self.game_id, "action_type": self.action_type,
                "sandboxed": self.sandboxed}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> AgentRef:
        return cls(str(data["kind"]), str(data["name"]), str(data["game_id"]), data.get("action_type"),
                   bool(data.get("sandboxed", False)))


def _load_artifact(ref: AgentRef) -> Policy:
    from arena_league.policies.artifacts import load_policy

    return load_policy(ref.name, ref.game_id, action_type=ref.action_type)


def load_agents(agents: Mapping[str, AgentRef | Policy], sandbox_limits: SandboxLimits | None = None
                ) -> dict[str, Policy]:
    """Loads every reference of ``agents`` (policies pass through); a reference named under several
    keys is loaded once, so those keys share one policy (and one batched call). Sandboxed references
    are loaded together into the process's sandbox (started, or restarted, with ``sandbox_limits``),
    which then holds exactly those agents."""
    loaded: dict[AgentRef, Policy] = {}
    sandboxed = [a for a in dict.fromkeys(agents.values()) if isinstance(a, AgentRef) and a.sandboxed]
    if sandboxed:
        from arena_league.policies.sandbox import process_sandbox

        proxies = process_sandbox(sandbox_limits).load({ref.key: ref.sandbox_source() for ref in sandboxed})
        loaded.update({ref: proxies[ref.key] for ref in sandboxed})
    out: dict[str, Policy] = {}
    for key, agent in agents.items():
        if isinstance(agent, AgentRef):
            if agent not in loaded:
                loaded[agent] = agent.load()
            out[key] = loaded[agent]
        elif isinstance(agent, Policy):
            out[key] = agent
        else:
            raise TypeError(f"agent {key!r} is a {type(agent).__name__}; give an AgentRef or a Policy")
    return out
