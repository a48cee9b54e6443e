"""Fixtures of the remote-component tests: a component host and a gateway as processes on loopback."""

from __future__ import annotations

from collections.abc import AsyncIterator

import aiohttp
import pytest

from ._processes import Process, processes, start_host_and_gateway


@pytest.fixture
async def started() -> AsyncIterator[list[Process]]:
    """Processes a test starts; all of them are ended after it, even when it fails."""
    async with processes() as running:
        yield running


@pytest.fixture
async def demo_rig(started: list[Process]) -> AsyncIterator[tuple[str, Process, str]]:
    """A component host running ``demo`` and ``countserver``, and a gateway that finds them.

    Yields the gateway URL, the host process and its Zenoh endpoint.
    """
    host, url, endpoint = await start_host_and_gateway(started, ["demo", "countserver"])
    yield url, host, endpoint


@pytest.fixture
async def http_rig(demo_rig: tuple[str, Process, str]) -> AsyncIterator[aiohttp.ClientSession]:
    """An HTTP client of the gateway of :func:`demo_rig`."""
    async with aiohttp.ClientSession(base_url=demo_rig[0]) as session:
        yield session
