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
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from arena_league.envs import make
from arena_league.matchmaking.specs import MatchResult, MatchSpec
from arena_league.population.policy import ActionSpec, Policy

__all__ = ["LockstepRunner", "PolicyError", "PolicyUnit", "action_spec_of", "policy_units"]


class PolicyError(RuntimeError):
    """A policy returned actions the game cannot take (wrong shape, out of range, not finite)."""


def action_spec_of(env: Any) -> ActionSpec:
    """The :class:`ActionSpec` of an env made by :func:`arena_league.envs.make`."""
    rules = env.rules
    obs_dim = int(env.observation_space(env.possible_agents[0]).shape[0])
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
    :class:`~arena_league.population.families.StackedPolicy` (one forward for all of them, with
    each row's owner index); every other policy is a unit of its own."""
    families = sys.modules.get("arena_league.population.families")
    if families is None:  # no torch agent can exist unless the families module was imported
        return [PolicyUnit(p, (i,), False) for i, p in enumerate(policies)]
    return [PolicyUnit(g.policy, tuple(g.members), isinstance(g.policy, families.StackedPolicy))
            for g in families.stack_policies(list(policies))]


@dataclass
class _Slot:
    """A match in flight."""

    order: int  # position of the spec in the input, for returning results in order
    spec: MatchSpec
    env: Any
    rng: np.random.Generator
    obs: np.ndarray
    states: list[np.ndarray | None] = field(default_factory=list)
    recorder: Any = None


class LockstepRunner:
    """Plays matches of one game in lockstep with batched policy calls.

    Args:
        game_id: the game every spec plays.
        policies: agent key -> :class:`Policy`; every key named in a spec's seats must be here.
        batch_size: matches in flight at once (1 plays them one after another).
        env_kwargs: extra arguments of :func:`arena_league.envs.make` (``tree``, ``action_type``,
            ``max_cycles``, game options); the same for every match.
        record_dir: when given, each match writes an MCAP replay there
            (:mod:`arena_league.replay`) and its result carries the path.
    """

    def __init__(self, game_id: str, policies: Mapping[str, Policy], *, batch_size: int = 64,
                 env_kwargs: Mapping[str, Any] | None = None, record_dir: str | Path | None = None) -> None:
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
        self.record_dir = None if record_dir is None else Path(record_dir)
        probe = make(game_id, **self.env_kwargs)
        self.spec = action_spec_of(probe)
        rules = probe.rules
        self.n_agents = rules.n_agents
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.turn_based = bool(rules.turn_based)
        self.discrete = rules.action_type == "discrete"
        self.uniforms_per_seat = self.spec.uniforms_per_seat
        probe.reset_arrays(0)
        self.masked = probe.rules.action_mask() is not None
        self._envs: list[Any] = [probe]
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
        unit_of: dict[int, tuple[int, int]] = {}
        for u, unit in enumerate(self._units):
            for owner, member in enumerate(unit.members):
                unit_of[member] = (u, owner)
        self._unit_of_key = {key: unit_of[position[id(p)]][0] for key, p in self.policies.items()}
        self._owner_of_key = {key: unit_of[position[id(p)]][1] for key, p in self.policies.items()}

    # --- public ---------------------------------------------------------------------------------
    def play(self, specs: Iterable[MatchSpec],
             on_result: Callable[[MatchResult], None] | None = None) -> list[MatchResult]:
        """Plays every spec; returns the results in the order of ``specs``. ``on_result`` is called
        as each match ends (in the order they end)."""
        specs = list(specs)
        for spec in specs:
            self._check_spec(spec)
        results: list[MatchResult | None] = [None] * len(specs)
        n, k = self.n_agents, self.uniforms_per_seat
        width = min(self.batch_size, len(specs))
        if width == 0:
            return []
        while len(self._envs) < width:
            self._envs.append(make(self.game_id, **self.env_kwargs))
        rows = width * n
        obs_dim = self.spec.obs_dim
        obs = np.zeros((rows, obs_dim), dtype=np.float32)
        uniforms = np.zeros((rows, k), dtype=np.float64)
        mask = np.ones((rows, self.spec.n_actions), dtype=bool) if self.masked else None
        acting = np.zeros(rows, dtype=bool)
        if self.discrete:
            actions = np.zeros(rows, dtype=np.int64)
        else:
            actions = np.zeros((rows, self.spec.act_dim), dtype=np.float32)
        row_unit = np.full(rows, -1, dtype=np.int64)
        row_owner = np.full(rows, -1, dtype=np.int64)
        row_key: list[str | None] = [None] * rows

        slots: list[_Slot | None] = [None] * width
        queue = iter(enumerate(specs))

        def start(position: int) -> None:
            nxt = next(queue, None)
            base = position * n
            if nxt is None:
                slots[position] = None
                row_unit[base: base + n] = -1
                return
            order, spec = nxt
            env = self._envs[position]
            first = env.reset_arrays(spec.seed)
            slot = _Slot(order, spec, env, spec.seat_rng(), first)
            slot.states = [self._initial_state(key) for key in spec.seats]
            if self.record_dir is not None:
                from arena_league.replay.writer import MatchRecorder

                slot.recorder = MatchRecorder.open(self.record_dir, spec, env, self.env_kwargs)
            slots[position] = slot
            for seat, key in enumerate(spec.seats):
                row_unit[base + seat] = self._unit_of_key[key]
                row_owner[base + seat] = self._owner_of_key[key]
                row_key[base + seat] = key

        try:
            for position in range(width):
                start(position)
            self._run(slots, start, results, on_result, obs, uniforms, mask, acting, actions, row_unit, row_owner,
                      row_key)
        finally:
            for slot in slots:
                if slot is not None and slot.recorder is not None:
                    slot.recorder.abort()
        return [r for r in results if r is not None]

    # --- internals ------------------------------------------------------------------------------
    def _run(self, slots: list, start: Callable[[int], None], results: list, on_result: Callable | None,
             obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None, acting: np.ndarray,
             actions: np.ndarray, row_unit: np.ndarray, row_owner: np.ndarray, row_key: list) -> None:
        n = self.n_agents
        while any(slot is not None for slot in slots):
            # gather: observations, uniforms, masks, who acts
            for position, slot in enumerate(slots):
                base = position * n
                if slot is None:
                    acting[base: base + n] = False
                    continue
                obs[base: base + n] = slot.obs
                slot.rng.random(out=uniforms[base: base + n])
                rules = slot.env.rules
                if mask is not None:
                    mask[base: base + n] = rules.action_mask()
                if self.turn_based:
                    acting[base: base + n] = False
                    acting[base + rules.current_player()] = True
                else:
                    acting[base: base + n] = rules.measures.active
            # act: one call per policy unit over all its acting rows
            actions[...] = 0
            live_rows = np.flatnonzero(acting)
            units = row_unit[live_rows]
            order = np.argsort(units, kind="stable")
            live_rows, units = live_rows[order], units[order]
            bounds = np.flatnonzero(np.diff(units)) + 1
            for group in np.split(live_rows, bounds):
                if group.size:
                    self._act(int(row_unit[group[0]]), group, obs, uniforms, mask, actions, row_owner,
                              row_key, slots)
            # step every live match
            for position, slot in enumerate(slots):
                if slot is None:
                    continue
                base = position * n
                seat_actions = actions[base: base + n]
                if slot.recorder is not None:
                    slot.recorder.before_step(slot.obs, seat_actions, acting[base: base + n])
                next_obs, rewards, terminated, truncated = slot.env.step_arrays(seat_actions)
                slot.obs = next_obs
                if slot.recorder is not None:
                    slot.recorder.after_step(rewards)
                if terminated or truncated:
                    result = self._finish(slot)
                    results[slot.order] = result
                    if on_result is not None:
                        on_result(result)
                    start(position)

    def _check_spec(self, spec: MatchSpec) -> None:
        if spec.game_id != self.game_id:
            raise ValueError(f"match {spec.match_id} plays {spec.game_id}, but this runner plays {self.game_id}; "
                             "play each game with its own runner (play_matches groups them)")
        if len(spec.seats) != self.n_agents:
            raise ValueError(f"match {spec.match_id}: {self.game_id} has {self.n_agents} seats, the spec names "
                             f"{len(spec.seats)}")
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

    def _act(self, unit_index: int, rows: np.ndarray, obs: np.ndarray, uniforms: np.ndarray,
             mask: np.ndarray | None, actions: np.ndarray, row_owner: np.ndarray, row_key: list,
             slots: list) -> None:
        unit = self._units[unit_index]
        n = self.n_agents
        recurrent = bool(unit.policy.recurrent)
        state = None
        if recurrent:
            state = np.stack([slots[r // n].states[r % n] for r in rows])
        # a policy reads its own width: the base observation first, then boards, then the state
        width = unit.policy.spec.obs_dim
        unit_obs = obs[rows] if width == obs.shape[1] else obs[rows, :width]
        out, next_state = unit.act(unit_obs, uniforms[rows], row_owner[rows], None if mask is None else mask[rows],
                                   state)
        out = np.asarray(out)
        self._check_actions(out, rows, row_key)
        actions[rows] = out
        if recurrent and next_state is not None:
            next_state = np.asarray(next_state)
            for i, r in enumerate(rows):
                slots[r // n].states[r % n] = next_state[i]

    def _check_actions(self, out: np.ndarray, rows: np.ndarray, row_key: list) -> None:
        spec = self.spec
        if self.discrete:
            if out.shape != (rows.size,) or out.dtype.kind not in "iu":
                raise PolicyError(f"agent {row_key[rows[0]]!r} returned actions of shape {out.shape} dtype "
                                  f"{out.dtype}; discrete policies return int64[N], one action per row")
            bad = np.flatnonzero((out < 0) | (out >= spec.n_actions))
        else:
            if out.shape != (rows.size, spec.act_dim):
                raise PolicyError(f"agent {row_key[rows[0]]!r} returned actions of shape {out.shape}; continuous "
                                  f"policies return float32[N, {spec.act_dim}]")
            bad = np.flatnonzero(~(np.isfinite(out) & (np.abs(out) <= 1.0)).all(axis=1))
        if bad.size:
            row = int(rows[bad[0]])
            raise PolicyError(f"agent {row_key[row]!r} returned the invalid action {out[bad[0]].tolist()} for "
                              f"{self.game_id} (seat {row % self.n_agents}); valid: "
                              + (f"integers 0..{spec.n_actions - 1}" if self.discrete
                                 else f"{spec.act_dim} finite floats in [-1, 1]"))

    def _finish(self, slot: _Slot) -> MatchResult:
        env = slot.env
        replay_path = None
        result = MatchResult.from_team_result(slot.spec, self.team_of, env.team_result(), env.step_count)
        if slot.recorder is not None:
            replay_path = slot.recorder.close(result)
            result = MatchResult.from_team_result(slot.spec, self.team_of, env.team_result(), env.step_count,
                                                  replay_path=str(replay_path))
        return result
