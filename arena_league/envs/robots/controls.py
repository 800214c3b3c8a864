"""How a person plays a robot game: steer the ant by direction on the arena as drawn.

The person picks a direction (``w`` up, ``a`` left, ``s`` down, ``d`` right, two letters for a
diagonal such as ``wd``, ``x`` to stand) and, optionally, how many steps to hold it (``d 10``;
default :attr:`RobotControls.HOLD`); Enter repeats the last command. The scripted trot
(:mod:`arena_league.envs.robots.gait`) walks that way, as the games' heuristics do toward their
own choice. The view is a coarse text picture of the arena from above; in an arena with a ring
(Sumo), whose edge is too thin to draw in text, every ant's distance from the ring's centre is
written under it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from arena_league.envs.controls import Controls, arrow_keys, ascii_topdown, key_controls
from arena_league.envs.robots.gait import stand, trot

if TYPE_CHECKING:
    from arena_league.envs.robots.game import RobotGameRules

__all__ = ["RobotControls"]

#: Walking directions on the arena as drawn (x right, y up).
DIRECTION_KEYS: dict[str, np.ndarray] = {"w": np.array([0.0, 1.0]), "s": np.array([0.0, -1.0]),
                                         "a": np.array([-1.0, 0.0]), "d": np.array([1.0, 0.0])}


class RobotControls(Controls):
    """An ant steered on the arena as drawn (see the module docstring). A command is
    ``(direction, keys, steps)``: a unit vector in the world frame (zero to stand), the letters
    typed, and the steps it holds."""

    HOLD = 5  # steps a command lasts unless told (0.25 s of play)

    rules: RobotGameRules

    def __init__(self, rules: RobotGameRules, seat: int) -> None:
        super().__init__(rules, seat)
        self.direction = np.zeros(2)
        self.keys = "x"
        self.held = 0

    def wants_command(self) -> bool:
        return self.held <= 0

    def action(self, command: Any) -> np.ndarray:
        if command is not None:
            self.direction, self.keys, self.held = command
        self.held -= 1
        rules = self.rules
        obs = rules.observe()[self.seat: self.seat + 1]
        if not self.direction.any():
            return stand(obs)[0]
        # world frame (as drawn) -> the seat's frame: turn by minus the seat's angle
        way = complex(*self.direction) * np.exp(-1j * float(rules.seat_angle[self.seat]))
        return trot(obs, [[way.real, way.imag]])[0]

    def web(self) -> dict[str, Any]:
        return key_controls(arrow_keys("w", "a", "s", "d"), 20.0,
                            "Arrow keys or W A S D walk your ant on the arena as drawn (two at once: diagonally); "
                            "let go to stand.", release="x", combine="wsad", accepts=("wa", "wd", "sa", "sd"))

    def parse(self, text: str) -> tuple[Any, str | None]:
        """``text`` (``<direction> [steps]``; Enter repeats the last) as ``(direction, keys, steps)``."""
        words = text.split() or [self.keys]
        keys, steps = words[0], self.HOLD
        if len(words) > 2 or (len(words) == 2 and not (words[1].isdigit() and int(words[1]) > 0)):
            return None, (f"{text!r} is not a command: type a direction (w, a, s, d, two of them such as wd, or x "
                          "to stand) and optionally a number of steps, such as 'd 10'")
        if len(words) == 2:
            steps = int(words[1])
        if keys in ("x", "stand"):
            direction = np.zeros(2)
        elif keys and all(k in DIRECTION_KEYS for k in keys) and len(keys) <= 2:
            direction = sum(DIRECTION_KEYS[k] for k in keys)
            if not direction.any():
                return None, f"{keys!r} cancels out: choose directions that are not opposite (wd, sa, ...)"
            direction = direction / np.linalg.norm(direction)
        else:
            return None, f"{keys!r} is not a direction: type w (up), a (left), s (down), d (right), two of them, or x"
        return (direction, keys, steps), None

    def view(self) -> str:
        rules = self.rules
        team = int(rules.team_of[self.seat])
        text = ascii_topdown(rules.render_topdown()) + (
            f"\nYou are the ant of team {team} (digit {team}); the white stroke on each ant points where it faces.")
        rings = [numbers[0] for kind, numbers in rules.scene.layout.markings if kind == "ring"]
        if rings:  # the ring's edge is too thin to draw in text
            torsos = rules.data.xpos[rules.scene.torso_body][:, :2]
            where = ", ".join(f"{'you' if i == self.seat else f'team {int(rules.team_of[i])}'} "
                              f"{np.linalg.norm(p):.1f} m" for i, p in enumerate(torsos))
            text += f"\nRing radius {rings[0]:.1f} m; distance from its centre: {where}."
        return text

    def prompt(self, step: int) -> str:
        return (f"step {step}: walk w up, a left, s down, d right, wd/sa.. diagonal, x stand; add steps to hold "
                f"(default {self.HOLD}); Enter repeats {self.keys!r} > ")
