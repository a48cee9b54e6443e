"""Issue 14, defect 9: the console's token exchange over HTTP (the browser test drives it in chromium)."""

from __future__ import annotations

import aiohttp
import pytest

from aiogenomix.gateway import GatewayConfig

from ..conftest import TEST_TIME_SCALE

TOKEN = "s3cret"


@pytest.fixture
def gateway_config() -> GatewayConfig:
    return GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, token=TOKEN)


async def test_the_token_buys_a_cookie_and_nothing_else_does(gateway: str) -> None:
    # unsafe=True: aiohttp's jar otherwise keeps no cookie of a gateway named by its IP address.
    async with aiohttp.ClientSession(base_url=gateway, cookie_jar=aiohttp.CookieJar(unsafe=True)) as browser:
        async with browser.get("/console") as page:
            assert page.status == 200                                   # the page asks for the token itself
        async with browser.get("/console/auth") as auth:
            assert (await auth.json()) == {"authorized": False}
        async with browser.get("/console/login", headers={"Authorization": "Bearer guess"}) as wrong:
            assert wrong.status == 401 and "aiogenomix_console" not in wrong.cookies
        async with browser.get("/") as index:
            assert index.status == 401
        async with browser.get("/console/login", headers={"Authorization": f"Bearer {TOKEN}"}) as login:
            assert login.status == 204
            cookie = login.cookies["aiogenomix_console"]
            assert cookie.value != TOKEN and cookie["httponly"] and cookie["samesite"] == "Strict"
        async with browser.get("/console/auth") as auth:
            assert (await auth.json()) == {"authorized": True}
        async with browser.get("/") as index:                           # the cookie goes with every request
            assert index.status == 200
    async with aiohttp.ClientSession(base_url=gateway, cookies={"aiogenomix_console": TOKEN}) as forger:
        async with forger.get("/") as index:                            # the token is not the cookie
            assert index.status == 401
