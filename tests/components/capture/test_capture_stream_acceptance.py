"""Issue 5, acceptance 1: a minute of simulated capture streamed to four socket clients with no gap.

The capture runs at 44.1 kHz, 50 ms chunks, 20 chunks on the port, for 60 s of
runtime clock (1.2 s of real time at the tests' time scale).  Each client reads
after every publication of the port (awaited, never slept for), so it never
falls behind; a fifth client pauses for longer than the port and must report
exactly the chunks it missed.  Samples must equal an offline rendering of the
same seeded scene with the same head motion.
"""

from __future__ import annotations

import asyncio
import math

import numpy as np

from aiogenomix.clients.audio_socket import AsyncAudioSocketClient, AudioBlock
from aiogenomix.components.capture import DEFAULT_SCENE, Capture, SphericalHeadRenderer

RATE, FPC, PORT_CHUNKS = 44100, 2205, 20
CHUNKS = 1200  # 60 s of 50 ms chunks


def head_motion() -> list[float]:
    """Head azimuth at the end of each chunk: a slow back-and-forth sweep, so the head moves."""
    return [40.0 * math.sin(2 * math.pi * k / 400) for k in range(CHUNKS + 200)]


def reference_frames(count: int) -> np.ndarray:
    renderer = SphericalHeadRenderer(DEFAULT_SCENE, RATE)
    return np.concatenate([renderer.render(FPC, az) for az in head_motion()[:count]])


async def follow(capture: Capture, port: int, until: int) -> list[AudioBlock]:
    """Read after every publication of the port until chunk *until* has been received."""
    blocks: list[AudioBlock] = []
    async with AsyncAudioSocketClient(port=port, frames_per_chunk=FPC) as client:
        version = capture.Port.version
        while client.index < until:
            version = await capture.Port.wait_published(version)
            block = await client.read()
            if block.count:
                blocks.append(block)
    return blocks


async def pause_then_read(capture: Capture, port: int) -> tuple[AudioBlock, AudioBlock]:
    """Read once, then wait until the port has moved on by more than its length, and read again."""
    async with AsyncAudioSocketClient(port=port, frames_per_chunk=FPC) as client:
        while (first := await client.read()).count == 0:
            await capture.Port.wait_published()
        while capture.Port.read().index < first.last_index + PORT_CHUNKS + 13:
            await capture.Port.wait_published()
        return first, await client.read()


async def test_a_minute_of_capture_reaches_every_client_without_a_gap(capture: Capture) -> None:
    motion = iter(head_motion())
    capture.head_azimuth = lambda: next(motion)
    socket = await capture.send("DedicatedSocket")
    port = await capture.wait_socket()
    start = capture.clock.now()
    request = await capture.send("StartCapture", {"device": "sim", "transfer_rate": RATE, "chunk_time": 50,
                                                  "Port_chunks": PORT_CHUNKS})
    followers = [asyncio.create_task(follow(capture, port, CHUNKS)) for _ in range(4)]
    pauser = asyncio.create_task(pause_then_read(capture, port))
    results = await asyncio.gather(*followers)
    first, after_pause = await pauser
    await capture.send("StopCapture")
    await request.ended.wait()
    await capture.send("CloseSocket")
    await socket.ended.wait()
    assert capture.clock.now() - start >= 60.0

    reference = reference_frames(CHUNKS + 40)
    for blocks in results:
        indices = [i for b in blocks for i in range(b.first_index, b.last_index + 1)]
        assert indices == list(range(1, len(indices) + 1)) and len(indices) >= CHUNKS
        assert sum(b.lost for b in blocks) == 0
        frames = np.concatenate([b.frames for b in blocks])
        np.testing.assert_array_equal(frames, reference[:len(frames)])

    # The pausing client: the port's length of newest chunks, and an exact count of the rest.
    assert after_pause.count == PORT_CHUNKS
    assert after_pause.lost == after_pause.first_index - first.last_index - 1 >= 13
    assert after_pause.lost + after_pause.count == after_pause.last_index - first.last_index
    start_frame = (after_pause.first_index - 1) * FPC
    np.testing.assert_array_equal(after_pause.frames, reference[start_frame:start_frame + PORT_CHUNKS * FPC])
