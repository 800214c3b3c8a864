"""Human ranking: a person plays base agents in the terminal, from the weakest upward.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) reports a "human ranking among the base population": people play the
base agents and are placed among them like any entrant. :func:`play_human` does that:

* the person is an agent of kind ``human`` (``<player>@<game>``); every match is recorded in the
  registry like any other, so leaderboards count it;
* opponents come from a frozen, rated base population (by default the one its entrants are ranked
  against: ``base-v2`` where one is shipped), weakest first;
  a win climbs the ladder by ``climb`` places, a draw stays, a loss steps back half as far;
* after each match the person's rating, its 95% interval and rank among the base come from the
  rating engine's :func:`~arena_league.rating.place_entrant` over all their results against
  that population, kept as a finished ``rank`` job, so the game's leaderboard places the person
  like any entrant;
* the person holds one seat (team 0's first seat in odd-numbered matches, team 1's in the
  others); in team layouts the person's teammates are played by the same base agent as the
  opponents, so the two teams differ only in the seat the person holds;
* in a game played in pairs (a runner and a blocker: :meth:`~arena_league.matchmaking.MatchSpec.halves`)
  a match is a pair: the person plays its first half in one role and, from the same start, its
  second half in the other, and the pair is decided by the game's comparison of the two halves.

What the person sees and types is the game's own: its rules give the controls of the person's
seat (``GameRules.human_controls``, see :mod:`arena_league.envs.controls`), and each game's
manual (its module docstring, "Playing it") says what to type: a cell on a board game, a move on
the board as drawn, an action by number or name, a walking direction for the robots. An answer
the controls refuse is refused with the reason, and asked again. ``picture_dir`` also saves the
top-down picture of every step the person acts as a PNG.

``q`` (or end of input) resigns the match in progress, which counts as a loss, and ends the session.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from arena_league import registry as reg
from arena_league.envs import game_spec, make
from arena_league.envs.controls import Controls
from arena_league.matchmaking import MatchResult, MatchSpec
from arena_league.rating import place_entrant
from arena_league.registry.repository import AGENT_NAME_PATTERN

__all__ = ["HumanMatch", "HumanSession", "Ladder", "LiveMatch", "play_human"]

InputFn = Callable[[str], str]

_QUIT = {"q", "quit", "resign", "exit"}


@dataclass
class HumanMatch:
    """One match the person played."""

    opponent: str
    opponent_rating: float
    team: int
    outcome: str
    """``win``, ``loss`` or ``draw`` for the person."""
    steps: int
    match_key: str
    resigned: bool = False


@dataclass
class HumanSession:
    """What a session of :func:`play_human` did, and where the person stands."""

    agent: str
    game_id: str
    base: str
    base_size: int
    matches: list[HumanMatch] = field(default_factory=list)
    rating: float | None = None
    lower: float | None = None
    upper: float | None = None
    rank: int | None = None
    rank_lower: int | None = None
    rank_upper: int | None = None
    percentile: float | None = None
    total_matches: int = 0
    """The person's matches against this base, earlier sessions included."""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class _Resign(Exception):
    """The person typed q (or input ended)."""


def play_human(game_id: str, against: str | None = None, league: reg.League | None = None, *,
               player: str = "human", input_fn: InputFn = input, output: TextIO | None = None, seed: int = 0,
               matches: int | None = None, climb: int | None = None, picture_dir: str | Path | None = None
               ) -> HumanSession:
    """Let a person play ``game_id`` against the base population ``against`` in the terminal.

    Args:
        game_id: a two-team game.
        against: the frozen base population (``name`` or ``name:version``) of that game; by default
            the one its entrants are ranked against (the newest: ``base-v2`` where one is shipped).
        league: the league (default: :func:`arena_league.league.home.open_home`).
        player: the person's name; their agent is ``<player>@<game_id>`` (kind ``human``), and a
            later session with the same name continues their record.
        input_fn: reads one line after a prompt (``input``; tests pass a scripted one).
        output: where the board and messages go (default stdout).
        seed: seeds the matches (env and the agents' sampling).
        matches: matches to play at most (default: until the person types ``q``).
        climb: places to climb after a win (default a tenth of the base, at least 1).
        picture_dir: save the top-down picture of every step the person acts there as PNG.
    """
    out = output if output is not None else sys.stdout
    ladder = Ladder(game_id, against, league, player=player, climb=climb)
    if ladder.imported:
        out.write(f"imported the shipped base population {ladder.against} of {game_id}\n")
    report = ladder.report
    names, ratings = ladder.names, ladder.ratings
    print(f"You are {ladder.agent_name}. {report.base} has {len(names)} agents, rated {ratings.min():.0f} to "
          f"{ratings.max():.0f}; you start with the weakest. Type q to resign and stop.", file=out)
    while matches is None or ladder.played < matches:
        match = ladder.next_match(seed)
        pair = (f" in the first half of a pair, then team {1 - match.team} in the second from the same start"
                if match.half is not None else "")
        print(f"\n=== Match {ladder.played + 1}: you play team {match.team}{pair} against {match.opponent} (rating "
              f"{match.opponent_rating:.0f}, {ladder.rung + 1} of {len(names)} from the bottom)", file=out)
        resigned = False
        try:
            _play_match(match, input_fn, out, picture_dir)
        except _Resign:
            resigned = True
        played = ladder.record(match, resigned=resigned)
        print(f"--- You {'resigned: a loss' if resigned else {'win': 'won', 'loss': 'lost', 'draw': 'drew'}[played.outcome]}"
              f" against {match.opponent}.", file=out)
        print(f"Your estimated placement: rating {report.rating:.0f} (95% {report.lower:.0f} .. {report.upper:.0f}), "
              f"rank {report.rank} of {len(names) + 1} (between {report.rank_lower} and {report.rank_upper}), above "
              f"{report.percentile:.0f}% of {report.base}, from {report.total_matches} match(es).", file=out)
        if resigned or (matches is not None and ladder.played >= matches):
            break
        try:
            answer = input_fn("Next match? [Enter: play, q: stop] ").strip().lower()
        except EOFError:
            break
        if answer in _QUIT:
            break
    return report


class Ladder:
    """A person's climb through a frozen base population, weakest first (see the module docstring):
    the opponent of the next match, and each match played recorded and placed.

    Both front ends use it: the terminal (:func:`play_human`) and the browser
    (:mod:`arena_league.league.live`). ``owner`` is who owns the person's agent (default: the
    player's name)."""

    def __init__(self, game_id: str, against: str | None = None, league: reg.League | None = None, *,
                 player: str = "human", owner: str | None = None, climb: int | None = None) -> None:
        from arena_league.league.home import open_home, register_game
        from arena_league.league.populations import default_population, ensure_population
        from arena_league.league.service import agent_refs, base_population

        spec = game_spec(game_id)
        if spec.n_teams != 2:
            raise ValueError(f"{game_id} has {spec.n_teams} teams; human ranking places a person among a base "
                             "population with two-team matches")
        league = league if league is not None else open_home()
        register_game(league, game_id)
        agent_name = f"{player}@{game_id}"
        if not AGENT_NAME_PATTERN.match(agent_name):
            raise ValueError(f"player name {player!r} is not allowed: use letters, digits and . _ - (it becomes the "
                             f"agent name {agent_name!r})")
        if against is None:  # the population its entrants are ranked against
            found, self.imported = default_population(league, game_id)
            if found is None:
                raise ValueError(f"{game_id} has no base population in this league and none is shipped; import or "
                                 f"build one (`arena-league population import FOLDER`, `arena-league population build "
                                 f"{game_id}`)")
            against = found
        else:
            against, self.imported = ensure_population(league, game_id, against)
        label, names, ratings = base_population(league, game_id, agent_name, against)
        if not names:
            raise ValueError(f"population {against} of {game_id} has no members to play")
        if ratings is None:
            raise ValueError(f"population {label} has no stored ratings (it is not frozen with ratings); import a "
                             f"built base population: `arena-league population import checkpoints/{game_id}/base-v1`")
        self.league, self.game_id, self.against, self.agent_name = league, game_id, against, agent_name
        self.n_agents = spec.n_agents
        self.names, self.ratings = names, ratings
        self.human_id = _human_agent(league, agent_name, game_id, owner or player, player)
        self.order = np.argsort(ratings, kind="stable")  # weakest first
        with league.reading() as session:
            self.refs = agent_refs(session, league, [reg.require_agent(session, name) for name in names])
        self.step = climb if climb is not None else max(1, len(names) // 10)
        self.report = HumanSession(agent_name, game_id, label, len(names))
        self.rung = 0
        self.played = 0

    @property
    def opponent(self) -> tuple[str, float]:
        """The next opponent and its frozen rating."""
        member = int(self.order[self.rung])
        return self.names[member], float(self.ratings[member])

    def next_match(self, seed: int = 0) -> LiveMatch:
        """The next match, ready to step: the person in team ``played % 2``'s first seat, every other
        seat played by the current opponent."""
        opponent, rating = self.opponent
        with self.league.reading() as session:
            number = reg.count_matches(session, self.game_id, agent_id=self.human_id)
        spec = MatchSpec(number + 1, self.game_id, tuple(opponent for _ in range(self.n_agents)), seed,
                         paired=game_spec(self.game_id).paired)
        return LiveMatch(spec, self.refs[opponent].load(), self.played % 2, opponent, rating,
                         f"human:{self.human_id}:{number + 1}")

    def record(self, match: LiveMatch, *, resigned: bool = False) -> HumanMatch:
        """Store ``match`` (a resignation is a loss, whatever the board said), place the person
        again from all their matches against this base, and move along the ladder."""
        team, steps = match.team, match.steps
        match.scores = np.where(np.arange(2) == team, 0.0, 1.0) if resigned else match.finish()
        result, match.match_id = _record(self.league, match, match.scores, self.human_id, self.agent_name)
        outcome = result.outcomes[result.teams.index(team)]
        played = HumanMatch(match.opponent, match.opponent_rating, team, outcome, steps, match.key, resigned)
        self.report.matches.append(played)
        self.played += 1
        _place(self.league, self.game_id, self.agent_name, self.names, self.ratings, self.report)
        if outcome == "win":
            self.rung = min(len(self.names) - 1, self.rung + self.step)
        elif outcome == "loss":
            self.rung = max(0, self.rung - max(1, self.step // 2))
        return played


def _human_agent(league: reg.League, name: str, game_id: str, owner: str, player: str) -> int:
    """The person's agent (created on first play). Registered as retired: kept with its matches,
    but never scheduled into the league's automatic evaluations, which need an artifact to play."""
    with league.transaction() as session:
        agent = reg.get_agent(session, name)
        if agent is None:
            agent = reg.create_agent(session, name, game_id, "human", owner=owner, status="retired",
                                     metadata={"player": player})
            session.flush()
        elif agent.kind != "human" or agent.game_id != game_id or agent.owner != owner:
            raise ValueError(f"the name {name} belongs to another {agent.kind} agent of {agent.game_id}; play under "
                             "another player name")
        return int(agent.id)


def _record(league: reg.League, match: LiveMatch, team_scores: np.ndarray, human_id: int, person: str
            ) -> tuple[MatchResult, int]:
    """Store ``match`` ended with ``team_scores`` (the person, agent ``person``, holding the first seat
    of their team): its result and its row id."""
    spec = match.spec
    result = MatchResult.from_team_result(spec, match.rules.team_of, team_scores, match.steps)
    halves = None
    if len(match.halves) == 2:  # a pair played out (a resignation leaves it unfinished: no halves)
        halves = MatchResult.from_halves(spec, match.halves).halves_summary()
        for k, half in enumerate(halves):  # the person's seat: the first of the team they held in that half
            side = match.team if k == 0 else 1 - match.team
            half["seats"][half["teams"].index(side)] = person
    with league.transaction() as session:
        opponent_id = reg.require_agent(session, match.opponent).id
        seats = [reg.SeatResult(human_id if t == match.team else opponent_id, t, score, outcome)
                 for t, score, outcome in zip(result.teams, result.scores, result.outcomes)]
        [stored] = reg.record_matches(session, spec.game_id, [reg.MatchRecord(match.key, spec.seed, seats,
                                                                              halves=halves)])
    return result, stored.match_id


def _place(league: reg.League, game_id: str, agent: str, names: list[str], ratings: np.ndarray,
           report: HumanSession) -> None:
    """The person's placement from all their matches against the base members."""
    from arena_league.league.service import base_seat_advantage

    index = {n: i for i, n in enumerate(names)}
    # per side the person held (team 0 or 1), so that the base's seat term applies
    wins, losses, draws = (np.zeros((2, len(names))) for _ in range(3))
    with league.reading() as session:
        rows = reg.match_seat_rows(session, game_id, agents=[agent, *names])
    by_match: dict[int, dict[str, tuple[str, int]]] = {}
    for row in rows:
        by_match.setdefault(row["match_id"], {})[row["agent"]] = (row["outcome"], int(row["team"]))
    total = 0
    for seats in by_match.values():
        if agent not in seats or len(seats) != 2:
            continue
        (opponent,) = [a for a in seats if a != agent]
        outcome, side = seats[agent]
        counter = {"win": wins, "loss": losses, "draw": draws}[outcome]
        counter[side, index[opponent]] += 1
        total += 1
    placement = place_entrant(ratings, wins, losses, draws,
                              seat_advantage=base_seat_advantage(league, game_id, report.base))
    report.rating, report.lower, report.upper = placement.rating, placement.lower, placement.upper
    report.rank, report.rank_lower, report.rank_upper = placement.rank, placement.rank_lower, placement.rank_upper
    report.percentile = placement.percentile
    report.total_matches = total
    # kept as a finished placement, so the game's leaderboard lists the person like any entrant
    with league.transaction() as session:
        reg.record_finished_job(session, "rank", {"agent": agent, "game_id": game_id, "base_label": report.base,
                                                  "human": True},
                                {**asdict(placement), "agent": agent, "game_id": game_id, "base": report.base,
                                 "base_size": len(names), "human": True})


# --- one match ---------------------------------------------------------------------------------------

#: How an event reads in a sentence, by kind (other kinds read as their name).
_EVENT_VERBS = {"five": "made five in a row", "goal": "scored a goal", "death": "died", "eat": "ate",
                "arrive": "arrived", "out": "was pushed out of the ring", "fall": "fell", "move": "moved",
                "illegal_move": "tried an illegal move", "draw": "drew"}


class LiveMatch:
    """One match with a person in one seat, stepped one env step at a time: the person's seat is
    team ``team``'s first, every other seat is played by ``policy`` (the opponent). What the person
    types goes through the game's own controls (``rules.human_controls(seat)``)."""

    def __init__(self, spec: MatchSpec, policy: Any, team: int, opponent: str, opponent_rating: float, key: str
                 ) -> None:
        env = make(spec.game_id)
        self.spec, self.policy, self.team, self.key = spec, policy, int(team), key
        """``team``: the person's team in the match (in a pair: in its first half)."""
        self.opponent, self.opponent_rating = opponent, float(opponent_rating)
        self.rules = env.rules
        self.n = self.rules.n_agents
        self.max_cycles = env.max_cycles
        self.steps = 0
        """Steps played (both halves of a pair)."""
        self.half: int | None = 0 if spec.paired else None
        """The half of a pair in play (0, then 1); None for a single match."""
        self.halves: list[MatchResult] = []
        """Each finished half of a pair, as the match engine reports one (its seats are keys)."""
        self._start(int(team))
        self.events: list[dict[str, Any]] = []
        """Every event the rules reported, with its ``step``."""
        self.scores: np.ndarray | None = None
        """The team scores, once :meth:`Ladder.record` stored the match (a resignation: a loss)."""
        self.match_id: int | None = None
        """The stored match's row id, once recorded."""

    def _start(self, side: int) -> None:
        """(Re)start the rules from the match seed with the person on team ``side``."""
        rules = self.rules
        rules.reset(self.spec.seed)
        self.rng = self.spec.seat_rng()  # both halves of a pair: the same luck for the same role
        self.side = side
        """The person's team in the match (or half) in play."""
        self.seat = int(np.flatnonzero(rules.team_of == side)[0])
        self.states = self.policy.initial_state(self.n)
        self.controls = rules.human_controls(self.seat)
        self.half_steps = 0

    @property
    def over(self) -> bool:
        ended = bool(self.rules.game_over) or self.half_steps >= self.max_cycles
        return ended and self.half != 0

    def person_acts(self) -> bool:
        """Whether the person's seat acts this step (its turn, or it is still in play)."""
        return bool(self._acting()[self.seat])

    def _acting(self) -> np.ndarray:
        """Which seats act this step: the one whose turn it is, or those still in play."""
        rules = self.rules
        if rules.turn_based:
            acting = np.zeros(self.n, dtype=bool)
            acting[rules.current_player()] = True
            return acting
        return np.asarray(rules.measures.active, dtype=bool).copy()

    def needs_command(self) -> bool:
        """Whether this step waits for the person to say something (their seat acts and their
        controls ask; the robots' controls hold a direction for some steps)."""
        return not self.over and self.person_acts() and self.controls.wants_command()

    def step(self, command: Any = None) -> list[dict[str, Any]]:
        """One env step: the opponent's seats act, the person's seat acts by ``command`` (accepted by
        the controls' ``parse``; None on a step that asks nothing); the step's events."""
        if self.over:
            raise ValueError("the match is over")
        rules, policy, n = self.rules, self.policy, self.n
        obs = rules.observe()
        mask = rules.action_mask()
        uniforms = self.rng.random((n, policy.spec.uniforms_per_seat))
        acting = self._acting()
        if acting[self.seat] and command is None and self.controls.wants_command():
            raise ValueError("this step waits for the person's move")
        actions = np.zeros(n, dtype=np.int64) if rules.action_type == "discrete" else \
            np.zeros((n, rules.act_dim), dtype=np.float32)
        agents = np.flatnonzero(acting & (np.arange(n) != self.seat))
        if agents.size:
            chosen, next_state = policy.act(obs[agents, : policy.spec.obs_dim], uniforms[agents],
                                            None if mask is None else mask[agents],
                                            None if self.states is None else self.states[agents])
            actions[agents] = chosen
            if self.states is not None and next_state is not None:
                self.states[agents] = next_state
        if acting[self.seat]:
            actions[self.seat] = self.controls.action(command)
        rules.step(actions)
        events = [{**event, "step": self.steps} for event in rules.events()]
        self.steps += 1
        self.half_steps += 1
        if self.half == 0 and (rules.game_over or self.half_steps >= self.max_cycles):
            self._end_half()
            self.half = 1
            self._start(1 - self.team)
            events.append({"kind": "half_time", "step": self.steps - 1, "team": self.side})
        self.events += events
        return events

    def _end_half(self) -> None:
        """Keep the half in play as a finished match of the pair."""
        rules = self.rules
        if not rules.game_over:
            rules.finish()
        half = self.spec.halves()[self.half]
        self.halves.append(MatchResult.from_team_result(half, rules.team_of, rules.team_result(), self.half_steps,
                                                        pair_points=rules.pair_points()))

    @property
    def half_points(self) -> list[np.ndarray]:
        """Each finished half's ``pair_points`` per team."""
        return [np.asarray([h.points[h.teams.index(t)] for t in (0, 1)]) for h in self.halves]

    def finish(self) -> np.ndarray:
        """The team scores once the match is over (a match cut by its step limit is finished by
        the rules: a draw or by the score, as the game says). A pair's are its teams' (those of its
        first half): the higher total of ``pair_points`` over both halves wins."""
        if self.half is None:
            if not self.rules.game_over:
                self.rules.finish()
            return np.asarray(self.rules.team_result(), dtype=np.float64)
        if len(self.halves) < 2:
            self._end_half()
        # decided as the match engine decides a pair, by its one rule
        scores = MatchResult.from_halves(self.spec, self.halves).team_scores()
        return np.asarray([scores[team] for team in sorted(scores)], dtype=np.float64)

    def describe_event(self, event: dict[str, Any], names: list[str]) -> str:
        """An event as a sentence, the seats named by ``names``."""
        kind = str(event.get("kind", "event"))
        if "seat" in event and 0 <= int(event["seat"]) < len(names):
            who = names[int(event["seat"])]
        elif "team" in event:
            who = f"team {int(event['team'])}" + (" (yours)" if int(event["team"]) == self.team else "")
        else:
            who = ""
        details = ", ".join(f"{k} {v}" for k, v in event.items() if k not in ("kind", "seat", "team", "step", "cell"))
        if kind == "half_time":
            return (f"half time: from the same start, you now play team {int(event['team'])}; the pair goes to "
                    "the better of the two halves")
        text = f"{who} {_EVENT_VERBS.get(kind, kind.replace('_', ' '))}".strip()
        return f"{text} ({details})" if details else text

    def end_reason(self, names: list[str], resigned: bool = False) -> str:
        """Why the match ended, in a sentence."""
        if resigned:
            return "you resigned (a loss)"
        if self.half is not None:
            points = self.half_points
            first, second = points if len(points) == 2 else (points[0], None)
            yours = first[self.team] + (0.0 if second is None else second[1 - self.team])
            theirs = first[1 - self.team] + (0.0 if second is None else second[self.team])
            return f"the pair ended: your two halves scored {yours:g} against the opponent's {theirs:g}"
        if not self.rules.game_over:
            return f"the step limit ({self.max_cycles} steps) ran out"
        last = [e for e in self.events if e["step"] == self.steps - 1 and e.get("kind") not in ("move", "eat")]
        if not last:
            return "the game reached its end"
        return "; ".join(self.describe_event(e, names) for e in last)


def _play_match(match: LiveMatch, input_fn: InputFn, out: TextIO, picture_dir: str | Path | None) -> None:
    """Play ``match`` in the terminal: show, ask and step until it ends."""
    if picture_dir is not None:
        Path(picture_dir).mkdir(parents=True, exist_ok=True)
    while not match.over:
        command = None
        if match.person_acts():
            if picture_dir is not None:
                from PIL import Image

                Image.fromarray(match.rules.render_topdown()).save(Path(picture_dir) / f"step-{match.steps:05d}.png")
            if match.controls.wants_command():
                command = _ask(match.controls, match.steps, input_fn, out)
        for event in match.step(command):
            if event["kind"] == "half_time":
                print(f"--- {match.describe_event(event, [])}.", file=out)
    print(match.controls.final_view(), file=out)


def _ask(controls: Controls, step: int, input_fn: InputFn, out: TextIO) -> Any:
    """Show the match and ask until the controls take the answer; q (or end of input) resigns."""
    print(controls.view(), file=out)
    while True:
        try:
            text = input_fn(controls.prompt(step))
        except EOFError:
            raise _Resign from None
        text = text.strip().lower()
        if text in _QUIT:
            raise _Resign
        command, problem = controls.parse(text)
        if problem is None:
            return command
        print(f"  {problem}", file=out)
