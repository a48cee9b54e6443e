"""Issue 26, acceptance 4: the live view in Foxglove (``--foxglove PORT``), read by a plain WebSocket client.

The client speaks the Foxglove WebSocket protocol (``foxglove.websocket.v1``; the SDK names it
``foxglove.sdk.v1``, and the view answers both): it gets ``serverInfo`` and the advertisements,
subscribes to the head's state, a camera and the audio, and decodes them with the protobuf schemas
the server advertises.  Meanwhile a second viewer subscribes to everything and never reads: the
gateway's own listen stream goes on undelayed.
"""

from __future__ import annotations

import asyncio
import base64
import importlib.util
import json
import socket
import statistics
import time
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import numpy as np
import pytest

from aiogenomix.clients import aconnect
from aiogenomix.gateway import GatewayConfig, serve

from ..conftest import RawEventStream

pytestmark = pytest.mark.skipif(importlib.util.find_spec("foxglove") is None or
                                importlib.util.find_spec("mujoco") is None,
                                reason="needs the Foxglove SDK and MuJoCo")


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def decoder(channel: dict[str, Any]) -> Any:
    """The protobuf message class of an advertised channel, built from the schema the server sent."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


INSTANCES = ("kemar", "world", "demo", "kemarcapture")


@pytest.fixture
async def gateway() -> AsyncIterator[tuple[str, int]]:
    port = free_port()
    async with serve(GatewayConfig(port=0, audio_socket_port=0, foxglove_port=port)) as url:
        async with aiohttp.ClientSession(base_url=url) as http:
            for name in INSTANCES:
                async with http.get(f"/load/{name}") as loaded:
                    assert loaded.status == 200, await loaded.text()
            capture = {"input": '{"device":"sim","Port_chunks":200}'}
            async with http.get("/module/kemarcapture/send/StartCapture", params=capture):
                pass
        yield url, port
        # Unloaded one by one, each to its end: the gateway's own shutdown gives them a second in all,
        # which a busy machine may not leave them.
        async with aiohttp.ClientSession(base_url=url) as http:
            for name in reversed(INSTANCES):
                async with http.get(f"/unload/{name}") as unloaded:
                    assert unloaded.status == 200, await unloaded.text()


async def advertised(viewer: Any, topics: set[str]) -> dict[str, dict[str, Any]]:
    """Read control messages until every topic of *topics* is advertised; return the channels by topic."""
    channels: dict[str, dict[str, Any]] = {}
    while not topics <= set(channels):
        message = json.loads(await asyncio.wait_for(viewer.recv(), 30))
        if message["op"] == "advertise":
            channels.update({c["topic"]: c for c in message["channels"]})
    return channels


async def test_a_viewer_gets_the_head_and_a_camera_while_a_stalled_one_delays_nobody(
        gateway: tuple[str, int]) -> None:
    import websockets

    url, port = gateway
    address = f"ws://127.0.0.1:{port}"
    wanted = {"/kemar/currentState", "/world/kemar_camera_left"}
    # (A stalled viewer never answers the closing handshake: neither waits long for it.)
    async with websockets.connect(address, subprotocols=["foxglove.websocket.v1", "foxglove.sdk.v1"],
                                  max_size=None, close_timeout=1) as viewer, \
            websockets.connect(address, subprotocols=["foxglove.sdk.v1"], max_queue=1, close_timeout=0.1) as stalled:
        # Both names of the protocol are served: the viewer's first choice is taken.
        assert viewer.subprotocol == "foxglove.websocket.v1" and stalled.subprotocol == "foxglove.sdk.v1"
        info = json.loads(await asyncio.wait_for(viewer.recv(), 30))
        assert info["op"] == "serverInfo" and info["name"] == "aiogenomix"
        channels = await advertised(viewer, wanted)
        assert channels["/kemar/currentState"]["schemaName"] == "foxglove.JointStates"
        assert channels["/world/kemar_camera_left"]["schemaName"] == "foxglove.RawImage"
        assert channels["/world/pr2_scan"]["schemaName"] == "foxglove.LaserScan"
        assert channels["/world/pr2_odom"]["schemaName"] == "foxglove.Odometry"
        assert channels["/demo/Mobile"]["encoding"] == "json"   # any other port: its JSON and JSON Schema

        # The gateway's clients before the stalled viewer subscribes: how soon a request's end reaches the
        # session's listen stream.
        everything = await advertised(stalled, set(channels))
        unhindered = await listen_delays(url, 30)
        # The stalled viewer subscribes to every channel (three 256×256 cameras at 10 Hz: 8 MB/s) and never
        # reads again: its socket's buffers fill in a moment, then the server drops its oldest messages.
        await stalled.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": n, "channelId": c["id"]} for n, c in enumerate(everything.values())]}))

        head, camera, audio = (channels[t] for t in ("/kemar/currentState", "/world/kemar_camera_left",
                                                     "/kemarcapture/Port"))
        await viewer.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 1, "channelId": head["id"]}, {"id": 2, "channelId": camera["id"]},
            {"id": 3, "channelId": audio["id"]}]}))
        decoded: dict[int, Any] = {}
        subscribed = {1: head, 2: camera, 3: audio}
        while len(decoded) < 3:
            frame = await asyncio.wait_for(viewer.recv(), 30)
            if isinstance(frame, bytes) and frame[0] == 1:  # messageData: op, subscription, log time, payload
                subscription = int.from_bytes(frame[1:5], "little")
                decoded[subscription] = decoder(subscribed[subscription]).FromString(frame[13:])
        joints = decoded[1].joints
        assert [j.name for j in joints] == ["head_yaw"] and joints[0].position == pytest.approx(0.0)
        picture = decoded[2]
        assert (picture.width, picture.height, picture.encoding) == (256, 256, "rgba8")
        assert len(picture.data) == 256 * 256 * 4
        # Audio: RawAudio's pcm-s16, the upper 16 bits of the port's int32 samples, one chunk at a time.
        sound = decoded[3]
        assert (sound.format, sound.sample_rate, sound.number_of_channels) == ("pcm-s16", 44100, 2)
        shown = np.frombuffer(sound.data, "<i2").reshape(-1, 2)
        assert shown.shape[1] == 2 and shown.shape[0] and shown.shape[0] % 2205 == 0  # whole chunks (two if late)
        async with aconnect(url) as client:
            window = (await client.module("kemarcapture")).Port
            port = await window()
        captured = np.stack([np.asarray(port.left), np.asarray(port.right)], axis=1) >> 16
        starts = [k for k in range(0, len(captured) - len(shown) + 1, 2205)
                  if np.array_equal(captured[k:k + len(shown)], shown)]
        assert len(starts) == 1  # those very chunks of the capture

        # The gateway's clients meanwhile: the listen stream is as prompt as before (the median within
        # 20 ms). Its 90th percentile is judged against the same measure without the stalled viewer, with
        # 250 ms to spare: a machine whose cores are shared six times over delays some events by itself
        # (seen: 0.19 s against 0.02 s a minute earlier), while a viewer that held the gateway up would
        # hold it for as long as it does not read, seconds.
        hindered = await listen_delays(url, 30)
        assert statistics.median(hindered) < 0.02, hindered
        assert percentile(hindered, 0.9) <= percentile(unhindered, 0.9) + 0.25, (unhindered, hindered)
        # (the viewer is still served)
        await asyncio.wait_for(viewer.recv(), 30)


def percentile(samples: list[float], fraction: float) -> float:
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


async def listen_delays(url: str, count: int) -> list[float]:
    """Seconds from sending a request to its end on the session's listen stream, for *count* requests."""
    async with aiohttp.ClientSession(base_url=url) as http:
        async with http.get("/session/start", params={"s": "fox"}) as started:
            session = (await started.text()).strip()
        stream = await RawEventStream.open(url, session)
        delays = []
        try:
            for n in range(count):
                speed = "FAST" if n % 2 else "SLOW"
                sent = time.perf_counter()
                async with http.get("/module/demo/send/SetSpeed", params={"s": session, "input": f'"{speed}"'}):
                    pass
                while True:
                    name, data = await stream.next_event()
                    if name == "request" and json.loads(data or "{}").get("status") == "done":
                        break
                delays.append(time.perf_counter() - sent)
                await asyncio.sleep(0.02)  # a client's pace, not synchronisation: the cameras keep publishing
        finally:
            stream.close()
    return delays

