"""A watch or a session's events whose connection drops: the client opens the stream again where it was.

The connections go through a relay the test cuts, as a network failure would, over real
sockets; the rig runs on a clock the test steps, so no chunk leaves the window meanwhile.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any

import aiohttp
from aiogenomix.clients import PortEvent, SessionEvent, aconnect
from aiogenomix.components.core import ManualClock

from tests._cut_links import cuttable

FPC = 2205


async def test_a_watch_from_an_index_resumes_after_the_last_chunk_it_had(stepped: tuple[str, ManualClock]) -> None:
    url, clock = stepped
    async with cuttable(url) as link, aconnect(url) as direct, aconnect(link.url) as client:
        capture = await direct.load("capture")
        await capture.StartCapture(device="sim", Port_chunks=400, ack=True)
        await clock.advance(0.5)
        events: list[PortEvent] = []
        arrived = asyncio.Event()

        async def follow() -> None:
            async for event in client.watch("capture", "Port", since=3):
                events.append(event)
                arrived.set()

        async def until(index: int) -> None:
            while not events or events[-1].data["index"] < index:
                arrived.clear()
                await arrived.wait()

        watching = asyncio.create_task(follow())
        try:
            for connections in (3, 4):  # (the client's first read and the watch came before)
                await clock.advance(0.5)
                await until((await capture.Port(since=2**62))[0].index)
                assert link.cut() >= 1
                await link.connected(connections)
            await clock.advance(0.5)
            await until((await capture.Port(since=2**62))[0].index)
        finally:
            watching.cancel()
            await asyncio.gather(watching, return_exceptions=True)
    # Each event holds the chunks after the one before it: every chunk once, none lost.
    held = [(e.data["index"] - len(e.data["left"]) // FPC + 1, e.data["index"]) for e in events]
    assert held[0][0] == 4 and all(lost == 0 for lost in (e.lost for e in events))
    assert all(first == previous_last + 1 for (_, previous_last), (first, _) in zip(held, held[1:], strict=False))


async def test_a_session_listened_to_again_loses_no_request_end(stepped: tuple[str, ManualClock]) -> None:
    url, _ = stepped
    async with cuttable(url) as link, aconnect(link.url) as client, aiohttp.ClientSession(base_url=url) as http:
        await (await http.get("/load/demo")).read()
        heard: list[SessionEvent] = []
        arrived = asyncio.Event()

        async def listen() -> None:
            async for event in client.session_events("lab"):
                heard.append(event)
                arrived.set()

        async def ended(speed: str) -> str:
            async with http.get("/module/demo/send/SetSpeed", params={"s": "lab", "input": json.dumps(speed)}) as sent:
                request = (await sent.json())["id"]
            while request not in _ends(heard):
                arrived.clear()
                await arrived.wait()
            return str(request)

        listening = asyncio.create_task(listen())
        try:
            sent = [await ended("FAST")]
            assert link.cut() >= 1
            sent.append(await ended("SLOW"))  # sent while the listen stream is down or opening again
            sent.append(await ended("FAST"))
        finally:
            listening.cancel()
            await asyncio.gather(listening, return_exceptions=True)
    assert _ends(heard) == sent  # each end once, in order


def _ends(heard: list[SessionEvent]) -> list[str]:
    """The requests whose end was heard, in the order heard."""
    data: list[Any] = [e.data for e in heard if e.event == "request"]
    return [d["id"] for d in data if d["status"] == "done"]
