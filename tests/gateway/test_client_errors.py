"""Issue 24: client-caused errors are documented 4xx answers or exceptions, never a 500, a drop or a traceback.

Each defect the second audit reproduced, through the gateway: a read of an in port, a ``since`` of
5000 digits on the fast read path, a load option of Unicode digits, ``abort_activity`` of an unknown
id, a device string holding NUL; and the answers of the newer bounds: a port whose data is withdrawn
(503), a bound in all reached at load (429).
"""

from __future__ import annotations

import json
import logging
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import pytest

from aiogenomix.components.basc import Basc
from aiogenomix.components.bass import Bass
from aiogenomix.components.core import (
    Budgets, Component, ComponentHost, GenomException, HostSettings, ManualClock, OutPort, String, idl_struct,
)
from aiogenomix.gateway import GatewayConfig, serve
from tests.gateway._raw_http import Connection


@idl_struct("sensor::frame")
class Frame:
    seq: int = 0


class DOWN(GenomException):
    """The sensor is down."""

    scope = "sensor"
    what: String


class Sensor(Component, name="sensor"):
    Frames = OutPort(Frame, doc="frames")


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    """bass, basc and a sensor on a clock nobody moves: what a read answers is what the test published."""
    budgets = Budgets(render_bytes=100 * 2**20)
    async with ComponentHost(clock=ManualClock(), settings=HostSettings(audio_socket_port=0, budgets=budgets),
                             factories={"bass": Bass, "basc": Basc, "sensor": Sensor, "world": _world()}) as running:
        yield running


def _world() -> Any:
    from aiogenomix.components.world import World

    return World


@pytest.fixture
async def url(host: ComponentHost) -> AsyncIterator[str]:
    async with serve(GatewayConfig.of(port=0), host=host) as base:
        yield base


@pytest.fixture
def tracebacks(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    """The log records carrying a traceback, or at ERROR (none may come from a client's request)."""
    caplog.set_level(logging.DEBUG)
    return caplog.records


def faults(records: list[logging.LogRecord]) -> list[str]:
    return [r.getMessage() for r in records if r.exc_info or r.levelno >= logging.ERROR]


async def send(http: aiohttp.ClientSession, url: str, module: str, service: str, inputs: dict[str, Any]) -> Any:
    async with http.get(f"{url}/module/{module}/send/{service}", params={"input": json.dumps(inputs)}) as reply:
        assert reply.status == 200
        sent = await reply.json()
    async with http.get(f"{url}/module/{module}/wait/{sent['id']}", params={"timeout": "10"}) as reply:
        return await reply.json()


async def test_a_read_of_an_in_port_answers_what_it_holds(host: ComponentHost, url: str,
                                                          tracebacks: list[logging.LogRecord]) -> None:
    bass, basc = await host.load("bass"), await host.load("basc")
    async with aiohttp.ClientSession() as http:
        async with http.get(f"{url}/module/basc/read/Audio") as reply:   # not connected: it holds nothing
            assert reply.status == 200 and await reply.json() == {"Audio": None}
        version = bass.Audio.version
        await http.get(f"{url}/module/bass/send/Acquire", params={"input": '{"device":"sim"}'})
        await bass.Audio.wait_published(version)
        assert isinstance(bass.clock, ManualClock)
        while bass.snapshot.last_frame_index < 3 * 2205:                  # three chunks
            await bass.clock.advance(2205 / 44100)
        connected = await send(http, url, "basc", "connect_port", {"local": "Audio", "remote": "bass/Audio"})
        assert connected["status"] == "done"
        for query in ("", "?format=binary", "?since=2205"):
            async with http.get(f"{url}/module/basc/read/Audio{query}") as reply:
                assert reply.status == 200, await reply.text()
                held = await reply.read()
            async with http.get(f"{url}/module/bass/read/Audio{query}") as reply:
                published = await reply.read()
            assert held == published, query
        assert json.loads(held)["Audio"]["lastFrameIndex"] == 3 * 2205
        async with http.get(f"{url}/module/basc/watch/Audio") as reply:
            assert reply.status == 400                                     # an in port is watched at its source
    assert isinstance(basc, Basc)
    await bass.send("Stop")
    assert not faults(tracebacks)


async def test_a_since_of_any_length_is_refused_on_the_fast_path_and_the_connection_goes_on(
        host: ComponentHost, url: str, tracebacks: list[logging.LogRecord]) -> None:
    await host.load("bass")
    connection = await Connection.open(url)
    try:
        for since in ("1" * 5000, "9" * 20, "%C2%B2", "-1", "1e3", "%201", "0x1"):
            status, _, body = await connection.get(f"/module/bass/read/Audio?since={since}")
            assert status == 400 and json.loads(body)["ex"] == "::genom::serialization", (since[:20], body[:200])
        status, _, body = await connection.get("/module/bass/read/Audio?since=0")
        assert status == 200 and json.loads(body)["lost"] == 0
    finally:
        await connection.close()
    assert not faults(tracebacks)


async def test_load_options_abort_activity_and_device_names_are_refused_as_documented(
        host: ComponentHost, url: str, tracebacks: list[logging.LogRecord]) -> None:
    await host.load("bass")
    async with aiohttp.ClientSession() as http:
        for argv in ("-i w2 -size ²x8", "-i w2 -rate ٣", "-i w2 -size " + "9" * 5000 + "x8"):
            async with http.get(f"{url}/load/world", params={"argv": argv}) as reply:
                body = await reply.json()
                assert reply.status == 400 and body["ex"] == "::genomix::bad_load", body
                assert body["message"].startswith("bad camera")
        aborted = await send(http, url, "bass", "abort_activity", {"activity": 77})
        assert aborted["status"] == "error" and aborted["exception"] == {"ex": "::genom::no_such_activity"}
        nul = await send(http, url, "bass", "Acquire", {"device": "hw:0\u0000,0"})
        assert nul["exception"]["ex"] == "::bass::e_device"
        assert "no control characters" in nul["exception"]["detail"]["what"]
    assert not faults(tracebacks)


async def test_withdrawn_data_is_503_with_the_components_reason(host: ComponentHost, url: str) -> None:
    sensor = await host.load("sensor")
    sensor.Frames.publish(Frame(1))
    sensor.Frames.withdraw(DOWN(what="the camera process died; a new one is starting"))
    async with aiohttp.ClientSession() as http:
        for path in ("read/Frames", "read/Frames?format=binary", "watch/Frames"):
            async with http.get(f"{url}/module/sensor/{path}") as reply:
                assert reply.status == 503, path
                body = await reply.json()
            assert body["ex"] == "::sensor::DOWN" and body["detail"] == {
                "what": "the camera process died; a new one is starting"}, body
            assert "Frames has no current data" in body["message"]
        sensor.Frames.publish(Frame(2))
        async with http.get(f"{url}/module/sensor/read/Frames") as reply:
            assert reply.status == 200 and await reply.json() == {"Frames": {"seq": 2}}


async def test_a_bound_in_all_reached_at_load_is_429_naming_its_flag(url: str) -> None:
    async with aiohttp.ClientSession() as http:
        async with http.get(f"{url}/load/world", params={"argv": "-size 8x8"}) as reply:
            body = await reply.json()
    assert reply.status == 429 and body["ex"] == "::genomix::over_budget"
    assert body["detail"]["flag"] == "--max-render-bytes"
    assert body["message"] == "a world of 8x8 cameras needs 192.0 MiB, more than the 100 MiB of --max-render-bytes"
