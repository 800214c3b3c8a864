"""Human ranking: a person plays base agents in the terminal, from the weakest upward.

Arena (Song et al., "Arena: A General Evaluation Platform and Building Toolkit for Multi-Agent
Intelligence", AAAI 2020) reports a "human ranking among the base population": people play the
base agents and are placed among them like any entrant. :func:`play_human` does that:

* the person is an agent of kind ``human`` (``<player>@<game>``); every match is recorded in the
  registry like any other, so leaderboards count it;
* opponents come from a frozen, rated base population (``base-v1`` by default), weakest first;
  a win climbs the ladder by ``climb`` places, a draw stays, a loss steps back half as far;
* after each match the person's rating, its 95% interval and rank among the base come from the
  rating engine's :func:`~arena_league.rating.place_entrant` over all their results against
  that population;
* the person holds one seat (team 0's first seat in odd-numbered matches, team 1's in the
  others); in team layouts the person's teammates are played by the same base agent as the
  opponents, so the two teams differ only in the seat the person holds.

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

__all__ = ["HumanMatch", "HumanSession", "play_human"]

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
    rank_best: int | None = None
    rank_worst: int | None = None
    percentile: float | None = None
    total_matches: int = 0
    """The person's matches against this base, earlier sessions included."""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class _Resign(Exception):
    """The person typed q (or input ended)."""


def play_human(game_id: str, against: str = "base-v1", league: reg.League | None = None, *,
               player: str = "human", input_fn: InputFn = input, output: TextIO | None = None, seed: int = 0,
               matches: int | None = None, climb: int | None = None, picture_dir: str | Path | None = None
               ) -> HumanSession:
    """Let a person play ``game_id`` against the base population ``against`` in the terminal.

    Args:
        game_id: a two-team game.
        against: the frozen base population (``name`` or ``name:version``) of that game.
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
    from arena_league.league.home import open_home, register_game
    from arena_league.league.populations import ensure_population
    from arena_league.league.service import agent_refs, base_population

    out = output if output is not None else sys.stdout
    spec = game_spec(game_id)
    if spec.n_teams != 2:
        raise ValueError(f"{game_id} has {spec.n_teams} teams; human ranking places a person among a base population "
                         "with two-team matches")
    league = league if league is not None else open_home()
    register_game(league, game_id)
    agent_name = f"{player}@{game_id}"
    if not AGENT_NAME_PATTERN.match(agent_name):
        raise ValueError(f"player name {player!r} is not allowed: use letters, digits and . _ - (it becomes the "
                         f"agent name {agent_name!r})")
    against, imported = ensure_population(league, game_id, against)
    if imported:
        out.write(f"imported the shipped base population {against} of {game_id}\n")
    label, names, ratings = base_population(league, game_id, agent_name, against)
    if not names:
        raise ValueError(f"population {against} of {game_id} has no members to play")
    if ratings is None:
        raise ValueError(f"population {label} has no stored ratings (it is not frozen with ratings); import a built "
                         f"base population: `arena-league population import checkpoints/{game_id}/base-v1`")
    human_id = _human_agent(league, agent_name, game_id, player)
    order = np.argsort(ratings, kind="stable")  # weakest first
    with league.reading() as session:
        refs = agent_refs(session, league, [reg.require_agent(session, name) for name in names])
    step = climb if climb is not None else max(1, len(names) // 10)
    report = HumanSession(agent_name, game_id, label, len(names))
    rung = 0
    played = 0
    print(f"You are {agent_name}. {label} has {len(names)} agents, rated {ratings.min():.0f} to {ratings.max():.0f}; "
          "you start with the weakest. Type q to resign and stop.", file=out)
    while matches is None or played < matches:
        opponent = names[int(order[rung])]
        team = played % 2
        with league.reading() as session:
            number = len(reg.list_matches(session, game_id, agent_id=human_id))
        print(f"\n=== Match {played + 1}: you play team {team} against {opponent} (rating "
              f"{ratings[order[rung]]:.0f}, {rung + 1} of {len(names)} from the bottom)", file=out)
        policy = refs[opponent].load()
        resigned = False
        match_key = f"human:{human_id}:{number + 1}"
        spec_ = MatchSpec(number + 1, game_id, tuple(opponent for _ in range(spec.n_agents)), seed)
        try:
            team_scores, steps = _play_match(game_id, spec_, policy, team, input_fn, out, picture_dir)
        except _Resign:
            team_scores, steps, resigned = np.where(np.arange(2) == team, 0.0, 1.0), 0, True
        result = _record(league, game_id, match_key, spec_, team, team_scores, steps, human_id, opponent)
        outcome = result.outcomes[result.teams.index(team)]
        report.matches.append(HumanMatch(opponent, float(ratings[order[rung]]), team, outcome, steps, match_key,
                                         resigned))
        played += 1
        _place(league, game_id, agent_name, names, ratings, report)
        print(f"--- You {'resigned: a loss' if resigned else {'win': 'won', 'loss': 'lost', 'draw': 'drew'}[outcome]}"
              f" against {opponent}.", file=out)
        print(f"Your estimated placement: rating {report.rating:.0f} (95% {report.lower:.0f} .. {report.upper:.0f}), "
              f"rank {report.rank} of {len(names) + 1} (between {report.rank_best} and {report.rank_worst}), above "
              f"{report.percentile:.0f}% of {label}, from {report.total_matches} match(es).", file=out)
        if resigned:
            break
        if outcome == "win":
            rung = min(len(names) - 1, rung + step)
        elif outcome == "loss":
            rung = max(0, rung - max(1, step // 2))
        if matches is not None and played >= matches:
            break
        try:
            answer = input_fn("Next match? [Enter: play, q: stop] ").strip().lower()
        except EOFError:
            break
        if answer in _QUIT:
            break
    return report


def _human_agent(league: reg.League, name: str, game_id: str, player: str) -> int:
    """The person's agent (created on first play). Registered as retired: kept with its matches,
    but never scheduled into the league's automatic evaluations, which need an artifact to play."""
    with league.transaction() as session:
        agent = reg.get_agent(session, name)
        if agent is None:
            agent = reg.create_agent(session, name, game_id, "human", owner=player, status="retired",
                                     metadata={"player": player})
            session.flush()
        elif agent.kind != "human" or agent.game_id != game_id:
            raise ValueError(f"the name {name} belongs to a {agent.kind} agent of {agent.game_id}; play under another "
                             "player name")
        return int(agent.id)


def _record(league: reg.League, game_id: str, match_key: str, spec: MatchSpec, team: int, team_scores: np.ndarray,
            steps: int, human_id: int, opponent: str) -> MatchResult:
    rules_team = game_spec(game_id)
    team_of = np.repeat(np.arange(rules_team.n_teams), rules_team.players_per_team)
    result = MatchResult.from_team_result(spec, team_of, team_scores, steps)
    with league.transaction() as session:
        opponent_id = reg.require_agent(session, opponent).id
        seats = [reg.SeatResult(human_id if t == team else opponent_id, t, score, outcome)
                 for t, score, outcome in zip(result.teams, result.scores, result.outcomes)]
        reg.record_matches(session, game_id, [reg.MatchRecord(match_key, spec.seed, seats)])
    return result


def _place(league: reg.League, game_id: str, agent: str, names: list[str], ratings: np.ndarray,
           report: HumanSession) -> None:
    """The person's placement from all their matches against the base members."""
    index = {n: i for i, n in enumerate(names)}
    wins, losses, draws = (np.zeros(len(names)) for _ in range(3))
    with league.reading() as session:
        rows = reg.match_seat_rows(session, game_id, agents=[agent, *names])
    by_match: dict[int, dict[str, str]] = {}
    for row in rows:
        by_match.setdefault(row["match_id"], {})[row["agent"]] = row["outcome"]
    total = 0
    for seats in by_match.values():
        if agent not in seats or len(seats) != 2:
            continue
        (opponent,) = [a for a in seats if a != agent]
        counter = {"win": wins, "loss": losses, "draw": draws}[seats[agent]]
        counter[index[opponent]] += 1
        total += 1
    placement = place_entrant(ratings, wins, losses, draws)
    report.rating, report.lower, report.upper = placement.rating, placement.lower, placement.upper
    report.rank, report.rank_best, report.rank_worst = placement.rank, placement.rank_best, placement.rank_worst
    report.percentile = placement.percentile
    report.total_matches = total


# --- one match ---------------------------------------------------------------------------------------

def _play_match(game_id: str, spec: MatchSpec, policy: Any, team: int, input_fn: InputFn, out: TextIO,
                picture_dir: str | Path | None) -> tuple[np.ndarray, int]:
    """Play one match with the person in team ``team``'s first seat; (team scores, steps)."""
    env = make(game_id)
    rules = env.rules
    rules.reset(spec.seed)
    rng = spec.seat_rng()
    n = rules.n_agents
    seat = int(np.flatnonzero(rules.team_of == team)[0])
    width = policy.spec.uniforms_per_seat
    states = policy.initial_state(n)
    controls = rules.human_controls(seat)
    max_cycles = env.max_cycles
    steps = 0
    if picture_dir is not None:
        Path(picture_dir).mkdir(parents=True, exist_ok=True)
    while not rules.game_over and steps < max_cycles:
        obs = rules.observe()
        mask = rules.action_mask()
        uniforms = rng.random((n, width))
        if rules.turn_based:
            acting = np.zeros(n, dtype=bool)
            acting[rules.current_player()] = True
        else:
            acting = np.asarray(rules.measures.active, dtype=bool).copy()
        actions = np.zeros(n, dtype=np.int64) if rules.action_type == "discrete" else \
            np.zeros((n, rules.act_dim), dtype=np.float32)
        agents = np.flatnonzero(acting & (np.arange(n) != seat))
        if agents.size:
            chosen, next_state = policy.act(obs[agents, : policy.spec.obs_dim], uniforms[agents],
                                            None if mask is None else mask[agents],
                                            None if states is None else states[agents])
            actions[agents] = chosen
            if states is not None and next_state is not None:
                states[agents] = next_state
        if acting[seat]:
            if picture_dir is not None:
                from PIL import Image

                Image.fromarray(rules.render_topdown()).save(Path(picture_dir) / f"step-{steps:05d}.png")
            command = _ask(controls, steps, input_fn, out) if controls.wants_command() else None
            actions[seat] = controls.action(command)
        rules.step(actions)
        steps += 1
    if not rules.game_over:
        rules.finish()
    print(controls.final_view(), file=out)
    return np.asarray(rules.team_result(), dtype=np.float64), steps


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
