"""A recorder on a robot's host, started in a session of a gateway: the recording ends with that session.

The gateway's session ends (``/session/stop``, or the gateway vanishes, and every session of it
with it): the host stops the recordings that session sent, and no other (one sent in no session,
one asked to outlive its session, another gateway's session of the same name).  Real Zenoh
sessions on loopback in this process, the gateway's HTTP door in front.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import orjson
import pytest

from aiogenomix.components.core import Component, ComponentHost, Double, HostSettings, OutPort
from aiogenomix.components.recorder import Recorder
from aiogenomix.gateway import GatewayConfig
from aiogenomix.gateway import serve as serve_gateway
from aiogenomix.remote import HostNode, RemoteInstance, ZenohDirectory, ZenohSettings

from ._processes import free_port
from .test_letting_go import WITHIN, gateway


class Probe(Component, name="probe"):
    """A sensor the test publishes by hand."""

    Reading = OutPort(Double, doc="The sensor's reading")


@contextlib.asynccontextmanager
async def robot(endpoint: str, records: Path) -> AsyncIterator[ComponentHost]:
    """A component host offering a probe and a recorder on *endpoint*, recordings allowed in *records*."""
    host = ComponentHost(settings=HostSettings(audio_socket_port=0, record_dirs=(str(records),)),
                         factories={"probe": Probe, "recorder": Recorder})
    for name in ("probe", "recorder"):
        await host.load(name)
    directory = await ZenohDirectory.open(ZenohSettings(listen=[endpoint]), gateway=False)
    host.finder = directory
    host.shared("zenoh", lambda: directory)
    node = HostNode(directory.session, host, "robot1", [endpoint])
    for name in ("probe", "recorder"):
        component = host.get(name)
        assert isinstance(component, Component)
        node.offer(component)
    try:
        yield host
    finally:
        await node.close()
        await host.close()


@pytest.fixture
def endpoint() -> str:
    return f"tcp/127.0.0.1:{free_port()}"


def recorder_of(host: ComponentHost) -> Recorder:
    recorder = host.get("recorder")
    assert isinstance(recorder, Recorder)
    return recorder


async def start(http: aiohttp.ClientSession, path: str, session: str | None, **inputs: Any) -> dict[str, Any]:
    params = {"input": orjson.dumps({"path": path, "ports": ["probe/Reading"], **inputs}).decode()}
    if session is not None:
        params["s"] = session
    async with http.get("/module/recorder/send/Start", params=params) as reply:
        status: dict[str, Any] = await reply.json()
    assert status["status"] == "sent", status
    return status


async def test_stopping_a_gateway_s_session_stops_the_recording_it_sent_to_a_host(endpoint: str,
                                                                                  tmp_path: Path) -> None:
    async with robot(endpoint, tmp_path) as robot_host, gateway(endpoint, offers=2) as (gateway_host, _), \
            serve_gateway(GatewayConfig.of(port=0), gateway_host) as url, aiohttp.ClientSession(base_url=url) as http:
        for name in ("probe", "recorder"):
            await gateway_host.load(name)
        recorder = recorder_of(robot_host)
        sent = await start(http, "lab.mcap", "lab")
        (request,) = recorder.requests.running()
        async with http.get("/session/stop", params={"s": "lab"}) as stopped:
            assert stopped.status == 200
        await asyncio.wait_for(request.ended.wait(), WITHIN)
        assert request.status == "done" and request.output is not None
        assert request.output["status"]["ended"] == "session lab ended"
        async with http.get(f"/module/recorder/wait/{sent['id']}", params={"timeout": str(WITHIN)}) as reply:
            assert (await reply.json())["output"]["status"]["ended"] == "session lab ended"


async def test_another_gateway_s_session_of_the_same_name_is_another_session(endpoint: str, tmp_path: Path) -> None:
    async with robot(endpoint, tmp_path) as robot_host, gateway(endpoint, offers=2) as (first, _), \
            gateway(endpoint, offers=2) as (second, _):
        recorder = recorder_of(robot_host)
        theirs = await (await second.load("recorder")).send(
            "Start", {"path": "theirs.mcap", "ports": ["probe/Reading"]}, session="lab")
        mine = await first.load("recorder")
        assert isinstance(mine, RemoteInstance)
        await mine.send("GetStatus", session="lab")
        await mine.session_ended("lab")   # answered once the host has handled it
        (running,) = recorder.requests.running()
        assert running.inputs["path"] == "theirs.mcap" and theirs.status == "sent"
        await mine.send("Stop")   # a Stop is anybody's to send (as over HTTP)
        await asyncio.wait_for(running.ended.wait(), WITHIN)


async def test_a_vanished_gateway_s_sessions_stop_the_recordings_they_sent(endpoint: str, tmp_path: Path) -> None:
    async with robot(endpoint, tmp_path) as robot_host:
        recorder = recorder_of(robot_host)
        async with gateway(endpoint, offers=2) as (gateway_host, directory):
            proxy = await gateway_host.load("recorder")
            await proxy.send("Start", {"path": "lab.mcap", "ports": ["probe/Reading"]}, session="lab")
            (request,) = recorder.requests.running()
            # The gateway's process dies: its Zenoh session ends without a word, its sessions with it.
            gateway_host.finder = None
            await directory.aclose()
            await asyncio.wait_for(request.ended.wait(), WITHIN)
        assert request.output is not None and request.output["status"]["ended"] == "session lab ended"
