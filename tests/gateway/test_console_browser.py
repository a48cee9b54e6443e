"""The console in a real browser (Debian's chromium, driven by Playwright; no browser is downloaded).

With ``--token`` the console asks for the token once, trades it for an HttpOnly
cookie and then works like on an open gateway: its requests and its event
streams carry the cookie.  Its Content-Security-Policy must not stop its own
script, and the page must log no error.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import pytest

from aiogenomix.gateway import GatewayConfig

from ..conftest import TEST_TIME_SCALE
from ._browser import browser_page, needs_browser

pytestmark = needs_browser
TOKEN = "s3cret-console"


@pytest.fixture
def gateway_config() -> GatewayConfig:
    return GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, token=TOKEN)


@pytest.fixture
async def page(gateway: str) -> AsyncIterator[Any]:
    async with browser_page() as opened:
        yield opened


async def test_the_console_asks_for_the_token_once_then_works(page: Any, gateway: str) -> None:
    await page.goto(f"{gateway}/console")
    await page.locator("#token").fill(TOKEN)
    await page.locator("#login").click()
    # Logged in: the gateway's modules are listed; load demo and open it.
    available = page.locator("#available li", has_text="demo")
    await available.get_by_role("button", name="load").click()
    await page.locator("#loaded").get_by_role("button", name="demo").click()
    service = page.locator("details", has=page.locator("summary", has_text="GotoPosition"))
    await service.locator("summary").click()
    await service.locator("input").first.fill("0.25")
    await service.get_by_role("button", name="send").click()
    # The request's events arrive on the session's stream, which carries the cookie too.
    await page.locator("#events .event", has_text="GotoPosition done").first.wait_for(timeout=20_000)
    result = service.locator("pre")
    await result.filter(has_text="done").wait_for(timeout=20_000)
    cookies = await page.context.cookies()
    (cookie,) = [c for c in cookies if c["name"] == "aiogenomix_console"]
    assert cookie["httpOnly"] and cookie["sameSite"] == "Strict" and cookie["value"] != TOKEN
    assert page.problems == []          # no CSP refusal, no script error, no failed request
