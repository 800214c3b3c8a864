"""Submission validation: is this artifact an agent the league can rank?

Arena (Song et al., AAAI 2020) ranks submitted agents against a base population; before a
submission enters the league it must be safe to load and able to play. As Kaggle's simulation
competitions do, the last check is a *validation match* in which every seat is played by a copy
of the candidate; it must finish without error. The stages, each written to the log:

1. ``read``: size limits (by ``stat``, before reading) and format (no pickle, TorchScript, .pt2);
2. ``load``: the agent's inputs and outputs match the game's spaces;
3. ``probe``: on probe observations (random normal, random uniform in [-1, 1], zeros, and real
   observations from a few steps of random play) the outputs are finite, continuous actions lie
   in [-1, 1], the same input gives the same output, and a row's output does not depend on the
   other rows of the batch (the league batches seats of many matches together);
4. ``match``: a short match (``match_cycles`` steps at most) through ``make(game_id)`` and the
   env's array API, all seats played by the candidate, within ``max_seconds``.

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
    load_agent,
    read_artifact,
)
from arena_league.policies.errors import ArtifactError
from arena_league.policies.onnx_policy import PolicyOutputError
from arena_league.policies.policy import ActionSpec, Policy
from arena_league.policies.scripted import RandomPolicy
from arena_league.policies.spaces import action_types
from arena_league.policies.threads import torch_threads

#: Relative tolerance when comparing a row computed alone with the same row in a batch.
BATCH_TOLERANCE = 1e-4


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

    def as_dict(self) -> dict[str, Any]:
        return {"ok": self.ok, "reason": self.reason, "log": self.log, "game_id": self.game_id, "digest": self.digest,
                "spec": self.spec.as_dict() if self.spec else None, "seconds": self.seconds, "match": self.match}


class _Rejected(Exception):
    """Raised inside validation to stop at the failing stage with its reason."""


def validate_submission(source: str | os.PathLike[str] | AgentArtifact, game_id: str, *,
                        action_type: str | None = None, limits: ArtifactLimits = DEFAULT_LIMITS, n_probes: int = 32,
                        match_cycles: int = 200, seed: int = 0, max_seconds: float = 120.0) -> ValidationResult:
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
    """
    action_types(game_id)  # unknown game: ValueError listing the valid ids
    lines: list[str] = []
    start = time.perf_counter()
    state: dict[str, Any] = {"digest": None, "spec": None, "match": {}}

    def log(stage: str, message: str) -> None:
        lines.append(f"[{stage}] {message}")

    # Tiny forwards run far faster on one thread than with OpenMP's hand-offs on a busy machine.
    with torch_threads(1):
        try:
            artifact = _stage_read(source, limits, log)
            state["digest"] = artifact.digest
            loaded = _stage_load(artifact, game_id, action_type, limits, log)
            state["spec"] = loaded.info
            _stage_probe(loaded.policy, game_id, loaded.info, n_probes, seed, log)
            state["match"] = _stage_match(loaded.policy, game_id, loaded.info, match_cycles, seed, max_seconds, log)
        except _Rejected as rejection:
            reason = str(rejection)
            log("result", f"rejected: {reason}")
            return ValidationResult(False, reason, "\n".join(lines) + "\n", game_id, state["digest"], state["spec"],
                                    time.perf_counter() - start, state["match"])
    seconds = time.perf_counter() - start
    log("result", f"accepted in {seconds:.2f} s")
    return ValidationResult(True, None, "\n".join(lines) + "\n", game_id, state["digest"], state["spec"], seconds,
                            state["match"])


def _stage_read(source: Any, limits: ArtifactLimits, log: Any) -> AgentArtifact:
    try:
        artifact = source if isinstance(source, AgentArtifact) else read_artifact(source, limits)
    except (ArtifactError, OSError) as error:
        raise _Rejected(str(error)) from None
    log("read", f"{artifact.kind} artifact from {artifact.source}: {artifact.size_bytes} bytes, "
                f"sha256 {artifact.digest}")
    return artifact


def _stage_load(artifact: AgentArtifact, game_id: str, action_type: str | None, limits: ArtifactLimits, log: Any):
    try:
        loaded = load_agent(artifact, game_id, action_type=action_type, limits=limits)
    except ArtifactError as error:
        raise _Rejected(str(error)) from None
    info = loaded.info
    out = f"{info.n_actions} actions" if info.action_type == "discrete" else f"{info.act_dim} action components"
    extra = []
    if info.family:
        extra.append(f"family {info.family}")
    if info.recurrent:
        extra.append(f"recurrent state {list(info.state_shape)}")
    if info.fixed_batch is not None:
        extra.append(f"fixed batch {info.fixed_batch} (run in chunks of {info.fixed_batch} rows; export with a "
                     "dynamic batch dimension to be faster)")
    log("load", f"{loaded.policy.name} plays {game_id}: obs float32[N, {info.obs_dim}] -> {info.action_type}, {out}"
                + (f"; {', '.join(extra)}" if extra else ""))
    return loaded


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


def _forward(policy: Policy, obs: np.ndarray, state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Raw outputs of a learned policy; a scripted one's actions."""
    forward = getattr(policy, "forward", None)
    if forward is not None:
        out, next_state = forward(obs, state)
        return np.asarray(out, dtype=np.float64), next_state
    uniforms = np.full((obs.shape[0], policy.spec.uniforms_per_seat), 0.5)
    actions, next_state = policy.act(obs, uniforms, None, state)
    return np.asarray(actions, dtype=np.float64).reshape(obs.shape[0], -1), next_state


def _stage_probe(policy: Policy, game_id: str, info: AgentInfo, n_probes: int, seed: int, log: Any) -> None:
    rng = np.random.default_rng(seed)
    obs_dim = info.obs_dim
    probes = {
        "random normal": rng.standard_normal((n_probes, obs_dim)).astype(np.float32),
        "random uniform [-1, 1]": rng.uniform(-1.0, 1.0, (n_probes, obs_dim)).astype(np.float32),
        "zeros": np.zeros((1, obs_dim), np.float32),
        "real (random play)": _real_observations(game_id, info.action_type, obs_dim, seed),
    }
    if getattr(policy, "forward", None) is None:
        output = "actions"
    else:
        output = "logits" if info.action_type == "discrete" else "action"
    for label, obs in probes.items():
        n = obs.shape[0]
        state = policy.initial_state(n)
        if state is not None:
            state = rng.standard_normal(state.shape).astype(np.float32) * 0.5 if label != "zeros" else state
        try:
            out, next_state = _forward(policy, obs, state)
            again, _ = _forward(policy, obs, state)
            alone = [_forward(policy, obs[i: i + 1], state[i: i + 1] if state is not None else None)[0]
                     for i in range(min(n, 4))]
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
