"""Watching a multiple port: one element at a time, refused before the stream starts otherwise."""

from __future__ import annotations

from collections.abc import AsyncIterator

import aiohttp
import orjson
import pytest

from aiogenomix.components.core import Component, ComponentHost, Double, OutPort, ScaledClock
from aiogenomix.gateway import GatewayConfig, serve


class Gauges(Component, name="gauges"):
    """A component with a multiple port."""

    Level = OutPort(Double, doc="One level per tank", multiple=True)

    async def on_start(self) -> None:
        await super().on_start()
        self.Level.publish(1.5, name="north")


@pytest.fixture
async def url() -> AsyncIterator[str]:
    async with ComponentHost(clock=ScaledClock(1), factories={"gauges": Gauges}) as host:
        await host.load("gauges")
        async with serve(GatewayConfig.of(port=0), host=host) as base:
            yield base


async def test_a_multiple_port_is_watched_by_element(url: str) -> None:
    async with aiohttp.ClientSession(base_url=url) as http:
        async with http.get("/module/gauges/watch/Level") as reply:
            assert reply.status == 400 and "name=" in (await reply.json())["message"]
        async with http.get("/module/gauges/watch/Level", params={"name": "south"}) as reply:
            assert reply.status == 404
        async with http.get("/module/gauges/watch/Level", params={"name": "north"}) as stream:
            async for line in stream.content:
                if line.startswith(b"data: "):
                    assert orjson.loads(line[6:]) == {"Level": 1.5, "lost": 0}
                    break
