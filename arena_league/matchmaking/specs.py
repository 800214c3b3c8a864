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

Pairs
    A game whose teams play different roles (a runner and a blocker) declares its matches paired
    (``GameSpec.paired``): a pair is two matches, its *halves*, from the same env seed and the same
    seats' uniforms, with the two teams' agents swapped in the second, as boards are replayed with
    the cards turned in duplicate bridge and openings with colours reversed in engine matches. Each
    half reports the rules' ``pair_points()`` (what each team scored toward the pair); an agent's
    pair total is what its team scored in both halves, the higher total wins the pair and equal
    totals draw. A pair is rated as one match (its :class:`MatchResult` has both halves inside), so
    a placement's or a round robin's count of matches is a count of pairs.

Results
    :class:`MatchResult` maps the env's ``team_result()`` (each team's score, higher is better) to
    seats. With two teams every seat's outcome is ``"win"``, ``"loss"`` or ``"draw"``; with more
    teams it also has a finishing ``position`` (1 = first; tied teams share a position), and its
    outcome is ``"win"`` for a team alone in first place, ``"draw"`` for a shared first place and
    ``"loss"`` otherwise.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace
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
    plays seat ``i`` (``player_i``); seats are in team order, team 0's players first. A ``paired``
    spec is a pair of two-team matches (see the module docstring); :meth:`halves` gives its two
    matches, each with its ``half`` (0 or 1).
    """

    match_id: int
    game_id: str
    seats: tuple[str, ...]
    league_seed: int = 0
    paired: bool = False
    half: int | None = None

    def __post_init__(self) -> None:
        _check_non_negative_int(self.match_id, "match_id")
        _check_non_negative_int(self.league_seed, "league_seed")
        if not isinstance(self.game_id, str) or not self.game_id:
            raise ValueError(f"game_id must be a game id such as 'Crossroads-2T2P-v1', not {self.game_id!r}")
        seats = tuple(self.seats)
        if not seats or not all(isinstance(s, str) and s for s in seats):
            raise ValueError(f"seats must be one non-empty agent key per seat, got {self.seats!r}")
        if self.half not in (None, 0, 1):
            raise ValueError(f"half must be 0 or 1 (a pair's first or second match) or None, not {self.half!r}")
        if self.paired and self.half is not None:
            raise ValueError("a spec is either a pair (paired=True) or one half of one (half=0 or 1), not both")
        if (self.paired or self.half is not None) and len(seats) % 2:
            raise ValueError(f"a pair swaps two teams of equal size, but {len(seats)} seats do not split in two")
        object.__setattr__(self, "seats", seats)
        object.__setattr__(self, "match_id", int(self.match_id))
        object.__setattr__(self, "league_seed", int(self.league_seed))
        object.__setattr__(self, "paired", bool(self.paired))

    @property
    def seed(self) -> int:
        """The env seed (from ``(match_id, league_seed)`` only)."""
        return match_seed(self.match_id, self.league_seed)

    def seat_rng(self) -> np.random.Generator:
        """A fresh generator of the seats' uniform draws (the same for both halves of a pair: each
        role gets the same luck whoever holds it)."""
        return seat_rng(self.match_id, self.league_seed)

    def halves(self) -> tuple[MatchSpec, MatchSpec]:
        """The two matches of a pair: these seats, then the two teams' agents swapped."""
        if not self.paired:
            raise ValueError(f"match {self.match_id} is not a pair; only a paired spec has halves")
        n = len(self.seats) // 2
        first = replace(self, paired=False, half=0)
        return first, replace(first, seats=self.seats[n:] + self.seats[:n], half=1)

    def to_dict(self) -> dict[str, Any]:
        data = {"match_id": self.match_id, "game_id": self.game_id, "seats": list(self.seats),
                "league_seed": self.league_seed}
        if self.paired:
            data["paired"] = True
        if self.half is not None:
            data["half"] = self.half
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MatchSpec:
        half = data.get("half")
        return cls(int(data["match_id"]), str(data["game_id"]), tuple(data["seats"]), int(data.get("league_seed", 0)),
                   bool(data.get("paired", False)), None if half is None else int(half))


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
    paired: bool = False
    """Whether this is a pair (its two matches in :attr:`halves`)."""
    half: int | None = None
    """0 or 1 for one match of a pair, else None."""
    points: tuple[float, ...] = ()
    """Per seat, what its team scored toward the pair: in a half, the rules' ``pair_points()``; in
    a pair, the agent's total over both halves (empty for a single match)."""
    halves: tuple[MatchResult, ...] = ()
    """A pair's two matches, in order (empty otherwise)."""

    @classmethod
    def from_team_result(cls, spec: MatchSpec, team_of: Sequence[int] | np.ndarray,
                         team_scores: Sequence[float] | np.ndarray, steps: int,
                         replay_path: str | None = None,
                         pair_points: Sequence[float] | np.ndarray | None = None) -> MatchResult:
        """Maps each team's score (higher is better) to the seats of ``spec``; a half of a pair also
        maps each team's ``pair_points``."""
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
            replay_path=replay_path, half=spec.half,
            points=() if pair_points is None else tuple(float(pair_points[t]) for t in team_of))

    @classmethod
    def from_halves(cls, spec: MatchSpec, halves: Sequence[MatchResult]) -> MatchResult:
        """The result of the pair ``spec`` from its two played halves (see the module docstring): a
        team's total is what its agents scored in both halves; a forfeit in either half forfeits the
        pair."""
        first, second = halves
        n = len(spec.seats)
        team_of = np.asarray(first.teams, dtype=np.int64)
        steps = first.steps + second.steps
        forfeits = dict(first.forfeits) | dict(second.forfeits)
        if forfeits:
            result = cls.forfeited(spec, team_of, forfeits, steps, first.replay_path)
            return replace(result, paired=True, halves=(first, second))
        # seat i of the pair sits at seat (i + n/2) mod n in the second half
        total = np.asarray(first.points) + np.roll(np.asarray(second.points), n // 2)
        team_total = np.zeros(int(team_of.max()) + 1)
        team_total[team_of] = total
        result = cls.from_team_result(spec, team_of, np.sign(team_total - team_total[::-1]) * 0.5 + 0.5, steps,
                                      first.replay_path)
        return replace(result, paired=True, half=None, points=tuple(float(t) for t in total),
                       halves=(first, second))

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
        return MatchSpec(self.match_id, self.game_id, self.seats, self.league_seed, self.paired, self.half)

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
        data = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "halves"}
        for key in ("seats", "teams", "scores", "outcomes", "points"):
            data[key] = list(data[key])
        data["forfeits"] = [list(pair) for pair in self.forfeits]
        if self.positions is not None:
            data["positions"] = list(self.positions)
        data["halves"] = [half.to_dict() for half in self.halves]
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
            forfeits=tuple((str(key), str(reason)) for key, reason in data.get("forfeits", ())),
            paired=bool(data.get("paired", False)), half=None if data.get("half") is None else int(data["half"]),
            points=tuple(float(p) for p in data.get("points", ())),
            halves=tuple(cls.from_dict(half) for half in data.get("halves", ())))

    def halves_summary(self) -> list[dict[str, Any]] | None:
        """A pair's two matches as the registry keeps them beside the pair (None when unpaired)."""
        if not self.halves:
            return None
        return [{"seats": list(h.seats), "teams": list(h.teams), "scores": list(h.scores),
                 "outcomes": list(h.outcomes), "points": list(h.points), "steps": h.steps,
                 "replay_path": h.replay_path, "forfeits": [list(f) for f in h.forfeits]} for h in self.halves]

    def without_replay(self) -> MatchResult:
        """The same result with no replay path (to compare results played with and without one)."""
        return replace(self, replay_path=None, halves=tuple(half.without_replay() for half in self.halves))


def specs_for_seatings(game_id: str, seatings: Sequence[Sequence[str]], league_seed: int = 0,
                       first_match_id: int = 0) -> list[MatchSpec]:
    """Match specs from team-level seatings: ``seatings[k][t]`` is the agent that plays every seat
    of team ``t`` in the k-th match; match ids run from ``first_match_id``. A game played in pairs
    (``GameSpec.paired``) gets paired specs: each seating is then a pair, both ways round."""
    from arena_league.envs import game_spec

    spec = game_spec(game_id)
    specs = []
    for k, seating in enumerate(seatings):
        if len(seating) != spec.n_teams:
            raise ValueError(f"{game_id} has {spec.n_teams} teams; seating {k} names {len(seating)} agents: "
                             f"{list(seating)}")
        seats = tuple(agent for agent in seating for _ in range(spec.players_per_team))
        specs.append(MatchSpec(first_match_id + k, game_id, seats, league_seed, paired=spec.paired))
    return specs
