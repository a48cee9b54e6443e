"""Shared fixtures: a real gateway on a free port, an HTTP client, an SSE reader over raw sockets."""

from __future__ import annotations

import asyncio
import gc
import logging
import os
import threading
from collections.abc import AsyncIterator, Iterator

import aiohttp
import pytest

from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.gateway import GatewayConfig, serve

#: Tests run the simulated rig this many times faster than real time.
TEST_TIME_SCALE = 20.0
#: Real seconds a simulated device served by a thread (the KEMAR drive) has to answer: the CAN reply
#: timeout is real time by design (decision 8); this bound holds when both cores are busy.
TEST_CAN_TIMEOUT = 10.0


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Skip hardware tests unless AIOGENOMIX_HW=1 says a sound card / CAN adapter is there."""
    if os.environ.get("AIOGENOMIX_HW") == "1":
        return
    skip = pytest.mark.skip(reason="needs real hardware: set AIOGENOMIX_HW=1")
    for item in items:
        if "hardware" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def gateway_config() -> GatewayConfig:
    """The configuration of the test gateway (override in a module to change it)."""
    return GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, can_timeout=TEST_CAN_TIMEOUT)


@pytest.fixture
async def gateway(gateway_config: GatewayConfig) -> AsyncIterator[str]:
    """A gateway serving on a free loopback port; yields its base URL."""
    async with serve(gateway_config) as url:
        yield url


@pytest.fixture
async def stepped() -> AsyncIterator[tuple[str, ManualClock]]:
    """A gateway whose rig runs on a clock the test steps; yields its base URL and the clock."""
    clock = ManualClock()
    async with ComponentHost(clock=clock, settings=HostSettings(can_timeout=10.0, audio_socket_port=0)) as host, \
            serve(GatewayConfig.of(port=0), host) as url:
        yield url, clock


@pytest.fixture
async def http(gateway: str) -> AsyncIterator[aiohttp.ClientSession]:
    """An HTTP client whose relative URLs go to the test gateway."""
    async with aiohttp.ClientSession(base_url=gateway) as session:
        yield session


class RawEventStream:
    """Reads ``/session/listen`` over a plain TCP socket, the way genomix's own clients do."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, headers: bytes) -> None:
        self.reader, self.writer, self.headers = reader, writer, headers

    @classmethod
    async def open(cls, url: str, session: str) -> RawEventStream:
        host, port = url.removeprefix("http://").rsplit(":", 1)
        reader, writer = await asyncio.open_connection(host, int(port))
        writer.write(f"GET /session/listen?s={session} HTTP/1.1\r\nHost: {host}\r\n\r\n".encode())
        await writer.drain()
        headers = await reader.readuntil(b"\r\n\r\n")
        return cls(reader, writer, headers)

    async def next_block(self) -> bytes:
        """The next event block, blank line included, exactly as sent."""
        while True:
            block = await asyncio.wait_for(self.reader.readuntil(b"\n\n"), 10)
            if not block.startswith(b":"):
                return block

    async def next_event(self) -> tuple[str, str | None]:
        """The next event as ``(name, data)``."""
        name, data = "", None
        for line in (await self.next_block()).decode().splitlines():
            if line.startswith("event: "):
                name = line[len("event: "):]
            elif line.startswith("data: "):
                data = line[len("data: "):]
        return name, data

    def close(self) -> None:
        self.writer.close()


class _AsyncioErrors(logging.Handler):
    """Collects what asyncio reports about tasks: destroyed while pending, exceptions never retrieved."""

    def __init__(self) -> None:
        super().__init__(level=logging.ERROR)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


@pytest.fixture(autouse=True)
def no_leaks() -> Iterator[None]:
    """Fail a test that leaves a thread running or a socket open behind it.

    Runs around every test (set up first, so torn down after its event loop is
    closed): leftovers are collected, and whatever they report is this test's.
    A young-generation collection is enough for what a test made (a full one per
    test would double the suite's time); the rest is collected at the end.
    """
    before = set(threading.enumerate())
    errors = _AsyncioErrors()
    logging.getLogger("asyncio").addHandler(errors)
    try:
        yield
        # Leaked tasks and sockets announce themselves when collected (sockets as ResourceWarnings,
        # which the warning filters make errors).
        gc.collect(1)
    finally:
        logging.getLogger("asyncio").removeHandler(errors)
    leaked = [t for t in threading.enumerate() if t not in before and t.is_alive()]
    for thread in leaked:
        # A thread that is ending (an executor's worker after shutdown) gets a moment to do so.
        thread.join(timeout=5)
    leaked = [t.name for t in leaked if t.is_alive()]
    assert not leaked, f"the test left threads running: {leaked}"
    tasks = [m for m in errors.messages if "Task was destroyed" in m or "never retrieved" in m]
    assert not tasks, f"the test left asyncio tasks behind: {tasks}"


@pytest.fixture(autouse=True)
async def no_pending_tasks() -> AsyncIterator[None]:
    """Fail a test that leaves asyncio tasks running on its loop after its own fixtures are torn down.

    (The loop's owner would cancel them silently when it closes the loop.)
    """
    before = asyncio.all_tasks()
    yield
    for _ in range(3):
        # Tasks whose end was just set in motion (a closed connection's handler) get to finish.
        await asyncio.sleep(0)
    me = asyncio.current_task()
    left = [t for t in asyncio.all_tasks() - before if t is not me and not t.done()]
    for task in left:
        task.cancel()
    assert not left, f"the test left asyncio tasks running: {[t.get_name() for t in left]}"
