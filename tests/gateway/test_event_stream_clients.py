"""Standard event-stream clients read every event as it is sent, ``quit`` included, and stop after it.

Each client library is the real one: sseclient-py over requests, httpx-sse,
aiohttp-sse-client, and Chromium's EventSource (Playwright driving Debian's
chromium).  They say ``Accept: text/event-stream`` and get the standard form
(chunked, ids, data on ``quit``); the next event is sent only once the client
has the last one, so an event that waited for the next one's bytes would hang
the test.  A reconnect after ``quit`` gets 204 and starts nothing again.  The
genomix form, for raw readers that do not ask, is in ``test_listen_stream``.
"""

from __future__ import annotations

import asyncio
import datetime
import queue
import threading
from collections.abc import Iterator
from typing import Any

import aiohttp
import httpx
import pytest
import requests
import sseclient
from aiohttp_sse_client import client as aiohttp_sse
from httpx_sse import connect_sse

from tests.gateway._browser import browser_page, needs_browser

EVENTS = 3


async def _send(http: aiohttp.ClientSession, session: str) -> dict[str, Any]:
    async with http.get("/module/demo/send/GetSpeed", params={"s": session}) as reply:
        status: dict[str, Any] = await reply.json()
        return status


async def _drive(http: aiohttp.ClientSession, session: str, received: queue.Queue[tuple[str, str, str]]
                 ) -> list[tuple[str, str, str]]:
    """Send EVENTS requests, each once the client has the event of the one before; then stop the session."""
    got = []
    for _ in range(EVENTS):
        sent = await _send(http, session)
        got.append(await asyncio.to_thread(received.get, timeout=10))
        assert sent["id"] in got[-1][2]
    async with http.get("/session/stop", params={"s": session}) as reply:
        assert reply.status == 200
    got.append(await asyncio.to_thread(received.get, timeout=10))
    return got


def _check(got: list[tuple[str, str, str]], session: str) -> None:
    assert [event for event, _, _ in got] == ["request"] * EVENTS + ["quit"]
    assert [int(identifier) for _, identifier, _ in got[:EVENTS]] == list(range(1, EVENTS + 1))
    assert got[-1][1:] == ("end", f'"{session}"')


@pytest.fixture
async def demo(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")


async def _session_gone(http: aiohttp.ClientSession, session: str) -> None:
    async with http.get("/session/stop", params={"s": session}) as reply:
        assert reply.status == 404  # not brought back by a reconnect
    async with http.get("/") as reply:
        assert (await reply.json())["sessions"] == 0


def _in_thread(target: Any) -> Iterator[threading.Thread]:
    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    yield thread
    thread.join(timeout=10)
    assert not thread.is_alive()


async def test_sseclient_py(gateway: str, http: aiohttp.ClientSession, demo: None) -> None:
    received: queue.Queue[tuple[str, str, str]] = queue.Queue()
    listening = threading.Event()

    def read() -> None:
        reply = requests.get(f"{gateway}/session/listen?s=py", stream=True, timeout=10,
                             headers={"Accept": "text/event-stream"})
        listening.set()
        for event in sseclient.SSEClient(reply).events():
            received.put((event.event, event.id, event.data))
        reply.close()

    for _ in _in_thread(read):
        await asyncio.to_thread(listening.wait, 10)
        _check(await _drive(http, "py", received), "py")
    await _session_gone(http, "py")


async def test_httpx_sse(gateway: str, http: aiohttp.ClientSession, demo: None) -> None:
    received: queue.Queue[tuple[str, str, str]] = queue.Queue()
    listening = threading.Event()

    def read() -> None:
        with httpx.Client(timeout=10) as client, connect_sse(client, "GET", f"{gateway}/session/listen?s=hx") as events:
            listening.set()
            for event in events.iter_sse():
                received.put((event.event, event.id, event.data))

    for _ in _in_thread(read):
        await asyncio.to_thread(listening.wait, 10)
        _check(await _drive(http, "hx", received), "hx")
    await _session_gone(http, "hx")


async def test_aiohttp_sse_client_stops_on_the_204(gateway: str, http: aiohttp.ClientSession, demo: None) -> None:
    received: queue.Queue[tuple[str, str, str]] = queue.Queue()
    opened = asyncio.Event()
    ended: list[BaseException] = []

    async def read() -> None:
        async with aiohttp_sse.EventSource(f"{gateway}/session/listen?s=ah", on_open=opened.set,
                                           reconnection_time=datetime.timedelta(seconds=0.1)) as events:
            try:
                async for event in events:
                    received.put((event.type, event.last_event_id, event.data))
            except ConnectionAbortedError as exc:  # how it reports a 204: it gives up
                ended.append(exc)

    reader = asyncio.create_task(read())
    await asyncio.wait_for(opened.wait(), 10)
    _check(await _drive(http, "ah", received), "ah")
    await asyncio.wait_for(reader, 10)  # it reconnected, got 204, and stopped
    assert "204" in str(ended[0])
    await _session_gone(http, "ah")


@needs_browser
async def test_chromium_event_source_gets_quit_and_never_reconnects(
        gateway: str, http: aiohttp.ClientSession, demo: None) -> None:
    from playwright.async_api import TimeoutError as PlaywrightTimeout

    async with browser_page() as page:
        await page.goto(f"{gateway}/version")  # a page of the gateway's own origin
        await page.evaluate("""() => {
            window.seen = []; window.opens = 0;
            const events = window.events = new EventSource("/session/listen?s=web");
            events.onopen = () => { window.opens += 1; };
            for (const name of ["request", "quit"]) {
                events.addEventListener(name, (e) => window.seen.push([name, e.lastEventId, e.data]));
            }
        }""")
        await page.wait_for_function("window.opens === 1")
        for n in range(1, EVENTS + 1):
            await _send(http, "web")
            await page.wait_for_function(f"window.seen.length === {n}")
        async with http.get("/session/stop", params={"s": "web"}) as reply:
            assert reply.status == 200
        await page.wait_for_function("window.seen.length === 4")
        seen = await page.evaluate("window.seen")
        assert [event for event, _, _ in seen] == ["request"] * EVENTS + ["quit"]
        assert seen[-1][1:] == ["end", '"web"']
        # The stream ended; the browser's reconnect got 204 and it closed for good.
        await page.wait_for_function("window.events.readyState === EventSource.CLOSED", timeout=10_000)
        with pytest.raises(PlaywrightTimeout):
            await page.wait_for_function("window.opens > 1", timeout=7_000)
        assert page.problems == []
    await _session_gone(http, "web")
