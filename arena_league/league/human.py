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

Drawing and input, per game:

* **GoBang**: the board in text (``X`` black, ``O`` white, the last stone in lower case); a move
  is a cell such as ``H8`` (column letter, row number) or ``8 8`` (row, column). An occupied
  cell, a cell off the board or something that is not a cell is refused with the reason, and
  asked again.
* **Snake**: the board in text (``#`` wall, ``*`` food, your snake ``@`` head and ``o`` body,
  the others ``A``/``a``, ``B``/``b``, ...); a move is ``w``/``a``/``s``/``d`` (or ``up``,
  ``left``, ``down``, ``right``) on the board as drawn; Enter keeps going straight.
* **physics games** (Crossroads, Soccer, and any other): a coarse text view of the top-down
  picture (team digits, ``#``/``+`` walls and markings, ``o`` a ball, ``*`` other objects), and optionally the picture itself as
  a PNG per step (``picture_dir``); a move is the action's number or name; Enter repeats the last.

``q`` (or end of input) resigns the match in progress, which counts as a loss, and ends the session.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from arena_league import registry as reg
from arena_league.envs import game_spec, make
from arena_league.matchmaking import MatchResult, MatchSpec
from arena_league.rating import place_entrant
from arena_league.registry.repository import AGENT_NAME_PATTERN

__all__ = ["HumanMatch", "HumanSession", "ascii_topdown", "play_human"]

InputFn = Callable[[str], str]

_QUIT = {"q", "quit", "resign", "exit"}
_SNAKE_KEYS = {"w": 0, "up": 0, "u": 0, "d": 1, "right": 1, "r": 1, "s": 2, "down": 2, "a": 3, "left": 3, "l": 3}
#: Robot games: walking directions on the arena as drawn (x right, y up).
_ROBOT_KEYS = {"w": np.array([0.0, 1.0]), "s": np.array([0.0, -1.0]), "a": np.array([-1.0, 0.0]),
               "d": np.array([1.0, 0.0])}
_SOCCER_MIRROR = np.array([0, 5, 4, 3, 2, 1, 8, 7, 6])  # E <-> W for the team seeing the field mirrored


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
        league: the league (default: :func:`arena_league.league.service.open_home`).
        player: the person's name; their agent is ``<player>@<game_id>`` (kind ``human``), and a
            later session with the same name continues their record.
        input_fn: reads one line after a prompt (``input``; tests pass a scripted one).
        output: where the board and messages go (default stdout).
        seed: seeds the matches (env and the agents' sampling).
        matches: matches to play at most (default: until the person types ``q``).
        climb: places to climb after a win (default a tenth of the base, at least 1).
        picture_dir: save the top-down picture of every step there as PNG (physics games).
    """
    from arena_league.league.service import (
        agent_ref,
        base_population,
        ensure_population,
        open_home,
        register_game,
    )

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
        refs = {name: agent_ref(league, reg.require_agent(session, name)) for name in names}
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
    human = _HumanSeat.for_game(rules, seat)
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
            actions[seat] = human.ask(rules, steps, input_fn, out)
        rules.step(actions)
        steps += 1
    if not rules.game_over:
        rules.finish()
    print(human.draw(rules), file=out)
    return np.asarray(rules.team_result(), dtype=np.float64), steps


class _HumanSeat:
    """Draws the game for the person and reads their moves."""

    def __init__(self, rules: Any, seat: int) -> None:
        self.rules = rules
        self.seat = seat
        self.last: int = 0

    @staticmethod
    def for_game(rules: Any, seat: int) -> _HumanSeat:
        if hasattr(rules, "seat_angle"):  # the MuJoCo robot games
            return _RobotSeat(rules, seat)
        if rules.action_type != "discrete":
            raise ValueError(f"{rules.name} has no human controls for continuous actions; make the game with "
                             "action_type='discrete'")
        kind = {"GoBang": _GoBangSeat, "Snake": _SnakeSeat, "Soccer": _SoccerSeat}.get(rules.name, _HumanSeat)
        return kind(rules, seat)

    def ask(self, rules: Any, step: int, input_fn: InputFn, out: TextIO) -> Any:
        self.last = int(self.read(rules, step, input_fn, out))
        return self.last

    def read(self, rules: Any, step: int, input_fn: InputFn, out: TextIO) -> Any:
        """Draw the game and ask until :meth:`parse` takes the answer (q resigns)."""
        print(self.draw(rules), file=out)
        while True:
            try:
                text = input_fn(self.prompt(step))
            except EOFError:
                raise _Resign from None
            text = text.strip().lower()
            if text in _QUIT:
                raise _Resign
            action, problem = self.parse(text)
            if problem is None:
                return action
            print(f"  {problem}", file=out)

    # generic (physics games): a coarse top-down view; actions by number or name
    def draw(self, rules: Any) -> str:
        team = int(rules.team_of[self.seat])
        return ascii_topdown(rules.render_topdown()) + f"\nYou are seat {self.seat}, team {team} (digit {team})."

    def prompt(self, step: int) -> str:
        names = ", ".join(f"{i} {m}" for i, m in enumerate(self.meanings()))
        return f"step {step}: action ({names}; Enter repeats {self.last}) > "

    def meanings(self) -> tuple[str, ...]:
        return tuple(self.rules.action_meanings) or tuple(str(i) for i in range(self.rules.n_actions))

    def parse(self, text: str) -> tuple[int | None, str | None]:
        if text == "":
            return self.last, None
        meanings = [m.lower() for m in self.meanings()]
        if text in meanings:
            return meanings.index(text), None
        if not text.lstrip("-").isdigit():
            return None, (f"{text!r} is not an action: type a number 0..{len(meanings) - 1} or a name "
                          f"({', '.join(meanings)})")
        action = int(text)
        if not 0 <= action < len(meanings):
            return None, f"action {action} does not exist: type a number 0..{len(meanings) - 1}"
        return action, None


class _GoBangSeat(_HumanSeat):
    """Stones by cell: ``H8`` (column letter, row number) or ``8 8`` (row, column), 1-based."""

    def draw(self, rules: Any) -> str:
        size = rules.size
        cells = rules.engine.cells[0]
        last = int(rules.engine.last_action[0])
        letters = [chr(ord("A") + c) for c in range(size)]
        lines = ["    " + " ".join(letters)]
        for r in range(size):
            marks = []
            for c in range(size):
                cell = r * size + c
                mark = ".XO"[int(cells[cell])]
                marks.append(mark.lower() if cell == last and mark != "." else mark)
            lines.append(f"{r + 1:>3} " + " ".join(marks))
        colour = "X (black, first)" if int(rules.team_of[self.seat]) == 0 else "O (white)"
        lines.append(f"You play {colour}.")
        return "\n".join(lines)

    def prompt(self, step: int) -> str:
        return "your move (e.g. H8, or row col: 8 8) > "

    def parse(self, text: str) -> tuple[int | None, str | None]:
        rules = self.rules
        size = rules.size
        letter = re.fullmatch(r"([a-z])\s*(-?\d+)", text)
        numbers = re.fullmatch(r"(-?\d+)[\s,]+(-?\d+)", text)
        if letter:
            row, col = int(letter.group(2)) - 1, ord(letter.group(1)) - ord("a")
        elif numbers:
            row, col = int(numbers.group(1)) - 1, int(numbers.group(2)) - 1
        else:
            return None, (f"{text!r} is not a cell: type a column letter and a row number such as H8, or two numbers "
                          "(row, column) such as 8 8")
        if not (0 <= row < size and 0 <= col < size):
            return None, (f"row {row + 1}, column {col + 1} is off the board: rows and columns run from 1 to {size} "
                          f"(columns A to {chr(ord('A') + size - 1)})")
        cell = row * size + col
        if rules.engine.cells[0, cell] != 0:
            return None, f"{chr(ord('A') + col)}{row + 1} is occupied: choose an empty cell (shown as .)"
        return cell, None


class _SnakeSeat(_HumanSeat):
    """Moves on the board as drawn (w/a/s/d), turned into the seat's own frame."""

    def draw(self, rules: Any) -> str:
        engine = rules.engine
        grid = engine.grid(0)
        size = grid.shape[0]
        others = [s for s in range(rules.n_agents) if s != self.seat]
        chars = np.full(grid.shape, ".", dtype="<U1")
        chars[grid == -2] = "*"
        for s in range(rules.n_agents):
            body = "o" if s == self.seat else chr(ord("a") + others.index(s))
            chars[grid == s] = body
            if engine.alive[0, s]:
                head = int(engine.head[0, s])
                chars.reshape(-1)[head] = "@" if s == self.seat else body.upper()
        border = "#" * (size + 2)
        lines = [border] + ["#" + "".join(row) + "#" for row in chars] + [border]
        lengths = ", ".join(f"{'you' if s == self.seat else chr(ord('A') + others.index(s))}: length "
                            f"{int(engine.length[0, s])}{'' if engine.alive[0, s] else ' (dead)'}"
                            for s in range(rules.n_agents))
        return "\n".join(lines) + f"\nYou are @ (body o). {lengths}"

    def prompt(self, step: int) -> str:
        return f"step {step}: w up, a left, s down, d right (Enter: straight on) > "

    def parse(self, text: str) -> tuple[int | None, str | None]:
        rotation = int(self.rules.engine.rotations[self.seat])
        if text == "":
            heading = int(self.rules.engine.direction[0, self.seat])  # board frame
            return (heading - rotation) % 4, None
        if text not in _SNAKE_KEYS:
            return None, f"{text!r} is not a move: type w (up), a (left), s (down) or d (right), or Enter to go on"
        return (_SNAKE_KEYS[text] - rotation) % 4, None


class _SoccerSeat(_HumanSeat):
    """Compass moves on the field as drawn (E = right), mirrored for the team that sees the field
    flipped."""

    def parse(self, text: str) -> tuple[int | None, str | None]:
        action, problem = super().parse(text)
        if problem is None and text != "" and int(self.rules.team_of[self.seat]) == 1:
            action = int(_SOCCER_MIRROR[action])
        return action, problem

    def prompt(self, step: int) -> str:
        names = ", ".join(f"{i} {m}" for i, m in enumerate(self.meanings()))
        return f"step {step}: move on the field as drawn ({names}; Enter repeats) > "


class _RobotSeat(_HumanSeat):
    """An ant steered on the arena as drawn: the person picks a direction (w up, a left, s down,
    d right, two letters for a diagonal such as ``wd``, ``x`` to stand) and, optionally, how many
    steps to hold it (``d 10``); the scripted trot (:mod:`arena_league.envs.robots.gait`) walks
    that way, as the game's heuristic does toward its own choice."""

    HOLD = 5  # steps a command lasts unless told (0.25 s of play)

    def __init__(self, rules: Any, seat: int) -> None:
        super().__init__(rules, seat)
        self.direction = np.zeros(2)
        self.text = "x"
        self.held = 0

    def ask(self, rules: Any, step: int, input_fn: InputFn, out: TextIO) -> np.ndarray:
        if self.held <= 0:
            self.direction, self.text, self.held = self.read(rules, step, input_fn, out)
        self.held -= 1
        from arena_league.envs.robots.gait import stand, trot

        obs = rules.observe()[self.seat: self.seat + 1]
        if not self.direction.any():
            return stand(obs)[0]
        # world frame (as drawn) -> the seat's frame: turn by minus the seat's angle
        way = complex(*self.direction) * np.exp(-1j * float(rules.seat_angle[self.seat]))
        return trot(obs, [[way.real, way.imag]])[0]

    def parse(self, text: str) -> tuple[Any, str | None]:
        """``text`` (``<direction> [steps]``; Enter repeats the last) as ``(direction, keys, steps)``."""
        words = text.split() or [self.text]
        keys, steps = words[0], self.HOLD
        if len(words) > 2 or (len(words) == 2 and not (words[1].isdigit() and int(words[1]) > 0)):
            return None, (f"{text!r} is not a command: type a direction (w, a, s, d, two of them such as wd, or x "
                          "to stand) and optionally a number of steps, such as 'd 10'")
        if len(words) == 2:
            steps = int(words[1])
        if keys in ("x", "stand"):
            direction = np.zeros(2)
        elif keys and all(k in _ROBOT_KEYS for k in keys) and len(keys) <= 2:
            direction = sum(_ROBOT_KEYS[k] for k in keys)
            if not direction.any():
                return None, f"{keys!r} cancels out: choose directions that are not opposite (wd, sa, ...)"
            direction = direction / np.linalg.norm(direction)
        else:
            return None, f"{keys!r} is not a direction: type w (up), a (left), s (down), d (right), two of them, or x"
        return (direction, keys, steps), None

    def draw(self, rules: Any) -> str:
        team = int(rules.team_of[self.seat])
        text = ascii_topdown(rules.render_topdown()) + (
            f"\nYou are the ant of team {team} (digit {team}); the white stroke on each ant points where it faces.")
        rings = [numbers[0] for kind, numbers in rules.scene.layout.markings if kind == "ring"]
        if rings:  # Sumo: the ring's edge is too thin to draw in text
            torsos = rules.data.xpos[rules.scene.torso_body][:, :2]
            where = ", ".join(f"{'you' if i == self.seat else f'team {int(rules.team_of[i])}'} "
                              f"{np.linalg.norm(p):.1f} m" for i, p in enumerate(torsos))
            text += f"\nRing radius {rings[0]:.1f} m; distance from its centre: {where}."
        return text

    def prompt(self, step: int) -> str:
        return (f"step {step}: walk w up, a left, s down, d right, wd/sa.. diagonal, x stand; add steps to hold "
                f"(default {self.HOLD}); Enter repeats {self.text!r} > ")


def ascii_topdown(picture: np.ndarray, columns: int = 64) -> str:
    """A coarse text view of a top-down picture: each character stands for a block of pixels;
    a team's colour is its team digit, dark strokes ``#`` (walls), light grey ``+`` (walls,
    markings), white ``o`` (a ball), other colours ``*``, open ground ``.``."""
    from arena_league.envs.rendering import TEAM_COLOURS

    image = np.asarray(picture, dtype=np.int64)
    height, width = image.shape[:2]
    block = max(1, width // columns)
    rows = max(1, height // (2 * block))  # characters are about twice as tall as wide
    flat = image.reshape(-1, 3)
    colours, counts = np.unique(flat, axis=0, return_counts=True)
    background = colours[np.argsort(-counts)[:2]]  # the two commonest colours are ground
    palette = np.asarray(TEAM_COLOURS[:4])
    lines = []
    for r in range(rows):
        line = []
        for c in range(width // block):
            cell = image[r * 2 * block:(r + 1) * 2 * block, c * block:(c + 1) * block].reshape(-1, 3)
            ground = (np.abs(cell[:, None, :] - background[None]).sum(axis=2) < 30).any(axis=1)
            things = cell[~ground]
            if things.shape[0] < max(1, cell.shape[0] // 8):
                line.append(".")
                continue
            mean = things.mean(axis=0)
            team_distance = np.abs(palette - mean).sum(axis=1)
            grey = mean.max() - mean.min() < 30
            if team_distance.min() < 90:
                line.append(str(int(team_distance.argmin())))
            elif grey and mean.mean() < 100:
                line.append("#")
            elif grey and mean.mean() <= 240:
                line.append("+")
            elif grey:
                line.append("o")
            else:
                line.append("*")
        lines.append("".join(line))
    return "\n".join(lines)
