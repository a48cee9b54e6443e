"""A host's events are data: what was commanded when, to whoever subscribes (a recorder, a view, the sessions)."""

from __future__ import annotations

import json
from typing import Annotated, Any

import aiohttp
import pytest

from aiogenomix.components.core import (
    Component, ComponentHost, Double, Event, InstanceLoaded, InstanceUnloaded, ManualClock, RequestEvent,
    SessionEnded, activity, function,
)
from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.gateway._sse import GENOMIX_FORM

from ..conftest import RawEventStream


class Lamp(Component, name="lamp"):
    """A lamp that dims slowly."""

    @activity
    async def Dim(self, to: Annotated[Double, "Target level"] = 0.0, seconds: Double = 1.0) -> None:
        """Dim the lamp, taking *seconds*."""
        await self.clock.sleep(seconds)

    @function
    def Fail(self) -> None:
        """Fail at once."""
        raise RuntimeError("the bulb blew")


async def test_a_subscriber_hears_what_was_commanded_when() -> None:
    clock = ManualClock(start=1000.0)
    async with ComponentHost(clock=clock, factories={"lamp": Lamp}, function_grace=0.01) as host:
        heard: list[Event] = []
        host.events.subscribe(heard.append)
        await host.load("lamp")
        lamp = host.get("lamp")
        dim = await lamp.send("Dim", {"to": 0.25, "seconds": 2}, session="lab")
        await clock.advance(2.0)
        await dim.ended.wait()
        await lamp.send("Fail", None)
        await host.unload("lamp")
    assert [type(e).__name__ for e in heard] == ["InstanceLoaded", "RequestEvent", "RequestEvent", "RequestEvent",
                                                 "InstanceUnloaded"]
    loaded, sent, done, failed, unloaded = heard
    assert isinstance(loaded, InstanceLoaded) and loaded.data() == {"instance": "lamp", "component": "lamp"}
    assert isinstance(sent, RequestEvent) and isinstance(done, RequestEvent) and isinstance(failed, RequestEvent)
    # The sent event keeps the status it had, although the request is done now.
    assert sent.data() == {"id": "lamp::0", "status": "sent"} and dim.status == "done"
    assert done.record() == {"event": "request", "time": sent.time + 2.0, "id": "lamp::0", "instance": "lamp",
                             "service": "Dim", "input": {"to": 0.25, "seconds": 2.0}, "session": "lab",
                             "sent": sent.time, "status": "done", "output": {}}
    assert sent.time == pytest.approx(clock.wall() - 2.0)  # stamped by the host's clock: sent at 1000 s
    assert failed.record()["exception"]["ex"] == "::genom::unkex" and failed.session is None
    assert failed.record()["input"] == {} and failed.record()["service"] == "Fail"
    assert isinstance(unloaded, InstanceUnloaded) and unloaded.data() == "lamp"
    json.dumps([e.record() for e in heard])  # every record is JSON-ready


async def test_a_session_s_subscriber_hears_its_requests_what_every_session_hears_and_its_end() -> None:
    async with ComponentHost(factories={"lamp": Lamp}, function_grace=0.01) as host:
        mine: list[Event] = []
        sessioned: list[Event] = []
        with host.events.subscribe(mine.append, session="mine"), \
                host.events.subscribe(sessioned.append, sessions_only=True):
            lamp = await host.load("lamp")
            await lamp.send("Fail", None, session="mine")
            await lamp.send("Fail", None, session="theirs")
            await lamp.send("Fail", None)  # in no session
            host.end_session("theirs")
            host.end_session("mine")
            await host.unload("lamp")
        await host.load("lamp")
        await lamp.send("Fail", None, session="mine")  # closed: heard by nobody
    assert [(e.name, e.session) for e in mine] == [("request", "mine"), ("quit", "mine"), ("unload", None)]
    assert [(e.name, e.session) for e in sessioned] == [
        ("request", "mine"), ("request", "theirs"), ("quit", "theirs"), ("quit", "mine"), ("unload", None)]
    assert isinstance(mine[1], SessionEnded) and mine[1].data() == "mine"


async def test_a_failing_subscriber_costs_neither_the_request_nor_the_others(caplog: Any) -> None:
    async with ComponentHost(factories={"lamp": Lamp}, function_grace=0.01) as host:
        heard: list[Event] = []

        def broken(event: Event) -> None:
            raise ValueError("a bug in a subscriber")

        host.events.subscribe(broken)
        host.events.subscribe(heard.append)
        lamp = await host.load("lamp")
        request = await lamp.send("Fail", None)
    assert request.status == "error" and [e.name for e in heard] == ["load", "request", "unload"]
    assert "a subscriber of the host's events failed" in caplog.text


async def test_a_second_delivery_writes_the_sessions_events_in_its_own_form() -> None:
    """Another way to deliver events (here JSON lines) subscribes to the host: the same events as a listen stream."""
    async with ComponentHost(factories={"lamp": Lamp}, function_grace=0.01) as host, \
            serve(GatewayConfig.of(port=0, audio_socket_port=0), host) as url, aiohttp.ClientSession(url) as http:
        lines: list[str] = []
        host.events.subscribe(lambda event: lines.append(json.dumps({"event": event.name, "data": event.data()})),
                              session="s")
        stream = await RawEventStream.open(url, "s")
        await http.get("/load/lamp")
        async with http.get("/module/lamp/send/Fail", params={"s": "s"}) as reply:
            assert (await reply.json())["status"] == "error"
        await http.get("/unload/lamp")
        blocks = [await stream.next_block() for _ in range(2)]
        stream.close()
    assert [json.loads(line) for line in lines] == [
        {"event": "request", "data": {"id": "lamp::0", "status": "error",
                                      "exception": {"ex": "::genom::unkex",
                                                    "detail": {"what": "RuntimeError: the bulb blew"}}}},
        {"event": "unload", "data": "lamp"}]
    # genomix's form of the same events, byte for byte.
    assert blocks == [b'event: request\ndata: {"id":"lamp::0","status":"error","exception":{"ex":"::genom::unkex",'
                      b'"detail":{"what":"RuntimeError: the bulb blew"}}}\n\n', b'event: unload\ndata: "lamp"\n\n']
    assert GENOMIX_FORM.frame(1, InstanceUnloaded("lamp", 0.0)) == blocks[1]
