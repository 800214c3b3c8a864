"""Match specs, seeds and results: what the engine is asked to play and what it reports.

A league plays many matches, each named by an integer ``match_id`` within a league whose
``league_seed`` is fixed once (after the population evaluation of Arena, Song et al., "Arena: A
General Evaluation Platform and Building Toolkit for Multi-Agent Intelligence", AAAI 2020, where
every new agent is ranked by matches against a fixed base population).

Seeds
    Every random draw of a match flows from ``(league_seed, match_id)`` and nothing else (not the
    batch a match is played in, not the backend, not the worker), through numpy's
    ``SeedSequence([league_seed, match_id])``:

    * the env seed (:attr:`MatchSpec.seed`) is its first 64-bit state word shifted right by one
      (a non-negative 63-bit integer, as stored in the registry's ``matches.seed``);
    * the seats' uniform draws (:meth:`MatchSpec.seat_rng`) come from the generator of its child
      ``SeedSequence([league_seed, match_id], spawn_key=(1,))``: each step, one
      ``float64[n_agents, k]`` draw for all seats, whether or not a seat acts.

Results
    :class:`MatchResult` maps the env's ``team_result()`` (each team's score, higher is better) to
    seats. With two teams every seat's outcome is ``"win"``, ``"loss"`` or ``"draw"``; with more
    teams it also has a finishing ``position`` (1 = first; tied teams share a position), and its
    outcome is ``"win"`` for a team alone in first place, ``"draw"`` for a shared first place and
    ``"loss"`` otherwise.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

__all__ = ["OUTCOMES", "MatchResult", "MatchSpec", "match_seed", "seat_rng", "specs_for_seatings"]

#: Words a seat's outcome can take (the registry's ``Outcome`` vocabulary).
OUTCOMES = ("win", "loss", "draw")

_SEAT_STREAM = 1  # spawn key of the seats' uniform stream, apart from the env seed


def _check_non_negative_int(value: Any, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{what} must be a non-negative integer, not {value!r}")
    return int(value)


def match_seed(match_id: int, league_seed: int) -> int:
    """The env seed of match ``match_id`` of a league: the first 64-bit word of
    ``SeedSequence([league_seed, match_id])`` shifted right by one (0 <= seed < 2**63)."""
    match_id = _check_non_negative_int(match_id, "match_id")
    league_seed = _check_non_negative_int(league_seed, "league_seed")
    word = np.random.SeedSequence([league_seed, match_id]).generate_state(1, np.uint64)[0]
    return int(word >> np.uint64(1))


def seat_rng(match_id: int, league_seed: int) -> np.random.Generator:
    """The generator of the seats' uniform draws of a match (see the module docstring)."""
    match_id = _check_non_negative_int(match_id, "match_id")
    league_seed = _check_non_negative_int(league_seed, "league_seed")
    sequence = np.random.SeedSequence([league_seed, match_id], spawn_key=(_SEAT_STREAM,))
    return np.random.Generator(np.random.PCG64(sequence))


@dataclass(frozen=True)
class MatchSpec:
    """One match to play: its id in the league, the game, and the agent key of every seat.

    ``seats[i]`` is the key (a name in the agents mapping given to the engine) of the agent that
    plays seat ``i`` (``player_i``); seats are in team order, team 0's players first.
    """

    match_id: int
    game_id: str
    seats: tuple[str, ...]
    league_seed: int = 0

    def __post_init__(self) -> None:
        _check_non_negative_int(self.match_id, "match_id")
        _check_non_negative_int(self.league_seed, "league_seed")
        if not isinstance(self.game_id, str) or not self.game_id:
            raise ValueError(f"game_id must be a game id such as 'Crossroads-2T2P-v1', not {self.game_id!r}")
        seats = tuple(self.seats)
        if not seats or not all(isinstance(s, str) and s for s in seats):
            raise ValueError(f"seats must be one non-empty agent key per seat, got {self.seats!r}")
        object.__setattr__(self, "seats", seats)
        object.__setattr__(self, "match_id", int(self.match_id))
        object.__setattr__(self, "league_seed", int(self.league_seed))

    @property
    def seed(self) -> int:
        """The env seed (from ``(match_id, league_seed)`` only)."""
        return match_seed(self.match_id, self.league_seed)

    def seat_rng(self) -> np.random.Generator:
        """A fresh generator of the seats' uniform draws."""
        return seat_rng(self.match_id, self.league_seed)

    def to_dict(self) -> dict[str, Any]:
        return {"match_id": self.match_id, "game_id": self.game_id, "seats": list(self.seats),
                "league_seed": self.league_seed}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MatchSpec:
        return cls(int(data["match_id"]), str(data["game_id"]), tuple(data["seats"]), int(data.get("league_seed", 0)))


@dataclass(frozen=True)
class MatchResult:
    """A played match, seat by seat (one entry per seat in every tuple)."""

    match_id: int
    game_id: str
    league_seed: int
    seed: int
    seats: tuple[str, ...]
    """Agent key of each seat."""
    teams: tuple[int, ...]
    scores: tuple[float, ...]
    """The seat's team score from ``team_result()`` (two teams: 1 win, 0.5 draw, 0 loss)."""
    outcomes: tuple[str, ...]
    """``"win"``, ``"loss"`` or ``"draw"`` per seat."""
    positions: tuple[int, ...] | None
    """Finishing position of the seat's team (1 = first) with more than two teams, else None."""
    steps: int
    replay_path: str | None = None
    forfeits: tuple[tuple[str, str], ...] = ()
    """``(agent key, reason)`` for each agent that forfeited the match (see :meth:`forfeited`)."""

    @classmethod
    def from_team_result(cls, spec: MatchSpec, team_of: Sequence[int] | np.ndarray,
                         team_scores: Sequence[float] | np.ndarray, steps: int,
                         replay_path: str | None = None) -> MatchResult:
        """Maps each team's score (higher is better) to the seats of ``spec``."""
        team_of = np.asarray(team_of, dtype=np.int64)
        team_scores = np.asarray(team_scores, dtype=np.float64)
        if team_of.shape != (len(spec.seats),):
            raise ValueError(f"match {spec.match_id}: {len(spec.seats)} seats but {team_of.size} team indices")
        n_teams = team_scores.size
        above = (team_scores[None, :] > team_scores[:, None]).sum(axis=1)
        tied = (team_scores[None, :] == team_scores[:, None]).sum(axis=1) - 1
        words = np.where(above > 0, "loss", np.where(tied > 0, "draw", "win"))
        positions = None if n_teams == 2 else tuple(int(1 + above[t]) for t in team_of)
        return cls(
            match_id=spec.match_id, game_id=spec.game_id, league_seed=spec.league_seed, seed=spec.seed,
            seats=spec.seats, teams=tuple(int(t) for t in team_of),
            scores=tuple(float(team_scores[t]) for t in team_of),
            outcomes=tuple(str(words[t]) for t in team_of), positions=positions, steps=int(steps),
            replay_path=replay_path)

    @classmethod
    def forfeited(cls, spec: MatchSpec, team_of: Sequence[int] | np.ndarray, forfeits: Mapping[str, str], steps: int,
                  replay_path: str | None = None) -> MatchResult:
        """A match cut short because agents of ``forfeits`` (key -> reason) failed: as in Kaggle's
        strict mode, a team with a forfeiting seat loses (score 0) and every other team wins (1);
        a match every team forfeits is a draw."""
        team_of = np.asarray(team_of, dtype=np.int64)
        failing = {int(team_of[i]) for i, key in enumerate(spec.seats) if key in forfeits}
        n_teams = int(team_of.max()) + 1
        scores = [0.0 if team in failing else 1.0 for team in range(n_teams)]
        result = cls.from_team_result(spec, team_of, scores, steps, replay_path)
        seated = [(key, forfeits[key]) for key in dict.fromkeys(spec.seats) if key in forfeits]
        return replace(result, forfeits=tuple(seated))

    @property
    def forfeit_of(self) -> dict[str, str]:
        """Agent key -> why it forfeited this match (empty when nobody did)."""
        return dict(self.forfeits)

    @property
    def spec(self) -> MatchSpec:
        return MatchSpec(self.match_id, self.game_id, self.seats, self.league_seed)

    def team_scores(self) -> dict[int, float]:
        """Each team's score."""
        return dict(zip(self.teams, self.scores))

    def seat_rows(self) -> list[dict[str, Any]]:
        """One row per seat with the registry's ``match_seats`` columns (agent is the seat's key)."""
        return [{"seat": i, "agent": agent, "team": team, "score": score, "outcome": outcome,
                 "position": None if self.positions is None else self.positions[i]}
                for i, (agent, team, score, outcome) in enumerate(zip(self.seats, self.teams, self.scores,
                                                                      self.outcomes))]

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        for key in ("seats", "teams", "scores", "outcomes"):
            data[key] = list(data[key])
        data["forfeits"] = [list(pair) for pair in self.forfeits]
        if self.positions is not None:
            data["positions"] = list(self.positions)
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MatchResult:
        positions = data.get("positions")
        return cls(
            match_id=int(data["match_id"]), game_id=str(data["game_id"]), league_seed=int(data["league_seed"]),
            seed=int(data["seed"]), seats=tuple(data["seats"]), teams=tuple(int(t) for t in data["teams"]),
            scores=tuple(float(s) for s in data["scores"]), outcomes=tuple(data["outcomes"]),
            positions=None if positions is None else tuple(int(p) for p in positions),
            steps=int(data["steps"]), replay_path=data.get("replay_path"),
            forfeits=tuple((str(key), str(reason)) for key, reason in data.get("forfeits", ())))

    def without_replay(self) -> MatchResult:
        """The same result with no replay path (to compare results played with and without one)."""
        return replace(self, replay_path=None)


def specs_for_seatings(game_id: str, seatings: Sequence[Sequence[str]], league_seed: int = 0,
                       first_match_id: int = 0) -> list[MatchSpec]:
    """Match specs from team-level seatings: ``seatings[k][t]`` is the agent that plays every seat
    of team ``t`` in the k-th match; match ids run from ``first_match_id``."""
    from arena_league.envs import game_spec

    spec = game_spec(game_id)
    specs = []
    for k, seating in enumerate(seatings):
        if len(seating) != spec.n_teams:
            raise ValueError(f"{game_id} has {spec.n_teams} teams; seating {k} names {len(seating)} agents: "
                             f"{list(seating)}")
        seats = tuple(agent for agent in seating for _ in range(spec.players_per_team))
        specs.append(MatchSpec(first_match_id + k, game_id, seats, league_seed))
    return specs
