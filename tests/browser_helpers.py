"""Debian's Chromium driven by Playwright, for the browser tests: the module-level skip (with the
reason) where either is missing, and one launched browser.
PYTEST_DONT_REWRITE
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

CHROMIUM = Path("/usr/bin/chromium")
#: The replay painter's margin around the world bounds, in CSS pixels (replay.js).
PADDING = 12
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]


def playwright_or_skip() -> ModuleType:
    """``playwright.sync_api``; skips the calling test module where Playwright or Chromium is missing
    (``.ci/run`` installs both)."""
    sync_api = pytest.importorskip("playwright.sync_api", reason="the browser tests need Playwright (pip install "
                                                                 "playwright; its own browser download is not needed)")
    if not CHROMIUM.exists():
        pytest.skip(f"the browser tests need Debian's Chromium at {CHROMIUM} (apt-get install -y chromium)",
                    allow_module_level=True)
    return sync_api


@contextmanager
def chromium(sync_api: ModuleType) -> Iterator[Any]:
    """Debian's Chromium, headless, closed afterwards."""
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        try:
            yield browser
        finally:
            browser.close()


def to_screen(page: Any, x: float, y: float) -> tuple[float, float]:
    """The page position of the world point (x, y) on the play page's view (the painter's fit of
    the view's ``data-bounds`` into its canvas)."""
    bounds = json.loads(page.get_attribute("#play", "data-bounds"))
    box = page.locator('[data-role="view"]').bounding_box()
    span_x, span_y = bounds[2] - bounds[0], bounds[3] - bounds[1]
    scale = min((box["width"] - 2 * PADDING) / span_x, (box["height"] - 2 * PADDING) / span_y)
    offset_x = (box["width"] - span_x * scale) / 2
    offset_y = (box["height"] - span_y * scale) / 2
    return box["x"] + offset_x + (x - bounds[0]) * scale, box["y"] + offset_y + (bounds[3] - y) * scale
