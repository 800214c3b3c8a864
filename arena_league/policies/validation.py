"""Submission validation: is this artifact an agent the league can rank?

Arena (Song et al., AAAI 2020) ranks submitted agents against a base population; before a
submission enters the league it must be safe to load and able to play. As Kaggle's simulation
competitions do, the last check is a *validation match* in which every seat is played by a copy
of the candidate; it must finish without error. The stages, each written to the log:

1. ``read``: size limits (by ``stat``, before reading) and format (no pickle, TorchScript, .pt2);
2. ``load``: in an inference sandbox (:mod:`arena_league.policies.sandbox`: a child process
   with a memory limit and a time budget), the agent's inputs and outputs match the game's spaces;
3. ``size``: at the largest batch the engine hands a policy
   (:func:`~arena_league.policies.sandbox.largest_batch`, rows of real play), the memory the agent
   holds (loaded, plus its forwards' peak) must stay within
   :attr:`~arena_league.policies.sandbox.SandboxLimits.agent_memory_mib`; then at that size and at
   every other size the engine hands a call (:func:`~arena_league.policies.sandbox.timed_batch_sizes`:
   the sandbox pads every call of a submitted agent up to one of them), the time of a forward (the
   median of three) must stay within half the sandbox's budget per call (headroom for a busy
   machine) and within the time a step allows (past it, the agent would draw on its overage bank
   every step). The figures are logged, and named in the reason when over. This comes before the
   probes, so an agent that is slow or swells at some size is refused after a few forwards;
4. ``probe``: on probe observations (random normal, random uniform in [-1, 1], zeros, real
   observations from a few steps of random play, and those of the largest batch) the outputs are
   finite, continuous actions lie in [-1, 1], the same input gives the same output, and a row's
   output does not depend on the other rows of the batch (the league batches seats of many
   matches together);
5. ``match``: a short match (``match_cycles`` steps at most) through ``make(game_id)`` and the
   env's array API, all seats played by the candidate, within ``max_seconds``.

Every forward runs in the sandbox, each call within the budget: a graph that loops for ever, or
allocates past the limit, is rejected with that reason instead of hanging or killing the caller.
A failure stops at its stage; :class:`ValidationResult` carries the reason (one line, for the
agent's ``rejected`` status) and the whole log (kept by the registry).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from arena_league.envs import game_spec, make
from arena_league.policies.artifacts import (
    DEFAULT_LIMITS,
    AgentArtifact,
    AgentInfo,
    ArtifactLimits,
    read_artifact,
)
from arena_league.policies.errors import ArtifactError
from arena_league.policies.onnx_policy import PolicyOutputError
from arena_league.policies.policy import ActionSpec, Policy
from arena_league.policies.sandbox import (
    AgentSource,
    ForfeitError,
    InferenceSandbox,
    SandboxedPolicy,
    SandboxLimits,
    largest_batch,
    timed_batch_sizes,
)
from arena_league.policies.scripted import RandomPolicy
from arena_league.policies.spaces import action_types
from arena_league.policies.threads import torch_threads

#: Relative tolerance when comparing a row computed alone with the same row in a batch.
BATCH_TOLERANCE = 1e-4
#: Rows of each probe set a built-in (scripted) agent answers: a search agent takes a while per row.
SCRIPTED_PROBE_ROWS = 2
#: Share of the sandbox's budget per call a forward at the largest batch may take in validation.
TIME_HEADROOM = 0.5


@dataclass(frozen=True)
class ValidationResult:
    """The verdict on one submission."""

    ok: bool
    #: One line saying why it was rejected; None when accepted.
    reason: str | None
    #: The full validation log (text), one line per check.
    log: str
    game_id: str
    digest: str | None = None
    #: What the agent is (kind, spaces, family...) once it could be loaded.
    spec: AgentInfo | None = None
    seconds: float = 0.0
    #: The validation match: steps played and each team's result.
    match: dict[str, Any] = field(default_factory=dict)
    #: At the largest batch: ``rows``, ``seconds`` (median forward), ``memory_mib`` (load + peak);
    #: ``timed``: ``[rows, seconds]`` of the median forward at every size the engine hands a call.
    size: dict[str, Any] = field(default_factory=dict)
    #: The artifact error class that stopped validation at reading or loading (e.g.
    #: ``"CorruptArtifactError"``), None otherwise.
    error: str | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"ok": self.ok, "reason": self.reason, "log": self.log, "game_id": self.game_id, "digest": self.digest,
                "spec": self.spec.as_dict() if self.spec else None, "seconds": self.seconds, "match": self.match,
                "size": self.size, "error": self.error}


class _Rejected(Exception):
    """Raised inside validation to stop at the failing stage with its reason (and, for an artifact
    error, its class name)."""

    def __init__(self, reason: str, error: str | None = None) -> None:
        super().__init__(reason)
        self.error = error


def validate_submission(source: str | os.PathLike[str] | AgentArtifact, game_id: str, *,
                        action_type: str | None = None, limits: ArtifactLimits = DEFAULT_LIMITS, n_probes: int = 32,
                        match_cycles: int = 200, seed: int = 0, max_seconds: float = 120.0,
                        sandbox_limits: SandboxLimits | None = None,
                        sandbox: InferenceSandbox | None = None) -> ValidationResult:
    """Validate an agent for ``game_id`` (see the module docstring for the stages).

    Args:
        source: an ONNX file, an arena-policy folder, ``scripted:<name>``, or an artifact read already.
        game_id: the game it is submitted to. An unknown id raises ``ValueError`` (the caller's
            mistake, not the submission's).
        action_type: the game's action variant (default: the one the agent declares).
        limits: size limits.
        n_probes: rows of each random probe set.
        match_cycles: length cap of the validation match.
        seed: seed of the probes and of the validation match.
        max_seconds: time allowed for the validation match.
        sandbox_limits: the budgets the agent runs within (memory, time per call, time to load,
            memory an agent may add); default :class:`SandboxLimits`.
        sandbox: a sandbox to load the agent into (it then holds only this agent); default a new
            one, stopped at the end.
    """
    action_types(game_id)  # unknown game: ValueError listing the valid ids
    lines: list[str] = []
    start = time.perf_counter()
    state: dict[str, Any] = {"digest": None, "spec": None, "match": {}, "size": {}}
    own = sandbox is None
    sandbox = InferenceSandbox(sandbox_limits) if sandbox is None else sandbox

    def log(stage: str, message: str) -> None:
        lines.append(f"[{stage}] {message}")

    def verdict(reason: str | None, error: str | None = None) -> ValidationResult:
        return ValidationResult(reason is None, reason, "\n".join(lines) + "\n", game_id, state["digest"],
                                state["spec"], time.perf_counter() - start, state["match"], state["size"], error)

    # Tiny forwards run far faster on one thread than with OpenMP's hand-offs on a busy machine.
    try:
        with torch_threads(1):
            artifact = _stage_read(source, limits, log)
            state["digest"] = artifact.digest
            policy = _stage_load(sandbox, artifact, game_id, action_type, limits, log)
            info = state["spec"] = policy.info
            real = _real_observations(game_id, info.action_type, info.obs_dim, seed)
            if info.kind == "scripted":
                # the league's own code: a search agent's time per move is bounded by its budget
                # (policies.scripted.SEARCH_LIMITS), so the gate of foreign code does not time it,
                # and a few rows show it plays the game's spaces
                big, real, n_probes = None, real[:SCRIPTED_PROBE_ROWS], min(n_probes, SCRIPTED_PROBE_ROWS)
                log("size", f"{info.name} is a built-in agent: not timed at the largest batch")
            else:
                big = _largest_batch_observations(real, game_id, seed)
                state["size"] = _stage_size(sandbox, policy, big, log)
            _stage_probe(policy, info, real, big, n_probes, seed, log)
            state["match"] = _stage_match(policy, game_id, info, match_cycles, seed, max_seconds, log)
    except _Rejected as rejection:
        reason = str(rejection)
        log("result", f"rejected: {reason}")
        return verdict(reason, rejection.error)
    finally:
        if own:
            sandbox.close()
    log("result", f"accepted in {time.perf_counter() - start:.2f} s")
    return verdict(None)


def _stage_read(source: Any, limits: ArtifactLimits, log: Any) -> AgentArtifact:
    try:
        artifact = source if isinstance(source, AgentArtifact) else read_artifact(source, limits)
    except (ArtifactError, OSError) as error:
        raise _Rejected(str(error), type(error).__name__) from None
    log("read", f"{artifact.kind} artifact from {artifact.source}: {artifact.size_bytes} bytes, "
                f"sha256 {artifact.digest}")
    return artifact


def _stage_load(sandbox: InferenceSandbox, artifact: AgentArtifact, game_id: str, action_type: str | None,
                limits: ArtifactLimits, log: Any) -> SandboxedPolicy:
    try:
        policy = sandbox.load_one(AgentSource(artifact, game_id, action_type, limits))
    except ArtifactError as error:
        raise _Rejected(str(error), type(error).__name__) from None
    except ForfeitError as error:
        raise _Rejected(error.reason) from None
    info = policy.info
    out = f"{info.n_actions} actions" if info.action_type == "discrete" else f"{info.act_dim} action components"
    extra = []
    if info.family:
        extra.append(f"family {info.family}")
    if info.recurrent:
        extra.append(f"recurrent state {list(info.state_shape)}")
    if info.fixed_batch is not None:
        extra.append(f"fixed batch {info.fixed_batch} (run in chunks of {info.fixed_batch} rows; export with a "
                     "dynamic batch dimension to be faster)")
    log("load", f"{policy.name} plays {game_id}: obs float32[N, {info.obs_dim}] -> {info.action_type}, {out}"
                + (f"; {', '.join(extra)}" if extra else "")
                + f"; loaded in a sandbox, adding {sandbox.memory_of(policy.key):.1f} MiB")
    return policy


def _real_observations(game_id: str, action_type: str, obs_dim: int, seed: int, steps: int = 16) -> np.ndarray:
    """Observations of every seat over a few steps of random play."""
    env = make(game_id, action_type=action_type)
    rng = np.random.default_rng(seed)
    obs = env.reset_arrays(seed)
    random = RandomPolicy(_env_spec(env, obs_dim))
    rows = [obs[:, :obs_dim]]
    for _ in range(steps):
        actions, _ = random.act(obs, rng.random((obs.shape[0], random.spec.uniforms_per_seat)),
                                env.rules.action_mask())
        obs, _, terminated, truncated = env.step_arrays(actions)
        rows.append(obs[:, :obs_dim])
        if terminated or truncated:
            break
    return np.concatenate(rows).astype(np.float32)


def _env_spec(env: Any, obs_dim: int) -> ActionSpec:
    rules = env.rules
    if rules.action_type == "discrete":
        return ActionSpec("discrete", obs_dim, n_actions=rules.n_actions)
    return ActionSpec("continuous", obs_dim, act_dim=rules.act_dim)


def _largest_batch_observations(real: np.ndarray, game_id: str, seed: int) -> np.ndarray:
    """Rows of real play, as many as the largest batch, each made its own by a little noise."""
    rows = largest_batch(game_id)
    noise = np.random.default_rng([seed, 1]).normal(0.0, 0.05, (rows, real.shape[1]))
    return (real[np.arange(rows) % len(real)] + noise).astype(np.float32)


def _stage_probe(policy: SandboxedPolicy, info: AgentInfo, real: np.ndarray, big: np.ndarray | None, n_probes: int,
                 seed: int, log: Any) -> None:
    rng = np.random.default_rng(seed)
    obs_dim = info.obs_dim
    probes = {
        "random normal": rng.standard_normal((n_probes, obs_dim)).astype(np.float32),
        "random uniform [-1, 1]": rng.uniform(-1.0, 1.0, (n_probes, obs_dim)).astype(np.float32),
        "zeros": np.zeros((1, obs_dim), np.float32),
        "real (random play)": real,
    }
    if big is not None:
        probes[f"largest batch ({len(big)} rows of real play)"] = big
    if info.kind == "scripted":
        output = "actions"
    else:
        output = "logits" if info.action_type == "discrete" else "action"
    for label, obs in probes.items():
        n = obs.shape[0]
        state = policy.initial_state(n)
        if state is not None:
            state = rng.standard_normal(state.shape).astype(np.float32) * 0.5 if label != "zeros" else state
        try:
            out, next_state = policy.forward(obs, state)
            again, _ = policy.forward(obs, state)
            alone = [policy.forward(obs[i: i + 1], state[i: i + 1] if state is not None else None)[0]
                     for i in range(min(n, 4))]
        except ForfeitError as error:
            raise _Rejected(f"on probe observations ({label}) it {error.reason}") from None
        except (ArtifactError, ValueError, RuntimeError) as error:
            raise _Rejected(f"fails on probe observations ({label}): {error}") from None
        bad = ~np.isfinite(out).all(axis=1)
        if bad.any():
            kinds = "NaN" if np.isnan(out).any() else "infinite values"
            raise _Rejected(f"outputs {kinds} on probe observations ({label}): {output} of {int(bad.sum())} of {n} "
                            f"rows (first row {int(np.argmax(bad))}) are not finite")
        if next_state is not None and not np.isfinite(next_state).all():
            raise _Rejected(f"state_out holds NaN or infinite values on probe observations ({label})")
        if info.action_type == "continuous" and np.abs(out).max(initial=0.0) > 1.0 + 1e-6:
            raise _Rejected(f"action out of range on probe observations ({label}): max |action| is "
                            f"{np.abs(out).max():.4g}; continuous actions lie in [-1, 1] (end the network with tanh)")
        if not np.array_equal(out, again):
            raise _Rejected(f"outputs differ for the same input ({label}); the agent must be deterministic "
                            "(randomness comes from the engine's uniforms; remove random operators)")
        for i, row in enumerate(alone):
            if not np.allclose(row[0], out[i], rtol=BATCH_TOLERANCE, atol=BATCH_TOLERANCE):
                raise _Rejected(f"the output for a row depends on the other rows of the batch ({label}, row {i}: "
                                f"max difference {np.abs(row[0] - out[i]).max():.3g}); each observation must be "
                                "processed on its own (no batch statistics)")
        log("probe", f"{label}: {n} rows, {output} finite, deterministic, batch-independent "
                     f"(range {out.min():.3g} .. {out.max():.3g})")


def _stage_size(sandbox: InferenceSandbox, policy: SandboxedPolicy, obs: np.ndarray, log: Any) -> dict[str, Any]:
    """Memory of a forward at the largest batch, and the time of a forward at every size the engine
    hands a call, against the sandbox's budgets."""
    limits = sandbox.limits
    rows = len(obs)
    figures = _measured(policy, obs, f"at the largest batch ({rows} rows)")
    seconds = float(np.median(figures["seconds"]))
    load_mib = sandbox.memory_of(policy.key)
    memory = max(figures["peak_mib"], load_mib)
    size = {"rows": rows, "seconds": seconds, "memory_mib": memory, "load_mib": load_mib,
            "forward_mib": figures["forward_mib"]}
    if memory > limits.agent_memory_mib:
        raise _Rejected(f"uses too much memory: {memory:.0f} MiB at a forward of {rows} rows (the largest batch the "
                        f"league plays; {load_mib:.0f} MiB once loaded), over the {limits.agent_memory_mib} MiB an "
                        "agent may use; submit a smaller network")
    per_call = limits.call_seconds * TIME_HEADROOM
    budget = min(per_call, limits.step_seconds)
    which = (f"half the {limits.call_seconds:g} s budget per call" if per_call <= limits.step_seconds else
             f"the {limits.step_seconds:g} s a step allows before the agent draws on its overage bank")
    timed = [[rows, seconds]]
    # the largest first (the size most agents are slowest at), then every smaller size a call is padded to
    for batch in [rows, *timed_batch_sizes(rows)[:-1]]:
        if batch != rows:
            part = obs[:batch]
            taken = float(np.median(_measured(policy, part, f"at a batch of {batch} rows")["seconds"]))
            timed.append([batch, taken])
        else:
            taken = seconds
        if taken > budget:
            label = f"{rows} rows (the largest batch the league plays)" if batch == rows else f"{batch} rows"
            raise _Rejected(f"too slow: a forward of {label} takes {1e3 * taken:.0f} ms, over {1e3 * budget:.0f} ms "
                            f"({which}); submit a smaller or faster network")
    size["timed"] = timed
    slowest = max(timed, key=lambda pair: pair[1])
    log("size", f"a forward of {rows} rows (the largest batch) takes {1e3 * seconds:.2f} ms (budget "
                f"{1e3 * budget:.0f} ms) and the agent uses {memory:.1f} MiB (budget {limits.agent_memory_mib} MiB)")
    log("size", f"timed at every batch size the league hands a call ({', '.join(str(b) for b, _ in timed)} rows): "
                f"the slowest, {slowest[0]} rows, takes {1e3 * slowest[1]:.2f} ms")
    return size


def _measured(policy: SandboxedPolicy, obs: np.ndarray, where: str) -> dict[str, Any]:
    """Three forwards of ``obs`` measured in the sandbox; a failure rejects the agent, saying ``where``."""
    try:
        return policy.measure(obs, policy.initial_state(len(obs)), repeats=3)
    except ForfeitError as error:
        raise _Rejected(f"{where} it {error.reason}") from None


def _stage_match(policy: Policy, game_id: str, info: AgentInfo, match_cycles: int, seed: int, max_seconds: float,
                 log: Any) -> dict[str, Any]:
    env = make(game_id, action_type=info.action_type, max_cycles=min(match_cycles, _default_cycles(game_id)))
    rng = np.random.default_rng(seed)
    obs = env.reset_arrays(seed)
    n_seats = obs.shape[0]
    state = policy.initial_state(n_seats)
    k = policy.spec.uniforms_per_seat
    started = time.perf_counter()
    act_seconds = 0.0
    steps = 0
    terminated = truncated = False
    while not (terminated or truncated):
        tick = time.perf_counter()
        try:
            actions, state = policy.act(obs[:, : info.obs_dim], rng.random((n_seats, k)), env.rules.action_mask(),
                                        state)
        except ForfeitError as error:
            raise _Rejected(f"failed in the validation match at step {steps}: it {error.reason}") from None
        except (PolicyOutputError, ArtifactError, ValueError, RuntimeError) as error:
            raise _Rejected(f"failed in the validation match at step {steps}: {error}") from None
        act_seconds += time.perf_counter() - tick
        try:
            obs, _, terminated, truncated = env.step_arrays(actions)
        except ValueError as error:
            raise _Rejected(f"played an invalid action in the validation match at step {steps}: {error}") from None
        steps += 1
        if time.perf_counter() - started > max_seconds:
            raise _Rejected(f"too slow: the validation match was not over after {max_seconds:g} s ({steps} steps, "
                            f"{1e3 * act_seconds / steps:.1f} ms per step for {n_seats} seats)")
    result = [float(x) for x in env.team_result()]
    log("match", f"{n_seats} seats, all played by the candidate: {steps} steps ("
                 f"{'ended by the rules' if terminated else 'length cap'}), team results {result}, "
                 f"{1e3 * act_seconds / max(steps, 1):.2f} ms per step to act for {n_seats} seats")
    return {"steps": steps, "terminated": terminated, "team_result": result, "seats": n_seats,
            "act_ms_per_step": 1e3 * act_seconds / max(steps, 1)}


def _default_cycles(game_id: str) -> int:
    return int(game_spec(game_id).rules.default_max_cycles)
