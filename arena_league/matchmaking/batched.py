"""Whole-array engines: many matches of one game stepped together by a few array operations.

Some games ship a batched engine beside their single-match rules and declare it as their rules'
``batched_matches`` (``GameRules.batched_matches``: a class called as ``batched_matches(rules,
n_slots, max_cycles)``, or None for games without one). When the league only needs outcomes (no
replay, no broadcast boards, no global state in the observations), the lockstep runner steps all
its matches through such an engine instead of one env per match: the same moves, observations and
results, without paying a Python env step per match. A match's result is still a function of its
spec and its agents only, so results are identical to the per-match path (tests check this).

An engine adapter offers, for ``n_slots`` matches:

* ``start(slot, seed)``: a new match in ``slot``;
* ``observe() -> float32[n_slots, n_agents, obs_dim]`` (rows of idle slots are unspecified);
* ``action_mask() -> bool[n_slots, n_agents, n_actions] | None``;
* ``acting() -> bool[n_slots, n_agents]``: the seats whose action the rules take this step;
* ``step(actions: int64[n_slots, n_agents]) -> bool[n_slots]`` (``float32[n_slots, n_agents,
  act_dim]`` for continuous actions): steps every live match, returns the slots whose match ended
  (terminated or cut at ``max_cycles``);
* ``steps(slot) -> int`` and ``team_result(slot) -> float64[n_teams]`` of an ended match, and
  ``pair_points(slot) -> float64[n_teams]``: what each team scored toward its pair, when the match
  is a half of a pair (the rules' ``pair_points()``).

A training run steps its envs on the same engines
(:class:`arena_league.training.engine_batch.EngineBatch`), computing rewards through the env's
social tree; for that an engine also offers ``measures`` (a ``Measures`` of ``[n_slots, n_agents]``
arrays holding what the rules' measures would, kept current by ``start`` and ``step``, ``outcome``
set when a match ends by the rules or at ``max_cycles``), ``state() -> float32[n_slots, state_dim]``,
``current_player() -> int64[n_slots]`` in turn-based games, and ``observe()`` rows of a match that
ended equal to the rules' observation after the end.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from arena_league.envs import GameRules

__all__ = ["batched_engine", "batched_matches_of", "has_batched_engine"]


def batched_matches_of(rules: GameRules) -> Callable[..., Any] | None:
    """The whole-array engine class the game of ``rules`` declares, or None (read off the rules'
    class, so a plain function declared there is not bound as a method)."""
    return type(rules).batched_matches


def has_batched_engine(rules: GameRules) -> bool:
    """Whether the game of ``rules`` has a whole-array engine."""
    return batched_matches_of(rules) is not None


def batched_engine(probe_env: Any, n_slots: int) -> Any | None:
    """A whole-array engine of ``n_slots`` matches of the game of ``probe_env`` (an env made with the
    league's options), or None when the game has none. The caller checks that the observations are
    the rules' own (no broadcast boards, no global state), which is all the engines build."""
    engine = batched_matches_of(probe_env.rules)
    return None if engine is None else engine(probe_env.rules, n_slots, probe_env.max_cycles)
