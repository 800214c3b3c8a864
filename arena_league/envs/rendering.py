"""Top-down pictures shared by the games, and the window that shows them to a person.

Every game draws its arena from above on a Pillow canvas in world coordinates (:class:`Canvas`,
:func:`grid_picture`), with no display: ``render_mode="rgb_array"`` returns that picture as a
``uint8[H, W, 3]`` array. ``render_mode="human"`` shows the same picture in a pygame window
(:class:`HumanWindow`; pygame is imported only then), at the env's ``metadata["render_fps"]``
frames per second. pygame has one window per process, so human-rendered envs of one process
share it. Where there is no display, asking for a window fails at once with what to do instead
(:func:`check_human_rendering`).
"""

from __future__ import annotations

import importlib.util
import os
import sys
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

#: Team colours (RGB), team 0 first.
TEAM_COLOURS: tuple[tuple[int, int, int], ...] = (
    (220, 60, 50),
    (50, 110, 220),
    (60, 170, 80),
    (230, 170, 40),
    (150, 80, 190),
    (40, 180, 190),
    (200, 100, 150),
    (120, 120, 120),
)


class Canvas:
    """A square picture of the world box ``[x0, x1] x [y0, y1]`` (y up), ``size`` pixels wide."""

    def __init__(self, x0: float, x1: float, y0: float, y1: float, size: int = 256,
                 background: tuple[int, int, int] = (240, 240, 235)) -> None:
        self.x0, self.y1 = x0, y1
        self.scale = size / max(x1 - x0, y1 - y0)
        self.width = max(1, round((x1 - x0) * self.scale))
        self.height = max(1, round((y1 - y0) * self.scale))
        self.image = Image.new("RGB", (self.width, self.height), background)
        self.draw = ImageDraw.Draw(self.image)

    def px(self, x: float, y: float) -> tuple[float, float]:
        """World point to pixel (y axis flipped so that up is up)."""
        return (x - self.x0) * self.scale, (self.y1 - y) * self.scale

    def circle(self, x: float, y: float, r: float, fill, outline=None) -> None:
        cx, cy = self.px(x, y)
        rr = max(1.0, r * self.scale)
        self.draw.ellipse((cx - rr, cy - rr, cx + rr, cy + rr), fill=fill, outline=outline)

    def rect(self, x0: float, y0: float, x1: float, y1: float, fill, outline=None) -> None:
        ax, ay = self.px(x0, y1)
        bx, by = self.px(x1, y0)
        self.draw.rectangle((ax, ay, bx, by), fill=fill, outline=outline)

    def line(self, x0: float, y0: float, x1: float, y1: float, fill, width_px: int = 1) -> None:
        self.draw.line((*self.px(x0, y0), *self.px(x1, y1)), fill=fill, width=width_px)

    def array(self) -> np.ndarray:
        return np.asarray(self.image, dtype=np.uint8).copy()


def grid_picture(cells: np.ndarray, palette: dict[int, tuple[int, int, int]], cell_px: int = 12) -> np.ndarray:
    """A picture of an integer grid: each cell value is painted with its palette colour."""
    lut = np.zeros((max(palette) + 1, 3), dtype=np.uint8)
    for value, colour in palette.items():
        lut[value] = colour
    picture = lut[cells]
    return np.repeat(np.repeat(picture, cell_px, axis=0), cell_px, axis=1)


class DisplayError(RuntimeError):
    """``render_mode="human"`` cannot open a window here; the message says what to do instead."""


_NO_WINDOW_FIX = ("use render_mode='rgb_array' to get the pictures as arrays without a window, run under a "
                  "display, or set SDL_VIDEODRIVER=dummy to draw to no screen (for tests)")


def check_human_rendering() -> None:
    """Raise :class:`DisplayError` unless a window can open: pygame is installed and, on Linux and
    other X11/Wayland systems, there is a display (``DISPLAY`` or ``WAYLAND_DISPLAY``) or
    ``SDL_VIDEODRIVER`` names a video driver."""
    if importlib.util.find_spec("pygame") is None:
        raise DisplayError("render_mode='human' shows the game in a pygame window, and pygame is not installed: "
                           "pip install pygame (or install arena-league[dev]); or use render_mode='rgb_array' to get "
                           "the pictures as arrays")
    if sys.platform in ("darwin", "win32") or any(os.environ.get(name) for name in
                                                  ("DISPLAY", "WAYLAND_DISPLAY", "SDL_VIDEODRIVER")):
        return
    raise DisplayError("render_mode='human' opens a window, but this process has no display (DISPLAY and "
                       f"WAYLAND_DISPLAY are unset, and so is SDL_VIDEODRIVER): {_NO_WINDOW_FIX}")


class HumanWindow:
    """A pygame window that shows top-down pictures, paced at a number of frames per second.

    The window opens on the first :meth:`show` and takes the picture's size; it stays responsive
    while frames come. Closing it (its close button) stops the showing; :meth:`close` shuts it.
    """

    def __init__(self, title: str) -> None:
        self.title = title
        self._pygame: Any = None
        self._clock: Any = None
        self._open = False
        self._dismissed = False

    def show(self, picture: np.ndarray, fps: float) -> None:
        """Show ``picture`` (``uint8[H, W, 3]``), then wait out the rest of a frame at ``fps``."""
        if self._dismissed:
            return
        pygame = self._start()
        size = (int(picture.shape[1]), int(picture.shape[0]))
        screen = pygame.display.get_surface()
        if screen is None or screen.get_size() != size:
            try:
                screen = pygame.display.set_mode(size)
            except pygame.error as error:
                raise DisplayError(f"render_mode='human' could not open a window ({error}): {_NO_WINDOW_FIX}") from None
            pygame.display.set_caption(self.title)
        self._open = True
        screen.blit(pygame.surfarray.make_surface(np.ascontiguousarray(picture.swapaxes(0, 1))), (0, 0))
        pygame.display.flip()
        if any(event.type == pygame.QUIT for event in pygame.event.get()):
            self._dismissed = True
            self.close()
            return
        self._clock.tick(fps)

    def close(self) -> None:
        """Shut the window, if this one opened it (a later :meth:`show` opens it again, unless the
        person closed it)."""
        if self._open:
            self._pygame.display.quit()
            self._open = False

    def _start(self) -> Any:
        if self._pygame is None:
            os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
            import pygame

            self._pygame = pygame
            self._clock = pygame.time.Clock()
        if not self._pygame.display.get_init():
            try:
                self._pygame.display.init()
            except self._pygame.error as error:
                raise DisplayError(f"render_mode='human' could not start pygame's display ({error}): "
                                   f"{_NO_WINDOW_FIX}") from None
        return self._pygame
