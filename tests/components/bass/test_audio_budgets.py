"""Issue 24: the audio a client can make the gateway hold is bounded: ports, all ports together, basc's blocks.

Each refusal names the bound and the flag that changes it; what a component holds is given back
when a smaller port replaces it or the component is unloaded.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import pytest

from aiogenomix.components.basc import Basc
from aiogenomix.components.bass import Bass
from aiogenomix.components.capture import Capture
from aiogenomix.components.core import Budgets, Component, ComponentHost, HostSettings, ManualClock

MIB = 2**20


async def acquiring(bass: Bass, inputs: dict[str, Any]) -> Any:
    """Send Acquire and wait until it has opened its device (it publishes a fresh port then)."""
    request = await bass.send("Acquire", inputs)
    await bass.Audio.wait_published()
    return request


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    """A host of 4 MiB ports, 6 MiB of audio in all and blocks of 100,000 frames, on a clock nobody moves."""
    budgets = Budgets(port_bytes=4 * MIB, audio_bytes=6 * MIB, block_frames=100_000)
    async with ComponentHost(clock=ManualClock(), settings=HostSettings(audio_socket_port=0, budgets=budgets),
                             factories={"bass": Bass, "basc": Basc, "capture": Capture}) as running:
        yield running


async def ended(component: Component, service: str, inputs: dict[str, Any] | None = None) -> Any:
    request = await component.send(service, inputs or {})
    await request.ended.wait()
    return request


async def test_a_port_past_its_bound_is_refused_naming_the_flag(host: ComponentHost) -> None:
    bass, capture = await host.load("bass"), await host.load("capture")
    # The port: 400 chunks of 50 ms at 384 kHz, 59 MiB.
    refused = await ended(bass, "Acquire", {"device": "sim", "sampleRate": 384000, "nFramesPerChunk": 19200,
                                            "nChunksOnPort": 400})
    assert refused.exception == {"ex": "::bass::e_nomem", "detail": {
        "what": "a port of 400 chunks of 19200 frames needs 58.6 MiB, more than the 4 MiB of --max-port-bytes"}}
    refused = await ended(capture, "StartCapture", {"device": "sim", "transfer_rate": 384000, "chunk_time": 50,
                                                    "Port_chunks": 400})
    assert refused.exception == {"ex": "::capture::ERROR_SEQUENCE_ENOMEM", "detail": {
        "what": "a port of 400 chunks of 19200 frames needs 58.6 MiB, more than the 4 MiB of --max-port-bytes"}}
    assert host.ledgers.audio.held == 0


async def test_every_port_together_is_bounded_and_a_port_is_given_back_with_its_component(
        host: ComponentHost) -> None:
    first, second = await host.load("bass"), await host.load("bass", ["-i", "bass2"])
    four_mib = {"device": "sim", "sampleRate": 48000, "nFramesPerChunk": 4096, "nChunksOnPort": 128}
    running = await acquiring(first, four_mib)
    assert host.ledgers.audio.held == 4 * MIB
    refused = await ended(second, "Acquire", four_mib)
    assert refused.exception == {"ex": "::bass::e_nomem", "detail": {
        "what": "a port of 128 chunks of 4096 frames needs 4 MiB, and 4 MiB of the 6 MiB of --max-audio-bytes "
                "are held"}}
    # An acquisition of the same size replaces the port it held: it fits, as the first did.
    await ended(first, "Stop")
    assert running.status == "error" and host.ledgers.audio.held == 4 * MIB
    again = await acquiring(first, four_mib)
    assert again.running and host.ledgers.audio.held == 4 * MIB
    await host.unload("bass")
    assert host.ledgers.audio.held == 0
    accepted = await acquiring(second, four_mib)
    assert accepted.running and host.ledgers.audio.held == 4 * MIB
    await ended(second, "Stop")


async def test_basc_refuses_a_block_past_its_bound_and_holds_what_it_collects(host: ComponentHost) -> None:
    bass, basc = await host.load("bass"), await host.load("basc")
    await ended(basc, "connect_port", {"local": "Audio", "remote": "bass/Audio"})
    await acquiring(bass, {"device": "sim", "nChunksOnPort": 4})   # 4 chunks of 2205 frames: 70 kB
    held = host.ledgers.audio.held
    refused = await ended(basc, "GetBlocks", {"nFramesPerBlock": 4294967295})
    assert refused.exception == {"ex": "::basc::e_nomem", "detail": {
        "what": "a block of 4294967295 frames needs 4294967295 frames, more than the 100000 frames of "
                "--max-block-frames"}}
    collecting = await basc.send("GetBlocks", {"nBlocks": 0, "nFramesPerBlock": 100_000})
    await basc.Blocks.wait_published()                    # it started: its first step publishes an empty block
    assert collecting.running
    # The block being filled and the last one completed, both channels, int32.
    assert host.ledgers.audio.held == held + 2 * 8 * 100_000
    await ended(basc, "Stop")
    assert host.ledgers.audio.held == held                 # no block completed: nothing published is held
    await host.unload("basc")
    assert host.ledgers.audio.held == held
    await ended(bass, "Stop")
