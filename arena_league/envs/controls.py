"""How a person plays a seat: the controls a game gives a human player at a terminal.

A game's rules give the controls of one seat with ``GameRules.human_controls(seat)``; the session
that seats a person (``arena-league play``, or the browser's ``/play/{game}``) draws, asks and
steps, and knows no game::

    controls = rules.human_controls(seat)
    # every step the seat acts:
    if controls.wants_command():
        print(controls.view())
        text = input(controls.prompt(step)).strip().lower()      # q resigns (the session's word)
        command, problem = controls.parse(text)                  # refused: print problem, ask again
    action = controls.action(command)                             # None on a step not asked
    # when the match ends:
    print(controls.final_view())

:class:`Controls` is that contract. :class:`ActionControls`, every game's default, offers the
game's actions by number or name (``action_meanings``) under a coarse text view of the top-down
picture (:func:`ascii_topdown`); games with a board or their own frames override
``human_controls`` (GoBang's cells, Snake's moves on the board as drawn, Soccer's mirrored
compass, the robot games' walking directions in ``envs.robots.controls``).

In a browser the same controls answer: :meth:`Controls.web` declares how a page plays the seat
(keys that send answers, a click on a cell, or typed text, and the pace the server steps at), and
:meth:`Controls.point` turns a click into an answer; what the page sends goes through ``parse``
like a typed line.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import numpy as np

from arena_league.envs.rendering import TEAM_COLOURS

if TYPE_CHECKING:
    from arena_league.envs.core import GameRules

__all__ = ["ActionControls", "CompassControls", "Controls", "TurnedCompassControls", "arrow_keys", "ascii_topdown",
           "key_controls"]


class Controls(ABC):
    """A person's controls of one seat: what they are shown, what they may type, and the action
    it makes. Subclasses give :meth:`view`, :meth:`prompt` and :meth:`parse`; the rest has
    defaults.

    ``parse`` receives the answer stripped and lower-cased (``""`` is Enter; the session keeps
    ``q`` for resigning) and returns ``(command, None)`` or ``(None, why it is refused)``, the
    reason saying what to type instead.
    """

    def __init__(self, rules: GameRules, seat: int) -> None:
        self.rules = rules
        self.seat = int(seat)

    @abstractmethod
    def view(self) -> str:
        """The match as the person sees it before they answer."""

    @abstractmethod
    def prompt(self, step: int) -> str:
        """The question asked at ``step``."""

    @abstractmethod
    def parse(self, text: str) -> tuple[Any, str | None]:
        """``(command, None)`` for an accepted answer, ``(None, reason)`` for a refused one."""

    def wants_command(self) -> bool:
        """Whether to ask the person this step (False while a command they gave still holds)."""
        return True

    def action(self, command: Any) -> int | np.ndarray:
        """The seat's action this step from the accepted ``command`` (None on a step
        :meth:`wants_command` declined). Default: the command is the action."""
        return command

    def final_view(self) -> str:
        """What the person is shown when the match ends. Default: :meth:`view`."""
        return self.view()

    # --- in a browser -----------------------------------------------------------------------------
    def web(self) -> dict[str, Any]:
        """How a browser plays this seat, as JSON (the play page reads it; see the module docstring):

        * ``"input"``: ``"keys"`` (keys send answers), ``"cells"`` (a click on the top-down view
          sends its world point, which :meth:`point` turns into an answer) or ``"text"`` (a typed
          answer, as at the terminal);
        * ``"pace"``: steps per second the server plays at without waiting, the person's last
          answer holding (``None``: every step the person acts waits for an answer);
        * ``"hint"``: one line saying what to press, click or type;
        * with keys: ``"keys"`` (browser key name, as ``KeyboardEvent.key``, -> the answer it
          sends), ``"release"`` (the answer sent when every key is up; ``None``: the last holds),
          ``"combine"`` (an order of answers: keys held together send their answers joined in
          that order, when the joined answer is in ``"accepts"``; ``None``: the newest key wins).

        Default: typed answers, each step the person acts waiting for one."""
        return {"input": "text", "pace": None, "hint": self.prompt(0).rstrip(" >")}

    def point(self, x: float, y: float) -> str | None:
        """The answer a click at the world point (x, y) of the top-down scene stands for (None: this
        game takes no clicks)."""
        return None


class ActionControls(Controls):
    """The game's actions by number or name under a text view of the top-down picture; Enter
    repeats the last action. Every discrete game's default controls."""

    def __init__(self, rules: GameRules, seat: int) -> None:
        if rules.action_type != "discrete":
            raise ValueError(f"{rules.name} has no human controls for continuous actions; make the game with "
                             "action_type='discrete'")
        super().__init__(rules, seat)
        self.last = 0

    def view(self) -> str:
        team = int(self.rules.team_of[self.seat])
        return ascii_topdown(self.rules.render_topdown()) + f"\nYou are seat {self.seat}, team {team} (digit {team})."

    def prompt(self, step: int) -> str:
        names = ", ".join(f"{i} {m}" for i, m in enumerate(self.meanings()))
        return f"step {step}: action ({names}; Enter repeats {self.last}) > "

    def meanings(self) -> tuple[str, ...]:
        """What each action does (its number when the game names none)."""
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

    def action(self, command: Any) -> int:
        self.last = int(command)
        return self.last

    #: Steps per second a browser plays the game's actions at.
    PACE = 10.0

    def web(self) -> dict[str, Any]:
        """Digit keys pick the action by number, the last one holding; see :meth:`Controls.web`."""
        meanings = self.meanings()
        keys = {str(i): str(i) for i in range(min(10, len(meanings)))}
        return key_controls(keys, self.PACE,
                            "keys " + ", ".join(f"{i} {m}" for i, m in enumerate(meanings[:10])) + " (the last holds)")


class CompassControls(ActionControls):
    """Compass moves (noop, E, NE, ... SE) on the view as drawn (E = right), turned into the seat's
    frame by :meth:`seat_move`; in a browser, the arrow keys or W A S D, two at once diagonally.
    Subclasses name what the person moves (:attr:`move`) and how the keys do it (:attr:`key_hint`)."""

    #: The prompt's verb: what a move does on the view as drawn.
    move = "move on the view as drawn"
    #: The browser's hint for the keys.
    key_hint = "Arrow keys or W A S D move on the view as drawn (two at once: diagonally); let go to stop."

    def seat_move(self, action: int) -> int:
        """The move ``action`` (as drawn) in the seat's own frame."""
        return action

    def parse(self, text: str) -> tuple[int | None, str | None]:
        action, problem = super().parse(text)
        if problem is None and text != "":
            action = self.seat_move(action)
        return action, problem

    def prompt(self, step: int) -> str:
        names = ", ".join(f"{i} {m}" for i, m in enumerate(self.meanings()))
        return f"step {step}: {self.move} ({names}; Enter repeats) > "

    def web(self) -> dict[str, Any]:
        return key_controls(arrow_keys("n", "w", "s", "e"), self.PACE, self.key_hint, release="noop", combine="nsew",
                            accepts=("ne", "nw", "se", "sw"))


#: Each compass move seen mirrored in x (E <-> W): a seat of a team that sees the field flipped.
_MIRRORED_COMPASS = (0, 5, 4, 3, 2, 1, 8, 7, 6)


class MirroredCompassControls(CompassControls):
    """Compass moves on the view as drawn (E = right), mirrored into the seat frame of the second
    team of a two-team field seen mirrored in x (Soccer, AirHockey, Tennis)."""

    def seat_move(self, action: int) -> int:
        return _MIRRORED_COMPASS[action] if int(self.rules.team_of[self.seat]) == 1 else action


class TurnedCompassControls(CompassControls):
    """Compass moves on the view as drawn (E = right), turned into the seat frame of a team that
    sees the world turned by ``team / n_teams`` of a turn (FightForFood, BlowBlow); the actions
    after the compass moves (a blow, say) pass unchanged."""

    def seat_move(self, action: int) -> int:
        if not 1 <= action <= 8:
            return action
        shift = 8 * int(self.rules.team_of[self.seat]) // self.rules.n_teams
        return 1 + (action - 1 - shift) % 8


def key_controls(keys: dict[str, str], pace: float, hint: str, *, release: str | None = None,
                 combine: str | None = None, accepts: tuple[str, ...] = ()) -> dict[str, Any]:
    """A :meth:`Controls.web` declaration of a seat played by keys at ``pace`` steps per second."""
    return {"input": "keys", "pace": pace, "keys": keys, "release": release, "combine": combine,
            "accepts": list(accepts), "hint": hint}


def arrow_keys(up: str, left: str, down: str, right: str) -> dict[str, str]:
    """A browser's arrow keys and W/A/S/D (either case) -> the answers for up, left, down and right
    on the view as drawn (see :meth:`Controls.web`)."""
    keys: dict[str, str] = {}
    for answer, names in ((up, ("ArrowUp", "w", "W")), (left, ("ArrowLeft", "a", "A")),
                          (down, ("ArrowDown", "s", "S")), (right, ("ArrowRight", "d", "D"))):
        keys.update(dict.fromkeys(names, answer))
    return keys


def ascii_topdown(picture: np.ndarray, columns: int = 64) -> str:
    """A coarse text view of a top-down picture: each character stands for a block of pixels;
    a team's colour is its team digit, dark strokes ``#`` (walls), light grey ``+`` (walls,
    markings), white ``o`` (a ball), other colours ``*``, open ground ``.``."""
    image = np.asarray(picture, dtype=np.int64)
    height, width = image.shape[:2]
    block = max(1, width // columns)
    rows = max(1, height // (2 * block))  # characters are about twice as tall as wide
    # colours packed into one integer each: counting them is a 1-D sort, not a sort of rows, and
    # packed order is the rows' lexicographic order, so ties fall the same way
    packed = (image[..., 0] << 16 | image[..., 1] << 8 | image[..., 2]).ravel()
    colours, counts = np.unique(packed, return_counts=True)
    commonest = colours[np.argsort(-counts)[:2]]
    background = np.stack([commonest >> 16, commonest >> 8 & 255, commonest & 255], axis=1)  # the ground
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
