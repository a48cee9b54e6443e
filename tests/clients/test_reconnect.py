"""Acceptance 4: the listen connection dies mid-activity; the client reconnects and reports each end exactly once."""

from __future__ import annotations

import asyncio

import pytest
from aiogenomix.clients import AsyncRequest, Interrupted, aconnect


async def _settled(client: object) -> None:
    tracker = client._tracker  # type: ignore[attr-defined]
    await asyncio.gather(*tracker._tasks)


async def test_pending_call_returns_once_after_the_stream_drops(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        ends: list[AsyncRequest] = []
        moving = await demo.GotoPosition(1, ack=True, callback=ends.append)
        assert client._listen.attachments == 1

        client._drop_listen_stream()                           # as if the network failed
        # A blocking call made while the stream is down or reconnecting still gets its result.
        crossed = await demo.Monitor(0.5, timeout=30)
        assert crossed.position >= 0.5
        assert await moving is None
        assert moving.status == "done"
        assert ends == [moving]                                # reported exactly once
        assert client._listen.attachments == 2

        # Everything tracked is cleaned once the stream proved it caught up.
        await demo.Monitor(1.0)
        await _settled(client)
        assert len(client._tracker) == 0


async def test_end_lost_with_the_dead_connection_is_reread(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        ends: list[AsyncRequest] = []
        moving = await demo.GotoPosition(-1, ack=True, callback=ends.append)
        client._drop_listen_stream()
        # Stop ends the motion at once, while the gateway may still write to the dead connection:
        # that event is lost, and only the status re-read after reconnecting can tell.
        await demo.Stop()
        with pytest.raises(Interrupted) as caught:
            await asyncio.wait_for(moving.result(), 30)
        assert caught.value.by == "Stop"
        assert ends == [moving]
        await client._listen.attached.wait()
        again = await demo.GotoPosition(0.1, ack=True, callback=ends.append)
        assert await again is None                             # its events prove the backlog was read
        assert ends == [moving, again]
        await _settled(client)
        assert len(client._tracker) == 0                       # nothing left uncleaned


async def test_repeated_drops(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        ends: list[AsyncRequest] = []
        moving = await demo.GotoPosition(1, ack=True, callback=ends.append)
        for attachments in (2, 3, 4):
            client._drop_listen_stream()
            await client._listen._wait_attachments(attachments)
        assert await moving is None
        assert ends == [moving]
