"""The capture component's services: validation, missing devices, a second start, stop, config, the socket."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aiogenomix.clients.audio_socket import AsyncAudioSocketClient
from aiogenomix.components.capture import (
    ALREADY_CAPTURING, ERROR_SEQUENCE_ENOMEM, INVALID_CHUNK_TIME, SOCKET_ERROR, Capture,
)
from aiogenomix.components.core import ComponentHost, HostSettings, ScaledClock
from aiogenomix.components.core.runtime import describe


async def wait_for_index(capture: Capture, index: int) -> None:
    while capture.Port.read().index < index:
        await capture.Port.wait_published()


def test_info_shows_the_default_device_of_the_host() -> None:
    for settings, device in ((HostSettings(), "sim"), (HostSettings(audio_device="hw:1,0"), "hw:1,0")):
        component = Capture(ComponentHost(clock=ScaledClock(1), settings=settings, factories={}), "capture")
        start = next(s for s in describe(component)["services"] if s["name"] == "StartCapture")
        defaults = {p["name"]: p.get("default") for p in start["parameters"]}
        assert defaults == {"device": device, "transfer_rate": 44100, "chunk_time": 50, "Port_chunks": 20}
        assert "::capture::INVALID_CHUNK_TIME" in start["throws"]


@pytest.mark.parametrize(("inputs", "message"), [
    ({"chunk_time": 33, "transfer_rate": 44100}, "not a whole number"),
    ({"chunk_time": 0}, "0 frames per chunk"),
    ({"transfer_rate": 10}, "outside 1000"),
    ({"chunk_time": 100_000}, "outside 1"),
])
async def test_impossible_chunk_times_are_refused(capture: Capture, inputs: dict[str, int], message: str) -> None:
    refused = await capture.send("StartCapture", inputs)
    assert refused.exception is not None and refused.exception["ex"] == INVALID_CHUNK_TIME.ex_id("capture")
    assert message in refused.exception["detail"]["what"]
    assert not capture.requests.running() and capture.Port.read().index == 0


@pytest.mark.parametrize("chunks", [0, 1_000_000])
async def test_ports_too_large_or_empty_are_refused(capture: Capture, chunks: int) -> None:
    refused = await capture.send("StartCapture", {"Port_chunks": chunks})
    assert refused.exception is not None and refused.exception["ex"] == ERROR_SEQUENCE_ENOMEM.ex_id("capture")


async def test_a_missing_device_ends_the_request_in_error(capture: Capture) -> None:
    request = await capture.send("StartCapture", {"device": "hw:7,0"})
    await request.ended.wait()
    assert request.status == "error"
    assert request.exception is not None and request.exception["ex"] == "::capture::NO_SUCH_DEVICE"
    assert request.exception["detail"]["device"] == "hw:7,0"
    available = request.exception["detail"]["available"]
    # Every source the gateway opens, not only the backend's own devices.
    assert "null" in available and "sim" in available and "file:<path.wav>" in available
    # The component keeps serving.
    again = await capture.send("StartCapture", {"device": "sim"})
    await wait_for_index(capture, 1)
    await capture.send("StopCapture")
    await again.ended.wait()


async def test_a_second_start_is_refused_and_the_first_goes_on(capture: Capture) -> None:
    first = await capture.send("StartCapture", {"Port_chunks": 4})
    refused = await capture.send("StartCapture", {"device": "sim", "Port_chunks": 8})
    assert refused.exception == {"ex": ALREADY_CAPTURING.ex_id("capture"), "detail": {"device": "sim"}}
    await wait_for_index(capture, 3)
    assert first.running and capture.capturing
    stop = await capture.send("StopCapture")
    await first.ended.wait()
    assert stop.status == "done"
    assert first.exception == {"ex": "::genom::interrupted", "detail": {"by": "StopCapture"}}
    assert not capture.capturing


async def test_port_config_and_status(capture: Capture) -> None:
    before = capture.clock.wall()
    request = await capture.send("StartCapture", {"transfer_rate": 16000, "chunk_time": 20, "Port_chunks": 6})
    await wait_for_index(capture, 1)
    first_seen = capture.clock.wall()
    await wait_for_index(capture, 8)
    port = capture.Port.read()
    assert (port.transfer_rate, port.nbframes) == (16000, 6 * 320)
    assert port.left.dtype == np.int32 and port.left.shape == port.right.shape == (6 * 320,)
    status = (await capture.send("GetCaptureStatus")).output
    assert status is not None and status["capturing"] == 1 and status["index"] >= 8 and status["overruns"] == 0
    config = (await capture.send("GetCaptureConfig")).output
    assert config == {"device": "sim", "transfer_rate": 16000, "chunk_time": 20, "Port_chunks": 6}
    # ts is the capture start: after StartCapture was sent, before its first chunk was seen, and the
    # same in every publication (bounds on the runtime clock, whatever the machine's load).
    assert before <= port.ts.seconds() <= first_seen
    await wait_for_index(capture, port.index + 3)
    assert capture.Port.read().ts == port.ts
    await capture.send("StopCapture")
    await request.ended.wait()


async def test_the_alsa_backend_runs_in_the_component(capture: Capture) -> None:
    # ALSA's null PCM is not paced: chunks arrive as fast as the loop takes them and the
    # hand-over drops (and reports) the rest.  Only the plumbing is checked.
    request = await capture.send("StartCapture", {"device": "null", "Port_chunks": 4})
    await wait_for_index(capture, 10)
    await capture.send("StopCapture")
    await request.ended.wait()
    assert capture.Port.read().left.shape == (4 * 2205,)
    assert request.exception == {"ex": "::genom::interrupted", "detail": {"by": "StopCapture"}}


async def test_portaudio_without_devices_is_a_declared_error(capture: Capture) -> None:
    from aiogenomix.components.audio._portaudio import portaudio_capture_devices
    if portaudio_capture_devices():
        pytest.skip("this machine has PortAudio input devices")
    request = await capture.send("StartCapture", {"device": "pa:Babyface"})
    await request.ended.wait()
    assert request.exception["ex"] == "::capture::NO_SUCH_DEVICE"
    assert request.exception["detail"]["device"] == "pa:Babyface" and "sim" in request.exception["detail"]["available"]


async def test_dedicated_socket_open_serve_and_close(capture: Capture) -> None:
    socket = await capture.send("DedicatedSocket")
    assert await capture.wait_socket() > 0 and socket.running
    again = await capture.send("DedicatedSocket")
    assert again.exception is not None and again.exception["ex"] == SOCKET_ERROR.ex_id("capture")
    assert "already open" in str(again.exception["detail"])
    capturing = await capture.send("StartCapture", {"Port_chunks": 5})
    await wait_for_index(capture, 2)
    async with AsyncAudioSocketClient(port=capture.socket_port) as client:
        block = await client.read()
        assert block.count >= 2 and block.frames.shape == (block.count * 2205, 2)
        status = (await capture.send("GetCaptureStatus")).output
        assert status is not None and status["socket_clients"] == 1 and status["socket_port"] == capture.socket_port
    close = await capture.send("CloseSocket")
    await close.ended.wait()
    assert close.status == "done" and not socket.running
    assert socket.exception == {"ex": "::genom::interrupted", "detail": {"by": "CloseSocket"}}
    assert capture.socket_port == 0
    await capture.send("StopCapture")
    await capturing.ended.wait()


async def test_socket_port_in_use_is_a_declared_error(host: ComponentHost, capture: Capture) -> None:
    first = await capture.send("DedicatedSocket")
    host.settings = dataclasses.replace(host.settings, audio_socket_port=await capture.wait_socket())
    other = await host.load("capture", ["-i", "capture2"])
    second = await other.send("DedicatedSocket")
    await second.ended.wait()
    assert second.exception is not None and second.exception["ex"] == "::capture::SOCKET_ERROR"
    await capture.send("CloseSocket")
    await first.ended.wait()


async def test_unloading_stops_capture_and_socket(host: ComponentHost, capture: Capture) -> None:
    socket = await capture.send("DedicatedSocket")
    capturing = await capture.send("StartCapture")
    await capture.wait_socket()
    await wait_for_index(capture, 1)
    await host.unload("capture")
    assert not socket.running and not capturing.running and capture.socket_port == 0
