"""Matches with submitted agents, played inside the inference sandbox's child process.

A match of submitted agents could be played here with their forwards sent to the sandbox step by
step (:class:`~arena_league.policies.sandbox.SandboxedPolicy` does that), but every step would then
cross between two processes twice. So the whole lockstep loop runs in the child instead: the
:class:`~arena_league.matchmaking.runner.LockstepRunner` plays there with every agent of the game
loaded (submitted and trusted alike), each unit's call marked and guarded
(:meth:`~arena_league.policies.sandbox.InferenceSandbox.run`), and results stream back as matches
end. The parent only watches: a call that runs past its budget is stopped by killing the child.
The budget binds the calls of units with a submitted (``sandboxed``) agent; trusted agents (the
built-in scripts, base members) are not held to it here, as they are not when they play outside
the sandbox, so the league's own agents never forfeit for the time a budget sized for submissions
allows.

What an agent's failure costs is the same as in the step-by-step path:

* an error, invalid actions or a non-finite state inside the child fail that agent's call; the
  runner in the child makes it forfeit its matches in flight and goes on;
* when the child dies (a call over its time budget, a crash, memory past the limit), the parent
  knows the call it was in (the shared progress marker) and so the agent: the matches that agent
  had in flight are forfeited here, at the step the child had reached, and every other match in
  flight is played again from its start in a new child. A match's result depends only on its spec
  and its agents, so a replayed match ends exactly as it would have;
* a stacked unit (agents of one architecture computed together) that kills the child is not
  blamed: its agents are computed apart from then on, and the replay finds the one at fault;
* an agent that cannot be loaded forfeits each of its matches without a step.

A submitted agent's time is bounded per call (the sandbox's budget) and per match (an overage bank,
:class:`~arena_league.matchmaking.runner.StepBudget`, with the sandbox's ``step_seconds`` and
``overage_seconds``); an overdrawn bank is a forfeit of that match, as a failed call is.

``forfeit_limit`` caps each agent's forfeits across all of this (see
:meth:`~arena_league.matchmaking.runner.LockstepRunner.play`): past it, its matches are skipped.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from arena_league.matchmaking.agents import AgentRef
from arena_league.matchmaking.runner import (
    LockstepRunner,
    MatchRecording,
    StepBudget,
    allowed,
    forfeit_allowance,
)
from arena_league.matchmaking.specs import MatchResult, MatchSpec
from arena_league.policies.policy import Policy
from arena_league.policies.sandbox import (
    ENGINE_BATCH_MATCHES,
    SandboxDied,
    SandboxLimits,
    largest_batch,
    process_sandbox,
)

__all__ = ["play_in_sandbox"]


def play_in_sandbox(game_id: str, specs: Sequence[MatchSpec], agents: Mapping[str, AgentRef], *,
                    batch_size: int = ENGINE_BATCH_MATCHES, env_kwargs: Mapping[str, Any] | None = None,
                    recording: MatchRecording | None = None, forfeit_limit: int | Mapping[str, int] | None = None,
                    on_result: Callable[[MatchResult], None] | None = None,
                    heartbeat: Callable[[], None] | None = None,
                    sandbox_limits: SandboxLimits | None = None, deadline: float | None = None
                    ) -> list[MatchResult]:
    """Plays ``specs`` (one game) in this process's sandbox child and returns their results in
    spec order, skipped specs left out (see the module docstring); past ``deadline`` (a
    ``time.time()``), the matches not finished are left out too."""
    from arena_league.envs import game_spec

    game = game_spec(game_id)
    team_of = np.repeat(np.arange(game.n_teams), game.players_per_team)
    sandbox = process_sandbox(sandbox_limits)
    refs = dict.fromkeys(agents.values())
    handles = sandbox.load({ref.key: ref.sandbox_source() for ref in refs})
    loaded = {seat: ref.key for seat, ref in agents.items()}
    timed = sorted(seat for seat, ref in agents.items() if ref.sandboxed)
    limit = forfeit_allowance(forfeit_limit, agents)
    play = _Play(specs, team_of, limit, on_result)
    for seat, key in list(loaded.items()):  # an agent that cannot be loaded loses each match without a step
        if handles[key].broken:
            play.forfeit_unplayed(seat, handles[key].broken)
            del loaded[seat]
    apart: set[str] = set()
    while True:
        pending = play.pending()
        if not pending:
            break
        play.round_started()
        try:
            sandbox.run(_play_task, (game_id, [(i, specs[i]) for i in pending], loaded, batch_size,
                                     dict(env_kwargs or {}), recording, play.allowance(), sorted(apart), timed,
                                     (sandbox.limits.step_seconds, sandbox.limits.overage_seconds), deadline),
                        on_message=play.receive, on_tick=heartbeat, what="a call")
            break  # what has no result now was skipped: its agents were past their forfeits
        except SandboxDied as death:
            culprits = play.culprits(death)
            if len({loaded[seat] for seat in culprits}) > 1:
                apart.update(loaded[seat] for seat in culprits)  # run them apart; the replay finds the one
            else:
                play.forfeit_in_flight(culprits, death)
        if heartbeat is not None:
            heartbeat()
    return play.results_in_order()


class _Play:
    """The parent's record of one ``play_in_sandbox`` call across the children it takes."""

    def __init__(self, specs: Sequence[MatchSpec], team_of: np.ndarray, limit: dict[str, float],
                 on_result: Callable[[MatchResult], None] | None) -> None:
        self.specs = specs
        self.team_of = team_of
        self.limit = limit
        self.on_result = on_result
        self.results: dict[int, MatchResult] = {}
        self.skipped: set[int] = set()
        self.forfeits: dict[str, int] = {}
        self.started: dict[int, int] = {}  # spec index -> the child's step when it started
        self.units: list[list[str]] = []

    def allowance(self) -> dict[str, float]:
        """What each agent may still forfeit, for the next child's runner."""
        return {key: value - self.forfeits.get(key, 0) for key, value in self.limit.items()}

    def stopped(self, seat: str) -> bool:
        return self.forfeits.get(seat, 0) >= allowed(self.limit, seat)

    def pending(self) -> list[int]:
        for index, spec in enumerate(self.specs):
            if index not in self.results and any(self.stopped(seat) for seat in spec.seats):
                self.skipped.add(index)
        return [i for i in range(len(self.specs)) if i not in self.results and i not in self.skipped]

    def round_started(self) -> None:
        self.started, self.units = {}, []

    def receive(self, message: tuple) -> None:
        kind = message[0]
        if kind == "units":
            self.units = message[1]
        elif kind == "start":
            self.started[message[1]] = message[2]
        elif kind == "result":
            self._record(message[1], message[2])

    def _record(self, index: int, result: MatchResult) -> None:
        self.results[index] = result
        for seat in result.forfeit_of:
            self.forfeits[seat] = self.forfeits.get(seat, 0) + 1
        if self.on_result is not None:
            self.on_result(result)

    def culprits(self, death: SandboxDied) -> list[str]:
        """The agents (seat keys) of the call the child died in."""
        if death.index is None or not 0 <= death.index < len(self.units):
            raise RuntimeError(f"the inference sandbox died outside any agent's call ({death.reason}); the "
                               "matches it was playing are not blamed on an agent")
        return self.units[death.index]

    def forfeit_in_flight(self, culprits: list[str], death: SandboxDied) -> None:
        """The matches the culprits had in flight when the child died end as their forfeits; the
        other matches in flight will be replayed from the start."""
        for index, start in self.started.items():
            spec = self.specs[index]
            failing = {seat: death.reason for seat in culprits if seat in spec.seats}
            if index not in self.results and failing:
                self._record(index, MatchResult.forfeited(spec, self.team_of, failing, death.step - start))

    def forfeit_unplayed(self, seat: str, reason: str) -> None:
        for index, spec in enumerate(self.specs):
            if seat in spec.seats and index not in self.results and not self.stopped(seat):
                self._record(index, MatchResult.forfeited(spec, self.team_of, {seat: reason}, 0))
        self.limit[seat] = min(self.limit.get(seat, np.inf), self.forfeits.get(seat, 0))  # it plays no more

    def results_in_order(self) -> list[MatchResult]:
        return [self.results[i] for i in sorted(self.results)]


class _Apart(Policy):
    """A policy that must not be stacked with others of its architecture (a stacked call of theirs
    killed the child): the engine stacks only torch policies, and this wrapper is not one."""

    def __init__(self, policy: Policy) -> None:
        self.policy = policy
        self.spec = policy.spec
        self.recurrent = policy.recurrent
        self.name = policy.name

    def initial_state(self, n: int) -> np.ndarray | None:
        return self.policy.initial_state(n)

    def act(self, obs: np.ndarray, uniforms: np.ndarray, mask: np.ndarray | None = None,
            state: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        return self.policy.act(obs, uniforms, mask, state)


def _play_task(child: Any, emit: Callable[[Any], None], game_id: str, indexed: list[tuple[int, MatchSpec]],
               loaded: Mapping[str, str], batch_size: int, env_kwargs: dict[str, Any],
               recording: MatchRecording | None, allowance: Mapping[str, float], apart: list[str],
               timed: list[str], per_step: tuple[float, float], deadline: float | None) -> None:
    """Runs in the sandbox child: plays ``indexed`` (spec index, spec) with the child's agents,
    every unit call guarded (held to the call budget when the unit holds a seat of ``timed``, whose
    agents also have ``per_step``: seconds a step and the overage bank of a match), emitting the
    units, each match's start (with the step) and result, until ``deadline``."""
    wrapped: dict[str, Policy] = {}
    for key in set(loaded.values()):
        policy = child.policies[key]
        wrapped[key] = _Apart(policy) if key in apart else policy
    policies = {seat: wrapped[key] for seat, key in loaded.items()}
    limit = largest_batch(game_id)
    timed_units: list[bool] = []

    def guard(index: int, *call: Any) -> tuple[Any, Any, dict[int, str]]:
        return child.guarded(index, *call, limit=limit, timed=timed_units[index])

    runner = LockstepRunner(game_id, policies, batch_size=batch_size, env_kwargs=env_kwargs, recording=recording,
                            guard=guard)
    units = runner.unit_agents()
    timed_units.extend(any(seat in timed for seat in unit) for unit in units)
    emit(("units", units))
    specs = [spec for _, spec in indexed]
    awaiting: dict[MatchSpec, list[int]] = {}

    def on_start(order: int) -> None:
        awaiting.setdefault(specs[order], []).append(order)
        emit(("start", indexed[order][0], int(child.progress[2])))

    def on_result(result: MatchResult) -> None:
        emit(("result", indexed[awaiting[result.spec].pop(0)][0], result))

    runner.play(specs, on_result, forfeit_limit=dict(allowance), heartbeat=child.tick, on_start=on_start,
                step_budget=StepBudget(per_step[0], per_step[1], frozenset(timed)), deadline=deadline)
