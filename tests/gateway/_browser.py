"""Debian's chromium driven by Playwright for the console's tests (no browser is downloaded)."""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import AsyncIterator
from typing import Any

import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
#: Browser tests are heavy: ./run runs them once, on the default Python (AIOGENOMIX_HEAVY=0 on the others).
needs_browser = pytest.mark.skipif(
    CHROMIUM is None or os.environ.get("AIOGENOMIX_HEAVY") == "0",
    reason="needs Debian's chromium (./run test installs it); run once, on the default Python")
#: Chromium as the machine allows it: no sandbox (root), no GPU, no calls home.
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage"]


@contextlib.asynccontextmanager
async def browser_page(**page_options: Any) -> AsyncIterator[Any]:
    """A page of a fresh headless chromium; ``page.problems`` collects its console errors and script errors."""
    from playwright.async_api import async_playwright

    async with async_playwright() as driver:
        browser = await driver.chromium.launch(executable_path=CHROMIUM, headless=True, args=FLAGS)
        try:
            page = await browser.new_page(**page_options)
            page.problems = []
            page.on("console", lambda m: m.type == "error" and page.problems.append(m.text))
            page.on("pageerror", lambda e: page.problems.append(str(e)))
            yield page
        finally:
            await browser.close()
