"""The batched lockstep runner: many matches of one game at once, one policy call per step.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) ranks agents by playing them against a population; a league plays
thousands of short matches, so the engine keeps ``batch_size`` matches in flight and steps them
together:

1. every live match contributes one row per seat to a single observation array;
2. the rows are grouped by policy, so each policy makes one ``act`` call per step over all the seats
   it holds in all matches (members of one stacked family make a single call together, with each
   row's owner index);
3. each env steps with its seats' actions; a match that ends reports its :class:`MatchResult` and
   its slot starts the next spec at once, so the number in flight stays fixed.

Determinism: a match's seats draw their uniforms from the match's own generator
(:meth:`MatchSpec.seat_rng`), one ``float64[n_agents, k]`` draw per step whether a seat acts or
not, and its env is reset with :attr:`MatchSpec.seed`; so a match's result depends on its spec and
its agents only, not on the batch size, the other matches in flight, or the backend. (Policies must
treat rows independently, as batched inference does; float32 kernels that round differently for
different batch sizes could in principle flip a sample lying on a probability boundary.)

Acting seats: in turn-based games only the seat to move is asked for an action; elsewhere only
active seats (not arrived, not eliminated). The others get a fixed legal filler (action 0, or
zeros) that the rules ignore; recurrent states advance only when a seat acts.

Forfeits: with a ``guard`` (the inference sandbox's child plays submitted agents so, see
:mod:`arena_league.matchmaking.sandboxed`), every unit's call goes through it, and an agent whose
call fails (an error, invalid actions, a non-finite state) *forfeits* every match it has in
flight: each ends at once, its team losing (:meth:`MatchResult.forfeited`, the reason recorded),
and the slot takes the next spec. With ``forfeit_limit``, an agent that has forfeited that many
matches is not seated again: the specs that name it are skipped (no result). Without a guard, a
policy that fails raises, as a bug would.

Time: with a :class:`StepBudget` (the sandbox's child holds submitted agents to one), each match
keeps an overage bank per budgeted agent, in the manner of Kaggle's simulations: a step's call may
take ``step_seconds``, what it takes beyond that is drawn from the bank, and an agent whose bank
is overdrawn forfeits that match. With a ``deadline`` (a job's wall-time bound), the runner stops
once it has passed: the matches in flight and those not started have no result.

Pairs: a paired spec (:meth:`MatchSpec.halves`) is played as its two matches, queued one after the
other; each half reports the rules' ``pair_points()``, and the pair's result
(:meth:`MatchResult.from_halves`) is made, and reported, when both have ended. A pair missing a half
(skipped, or cut by the deadline) has no result.

Stepping paths: a result needs the rules' outcome, not the social-tree rewards, so unless a replay
is recorded (or observations carry broadcast boards or the global state) the runner steps each
match's game rules directly, or, for games whose rules declare a whole-array engine
(``batched_matches``, see :mod:`arena_league.matchmaking.batched`), all matches at once on it; see
:class:`LockstepRunner`'s ``path``. Every path gives the same results.
"""

from __future__ import annotations

import copy
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np

from arena_league.envs import make
from arena_league.matchmaking.specs import MatchResult, MatchSpec
from arena_league.policies.policy import ActionSpec, Policy, invalid_actions, valid_actions_text
from arena_league.policies.sandbox import ENGINE_BATCH_MATCHES

__all__ = ["PATHS", "LockstepRunner", "PolicyError", "PolicyUnit", "StepBudget", "UnitGuard", "action_spec_of",
           "policy_units"]

#: How a runner steps its matches (see :class:`LockstepRunner`).
PATHS = ("auto", "env", "rules", "engine")


class MatchRecording(Protocol):
    """One match's recorder, opened when the match starts on the env path.

    ``recording(spec, env, env_kwargs)`` is called right after ``env`` was reset with ``spec.seed``
    and returns a recorder with ``before_step(obs, actions, acting)``, ``after_step(rewards)``,
    ``close(result) -> path`` (the result then carries that path as ``replay_path``) and
    ``abort()``. Must pickle for the process-pool and Ray backends.
    """

    def __call__(self, spec: MatchSpec, env: Any, env_kwargs: dict[str, Any]) -> Any: ...


class UnitGuard(Protocol):
    """Calls a policy unit and reports failures instead of raising: ``guard(index, unit, obs,
    uniforms, owners, mask, state)`` returns ``(actions or None, next_state, {owner: reason})``,
    owners being positions in ``unit.members``."""

    def __call__(self, index: int, unit: PolicyUnit, obs: np.ndarray, uniforms: np.ndarray, owners: np.ndarray,
                 mask: np.ndarray | None, state: np.ndarray | None) -> tuple[Any, Any, dict[int, str]]: ...


@dataclass(frozen=True)
class StepBudget:
    """Time per match for the agents ``agents`` (keys): each step, ``step_seconds`` for the call
    that holds the agent's seats; beyond it, the match's bank of ``overage_seconds`` pays; once the
    bank is overdrawn, the agent forfeits the match. ``clock`` times the calls."""

    step_seconds: float
    overage_seconds: float
    agents: frozenset[str]
    clock: Callable[[], float] = time.perf_counter

    def overdrawn(self, seconds: float, step: int) -> str:
        """The forfeit's reason, for a bank overdrawn at ``step`` by a call of ``seconds``."""
        return (f"ran out of time in the match: its overage bank of {self.overage_seconds:g} s (time over "
                f"{self.step_seconds:g} s a step, summed over the match) was used up at step {step}, whose call "
                f"took {seconds:.3g} s")


class PolicyError(RuntimeError):
    """A policy returned actions the game cannot take (wrong shape, out of range, not finite)."""


def action_spec_of(env: Any) -> ActionSpec:
    """The :class:`ActionSpec` of an env made by :func:`arena_league.envs.make`."""
    rules = env.rules
    obs_dim = int(env.vector_observation_space(env.possible_agents[0]).shape[0])
    if rules.action_type == "discrete":
        return ActionSpec("discrete", obs_dim, n_actions=int(rules.n_actions))
    return ActionSpec("continuous", obs_dim, act_dim=int(rules.act_dim))


@dataclass(frozen=True)
class PolicyUnit:
    """Policies that make one batched call per step: one policy, or a stacked family of torch agents
    (``members`` index the engine's distinct policies; a row's owner is its member's position)."""

    policy: Policy
    members: tuple[int, ...]
    stacked: bool

    def act(self, obs: np.ndarray, uniforms: np.ndarray, owners: np.ndarray, mask: np.ndarray | None,
            state: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        if self.stacked:
            return self.policy.act(obs, uniforms, mask, state, owners=owners)  # type: ignore[call-arg]
        return self.policy.act(obs, uniforms, mask, state)


def policy_units(policies: Sequence[Policy]) -> list[PolicyUnit]:
    """Groups distinct policies into units: torch agents of one architecture stack into a single
    :class:`~arena_league.policies.families.StackedPolicy` (one forward for all of them, with
    each row's owner index); every other policy is a unit of its own."""
    families = sys.modules.get("arena_league.policies.families")
    if families is None:  # no torch agent can exist unless the families module was imported
        return [PolicyUnit(p, (i,), False) for i, p in enumerate(policies)]
    return [PolicyUnit(g.policy, tuple(g.members), isinstance(g.policy, families.StackedPolicy))
            for g in families.stack_policies(list(policies))]


@dataclass
class _Slot:
    """A match in flight."""

    order: int  # position of the spec in the input, for returning results in order
    spec: MatchSpec
    rng: np.random.Generator
    states: list[np.ndarray | None] = field(default_factory=list)


class _EnvMatches:
    """One env per slot: the general path, and the only one that records replays. With ``direct``,
    it steps each env's game rules itself and skips the social-tree rewards, which no result needs
    (the env's own ``step_arrays`` minus the rewards: count the step, end when the rules say so,
    cut at ``max_cycles`` with the rules' ``finish``)."""

    def __init__(self, runner: LockstepRunner, width: int, direct: bool) -> None:
        self.runner = runner
        self.direct = direct
        self.envs = runner.envs(width)
        self.obs: list[np.ndarray | None] = [None] * width
        self.recorders: list[Any] = [None] * width
        self.steps = [0] * width
        self.max_cycles = self.envs[0].max_cycles

    def start(self, position: int, spec: MatchSpec) -> None:
        env = self.envs[position]
        if self.direct:
            env.rules.reset(spec.seed)
            self.obs[position] = env.rules.observe()
            self.steps[position] = 0
            return
        self.obs[position] = env.reset_arrays(spec.seed)
        if self.runner.recording is not None:
            self.recorders[position] = self.runner.recording(spec, env, self.runner.env_kwargs)

    def gather(self, live: list[int], obs: np.ndarray, mask: np.ndarray | None, acting: np.ndarray) -> None:
        n = self.runner.n_agents
        turn_based = self.runner.turn_based
        for position in live:
            base = position * n
            obs[base: base + n] = self.obs[position]
            rules = self.envs[position].rules
            if mask is not None:
                mask[base: base + n] = rules.action_mask()
            if turn_based:
                acting[base: base + n] = False
                acting[base + rules.current_player()] = True
            else:
                acting[base: base + n] = rules.measures.active

    def step(self, live: list[int], actions: np.ndarray, acting: np.ndarray) -> list[int]:
        n = self.runner.n_agents
        ended = []
        if self.direct:
            for position in live:
                rules = self.envs[position].rules
                rules.step(actions[position * n: (position + 1) * n])
                self.steps[position] += 1
                if not rules.game_over and self.steps[position] >= self.max_cycles:
                    rules.finish()
                    ended.append(position)
                elif rules.game_over:
                    ended.append(position)
                self.obs[position] = rules.observe()
            return ended
        for position in live:
            base = position * n
            seat_actions = actions[base: base + n]
            recorder = self.recorders[position]
            if recorder is not None:
                recorder.before_step(self.obs[position], seat_actions, acting[base: base + n])
            next_obs, rewards, terminated, truncated = self.envs[position].step_arrays(seat_actions)
            self.obs[position] = next_obs
            if recorder is not None:
                recorder.after_step(rewards)
            if terminated or truncated:
                ended.append(position)
        return ended

    def steps_of(self, position: int) -> int:
        return self.steps[position] if self.direct else self.envs[position].step_count

    def result(self, position: int, spec: MatchSpec, forfeits: Mapping[str, str] | None = None,
               steps: int | None = None) -> MatchResult:
        env = self.envs[position]
        steps = self.steps_of(position) if steps is None else steps
        if forfeits:
            result = MatchResult.forfeited(spec, self.runner.team_of, forfeits, steps)
        else:
            points = None if spec.half is None else env.rules.pair_points()
            result = MatchResult.from_team_result(spec, self.runner.team_of, env.rules.team_result(), steps,
                                                  pair_points=points)
        recorder = self.recorders[position]
        if recorder is not None:  # held until closed: a close that fails is aborted with the others
            result = replace(result, replay_path=str(recorder.close(result)))
            self.recorders[position] = None
        return result

    def abort(self) -> None:
        for position, recorder in enumerate(self.recorders):
            if recorder is not None:
                recorder.abort()
                self.recorders[position] = None


class _EngineMatches:
    """All slots on one whole-array engine (:mod:`arena_league.matchmaking.batched`)."""

    def __init__(self, runner: LockstepRunner, engine: Any) -> None:
        self.runner = runner
        self.engine = engine

    def start(self, position: int, spec: MatchSpec) -> None:
        self.engine.start(position, spec.seed)

    def gather(self, live: list[int], obs: np.ndarray, mask: np.ndarray | None, acting: np.ndarray) -> None:
        engine = self.engine
        obs[...] = engine.observe().reshape(obs.shape)
        if mask is not None:
            mask[...] = engine.action_mask().reshape(mask.shape)
        acting[...] = engine.acting().reshape(-1)

    def step(self, live: list[int], actions: np.ndarray, acting: np.ndarray) -> list[int]:
        n = self.runner.n_agents
        # discrete actions are one integer per seat; continuous ones keep their action dimension
        return np.flatnonzero(self.engine.step(actions.reshape(-1, n, *actions.shape[1:]))).tolist()

    def steps_of(self, position: int) -> int:
        return int(self.engine.steps(position))

    def result(self, position: int, spec: MatchSpec, forfeits: Mapping[str, str] | None = None,
               steps: int | None = None) -> MatchResult:
        if forfeits:
            return MatchResult.forfeited(spec, self.runner.team_of, forfeits,
                                         self.steps_of(position) if steps is None else steps)
        points = None if spec.half is None else self.engine.pair_points(position)
        return MatchResult.from_team_result(spec, self.runner.team_of, self.engine.team_result(position),
                                            self.engine.steps(position), pair_points=points)

    def abort(self) -> None:
        pass


def forfeit_allowance(forfeit_limit: int | Mapping[str, int] | None, keys: Iterable[str] | None = None
                      ) -> dict[str, float]:
    """A forfeit limit (one for every agent, or per agent key) as agent key -> forfeits allowed,
    ``""`` standing for every agent not named; with ``keys``, only those keys are kept."""
    if forfeit_limit is None:
        return {}
    if isinstance(forfeit_limit, Mapping):
        wanted = None if keys is None else set(keys)
        return {str(key): float(value) for key, value in forfeit_limit.items() if wanted is None or key in wanted}
    return {"": float(forfeit_limit)}


def allowed(allowance: Mapping[str, float], key: str) -> float:
    """Forfeits ``key`` may make under ``allowance`` (see :func:`forfeit_allowance`)."""
    return allowance.get(key, allowance.get("", np.inf))


class LockstepRunner:
    """Plays matches of one game in lockstep with batched policy calls.

    Args:
        game_id: the game every spec plays.
        policies: agent key -> :class:`Policy`; every key named in a spec's seats must be here.
        batch_size: matches in flight at once (1 plays them one after another).
        env_kwargs: extra arguments of :func:`arena_league.envs.make` (``tree``, ``action_type``,
            ``max_cycles``, game options); the same for every match.
        recording: when given, opens a recorder for each match (a :class:`MatchRecording`, such as
            ``arena_league.replay.ReplayRecording(directory)``, which writes MCAP replays), and
            each result carries the path its recorder returns.
        path: how matches are stepped. ``"env"``: one env per match through its array API (what
            recording uses). ``"rules"``: one game-rules object per match stepped directly, without
            the social-tree rewards no result needs. ``"engine"``: every match on the game's
            whole-array engine (:mod:`arena_league.matchmaking.batched`). ``"auto"`` (default):
            ``"env"`` when recording or when the observations carry broadcast boards or the global
            state, else ``"engine"`` where the game has one, else ``"rules"``. Results are the same
            on every path.
        guard: every unit's call goes through it (a :class:`UnitGuard`), which turns an agent's
            error or invalid output into a failure of that agent, so the agent forfeits as a
            sandboxed one does; the inference sandbox's child plays its matches so.
    """

    def __init__(self, game_id: str, policies: Mapping[str, Policy], *, batch_size: int = ENGINE_BATCH_MATCHES,
                 env_kwargs: Mapping[str, Any] | None = None, recording: MatchRecording | None = None,
                 path: str = "auto", guard: UnitGuard | None = None) -> None:
        if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
            raise ValueError(f"batch_size must be a positive integer (matches in flight), not {batch_size!r}")
        for key, policy in policies.items():
            if not isinstance(policy, Policy):
                raise TypeError(f"agent {key!r} maps to a {type(policy).__name__}, not a Policy; load agent "
                                "references first (AgentRef.load(), or play_matches which loads them)")
        self.game_id = game_id
        self.policies = dict(policies)
        self.batch_size = batch_size
        self.env_kwargs = dict(env_kwargs or {})
        if "render_mode" in self.env_kwargs:
            raise ValueError("env_kwargs must not set render_mode: matches are played without pictures "
                             "(replays render afterwards from the recorded actions)")
        self.recording = recording
        self.guard = guard
        self.path = path
        if path not in PATHS:
            raise ValueError(f"path must be one of {', '.join(PATHS)}, not {path!r}")
        probe = make(game_id, **self.env_kwargs)
        self._probe = probe
        self.spec = action_spec_of(probe)
        rules = probe.rules
        self.n_agents = rules.n_agents
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.turn_based = bool(rules.turn_based)
        self.discrete = rules.action_type == "discrete"
        self.uniforms_per_seat = self.spec.uniforms_per_seat
        probe.reset_arrays(0)
        self.masked = probe.rules.action_mask() is not None
        # the envs of the rules and env paths, made as first needed and kept: every match resets its
        # env with its seed, so later plays (and runners of with_policies) reuse them
        self._env_pool: list[Any] = [probe]
        self._bind()

    def with_policies(self, policies: Mapping[str, Policy]) -> LockstepRunner:
        """A runner of the same game, options and path for ``policies``, sharing this runner's envs:
        a caller that plays new weights over and over (training's evaluations) makes its envs once.
        The two runners must not play at the same time."""
        other = copy.copy(self)
        other.policies = dict(policies)
        for key, policy in other.policies.items():
            if not isinstance(policy, Policy):
                raise TypeError(f"agent {key!r} maps to a {type(policy).__name__}, not a Policy")
        other._bind()
        return other

    def envs(self, width: int) -> list[Any]:
        """``width`` envs of this runner's game and options (the probe first), made once and reused."""
        while len(self._env_pool) < width:
            self._env_pool.append(make(self.game_id, **self.env_kwargs))
        return self._env_pool[:width]

    def _bind(self) -> None:
        """Check the policies against the game and group them into policy units."""
        game_id = self.game_id
        for key, policy in self.policies.items():
            if policy.spec.action_type != self.spec.action_type:
                raise ValueError(f"agent {key!r} outputs {policy.spec.action_type} actions but {game_id} is "
                                 f"played with {self.spec.action_type} ones")
            if policy.spec.obs_dim > self.spec.obs_dim:
                raise ValueError(f"agent {key!r} reads observations of {policy.spec.obs_dim} floats but {game_id} "
                                 f"gives {self.spec.obs_dim} with these env options; check the agent's game and "
                                 "the env's boards / state_in_obs settings")
        # policy units: one batched call each per step; keys naming the same policy object share it
        distinct: list[Policy] = []
        position: dict[int, int] = {}
        for policy in self.policies.values():
            if id(policy) not in position:
                position[id(policy)] = len(distinct)
                distinct.append(policy)
        self._units = policy_units(distinct)
        self._keys_of_member: dict[int, list[str]] = {}
        for key, policy in self.policies.items():
            self._keys_of_member.setdefault(position[id(policy)], []).append(key)
        unit_of: dict[int, tuple[int, int]] = {}
        for u, unit in enumerate(self._units):
            for owner, member in enumerate(unit.members):
                unit_of[member] = (u, owner)
        self._unit_of_key = {key: unit_of[position[id(p)]][0] for key, p in self.policies.items()}
        self._owner_of_key = {key: unit_of[position[id(p)]][1] for key, p in self.policies.items()}

    # --- public ---------------------------------------------------------------------------------
    def play(self, specs: Iterable[MatchSpec], on_result: Callable[[MatchResult], None] | None = None, *,
             forfeit_limit: int | Mapping[str, int] | None = None,
             heartbeat: Callable[[], None] | None = None,
             on_start: Callable[[int], None] | None = None, step_budget: StepBudget | None = None,
             deadline: float | None = None) -> list[MatchResult]:
        """Plays every spec; returns the results in the order of ``specs``. ``on_result`` is called
        as each match ends (in the order they end); ``heartbeat`` once per step (a sign of progress);
        ``on_start`` with a spec's position in ``specs`` as its match starts.

        ``forfeit_limit``: how many matches an agent (by key, or every agent) may forfeit before its
        remaining specs are skipped (see the module docstring); None never skips. Skipped specs have
        no result, so the list may be shorter than ``specs``. ``step_budget``: the agents held to a
        time budget per match (guarded calls only, see the module docstring). ``deadline``: a
        ``time.time()`` past which play stops, leaving the matches not finished without a result."""
        specs = list(specs)
        for spec in specs:
            self._check_spec(spec)
        # a pair is played as its two matches, one after the other in the queue; its result is made
        # when both have ended (a pair missing a half, skipped or cut by the deadline, has none)
        played = [(order, half) for order, spec in enumerate(specs)
                  for half in (spec.halves() if spec.paired else (spec,))]
        halves_done: dict[int, list[MatchResult]] = {}
        forfeit_counts: dict[str, int] = {}
        allowance = forfeit_allowance(forfeit_limit)
        width = min(self.batch_size, len(played))
        if width == 0:
            return []
        n, k = self.n_agents, self.uniforms_per_seat
        rows = width * n
        obs = np.zeros((rows, self.spec.obs_dim), dtype=np.float32)
        uniforms = np.zeros((rows, k), dtype=np.float64)
        mask = np.ones((rows, self.spec.n_actions), dtype=bool) if self.masked else None
        acting = np.zeros(rows, dtype=bool)
        actions = (np.zeros(rows, dtype=np.int64) if self.discrete
                   else np.zeros((rows, self.spec.act_dim), dtype=np.float32))
        row_unit = np.full(rows, -1, dtype=np.int64)
        row_owner = np.full(rows, -1, dtype=np.int64)
        row_key: list[str | None] = [None] * rows
        results: list[MatchResult | None] = [None] * len(specs)
        slots: list[_Slot | None] = [None] * width
        queue = iter(played)
        matches = self._matches(width)
        stopped = {key for key, left in allowance.items() if key and left <= 0}  # past their forfeit allowance
        budget = step_budget if self.guard is not None else None
        banks: list[dict[str, float]] = [{} for _ in range(width)]  # per slot: agent -> overage left
        unit_seconds: dict[int, float] = {}

        def start(position: int) -> None:
            nxt = next(queue, None)
            while nxt is not None and stopped.intersection(nxt[1].seats):
                nxt = next(queue, None)
            base = position * n
            if nxt is None:
                slots[position] = None
                row_unit[base: base + n] = -1
                return
            order, spec = nxt
            if budget is not None:
                banks[position] = {key: float(budget.overage_seconds) for key in spec.seats if key in budget.agents}
            slot = _Slot(order, spec, spec.seat_rng(), [self._initial_state(key) for key in spec.seats])
            matches.start(position, spec)
            if on_start is not None and not spec.half:
                on_start(order)
            slots[position] = slot
            for seat, key in enumerate(spec.seats):
                row_unit[base + seat] = self._unit_of_key[key]
                row_owner[base + seat] = self._owner_of_key[key]
                row_key[base + seat] = key

        def finish(position: int, forfeits: Mapping[str, str] | None = None, steps: int | None = None) -> None:
            slot = slots[position]
            result = matches.result(position, slot.spec, forfeits, steps)
            if slot.spec.half is not None:
                done = halves_done.setdefault(slot.order, [])
                done.append(result)
                result = (MatchResult.from_halves(specs[slot.order], sorted(done, key=lambda h: h.half))
                          if len(done) == 2 else None)
            if result is not None:
                results[slot.order] = result
                if on_result is not None:
                    on_result(result)
            start(position)

        try:
            for position in range(width):
                start(position)
            live = [p for p, slot in enumerate(slots) if slot is not None]
            while live:
                if deadline is not None and time.time() > deadline:
                    break  # the job's time is up: what is in flight stays unplayed
                # gather: observations, masks and who acts; every live match draws its seats' uniforms
                matches.gather(live, obs, mask, acting)
                for position in live:
                    slots[position].rng.random(out=uniforms[position * n: (position + 1) * n])
                # act: one call per policy unit over all its acting rows (sandboxed units in one message)
                acting &= row_unit >= 0
                actions[...] = 0
                failures = self._act_all(acting, obs, uniforms, mask, actions, row_unit, row_owner, row_key, slots,
                                         unit_seconds, None if budget is None else budget.clock)
                # matches in flight of an agent whose call failed end as forfeits; the others step
                forfeited = {}
                if failures:
                    forfeited = {p: {key: failures[key] for key in slots[p].spec.seats if key in failures}
                                 for p in live if failures.keys() & set(slots[p].spec.seats)}
                if budget is not None:
                    for position, forfeits in self._overdrawn(budget, live, banks, unit_seconds, acting, failures,
                                                              slots, matches).items():
                        forfeited.setdefault(position, {}).update(forfeits)
                if forfeited:
                    for forfeits in forfeited.values():
                        for key in forfeits:
                            forfeit_counts[key] = forfeit_counts.get(key, 0) + 1
                            if forfeit_counts[key] >= allowed(allowance, key):
                                stopped.add(key)
                stepping = [p for p in live if p not in forfeited]
                steps_before = {p: matches.steps_of(p) for p in forfeited}  # the engine steps every slot
                ended = matches.step(stepping, actions, acting)
                if heartbeat is not None:  # the step is played (before the ended slots take new specs)
                    heartbeat()
                for position in ended:
                    # a whole-array engine steps every slot: a board left by a forfeit (its slot
                    # forfeited now, or empty since) may end too, and has no match to finish
                    if position in stepping:
                        finish(position)
                for position, forfeits in forfeited.items():
                    finish(position, forfeits, steps_before[position])
                live = [p for p, slot in enumerate(slots) if slot is not None]
        finally:
            matches.abort()
        return [r for r in results if r is not None]

    # --- internals ------------------------------------------------------------------------------
    def _matches(self, width: int) -> _EnvMatches | _EngineMatches:
        path = self.stepping_path(width)
        if path == "engine":
            from arena_league.matchmaking.batched import batched_engine

            return _EngineMatches(self, batched_engine(self._probe, width))
        return _EnvMatches(self, width, direct=path == "rules")

    def unit_agents(self) -> list[list[str]]:
        """The agent keys of each policy unit, in unit order (the index a ``guard`` is called with)."""
        return [[key for member in unit.members for key in self._keys_of_member[member]] for unit in self._units]

    def stepping_path(self, width: int = 1) -> str:
        """The path (see the class docstring) this runner takes: ``"env"``, ``"rules"`` or ``"engine"``."""
        from arena_league.matchmaking.batched import has_batched_engine

        probe = self._probe
        plain = (not self.env_kwargs.get("state_in_obs")
                 and probe.vector_observation_space(probe.possible_agents[0]).shape[0] == probe.rules.obs_dim)
        if self.path == "env" or self.recording is not None:
            return "env"
        if not plain:
            if self.path != "auto":
                raise ValueError(f"path {self.path!r} cannot build observations with broadcast boards or the "
                                 "global state; use path='env' (or 'auto')")
            return "env"
        if self.path == "rules":
            return "rules"
        has_engine = has_batched_engine(probe.rules)
        if self.path == "engine" and not has_engine:
            raise ValueError(f"{self.game_id} has no whole-array engine; use path='rules' or 'auto'")
        return "engine" if has_engine else "rules"

    def _check_spec(self, spec: MatchSpec) -> None:
        if spec.game_id != self.game_id:
            raise ValueError(f"match {spec.match_id} plays {spec.game_id}, but this runner plays {self.game_id}; "
                             "play each game with its own runner (play_matches groups them)")
        if len(spec.seats) != self.n_agents:
            raise ValueError(f"match {spec.match_id}: {self.game_id} has {self.n_agents} seats, the spec names "
                             f"{len(spec.seats)}")
        if (spec.paired or spec.half is not None) and len(set(self.team_of)) != 2:
            raise ValueError(f"match {spec.match_id}: a pair swaps two teams, but {self.game_id} has "
                             f"{len(set(self.team_of))}; play its matches unpaired")
        missing = [key for key in spec.seats if key not in self.policies]
        if missing:
            raise KeyError(f"match {spec.match_id}: no policy for agent(s) {sorted(set(missing))}; give every "
                           "agent key named in the specs a policy (or an AgentRef)")

    def _initial_state(self, key: str) -> np.ndarray | None:
        policy = self.policies[key]
        if not policy.recurrent:
            return None
        state = policy.initial_state(1)
        return None if state is None else np.asarray(state)[0]

    def _overdrawn(self, budget: StepBudget, live: list[int], banks: list[dict[str, float]],
                   unit_seconds: Mapping[int, float], acting: np.ndarray, failures: Mapping[str, str], slots: list,
                   matches: Any) -> dict[int, dict[str, str]]:
        """Charge this step's calls to the banks of the matches they served; the matches whose bank
        of an agent is overdrawn, with that agent's forfeit reason. A call serving many matches is
        charged in full to each: every one of them waited that long for the agent, and dividing the
        time would let an agent hide a slow forward behind the number of matches in flight."""
        n = self.n_agents
        overdrawn: dict[int, dict[str, str]] = {}
        for position in live:
            bank = banks[position]
            seats = slots[position].spec.seats
            for key in bank:
                seconds = unit_seconds.get(self._unit_of_key[key])
                if seconds is None or key in failures:
                    continue
                if not any(acting[position * n + seat] for seat, k in enumerate(seats) if k == key):
                    continue  # not its turn: it waited for no one
                bank[key] -= max(0.0, seconds - budget.step_seconds)
                if bank[key] < 0:
                    overdrawn.setdefault(position, {})[key] = budget.overdrawn(seconds, matches.steps_of(position))
        return overdrawn

    def _act_all(self, acting: np.ndarray, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None,
                 actions: np.ndarray, row_unit: np.ndarray, row_owner: np.ndarray, row_key: list,
                 slots: list, unit_seconds: dict[int, float] | None = None,
                 clock: Callable[[], float] | None = None) -> dict[str, str]:
        """Every unit's actions for the acting rows; with a ``guard``, returns the agents whose call
        failed (key -> reason), whose rows get a legal filler action that no match uses. With a
        ``clock``, ``unit_seconds`` is refilled with each guarded unit's time for this step."""
        if unit_seconds is not None:
            unit_seconds.clear()
        acting_rows = np.flatnonzero(acting)
        units = row_unit[acting_rows]
        order = np.argsort(units, kind="stable")
        acting_rows, units = acting_rows[order], units[order]
        failures: dict[str, str] = {}
        for group in np.split(acting_rows, np.flatnonzero(np.diff(units)) + 1):
            if not group.size:
                continue
            unit_index = int(row_unit[group[0]])
            if self.guard is None:
                self._act(unit_index, group, obs, uniforms, mask, actions, row_owner, row_key, slots)
                continue
            unit = self._units[unit_index]
            unit_obs, state = self._unit_inputs(unit, group, obs, slots)
            owners = row_owner[group]
            started = clock() if clock is not None else 0.0
            out, next_state, errors = self.guard(unit_index, unit, unit_obs, uniforms[group], owners,
                                                 None if mask is None else mask[group], state)
            if clock is not None and unit_seconds is not None:
                unit_seconds[unit_index] = clock() - started
            self._take(unit, group, owners, out, next_state, errors, mask, actions, slots, failures)
        return failures

    def _take(self, unit: PolicyUnit, rows: np.ndarray, owners: np.ndarray, out: np.ndarray | None,
              next_state: np.ndarray | None, errors: Mapping[int, str], mask: np.ndarray | None,
              actions: np.ndarray, slots: list, failures: dict[str, str]) -> None:
        """Store a guarded call's actions and states; the rows of failed owners (positions in the
        unit) get a legal filler, and their agents are added to ``failures``."""
        bad = np.zeros(rows.size, dtype=bool)
        for owner, reason in errors.items():
            bad |= owners == owner
            for key in self._keys_of_member[unit.members[owner]]:
                failures.setdefault(key, reason)
        if out is not None:
            actions[rows] = out
        if bad.any():
            actions[rows[bad]] = 0
            if mask is not None:
                actions[rows[bad]] = mask[rows[bad]].argmax(axis=1)
        if unit.policy.recurrent and next_state is not None:
            self._store_states(rows[~bad], np.asarray(next_state)[~bad], slots)

    def _unit_inputs(self, unit: PolicyUnit, rows: np.ndarray, obs: np.ndarray, slots: list
                     ) -> tuple[np.ndarray, np.ndarray | None]:
        """The unit's observations (a policy reads its own width: the base observation first, then
        boards, then the state) and recurrent states for ``rows``."""
        n = self.n_agents
        state = np.stack([slots[r // n].states[r % n] for r in rows]) if unit.policy.recurrent else None
        width = unit.policy.spec.obs_dim
        return (obs[rows] if width == obs.shape[1] else obs[rows, :width]), state

    def _act(self, unit_index: int, rows: np.ndarray, obs: np.ndarray, uniforms: np.ndarray,
             mask: np.ndarray | None, actions: np.ndarray, row_owner: np.ndarray, row_key: list,
             slots: list) -> None:
        unit = self._units[unit_index]
        recurrent = bool(unit.policy.recurrent)
        unit_obs, state = self._unit_inputs(unit, rows, obs, slots)
        out, next_state = unit.act(unit_obs, uniforms[rows], row_owner[rows], None if mask is None else mask[rows],
                                   state)
        out = np.asarray(out)
        self._check_actions(out, rows, row_key)
        actions[rows] = out
        if recurrent and next_state is not None:
            self._store_states(rows, np.asarray(next_state), slots)

    def _store_states(self, rows: np.ndarray, next_state: np.ndarray, slots: list) -> None:
        """Keep each row's next recurrent state in its match's slot."""
        n = self.n_agents
        for r, row_state in zip(rows, next_state):
            slots[r // n].states[r % n] = row_state

    def _check_actions(self, out: np.ndarray, rows: np.ndarray, row_key: list) -> None:
        problem, bad = invalid_actions(self.spec, out, rows.size)
        if problem is not None:
            raise PolicyError(f"agent {row_key[rows[0]]!r} {problem}")
        if bad.size:
            row = int(rows[bad[0]])
            raise PolicyError(f"agent {row_key[row]!r} returned the invalid action {out[bad[0]].tolist()} for "
                              f"{self.game_id} (seat {row % self.n_agents}); valid: {valid_actions_text(self.spec)}")
