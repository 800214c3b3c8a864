"""Whole-array engines: many matches of a board game stepped by a few numpy operations.

Some games ship a batched engine beside their single-match rules (GoBang's ``GoBangBoards`` and
Snake's ``SnakeBoards``, whose one-board instances *are* the rules' engines). When the league only needs outcomes (no
replay, no broadcast boards, no global state in the observations), the lockstep runner steps all
its matches through such an engine instead of one env per match: the same moves, observations and
results, without paying a Python env step per match. A match's result is still a function of its
spec and its agents only, so results are identical to the per-match path (tests check this).

An engine adapter offers, for ``n_slots`` matches:

* ``start(slot, seed)``: a new match in ``slot``;
* ``observe() -> float32[n_slots, n_agents, obs_dim]`` (rows of idle slots are unspecified);
* ``action_mask() -> bool[n_slots, n_agents, n_actions] | None``;
* ``acting() -> bool[n_slots, n_agents]``: the seats whose action the rules take this step;
* ``step(actions: int64[n_slots, n_agents]) -> bool[n_slots]``: steps every live match, returns the
  slots whose match ended (terminated or cut at ``max_cycles``);
* ``steps(slot) -> int`` and ``team_result(slot) -> float64[n_teams]`` of an ended match.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["BATCHED_GAMES", "GoBangMatches", "SnakeMatches", "batched_engine"]


class GoBangMatches:
    """GoBang matches stepped together on a ``GoBangBoards`` engine (see the GoBang manual: turn
    order, observation layout, illegal moves, draws)."""

    def __init__(self, rules: Any, n_slots: int, max_cycles: int) -> None:
        from arena_league.envs.games.gobang import GoBangBoards

        self.n_slots = n_slots
        self.n_agents = rules.n_agents
        self.players_per_team = rules.players_per_team
        self.team_of = np.asarray(rules.team_of, dtype=np.int64)
        self.max_cycles = max_cycles
        self.boards = GoBangBoards(n_slots, rules.size, rules.n_in_row)
        self.n_cells = self.boards.n_cells
        self.boards.done[:] = True  # idle slots: the engine leaves finished boards alone
        self._steps = np.zeros(n_slots, dtype=np.int64)
        self._seats = np.arange(self.n_agents)

    def start(self, slot: int, seed: int) -> None:
        # GoBang draws nothing at random: the seed is not needed, the board starts empty
        self.boards.reset(np.array([slot]))
        self._steps[slot] = 0

    def current_player(self) -> np.ndarray:
        """The seat to move on each board (GoBangRules.current_player, for every board at once)."""
        boards = self.boards
        return boards.to_move * self.players_per_team + (boards.n_stones // 2) % self.players_per_team

    def observe(self) -> np.ndarray:
        by_colour = self.boards.observe()  # [B, 2, obs_dim], 2T1P layout
        if self.players_per_team == 1:
            return by_colour
        obs = by_colour[:, self.team_of]  # teammates share a colour; "my turn" is per seat
        obs[:, :, 2 * self.n_cells] = self.current_player()[:, None] == self._seats[None, :]
        return obs

    def action_mask(self) -> np.ndarray:
        legal = self.boards.legal_mask()
        return np.broadcast_to(legal[:, None, :], (self.n_slots, self.n_agents, self.n_cells))

    def acting(self) -> np.ndarray:
        return (self.current_player()[:, None] == self._seats[None, :]) & ~self.boards.done[:, None]

    def step(self, actions: np.ndarray) -> np.ndarray:
        boards = self.boards
        live = ~boards.done
        moves = actions[np.arange(self.n_slots), self.current_player()]
        boards.step(np.where(live, moves, 0).astype(np.int64))
        self._steps += live
        # the env cuts a match at max_cycles: a draw (no winner yet, or the board would have ended it)
        cut = live & ~boards.done & (self._steps >= self.max_cycles)
        boards.done |= cut
        return live & boards.done

    def steps(self, slot: int) -> int:
        return int(self._steps[slot])

    def team_result(self, slot: int) -> np.ndarray:
        winner = int(self.boards.winner[slot])
        if winner < 0:
            return np.full(2, 0.5)
        return (np.arange(2) == winner).astype(np.float64)


class SnakeMatches:
    """Snake matches stepped together on a ``SnakeBoards`` engine built like ``SnakeRules``' own
    one-board engine (same size, food, start length, view, teams and quarter turns); each match's
    board key is drawn from its seed exactly as ``SnakeRules.reset`` draws it."""

    def __init__(self, rules: Any, n_slots: int, max_cycles: int) -> None:
        from arena_league.envs.games.snake import SnakeBoards

        one = rules.engine
        self.n_slots = n_slots
        self.max_cycles = max_cycles
        self.boards = SnakeBoards(n_slots, one.n_snakes, size=one.size, n_food=one.n_food,
                                  start_length=one.start_length, view_radius=one.view_radius,
                                  team_of=one.team_of, rotations=one.rotations)
        self.boards.done[:] = True  # idle slots: the engine leaves finished boards alone
        self._steps = np.zeros(n_slots, dtype=np.int64)

    def start(self, slot: int, seed: int) -> None:
        key = np.random.default_rng(seed).integers(0, 2**64, size=1, dtype=np.uint64)
        self.boards.reset(np.array([slot]), keys=key)
        self._steps[slot] = 0

    def observe(self) -> np.ndarray:
        return self.boards.observe()

    def action_mask(self) -> None:
        return None

    def acting(self) -> np.ndarray:
        return self.boards.alive & ~self.boards.done[:, None]

    def step(self, actions: np.ndarray) -> np.ndarray:
        boards = self.boards
        live = ~boards.done
        boards.step(actions.astype(np.int64, copy=False))
        self._steps += live
        cut = live & ~boards.done & (self._steps >= self.max_cycles)  # the env's max_cycles
        boards.done[cut] = True
        return live & boards.done

    def steps(self, slot: int) -> int:
        return int(self._steps[slot])

    def team_result(self, slot: int) -> np.ndarray:
        return self.boards.team_scores(np.array([slot]))[0]


#: Batched engines by game name (``GameRules.name``).
def _robot_matches(rules: Any, n_slots: int, max_cycles: int) -> Any:
    """Robot matches on a thread pool of MuJoCo datas (``envs.robots.game.RobotMatches``)."""
    from arena_league.envs.robots.game import RobotMatches

    return RobotMatches(rules, n_slots, max_cycles)


BATCHED_GAMES: dict[str, Callable[[Any, int, int], Any]] = {
    "GoBang": GoBangMatches,
    "Snake": SnakeMatches,
    **dict.fromkeys(("Sumo", "RunToGoal", "YouShallNotPass", "PushBox"), _robot_matches),
}


def batched_engine(probe_env: Any, n_slots: int) -> Any | None:
    """A whole-array engine of ``n_slots`` matches of the game of ``probe_env`` (an env made with the
    league's options), or None when the game has none. The caller checks that the observations are
    the rules' own (no broadcast boards, no global state), which is all the engines build."""
    engine = BATCHED_GAMES.get(probe_env.rules.name)
    return None if engine is None else engine(probe_env.rules, n_slots, probe_env.max_cycles)
