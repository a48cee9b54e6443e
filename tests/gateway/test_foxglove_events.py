"""Issue 33: the live view shows what is commanded as it happens, on ``/events`` (``foxglove.Log``).

A plain WebSocket client speaks the Foxglove WebSocket protocol, subscribes to ``/events`` and
decodes its messages with the protobuf schema the server advertises, while a session's client
sends requests over HTTP.
"""

from __future__ import annotations

import asyncio
import importlib.util
import json
from typing import Annotated, Any

import aiohttp
import pytest

from aiogenomix.components.core import Component, ComponentHost, Double, activity, function
from aiogenomix.gateway import GatewayConfig, serve

from .test_foxglove_view import advertised, decoder, free_port

pytestmark = pytest.mark.skipif(importlib.util.find_spec("foxglove") is None, reason="needs the Foxglove SDK")


class Lamp(Component, name="lamp"):
    """A lamp that dims slowly."""

    @activity
    async def Dim(self, to: Annotated[Double, "Target level"] = 0.0, seconds: Double = 0.05) -> None:
        """Dim the lamp, taking *seconds*."""
        await self.clock.sleep(seconds)

    @function
    def Fail(self) -> None:
        """Fail at once."""
        raise RuntimeError("the bulb blew")


async def test_a_viewer_sees_each_request_sent_and_ended_as_a_log_line() -> None:
    import websockets

    port = free_port()
    async with ComponentHost(factories={"lamp": Lamp}, function_grace=0.01) as host, \
            serve(GatewayConfig.of(port=0, audio_socket_port=0, foxglove_port=port), host) as url, \
            aiohttp.ClientSession(base_url=url) as http, \
            websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.websocket.v1"],
                               close_timeout=1) as viewer:
        channel = (await advertised(viewer, {"/events"}))["/events"]
        assert channel["schemaName"] == "foxglove.Log"
        await viewer.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": channel["id"]}]}))
        # The server reads a viewer's messages in order: once it has answered the next one, it has subscribed.
        await viewer.send(json.dumps({"op": "getParameters", "parameterNames": [], "id": "barrier"}))
        while not isinstance(said := json.loads(await asyncio.wait_for(viewer.recv(), 30)), dict) or \
                said.get("op") != "status":
            pass
        async with http.get("/load/lamp") as loaded:
            assert loaded.status == 200
        async with http.get("/module/lamp/send/Dim", params={"input": '{"to":0.5}', "s": "lab"}) as sent:
            dim = await sent.json()
        async with http.get(f"/module/lamp/wait/{dim['id']}", params={"s": "lab"}) as waited:
            assert (await waited.json())["status"] == "done"
        async with http.get("/module/lamp/send/Fail", params={"s": "lab"}) as sent:
            failed = await sent.json()
        lines: list[Any] = []
        while len(lines) < 4:
            frame = await asyncio.wait_for(viewer.recv(), 30)
            if isinstance(frame, bytes) and frame[0] == 1:  # messageData: op, subscription, log time, payload
                assert int.from_bytes(frame[1:5], "little") == 7
                lines.append(decoder(channel).FromString(frame[13:]))
    dimmed = f'{dim["id"]} Dim {{"to":0.5,"seconds":0.05}}'
    assert [line.message for line in lines] == [
        'load {"instance":"lamp","component":"lamp"}', f"{dimmed} sent [lab]", f"{dimmed} done {{}} [lab]",
        f'{failed["id"]} Fail {{}} error {json.dumps(failed["exception"], separators=(",", ":"))} [lab]']
    assert [line.name for line in lines] == ["aiogenomix", "lamp", "lamp", "lamp"]
    levels = [line.level for line in lines]
    assert levels[0] == levels[1] == levels[2] != levels[3]   # info, then an error
    lines = lines[1:]
    # Stamped with the rig's clock: the end after the sending, by the time the lamp took.
    times = [line.timestamp.seconds + line.timestamp.nanos * 1e-9 for line in lines]
    assert times[1] - times[0] >= 0.05 and times[2] >= times[1]
