"""Fixtures of the client tests: a real gateway on a free port, on the test's loop or on a thread of its own."""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import threading
from collections.abc import AsyncIterator, Iterator

import pytest
from aiogenomix.gateway import GatewayConfig, serve

#: Robot seconds per real second: a 1 m move at 0.1 m/s takes half a second.
TIME_SCALE = 20.0


def config() -> GatewayConfig:
    """A gateway on free ports, with a fast clock."""
    return GatewayConfig(port=0, time_scale=TIME_SCALE, audio_socket_port=0)


@contextlib.contextmanager
def gateway_thread() -> Iterator[str]:
    """Serve a gateway on its own loop thread (for sync clients, and tests that block their loop)."""
    started: concurrent.futures.Future[tuple[str, asyncio.Event]] = concurrent.futures.Future()

    async def main() -> None:
        try:
            async with serve(config()) as url:
                stop = asyncio.Event()
                started.set_result((url, stop))
                await stop.wait()
        except BaseException as exc:
            if not started.done():
                started.set_exception(exc)
            raise

    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_until_complete, args=(main(),), name="test-gateway", daemon=True)
    thread.start()
    url, stop = started.result(timeout=30)
    try:
        yield url
    finally:
        loop.call_soon_threadsafe(stop.set)
        thread.join(timeout=30)
        loop.close()


@pytest.fixture
async def gateway_url() -> AsyncIterator[str]:
    """A gateway served on the test's own event loop (for the async client)."""
    async with serve(config()) as url:
        yield url


@pytest.fixture
def threaded_gateway_url() -> Iterator[str]:
    """A gateway served on a thread of its own (for the sync client)."""
    with gateway_thread() as url:
        yield url
