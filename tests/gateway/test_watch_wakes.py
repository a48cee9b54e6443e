"""The watchers of a port wake together: at each publication, with pings while it is idle, and at its end.

Raw sockets, as genomix clients read event streams.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator

import pytest

from aiogenomix.components.core import ComponentHost, ScaledClock
from aiogenomix.gateway import GatewayConfig, serve
from tests.gateway._raw_http import address, open_raw
from tests.gateway.test_port_fast_paths import Ticker

PING_INTERVAL = 0.2


@pytest.fixture
async def served() -> AsyncIterator[tuple[ComponentHost, str]]:
    host = ComponentHost(clock=ScaledClock(20), factories={"ticker": Ticker})
    async with host, serve(GatewayConfig.of(port=0, ping_interval=PING_INTERVAL), host=host) as url:
        await host.load("ticker")
        yield host, url


async def watch(url: str, port: str) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    reader, writer = await open_raw(url)
    writer.write(f"GET /module/ticker/watch/{port} HTTP/1.1\r\nHost: {address(url)[0]}\r\n\r\n".encode())
    assert (await reader.readuntil(b"\r\n\r\n")).startswith(b"HTTP/1.1 200")
    return reader, writer


async def next_block(reader: asyncio.StreamReader) -> bytes:
    """The next event or comment (up to its blank line)."""
    return await asyncio.wait_for(reader.readuntil(b"\n\n"), 10)


async def test_idle_watchers_are_pinged_then_woken_together_by_a_publication_and_by_the_end(
        served: tuple[ComponentHost, str]) -> None:
    host, url = served
    streams = [await watch(url, "Scalar") for _ in range(3)]  # Scalar is not published yet
    readers = [reader for reader, _ in streams]
    for reader in readers:
        assert await next_block(reader) == b": ping\n\n"
    for reader in readers:  # the pings go on while nothing is published
        assert await next_block(reader) == b": ping\n\n"
    component = host.instances["ticker"]
    await component.send("Push", {"n": 1})
    for reader in readers:
        block = await next_block(reader)
        while block == b": ping\n\n":  # a ping due just before the publication
            block = await next_block(reader)
        assert block.startswith(b"event: port\ndata: ")
        assert json.loads(block.split(b"data: ", 1)[1]) == {"Scalar": 1, "lost": 0}
    await host.unload("ticker")
    for reader in readers:
        block = await next_block(reader)
        while block == b": ping\n\n":
            block = await next_block(reader)
        assert block == b'event: unload\ndata: "ticker"\n\n'
        assert await asyncio.wait_for(reader.read(), 10) == b""  # and the stream ends
    for _, writer in streams:
        writer.close()
        await writer.wait_closed()
