"""Issue 26, acceptance 1: ten seconds of kemarcapture's audio and head, recorded by the recorder component.

The rig runs on a clock the test steps (``ManualClock.run_until``): ten seconds of capture
take a fraction of a second here however busy the machine, and time stands still while the
test reads the port over HTTP afterwards.  The recording is read back with the ``mcap``
library's reader (and ``mcap-ros2-support``'s decoder) and with ``rosbags``, not with our own
reader: every frame is there once, its samples are those the gateway serves for the same
chunks by index, and its head azimuths are the port's.
"""

from __future__ import annotations

import math
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import orjson
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from aiogenomix.clients import aconnect
from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.gateway import GatewayConfig, serve

RATE, FPC = 44100, 2205
#: The port holds more than the recording: afterwards the gateway still serves every recorded chunk.
PORT_CHUNKS = 240


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[tuple[str, ManualClock, Path]]:
    """A gateway whose rig runs on a clock the test steps, recordings allowed in a directory of the test."""
    clock = ManualClock()
    settings = HostSettings(can_timeout=10.0, audio_socket_port=0, record_dirs=(str(tmp_path),))
    async with ComponentHost(clock=clock, settings=settings) as host, \
            serve(GatewayConfig.of(port=0), host) as url:
        yield url, clock, tmp_path


async def call(http: aiohttp.ClientSession, clock: ManualClock, module: str, service: str,
               inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    """Send a request and run the rig's time until it has ended; return its final status."""
    params = {"input": orjson.dumps(inputs or {}).decode()}
    async with http.get(f"/module/{module}/send/{service}", params=params) as sent:
        status = await sent.json()
    if status["status"] != "sent":
        return status  # type: ignore[no-any-return]

    async def ended() -> dict[str, Any]:
        async with http.get(f"/module/{module}/wait/{status['id']}", params={"timeout": "600"}) as waited:
            return await waited.json()  # type: ignore[no-any-return]

    return await clock.run_until(ended())


async def test_ten_seconds_of_audio_and_head_are_recorded_frame_for_frame(
        rig: tuple[str, ManualClock, Path]) -> None:
    url, clock, directory = rig
    async with aiohttp.ClientSession(base_url=url) as http:
        for name in ("kemarcapture", "recorder"):
            async with http.get(f"/load/{name}") as loaded:
                assert loaded.status == 200, await loaded.text()
        assert (await call(http, clock, "kemarcapture", "Homing"))["status"] == "done"
        params = {"input": orjson.dumps({"device": "sim", "Port_chunks": PORT_CHUNKS}).decode()}
        async with http.get("/module/kemarcapture/send/StartCapture", params=params) as started:
            assert (await started.json())["status"] == "sent"
        await clock.advance(0.5)
        # The head turns while the recording runs: sent now, it moves during the ten seconds.
        params = {"input": orjson.dumps({"target": 60}).decode()}
        async with http.get("/module/kemarcapture/send/MoveAbsolutePosition", params=params) as moved:
            assert (await moved.json())["status"] == "sent"
        recorded = await call(http, clock, "recorder", "Start", {
            "path": "session.mcap", "ports": ["kemarcapture/Port", "kemarcapture/currentState"], "duration": 10})
        assert recorded["status"] == "done", recorded
        async with http.get("/module/kemarcapture/send/StopCapture") as stopped:
            assert (await stopped.json())["status"] == "done"
        async with http.get("/module/recorder/read/Status") as read:
            published = (await read.json())["Status"]   # the port says how it ended, as the output does
    assert published == recorded["output"]["status"]
    status = recorded["output"]["status"]
    assert status["ended"] == "duration" and status["lost_frames"] == 0
    path = directory / "session.mcap"
    # The name within the record directory: the host's own path stays on the host.
    assert status["path"] == "session.mcap" and status["bytes"] == path.stat().st_size

    # -- read back with the mcap library's reader and the ROS 2 decoder ------------------------
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        audio, frames, states, joints = [], [], [], []
        for _, channel, message, decoded in reader.iter_decoded_messages(
                topics=["/kemarcapture/Port", "/kemarcapture/Port/frames", "/kemarcapture/currentState/joint_state"]):
            {"/kemarcapture/Port": audio, "/kemarcapture/Port/frames": frames,
             "/kemarcapture/currentState/joint_state": joints}[channel.topic].append((message, decoded))
        for _, channel, message in reader.iter_messages(topics=["/kemarcapture/currentState"]):
            assert channel.message_encoding == "json"
            states.append(orjson.loads(message.data))
    chunks = len(audio)
    assert 195 <= chunks <= 200 and len(frames) == chunks          # ten seconds of 50 ms chunks
    numbers = [decoded.chunk for _, decoded in frames]
    assert numbers == list(range(numbers[0], numbers[0] + chunks))  # every chunk once, in order
    assert [decoded.first_frame for _, decoded in frames] == [(n - 1) * FPC + 1 for n in numbers]
    assert all(decoded.frames == FPC and decoded.lost_frames == 0 for _, decoded in frames)
    # An audio message and its frame index are twins: same sequence number, same capture time.
    for (a_msg, a), (f_msg, f) in zip(audio, frames, strict=True):
        assert a_msg.sequence == f_msg.sequence
        assert (a.header.stamp.sec, a.header.stamp.nanosec) == (f.header.stamp.sec, f.header.stamp.nanosec)
    samples = np.frombuffer(b"".join(bytes(a.audio.data) for _, a in audio), "<i4").reshape(-1, 2)
    assert samples.shape == (chunks * FPC, 2)

    # -- the same chunks read over HTTP by index -------------------------------------------------
    async with aconnect(url) as gateway:
        capture = await gateway.module("kemarcapture")
        port, lost = await capture.Port(since=numbers[0] - 1)
    assert lost == 0
    served = port.index - numbers[0] + 1
    assert served >= chunks
    left, right = np.asarray(port.left)[:chunks * FPC], np.asarray(port.right)[:chunks * FPC]
    np.testing.assert_array_equal(samples[:, 0], left)
    np.testing.assert_array_equal(samples[:, 1], right)
    azimuths = np.array([decoded.head_azimuth for _, decoded in frames])
    np.testing.assert_array_equal(azimuths, np.asarray(port.positions)[:chunks])
    assert azimuths[0] < 5 and azimuths[-1] == pytest.approx(60, abs=0.5)   # the head turned meanwhile

    # -- the head state: as the port said (degrees) and as ROS says (radians) ---------------------
    assert len(states) == len(joints) >= 2
    assert states[-1]["position"] == pytest.approx(60, abs=0.5)
    for state, (_, joint) in zip(states, joints, strict=True):
        assert joint.name == ["head_yaw"]
        assert joint.position[0] == pytest.approx(math.radians(state["position"]))
        assert joint.velocity[0] == pytest.approx(math.radians(state["speed"]))

    # -- read back with rosbags -------------------------------------------------------------------
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as bag:
        wanted = [c for c in bag.connections if c.topic in ("/kemarcapture/Port", "/kemarcapture/Port/frames")]
        by_topic: dict[str, list[Any]] = {"/kemarcapture/Port": [], "/kemarcapture/Port/frames": []}
        for connection, _, raw in bag.messages(connections=wanted):
            by_topic[connection.topic].append(bag.deserialize(raw, connection.msgtype))
    assert [m.chunk for m in by_topic["/kemarcapture/Port/frames"]] == numbers
    again = np.concatenate([m.audio.data for m in by_topic["/kemarcapture/Port"]]).view("<i4").reshape(-1, 2)
    np.testing.assert_array_equal(again, samples)
