"""The bass component: the interface of bass.gen, acquisition, the socket's life, and the head it follows."""

from __future__ import annotations

import numpy as np

from aiogenomix.components.bass import Bass
from aiogenomix.components.core import ComponentHost, HostSettings, ScaledClock
from aiogenomix.components.core.runtime import describe

from .conftest import wait_for_frame


def test_info_declares_the_interface_of_bass_gen() -> None:
    host = ComponentHost(clock=ScaledClock(1), settings=HostSettings(audio_device="hw:1,0"), factories={})
    info = describe(Bass(host, "bass"))
    services = {s["name"]: s for s in info["services"]}
    assert list(services)[:5] == ["ListDevices", "Acquire", "Stop", "DedicatedSocket", "CloseSocket"]
    acquire = services["Acquire"]
    assert acquire["kind"] == "activity" and acquire["interrupts"] == ["Acquire"]
    assert [(p["name"], p["type"]["name"], p["default"]) for p in acquire["parameters"]] == [
        ("device", "string", "hw:1,0"), ("sampleRate", "unsigned long", 44100),
        ("nFramesPerChunk", "unsigned long", 2205), ("nChunksOnPort", "unsigned long", 20)]
    assert [p["doc"] for p in acquire["parameters"]] == [
        "ALSA name of the sound device", "Sample rate in Hz", "Chunk size in frames", "Port size in chunks"]
    assert acquire["doc"] == "Acquire data from an audio device and stream it on a port."
    assert {"::bass::e_nomem", "::bass::e_device", "::bass::e_hwparams", "::bass::e_swparams"} <= set(
        acquire["throws"])
    assert services["Stop"]["interrupts"] == ["Acquire"] and services["Stop"]["kind"] == "function"
    assert services["ListDevices"]["throws"] == ["::bass::e_nodevice"]
    audio = next(p for p in info["ports"] if p["name"] == "Audio")
    assert audio["dir"] == "out" and audio["type"]["name"] == "::binaudio::portStruct"
    assert [(m["name"], m["type"]["name"]) for m in audio["type"]["members"]] == [
        ("sampleRate", "unsigned long"), ("nChunksOnPort", "unsigned long"), ("nFramesPerChunk", "unsigned long"),
        ("lastFrameIndex", "unsigned long long"), ("left", "sequence<long>"), ("right", "sequence<long>")]


async def test_acquire_publishes_frames_and_a_new_acquire_interrupts_it(bass: Bass) -> None:
    first = await bass.send("Acquire", {"device": "sim", "nChunksOnPort": 4})
    await wait_for_frame(bass, 3 * 2205)
    port = bass.snapshot.data
    assert (port.sampleRate, port.nChunksOnPort, port.nFramesPerChunk) == (44100, 4, 2205)
    assert port.lastFrameIndex % 2205 == 0 and port.left.size == 4 * 2205 and np.any(port.left != 0)
    second = await bass.send("Acquire", {"device": "sim", "sampleRate": 16000, "nFramesPerChunk": 320,
                                         "nChunksOnPort": 8})
    await first.ended.wait()
    assert first.exception == {"ex": "::genom::interrupted", "detail": {"by": "Acquire"}}
    while bass.snapshot.sample_rate != 16000:   # the second acquisition's port, once its scene is open
        await bass.Audio.wait_published()
    await wait_for_frame(bass, 320)
    assert bass.snapshot.sample_rate == 16000 and bass.snapshot.last_frame_index < 20 * 320  # restarted at 0
    stop = await bass.send("Stop")
    await second.ended.wait()
    assert stop.status == "done" and second.exception == {"ex": "::genom::interrupted", "detail": {"by": "Stop"}}


async def test_devices_and_refusals(bass: Bass) -> None:
    listing = await bass.send("ListDevices")
    await listing.ended.wait()
    assert listing.status == "done" and listing.output is not None
    assert listing.output["devices"][0] == "sim" and "null" in listing.output["devices"]
    for inputs, ex in (({"device": "hw:7,0"}, "::bass::e_device"), ({"nChunksOnPort": 0}, "::bass::e_nomem"),
                       ({"nFramesPerChunk": 2**24, "nChunksOnPort": 100}, "::bass::e_nomem"),
                       ({"sampleRate": 10}, "::bass::e_hwparams")):
        request = await bass.send("Acquire", {"device": "sim", **inputs})
        await request.ended.wait()
        assert request.status == "error" and request.exception is not None
        assert request.exception["ex"] == ex and request.exception["detail"]["what"]
    missing = await bass.send("Acquire", {"device": "hw:7,0"})
    await missing.ended.wait()
    assert missing.exception is not None and "available" in missing.exception["detail"]["what"]


async def test_close_socket_ends_the_dedicated_socket_normally(bass: Bass) -> None:
    socket = await bass.send("DedicatedSocket")
    assert await bass.wait_socket() > 0
    again = await bass.send("DedicatedSocket")
    await again.ended.wait()
    assert again.exception is not None and again.exception["ex"] == "::bass::e_socket"
    assert socket.running
    close = await bass.send("CloseSocket")
    await close.ended.wait()
    assert close.status == "done" and socket.status == "done" and bass.socket_port == 0
    idle = await bass.send("CloseSocket")                 # nothing open: nothing to do
    await idle.ended.wait()
    assert idle.status == "done"


async def test_the_simulated_scene_follows_the_simulated_head(host: ComponentHost, bass: Bass) -> None:
    kemar = await host.load("kemar")
    acquiring = await bass.send("Acquire", {"device": "sim"})
    await wait_for_frame(bass, 4 * 2205)
    before = bass.snapshot.frames(bass.snapshot.last_frame_index - 2204, 2205)
    homing = await kemar.send("Homing")
    await homing.ended.wait()
    move = await kemar.send("MoveAbsolutePosition", {"target": 60})
    await move.ended.wait()
    assert move.status == "done"
    start = bass.snapshot.last_frame_index
    await wait_for_frame(bass, start + 2 * 2205)
    after = bass.snapshot.frames(bass.snapshot.last_frame_index - 2204, 2205)
    # Turning the head 60° changes which ear leads: the interaural level ratio moves.
    ratio = [float(np.abs(r.left.astype(float)).sum() / np.abs(r.right.astype(float)).sum()) for r in (before, after)]
    assert abs(ratio[0] - ratio[1]) > 0.05
    await bass.send("Stop")
    await acquiring.ended.wait()


def test_port_members_say_what_they_are() -> None:
    """Issue 13: a curl user reads in /info what a port's members mean (what is ts?)."""
    from aiogenomix.components.capture import PortData
    from aiogenomix.components.core.runtime import idl_type

    capture = {m["name"]: m.get("doc", "") for m in idl_type(PortData).describe()["members"]}
    assert "capture started" in capture["ts"] and "does not change" in capture["ts"]
    audio = next(p for p in describe(Bass(ComponentHost(factories={}), "bass"))["ports"] if p["name"] == "Audio")
    docs = {m["name"]: m.get("doc", "") for m in audio["type"]["members"]}
    assert "newest frame" in docs["lastFrameIndex"] and all(docs.values())
