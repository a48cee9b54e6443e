"""Issue 5, acceptance 1: a minute of simulated capture streamed to six readers with no gap.

The capture runs at 44.1 kHz, 50 ms chunks, 60 chunks on the port, for 60 s of
runtime clock (6 s of real time: slow enough that a reader on a loaded machine
keeps within the port's 60 chunks).  Four dedicated-socket clients read after
every publication of the port (awaited, never slept for); two HTTP readers go
through a real gateway: the generated Python client asking ``Port(since=k)``
(binary form) after every publication, and a ``watch`` event stream.  A
seventh reader pauses for longer than the port and must report exactly the
chunks it missed.  Samples must equal an offline rendering of the same seeded
scene with the same head motion.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncIterator

import aiohttp
import numpy as np
import orjson
import pytest

from aiogenomix.clients import aconnect
from aiogenomix.clients.audio_socket import AsyncAudioSocketClient, AudioBlock
from aiogenomix.components.audio import DEFAULT_SCENE, scene_renderer
from aiogenomix.components.capture import Capture
from aiogenomix.components.core import ComponentHost, HostSettings, ScaledClock
from aiogenomix.gateway import GatewayConfig, serve

# 60 chunks (3 s) on the port: 300 ms of real time for a reader delayed by a busy machine.
RATE, FPC, PORT_CHUNKS = 44100, 2205, 60
CHUNKS = 1200  # 60 s of 50 ms chunks


def head_motion() -> list[float]:
    """Head azimuth at the end of each chunk: a slow back-and-forth sweep, so the head moves."""
    return [40.0 * math.sin(2 * math.pi * k / 400) for k in range(CHUNKS + 200)]


def reference_frames(count: int) -> np.ndarray:
    renderer = scene_renderer(DEFAULT_SCENE, RATE)
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


@pytest.fixture
async def served() -> AsyncIterator[tuple[Capture, str]]:
    """The capture component on a 10× clock, also served by a gateway on a free port."""
    async with ComponentHost(clock=ScaledClock(10), settings=HostSettings(audio_socket_port=0),
                             factories={"capture": Capture}) as host:
        capture = await host.load("capture")
        assert isinstance(capture, Capture)
        async with serve(GatewayConfig.of(port=0), host=host) as url:
            yield capture, url


async def since_reader(capture: Capture, url: str, until: int) -> list[tuple[int, np.ndarray, int]]:
    """The generated client, asking only for new chunks after every publication."""
    reads = []
    async with aconnect(url) as client:
        port = (await client.module("capture")).Port
        index, version = 0, capture.Port.version
        while index < until:
            version = await capture.Port.wait_published(version)
            data, lost = await port(since=index)
            count = data.left.size // FPC
            if count:
                reads.append((data.index - count + 1, np.stack([data.left, data.right], axis=1), lost))
            index = data.index
    return reads


async def watch_reader(url: str, until: int) -> list[tuple[int, np.ndarray, int]]:
    """A ``watch`` event stream: each event holds the chunks this reader has not had."""
    reads = []
    async with aiohttp.ClientSession() as http:
        async with http.get(f"{url}/module/capture/watch/Port", params={"since": "0"}) as stream:
            async for line in stream.content:
                if not line.startswith(b"data: "):
                    continue
                event = orjson.loads(line[6:])
                port = event["Port"]
                count = len(port["left"]) // FPC
                if count:
                    frames = np.stack([np.asarray(port["left"], np.int32), np.asarray(port["right"], np.int32)],
                                      axis=1)
                    reads.append((port["index"] - count + 1, frames, event["lost"]))
                if port["index"] >= until:
                    return reads
    return reads


async def test_a_minute_of_capture_reaches_every_reader_without_a_gap(served: tuple[Capture, str]) -> None:
    capture, url = served
    motion = iter(head_motion())
    capture.head_azimuth = lambda: next(motion)
    socket = await capture.send("DedicatedSocket")
    port = await capture.wait_socket()
    start = capture.clock.now()
    request = await capture.send("StartCapture", {"device": "sim", "transfer_rate": RATE, "chunk_time": 50,
                                                  "Port_chunks": PORT_CHUNKS})
    watcher = asyncio.create_task(watch_reader(url, CHUNKS))
    followers = [asyncio.create_task(follow(capture, port, CHUNKS)) for _ in range(4)]
    reader = asyncio.create_task(since_reader(capture, url, CHUNKS))
    pauser = asyncio.create_task(pause_then_read(capture, port))
    results = await asyncio.gather(*followers)
    http_results = await asyncio.gather(reader, watcher)
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

    for reads in http_results:
        first_indices = [first for first, _, _ in reads]
        counts = [len(frames) // FPC for _, frames, _ in reads]
        assert first_indices == list(np.cumsum([1] + counts[:-1]))  # contiguous from chunk 1
        assert sum(counts) >= CHUNKS and sum(lost for _, _, lost in reads) == 0
        frames = np.concatenate([frames for _, frames, _ in reads])
        np.testing.assert_array_equal(frames, reference[:len(frames)])

    # The pausing client: the port's length of newest chunks, and an exact count of the rest.
    assert after_pause.count == PORT_CHUNKS
    assert after_pause.lost == after_pause.first_index - first.last_index - 1 >= 13
    assert after_pause.lost + after_pause.count == after_pause.last_index - first.last_index
    start_frame = (after_pause.first_index - 1) * FPC
    np.testing.assert_array_equal(after_pause.frames, reference[start_frame:start_frame + PORT_CHUNKS * FPC])
