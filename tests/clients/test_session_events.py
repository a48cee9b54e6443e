"""Sessions and events: callbacks, oneway, cleaning, load by path, other clients' modules, unload and quit."""

from __future__ import annotations

import asyncio
import threading

import aiohttp
import pytest
from aiogenomix.clients import (
    AsyncRequest,
    ClientClosed,
    Interrupted,
    NotFound,
    Request,
    aconnect,
    connect,
)


async def test_callbacks_run_once_and_requests_are_cleaned(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        ended: list[AsyncRequest] = []
        done = asyncio.Event()

        async def note(request: AsyncRequest) -> None:        # coroutine callbacks are awaited too
            ended.append(request)
            done.set()

        request = await demo.GotoPosition(0.2, ack=True, callback=note)
        await request
        await done.wait()
        assert ended == [request]
        assert await demo.Stop(callback=ended.append) is None
        assert len(ended) == 2 and ended[1].service == "Stop"
        # Stop ended in its send reply, but its final event may still be on its way, and cleaning
        # waits for it (ids are reused). An activity's end comes by event, after Stop's (FIFO).
        await demo.Monitor((await demo.Mobile()).position)
        await asyncio.gather(*client._tracker._tasks)         # the cleans spawned at the final events
        assert len(client._tracker) == 0
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{gateway_url}/module/demo/status/{request.id}") as reply:
                assert reply.status == 404                    # cleaned: the gateway forgot it


def test_sync_callback_runs_on_its_own_thread_and_may_call_the_client(threaded_gateway_url: str) -> None:
    with connect(threaded_gateway_url) as client:
        demo = client.load("demo")
        seen: list[tuple[Request, str]] = []
        finished = threading.Event()

        def note(request: Request) -> None:
            seen.append((request, demo.GetSpeed()))           # a blocking call from the callback
            finished.set()

        request = demo.GotoPosition(0.1, ack=True, callback=note)
        assert finished.wait(30)
        assert seen == [(request, "::demo::SLOW")]
        assert request.status == "done"


async def test_oneway_sends_and_forgets(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        assert await demo.GotoPosition(0.1, oneway=True) is None
        assert client.pending() == []
        watch = await demo.Monitor(0.1, ack=True)
        assert (await watch).position == 0.1


async def test_load_by_plugin_path_and_second_instance(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo2 = await client.load("/opt/openrobots/lib/genom/pocolibs/plugins/demo.so", "-i", "demo2")
        assert demo2.__name__ == "demo2"
        assert set(await client.loaded()) == {"demo2"}
        await demo2.GotoPosition(0.1)
        with pytest.raises(demo2.TOO_FAR_AWAY):
            await demo2.GotoPosition(5)
        await client.unload("demo2")
        assert "demo2" not in client.modules


async def test_modules_loaded_by_someone_else(gateway_url: str) -> None:
    async with aconnect(gateway_url) as loader, aconnect(gateway_url) as user:
        assert loader.session != user.session
        await loader.load("countserver")
        counter = await user.module("countserver")
        assert await counter.GetSpeed() == "::countserverinterface::SLOWFWD"
        assert (await counter.CounterPort()).keys() == {"initial", "current"}


async def test_unload_interrupts_pending_requests(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        moving = await demo.GotoPosition(1, ack=True)
        await client.unload("demo")
        with pytest.raises(Interrupted) as caught:
            await moving
        assert caught.value.by == "kill"
        with pytest.raises(NotFound):
            await demo.GetSpeed()


async def test_session_stopped_by_someone_else(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        moving = await demo.GotoPosition(1, ack=True)
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{gateway_url}/session/stop", params={"s": client.session}) as reply:
                assert reply.status == 200
        with pytest.raises(ClientClosed, match="stopped"):
            await moving                                      # failed by the quit event
        with pytest.raises(ClientClosed):
            await demo.GetSpeed()


async def test_close_stops_the_session(gateway_url: str) -> None:
    client = await aconnect(gateway_url, session="mine")
    assert client.session == "mine"
    async with aiohttp.ClientSession() as http:
        async with http.get(f"{gateway_url}/") as reply:
            assert (await reply.json())["sessions"] == 1
        await client.aclose()
        async with http.get(f"{gateway_url}/") as reply:
            assert (await reply.json())["sessions"] == 0
