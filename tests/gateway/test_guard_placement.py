"""The application ``create_app`` builds answers alike however it is served (decision 37).

``serve`` runs that application as it is, with the gateway's connections and the
plain reads ahead of the routes; an embedder may serve it with aiohttp's own runner.
The guard (access, token, errors as genomix JSON) is its middleware either way, and
the limits are its handler's (the rest of the suite runs ``serve``).
"""

from __future__ import annotations

from collections.abc import AsyncIterator

import aiohttp
import pytest
from aiohttp import web

from aiogenomix.gateway import GatewayConfig, create_app, serve

TOKEN = "s3cret"


@pytest.fixture(params=["gateway runner", "aiohttp runner"])
async def url(request: pytest.FixtureRequest) -> AsyncIterator[str]:
    config = GatewayConfig.of(port=0, audio_socket_port=0, token=TOKEN)
    if request.param == "gateway runner":
        async with serve(config) as served:
            yield served
        return
    runner = web.AppRunner(create_app(config), access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    try:
        yield f"http://127.0.0.1:{runner.addresses[0][1]}"
    finally:
        await runner.cleanup()


async def test_the_guard_answers_alike_under_either_runner(url: str) -> None:
    authorized = {"Authorization": f"Bearer {TOKEN}"}
    async with aiohttp.ClientSession(base_url=url) as http:
        async with http.get("/load/demo") as reply:
            assert reply.status == 401
            assert (await reply.json())["ex"] == "::genomix::unauthorized"
        async with http.get("/load/demo", headers=authorized) as reply:
            assert reply.status == 200
        async with http.get("/module/demo/read/Mobile", headers=authorized | {"Host": "rebound.example"}) as reply:
            assert reply.status == 403
            assert (await reply.json())["ex"] == "::genomix::forbidden"
        async with http.get("/module/demo/send/NoSuchService", headers=authorized) as reply:
            assert reply.status == 404
            assert (await reply.json())["ex"] == "::genom::no_such_service"
        async with http.get("/no/such/route", headers=authorized) as reply:
            assert reply.status == 404
            assert (await reply.json())["ex"] == "::genomix::http"
        async with http.get("/module/demo/read/Mobile", headers=authorized) as reply:
            assert reply.status == 200
            assert set(await reply.json()) == {"Mobile"}
