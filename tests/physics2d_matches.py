"""What the 2D physics games' tests share: playing a match out, the heuristic against random
teams, and the determinism check (from the same seed, the same actions give bit-identical
observations, states and measures, whatever the rules instance played before)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np


def play(r: Any, policy: Callable[[Any], np.ndarray], max_cycles: int = 300) -> int:
    """Step until the rules end the match or max_cycles; returns the number of steps."""
    for t in range(max_cycles):
        r.step(policy(r))
        if r.game_over:
            return t + 1
    r.finish()
    return max_cycles


def heuristic_against_random(rules_cls: Any, teams: int, players: int, action_type: str, seed: int,
                             heuristic_team: int) -> Any:
    """A match of ``rules_cls`` from ``seed``, played to its end (or its default ``max_cycles``):
    ``heuristic_team`` plays the heuristic, every other seat random actions drawn from
    ``1000 + seed``. Returns the finished rules."""
    r = rules_cls(teams, players, action_type)
    r.reset(seed)
    rng = np.random.default_rng(1000 + seed)
    random_seats = np.flatnonzero(r.team_of != heuristic_team)

    def policy(r: Any) -> np.ndarray:
        actions = rules_cls.heuristic(r.observe(), action_type)
        for seat in random_seats:
            actions[seat] = r.random_action(int(seat), rng)
        return actions

    play(r, policy, max_cycles=rules_cls.default_max_cycles)
    return r


def trace(r: Any, seed: int, steps: int, measures: Sequence[str]) -> list[Any]:
    """Observations, states, events and the named measures (copied: they change in place) of
    ``steps`` steps from ``r.reset(seed)``, team 0 playing the game's heuristic and team 1 the
    game's random actions drawn from ``seed``; a match that ends restarts from ``seed + 1``."""
    rng = np.random.default_rng(seed)
    r.reset(seed)
    out: list[Any] = [r.observe(), r.state()]
    for _ in range(steps):
        actions = type(r).heuristic(r.observe(), r.action_type)
        for seat in np.flatnonzero(r.team_of == 1):
            actions[seat] = r.random_action(int(seat), rng)
        r.step(actions)
        out += [r.observe(), r.state(), r.events()] + [getattr(r.measures, name).copy() for name in measures]
        if r.game_over:
            r.reset(seed + 1)
    return out


def assert_replays_bit_for_bit(make: Callable[[], Any], measures: Sequence[str], steps: int, detour: int) -> None:
    """A fresh instance and one that first played ``detour`` steps of another seed trace seed 3 alike;
    seed 4 starts elsewhere."""
    first = trace(make(), 3, steps, measures)
    used = make()
    trace(used, 11, detour, measures)  # a different history on the same instance
    second = trace(used, 3, steps, measures)
    assert len(first) == len(second)
    for a, b in zip(first, second):
        assert a == b if isinstance(a, list) else np.array_equal(a, b)
    assert not np.array_equal(first[0], trace(make(), 4, 0, measures)[0])


def heuristic_wins(rules_cls: Any, players: int, action_type: str, matches: int) -> int:
    """Two-team matches the heuristic wins against random moves, over seeds ``0 .. matches - 1``,
    the heuristic's team alternating with the seed."""
    wins = 0
    for seed in range(matches):
        heuristic_team = seed % 2
        r = heuristic_against_random(rules_cls, 2, players, action_type, seed, heuristic_team)
        wins += r.team_result()[heuristic_team] == 1.0
    return wins


def assert_a_copy_goes_on_as_the_original(r: Any, copier: Callable[[Any], Any], n_actions: int) -> None:
    """``copier(r)`` taken after 30 random steps plays the next 60 (or to the end) as ``r`` does."""
    rng = np.random.default_rng(0)
    for _ in range(30):
        r.step(rng.integers(0, n_actions, r.n_agents))
    duplicate = copier(r)
    for _ in range(60):
        step = rng.integers(0, n_actions, r.n_agents)
        r.step(step)
        duplicate.step(step)
        assert np.array_equal(r.observe(), duplicate.observe()) and r.events() == duplicate.events()
        if r.game_over:
            break
