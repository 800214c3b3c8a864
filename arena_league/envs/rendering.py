"""Headless top-down drawing shared by the games: a Pillow canvas in world coordinates.

No display and no window are ever opened; ``render_mode="rgb_array"`` returns the picture as a
``uint8[H, W, 3]`` array.
"""

from __future__ import annotations

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
