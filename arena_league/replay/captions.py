"""Captions of replay pictures: who plays, which step, and how the match ended.

A captioned frame is the game's top-down picture between two bands, so the caption never hides
the play:

* the band above names the agents of each team, team by team, in the team's colour
  (:data:`arena_league.envs.rendering.TEAM_COLOURS`, the colours the pictures draw the teams in),
  each team after a swatch of its colour;
* the band below shows the step (``step 12 / 40``) and the game, and on the match's last frame
  its outcome: the winning team (or a draw) and every team's score in its colour.

Text is drawn with Pillow's own default font, so nothing is downloaded. The layout depends on
the match and the picture's width only, so every frame of a match has the same size.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from arena_league.envs.rendering import TEAM_COLOURS

__all__ = ["BAND_COLOUR", "FONT_SIZE", "MatchCaption", "team_colour"]

#: Background of the caption bands (RGB).
BAND_COLOUR = (22, 22, 26)
#: Size in pixels of the caption text.
FONT_SIZE = 13
_TEXT = (236, 236, 236)
_MUTED = (150, 150, 158)
_PAD = 6
_GAP = 14
_ELLIPSIS = "..."

Piece = tuple[str, tuple[int, int, int]]
"""A piece of text and its colour."""


def team_colour(team: int) -> tuple[int, int, int]:
    """The colour of ``team`` in the pictures (and in their captions)."""
    return TEAM_COLOURS[int(team) % len(TEAM_COLOURS)]


def _default_font() -> Any:
    """Pillow's bundled default font at :data:`FONT_SIZE` (its fixed bitmap font where Pillow is
    older than 10.1 or built without FreeType)."""
    try:
        return ImageFont.load_default(size=FONT_SIZE)
    except TypeError:
        return ImageFont.load_default()


@dataclass(frozen=True)
class _Run:
    """Pieces that stay on one line, optionally after a colour swatch."""

    pieces: tuple[Piece, ...]
    swatch: tuple[int, int, int] | None = None


class MatchCaption:
    """Draws the caption bands of one match's pictures.

    Args:
        width: the width of the game's pictures in pixels.
        game_id: the game played.
        seats: the agent name of each seat.
        teams: the team of each seat.
        steps: the match's length in env steps.
        scores: each seat's team score (higher is better).
        outcomes: ``"win"``, ``"loss"`` or ``"draw"`` per seat.
    """

    def __init__(self, width: int, game_id: str, seats: Sequence[str], teams: Sequence[int], steps: int,
                 scores: Sequence[float], outcomes: Sequence[str]) -> None:
        if len(seats) != len(teams) or len(scores) != len(teams) or len(outcomes) != len(teams):
            raise ValueError(f"a caption needs one team, score and outcome per seat; got {len(seats)} seats, "
                             f"{len(teams)} teams, {len(scores)} scores and {len(outcomes)} outcomes (read them "
                             "from the replay with read_replay)")
        self.width = int(width)
        self.game_id = game_id
        self.steps = int(steps)
        self.font = _default_font()
        bbox = self.font.getbbox("Hgjy|")
        self.line_height = int(bbox[3]) + 4
        order = sorted({int(t) for t in teams})
        self._team_runs = [self._team_run(t, [s for s, team in zip(seats, teams) if int(team) == t])
                           for t in order]
        team_score = {int(t): float(s) for t, s in zip(teams, scores)}
        team_outcome = {int(t): str(o) for t, o in zip(teams, outcomes)}
        self._outcome_runs = self._outcome(order, team_score, team_outcome)
        self._top_lines = self._pack(self._team_runs)
        self._outcome_lines = self._pack(self._outcome_runs)
        widest_step = self._text_width(self._step_text(self.steps))
        self._game_fits = widest_step + _GAP + self._text_width(game_id) <= self.width - 2 * _PAD
        self.top_height = len(self._top_lines) * self.line_height + _PAD
        self.bottom_height = (1 + len(self._outcome_lines)) * self.line_height + _PAD

    @property
    def outcome_text(self) -> str:
        """The outcome as it reads on the last frame (``team 1 wins  0 : 1``)."""
        return "  ".join("".join(text for text, _ in run.pieces) for run in self._outcome_runs)

    def draw(self, picture: np.ndarray, step: int, final: bool) -> Image.Image:
        """``picture`` (``uint8[H, W, 3]``) between the caption bands, at ``step``; ``final``: the
        match's last frame, which also shows the outcome."""
        picture = np.asarray(picture)
        if picture.ndim != 3 or picture.shape[1] != self.width:
            raise ValueError(f"the caption was laid out for pictures {self.width} pixels wide, not of shape "
                             f"{picture.shape}; make one MatchCaption per match, with its pictures' width")
        height = picture.shape[0]
        image = Image.new("RGB", (self.width, self.top_height + height + self.bottom_height), BAND_COLOUR)
        image.paste(Image.fromarray(picture[..., :3].astype(np.uint8)), (0, self.top_height))
        draw = ImageDraw.Draw(image)
        y = _PAD // 2
        for line in self._top_lines:
            self._draw_line(draw, line, y)
            y += self.line_height
        y = self.top_height + height + _PAD // 2
        draw.text((_PAD, y), self._step_text(step), font=self.font, fill=_TEXT)
        if self._game_fits:
            draw.text((self.width - _PAD - self._text_width(self.game_id), y), self.game_id, font=self.font,
                      fill=_MUTED)
        if final:
            for line in self._outcome_lines:
                y += self.line_height
                self._draw_line(draw, line, y)
        return image

    # --- layout ---------------------------------------------------------------------------------
    def _step_text(self, step: int) -> str:
        return f"step {int(step)} / {self.steps}"

    def _team_run(self, team: int, names: Sequence[str]) -> _Run:
        seen: dict[str, int] = {}
        for name in names:
            seen[name] = seen.get(name, 0) + 1
        listed = ", ".join(name if count == 1 else f"{name} x{count}" for name, count in seen.items())
        return _Run(((f"team {team}: {listed}", team_colour(team)),), swatch=team_colour(team))

    @staticmethod
    def _outcome(order: list[int], score: dict[int, float], outcome: dict[int, str]) -> list[_Run]:
        winners = [t for t in order if outcome[t] == "win"]
        if winners:
            verdict: Piece = (" and ".join(f"team {t}" for t in winners)
                              + (" wins" if len(winners) == 1 else " win"), team_colour(winners[0]))
        elif all(outcome[t] == "draw" for t in order):
            verdict = ("draw", _TEXT)
        else:
            tied = [t for t in order if outcome[t] == "draw"]
            verdict = (f"teams {', '.join(str(t) for t in tied)} tie for first", _TEXT)
        separator = " : " if len(order) == 2 else "  "
        pieces: list[Piece] = [("scores ", _MUTED)]
        for i, t in enumerate(order):
            if i:
                pieces.append((separator, _MUTED))
            pieces.append((f"{score[t]:.3g}", team_colour(t)))
        return [_Run((verdict,)), _Run(tuple(pieces))]

    def _text_width(self, text: str) -> int:
        return int(np.ceil(self.font.getlength(text)))

    def _swatch_size(self) -> int:
        return max(6, self.line_height - 8)

    def _run_width(self, run: _Run) -> int:
        swatch = self._swatch_size() + 5 if run.swatch is not None else 0
        return swatch + sum(self._text_width(text) for text, _ in run.pieces)

    def _fit(self, run: _Run, room: int) -> _Run:
        """``run`` cut at the end, with an ellipsis, to at most ``room`` pixels."""
        if self._run_width(run) <= room:
            return run
        total = sum(len(text) for text, _ in run.pieces)
        for keep in range(total - 1, 0, -1):
            pieces: list[Piece] = []
            left = keep
            for text, colour in run.pieces:
                if left <= 0:
                    break
                pieces.append((text[:left], colour))
                left -= len(text)
            text, colour = pieces[-1]
            pieces[-1] = (text.rstrip(" ,:") + _ELLIPSIS, colour)
            candidate = _Run(tuple(pieces), run.swatch)
            if self._run_width(candidate) <= room:
                return candidate
        return _Run(((_ELLIPSIS, run.pieces[0][1]),), run.swatch)

    def _pack(self, runs: list[_Run]) -> list[list[_Run]]:
        """Runs flowed onto lines of the picture's width (a run too wide alone is cut)."""
        room = self.width - 2 * _PAD
        lines: list[list[_Run]] = []
        used = room + 1
        for run in runs:
            width = self._run_width(run)
            if lines and used + _GAP + width <= room:
                lines[-1].append(run)
                used += _GAP + width
                continue
            placed = self._fit(run, room)
            lines.append([placed])
            used = self._run_width(placed)
        return lines

    def _draw_line(self, draw: ImageDraw.ImageDraw, runs: list[_Run], y: int) -> None:
        x = _PAD
        for run in runs:
            if run.swatch is not None:
                size = self._swatch_size()
                top = y + (self.line_height - 4 - size) // 2 + 2
                draw.rectangle([x, top, x + size - 1, top + size - 1], fill=run.swatch)
                x += size + 5
            for text, colour in run.pieces:
                draw.text((x, y), text, font=self.font, fill=colour)
                x += self._text_width(text)
            x += _GAP
