"""Debian's Chromium driven by Playwright, for the browser tests: the module-level skip (with the
reason) where either is missing, and one launched browser.
PYTEST_DONT_REWRITE
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

CHROMIUM = Path("/usr/bin/chromium")
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
