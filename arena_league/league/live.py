"""A person playing a game in a browser, against the base population, one message at a time.

The browser's play page (``/play/{game}``) talks to a :class:`LivePlay` over a WebSocket; this
module knows nothing of sockets. The climb is the terminal's (:class:`~arena_league.league.human.Ladder`:
weakest base member first, a win climbs, a loss steps back; every match stored as the person's
human agent ``<player>@<game>`` and placed among the base with an interval, so the game's
leaderboard lists the person like any entrant). A match is a
:class:`~arena_league.league.human.LiveMatch`: the person holds team ``k``'s first seat
(alternating between matches), the opponent base member plays every other seat, teammates
included.

Messages to the browser (dicts, sent as JSON):

* ``hello``: the person's agent, the base (label, size, rating range), their placement so far;
* ``match``: a match begins: number, opponent and its rating, the person's team and seat, every
  seat (``seat``, ``team``, ``role`` ``you|teammate|opponent``, ``agent``, ``label`` as drawn,
  ``color``), the controls (:meth:`~arena_league.envs.controls.Controls.web`: keys, clicks or
  text, and the pace) and the view's ``bounds``;
* ``frame``: one step drawn: ``step``, ``shapes`` (those of
  :func:`~arena_league.league.replays.replay_document`, with every seat labelled), ``waiting``
  (the server waits for the person's move), ``events`` (what happened this step, in words);
* ``refused``: the person's move was refused: ``reason`` says what to do instead;
* ``end``: the match ended: ``outcome`` (for the person), ``reason`` (why it ended), team
  ``scores``, ``steps``, the stored ``match_id`` and the new ``placement``.

Messages from the browser: ``{"type": "act", "text": ...}`` or ``{"type": "act", "point": [x,
y]}`` (a click on the view, in world units), ``{"type": "next"}`` (the next match) and
``{"type": "resign"}``, each read by :func:`read_message` within bounds on its size and nesting.
Only a move the game takes (:meth:`LivePlay.act` not refused) counts as the person being there;
the web server closes a socket that sends no move for its idle time whatever else it sends
(``next`` and ``resign`` included), and :meth:`LivePlay.start` refuses a match past
``matches_per_minute`` in the last minute, since each match played writes rows and a rank job. In a game with a pace the server steps on its own (:meth:`LivePlay.tick`)
and the person's newest answer holds; otherwise every step the person acts waits for an answer.
"""

from __future__ import annotations

import json
import math
import re
import time
from collections import deque
from collections.abc import Callable
from dataclasses import asdict
from typing import Any

import numpy as np

from arena_league import registry as reg
from arena_league.envs.bounded import check_json_nesting
from arena_league.league.human import Ladder, LiveMatch
from arena_league.league.names import GUEST_PREFIX, check_guest_name
from arena_league.league.replays import frames_bounds, scene_shapes, shape_points, team_hex
from arena_league.replay.scenes import scene_entities
from arena_league.replay.writer import STEP_NS

__all__ = ["GUEST_PREFIX", "MESSAGE_BYTES", "MESSAGE_DEPTH", "LivePlay", "check_json_nesting", "player_of",
           "read_message"]

#: Scene entities that draw one seat: ``agent/<seat>`` and ``snake/<seat>``.
_SEAT_ENTITY = re.compile(r"^(?:agent|snake)/(\d+)$")
_LABEL_COLOUR = "rgba(20,20,20,1)"
_YOU_COLOUR = "rgba(240,190,20,1)"
#: Event kinds too common to report in words (every GoBang move).
_QUIET = frozenset({"move"})
#: The most one message from the page may hold, and how deep it may nest (a click's is 2 deep).
MESSAGE_BYTES, MESSAGE_DEPTH = 4096, 8
_MESSAGE_FORM = "a message is one JSON object such as {\"type\": \"act\", \"text\": \"w\"}"


def read_message(text: str) -> Any:
    """One message from the page parsed, its size and nesting checked before the parser sees it;
    ``ValueError`` with one line saying what a message is."""
    check_json_nesting(text, "a play message", max_depth=MESSAGE_DEPTH, max_bytes=MESSAGE_BYTES)
    try:
        return json.loads(text)
    except ValueError:
        raise ValueError(_MESSAGE_FORM) from None


def player_of(owner: str | None, guest: str | None) -> tuple[str, str]:
    """(player name, owner) of someone who plays: a signed-in owner plays as themself; a guest as
    ``guest-<name>`` (a prefix no owner may take). A bad guest name raises ``ValueError`` saying
    what is allowed, as does an owner named ``guest-...`` from before owners were kept out of the
    guests' names, who would otherwise share a guest's agent."""
    if owner is not None:
        if owner.startswith(GUEST_PREFIX):
            raise ValueError(f"owner {owner!r} is named like a guest, so playing would share guest "
                             f"{owner.removeprefix(GUEST_PREFIX)!r}'s agent; ask an administrator for a token under "
                             "another name")
        return owner, owner
    check_guest_name(guest)
    assert isinstance(guest, str)
    return GUEST_PREFIX + guest, GUEST_PREFIX + guest


class LivePlay:
    """One person's session of play: a ladder through the base population of ``game_id``, its
    matches stepped on demand (see the module docstring for the messages)."""

    def __init__(self, league: reg.League, game_id: str, *, player: str, owner: str, against: str | None = None,
                 seed: int = 0, climb: int | None = None, matches_per_minute: int | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.ladder = Ladder(game_id, against, league, player=player, owner=owner, climb=climb)
        self.game_id = game_id
        self.seed = int(seed)
        self.match: LiveMatch | None = None
        self.pending: Any = None
        self.bounds: list[float] = [-1.0, -1.0, 1.0, 1.0]
        self.names: list[str] = []
        self.labels: list[str] = []
        self.controls: dict[str, Any] = {}
        """How the page plays the match in progress (its controls' ``web()``)."""
        self.matches_per_minute = matches_per_minute
        self.clock = clock
        self.started: deque[float] = deque()
        """When (``clock``) the matches of the last minute started."""

    # --- what the page asks -------------------------------------------------------------------------
    def hello(self) -> dict[str, Any]:
        ladder = self.ladder
        return {"type": "hello", "agent": ladder.agent_name, "game_id": self.game_id, "base": ladder.report.base,
                "base_size": len(ladder.names), "ratings": [float(ladder.ratings.min()), float(ladder.ratings.max())],
                "placement": self._placement(), "leaderboard": f"/games/{self.game_id}"}

    @property
    def playing(self) -> bool:
        return self.match is not None

    @property
    def pace(self) -> float | None:
        """Steps per second the server plays the match at by itself (None: it waits for moves)."""
        return None if self.match is None else self.controls.get("pace")

    def start(self) -> list[dict[str, Any]]:
        """Begin the next match: its ``match`` message and frames up to the person's first move
        (a turn-based opponent moving first), or its first frame."""
        if self.match is not None:
            raise ValueError("a match is in progress: finish or resign it first")
        self._count_start()
        self.match, self.pending = self.ladder.next_match(self.seed), None
        opening, scene = self._opening()
        return [opening, self._frame([], scene), *self._advance()]

    def _opening(self) -> tuple[dict[str, Any], list]:
        """The ``match`` message of the match (or half of a pair) in play, and its scene."""
        match = self._require_match()
        self.controls = match.controls.web()
        n, seat = match.n, match.seat
        team_of = [int(t) for t in match.rules.team_of]
        roles = ["you" if s == seat else "teammate" if team_of[s] == match.side else "opponent" for s in range(n)]
        self.names = ["you" if s == seat else f"{roles[s]} #{s}" for s in range(n)]
        self.labels = ["you" if s == seat else f"#{s}" for s in range(n)]
        scene = self._scene()
        self.bounds = frames_bounds([{"shapes": [shape for _, shapes in scene for shape in shapes]}])
        seats = [{"seat": s, "team": team_of[s], "role": roles[s], "label": self.labels[s],
                  "agent": self.ladder.agent_name if s == seat else match.opponent,
                  "color": team_hex(team_of[s])} for s in range(n)]
        return {"type": "match", "number": self.ladder.played + 1, "opponent": match.opponent,
                "opponent_rating": match.opponent_rating, "rung": self.ladder.rung + 1, "team": match.side,
                "seat": seat, "seats": seats, "controls": self.controls, "bounds": self.bounds,
                "max_steps": match.max_cycles, "half": match.half}, scene

    def _step(self, command: Any) -> list[dict[str, Any]]:
        """One step's frame; at a pair's half time, then the second half's ``match`` message and frame."""
        match = self._require_match()
        events = match.step(command)
        out = [self._frame(events)]
        if any(e.get("kind") == "half_time" for e in events):
            opening, scene = self._opening()
            out += [opening, self._frame([], scene)]
        return out

    def act(self, message: dict[str, Any]) -> list[dict[str, Any]]:
        """The person's move (``text``, or a click's ``point``): refused with the reason, held for
        the next tick (a paced game), or played at once with the opponent's answers."""
        match = self._require_match()
        command, problem = self._parse(match, message)
        if problem is not None:
            return [{"type": "refused", "reason": problem}]
        if self.pace is not None:
            self.pending = command
            return []
        if not match.needs_command():
            return [{"type": "refused", "reason": "it is not your move yet"}]
        return [*self._step(command), *self._advance()]

    def tick(self) -> list[dict[str, Any]]:
        """One step of a paced game, the person's newest answer holding; its frame (and the end)."""
        match = self._require_match()
        command, self.pending = self.pending, None
        if command is None and match.needs_command():
            command, problem = match.controls.parse("")  # Enter: go on as before
            if problem is not None:
                return [self._frame([])]  # nothing to go on with: wait for an answer
        out = self._step(command)
        if match.over:
            out.append(self._end(resigned=False))
        return out

    def resign(self) -> list[dict[str, Any]]:
        """Resign the match in progress (a loss), if any; its ``end`` message."""
        return [self._end(resigned=True)] if self.match is not None else []

    # --- inside -------------------------------------------------------------------------------------
    def _require_match(self) -> LiveMatch:
        if self.match is None:
            raise ValueError("no match in progress: send {\"type\": \"next\"} to start one")
        return self.match

    def _count_start(self) -> None:
        """Count a match starting now; ``ValueError`` naming the limit and the wait when
        ``matches_per_minute`` matches already started in the last minute."""
        now = self.clock()
        while self.started and self.started[0] <= now - 60.0:
            self.started.popleft()
        limit = self.matches_per_minute
        if limit is not None and len(self.started) >= limit:
            wait = math.ceil(self.started[0] + 60.0 - now)
            raise ValueError(f"at most {limit} match(es) a minute start on one play page (the league's "
                             f"web.live_matches_per_minute); the next can start in {wait} s")
        self.started.append(now)

    def _parse(self, match: LiveMatch, message: dict[str, Any]) -> tuple[Any, str | None]:
        point = message.get("point")
        if point is not None:
            if (not isinstance(point, list) or len(point) != 2 or
                    not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                            for v in point)):
                return None, "a click is sent as point: [x, y], two finite numbers"
            x, y = float(point[0]), float(point[1])
            xmin, ymin, xmax, ymax = self.bounds
            if not (xmin <= x <= xmax and ymin <= y <= ymax):
                return None, "that click is outside the view; click on the board"
            text = match.controls.point(x, y)
            if text is None:
                return None, "this game is not played by clicking; use the keys the page lists"
        else:
            text = message.get("text")
            if not isinstance(text, str) or len(text) > 64:
                return None, "a move is sent as text (at most 64 characters), or a click as point: [x, y]"
        return match.controls.parse(text.strip().lower())

    def _advance(self) -> list[dict[str, Any]]:
        """Play a waiting game on until the person's move (or the end): the opponent's turns."""
        match = self._require_match()
        out: list[dict[str, Any]] = []
        if self.pace is None:
            while not match.over and not match.needs_command():
                out += self._step(None)
        if match.over:
            out.append(self._end(resigned=False))
        return out

    def _scene(self) -> list[tuple[dict[str, Any], list[dict[str, Any]]]]:
        """The match now: every scene entity with its shapes."""
        match = self._require_match()
        return [(entity, scene_shapes({"entities": [entity]}))
                for entity in scene_entities(match.rules, match.steps * STEP_NS)]

    def _frame(self, events: list[dict[str, Any]], scene: list | None = None) -> dict[str, Any]:
        match = self._require_match()
        scene = scene if scene is not None else self._scene()
        # one stable sort by height over the entities' shapes: the order scene_shapes gives the whole scene
        shapes = sorted((shape for _, parts in scene for shape in parts), key=lambda shape: shape["z"])
        return {"type": "frame", "step": match.steps, "shapes": shapes + self._seat_labels(scene),
                "waiting": self.pace is None and match.needs_command(),
                "events": [match.describe_event(e, self.names) for e in events if e.get("kind") not in _QUIET]}

    def _seat_labels(self, scene: list[tuple[dict[str, Any], list[dict[str, Any]]]]) -> list[dict[str, Any]]:
        """A label over every seat's body (``you`` for the person, ``#k`` for seat k) and a ring
        around the person's."""
        span = max(self.bounds[2] - self.bounds[0], self.bounds[3] - self.bounds[1])
        out: list[dict[str, Any]] = []
        for entity, shapes in scene:
            found = _SEAT_ENTITY.match(str(entity.get("id", "")))
            if not found or int(found.group(1)) >= len(self.labels) or not shapes:
                continue
            seat = int(found.group(1))
            top = shapes[-1]  # the highest: a snake's head, an ant's torso
            points = list(shape_points(top))
            x = sum(p[0] for p in points) / len(points)
            y = sum(p[1] for p in points) / len(points)
            reach = max(max(abs(px - x), abs(py - y)) for px, py in points)
            you = seat == self.match.seat  # type: ignore[union-attr]
            if you:
                radius = reach + 0.02 * span
                ring = [[round(x + radius * math.cos(a), 4), round(y + radius * math.sin(a), 4)]
                        for a in np.linspace(0.0, 2 * math.pi, 24, endpoint=False)]
                out.append({"kind": "line", "points": ring, "width": 3, "closed": True, "segments": False,
                            "screen": True, "color": _YOU_COLOUR, "z": 99.0})
            out.append({"kind": "text", "x": round(x, 4), "y": round(y + reach + 0.035 * span, 4),
                        "text": self.labels[seat], "size": 13 if you else 11, "screen": True,
                        "color": _LABEL_COLOUR, "z": 100.0})
        return out

    def _end(self, *, resigned: bool) -> dict[str, Any]:
        match = self._require_match()
        reason = match.end_reason(self.names, resigned=resigned)
        played = self.ladder.record(match, resigned=resigned)
        self.match, self.pending = None, None
        return {"type": "end", "outcome": played.outcome, "reason": reason, "resigned": resigned,
                "scores": [float(v) for v in match.scores], "team": match.team, "steps": played.steps,
                "match_id": match.match_id, "opponent": played.opponent,
                "placement": self._placement(), "at": time.time()}

    def _placement(self) -> dict[str, Any]:
        report = asdict(self.ladder.report)
        report.pop("matches", None)
        return report
