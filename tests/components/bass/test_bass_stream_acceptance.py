"""Issue 9, acceptance 2: a minute of bass streamed to four socket clients, an HTTP reader and basc, with no gap.

bass captures the simulated scene at 44.1 kHz, 2205-frame chunks, 100 chunks on
the port, for 60 s of runtime clock (6 s of real time).  Two raw clients speak
the MATLAB client's bytes and two use the Python 2015 client; each asks for
the frames after the last it holds after every publication (awaited, never
slept for).  The generated Python client reads ``Audio(since=k)`` through a
real gateway, and ``basc``, connected to ``bass/Audio``, reads 22050-frame
blocks.  Every reader must get every frame once, nothing lost, equal to an
offline rendering of the same scene with the same head motion.
"""

from __future__ import annotations

import asyncio
import math

import numpy as np

from aiogenomix.clients import AsyncFrameSocketClient, aconnect
from aiogenomix.components.basc import Basc
from aiogenomix.components.bass import Bass
from aiogenomix.components.core import ComponentHost

from .conftest import MatlabSocket, reference_frames, wait_for_frame

# 100 chunks (5 s) on the port: half a second of real time for a reader delayed by a busy machine.
RATE, FPC, CHUNKS_ON_PORT = 44100, 2205, 100
SECONDS = 60
FRAMES = SECONDS * RATE
BLOCK = 22050


def head_motion() -> list[float]:
    """Head azimuth for each chunk: a slow back-and-forth sweep, so the sound moves."""
    return [40.0 * math.sin(2 * math.pi * k / 400) for k in range(FRAMES // FPC + 400)]


async def matlab_reader(bass: Bass, port: int) -> tuple[np.ndarray, int, int]:
    """Frames 1… read after every publication; returns them, the frames lost and the first index."""
    client = await MatlabSocket.open(port)
    pieces, lost, next_frame, version = [], 0, 1, bass.Audio.version
    while next_frame <= FRAMES:
        version = await bass.Audio.wait_published(version)
        n, loss, next_frame, left, right = await client.read(4410 * 10, next_frame)
        lost += loss
        pieces.append(np.stack([left, right], axis=1))
    await client.close()
    return np.concatenate(pieces), lost, 1


async def python_reader(bass: Bass, port: int) -> tuple[np.ndarray, int, int]:
    pieces, lost, version = [], 0, bass.Audio.version
    async with AsyncFrameSocketClient(port=port, next_frame=1) as client:
        while client.next_frame <= FRAMES:
            version = await bass.Audio.wait_published(version)
            block = await client.read()
            lost += block.lost
            pieces.append(np.array(block.frames))
    return np.concatenate(pieces), lost, 1


async def since_reader(bass: Bass, url: str) -> tuple[np.ndarray, int, int]:
    """The generated client, asking only for the frames after the last one it holds."""
    pieces, lost, index, version = [], 0, 0, bass.Audio.version
    async with aconnect(url) as client:
        audio = (await client.module("bass")).Audio
        while index < FRAMES:
            version = await bass.Audio.wait_published(version)
            data, missed = await audio(since=index)
            assert data.lastFrameIndex - len(data.left) == index + missed
            lost += missed
            pieces.append(np.stack([data.left, data.right], axis=1))
            index = data.lastFrameIndex
    return np.concatenate(pieces), lost, 1


async def basc_reader(basc: Basc) -> tuple[np.ndarray, int, int]:
    """Every block basc completes, from its Blocks port (awaited publication by publication)."""
    # basc takes at most one block a period (250 ms): blocks of half a second keep it twice as fast as the
    # capture even when a busy machine makes it skip periods.
    request = await basc.send("GetBlocks", {"nBlocks": FRAMES // BLOCK, "nFramesPerBlock": BLOCK,
                                            "startOffs": 0})
    pieces, first, version = [], -1, basc.Blocks.version
    while request.running:
        version = await basc.Blocks.wait_published(version)
        report = basc.Blocks.read()
        if report.blocks:
            first = report.firstFrameIndex if first < 0 else first
            assert report.firstFrameIndex == first + BLOCK * len(pieces)   # consecutive blocks
            pieces.append(np.stack([report.left, report.right], axis=1))
    await request.ended.wait()
    assert request.status == "done"
    return np.concatenate(pieces), basc.Blocks.read().lost, first


async def test_a_minute_of_bass_reaches_every_reader_without_a_gap(url: str, host: ComponentHost,
                                                                    bass: Bass) -> None:
    motion = iter(head_motion())
    bass.head_azimuth = lambda: next(motion)
    basc = await host.load("basc")
    assert isinstance(basc, Basc)
    await basc.send("connect_port", {"local": "Audio", "remote": "bass/Audio"})
    socket = await bass.send("DedicatedSocket")
    port = await bass.wait_socket()
    start = bass.clock.now()
    acquiring = await bass.send("Acquire", {"device": "sim", "sampleRate": RATE, "nFramesPerChunk": FPC,
                                            "nChunksOnPort": CHUNKS_ON_PORT})
    await wait_for_frame(bass, 1)   # the scene is open (its renderer is built off the event loop)
    results = await asyncio.gather(
        matlab_reader(bass, port), matlab_reader(bass, port), python_reader(bass, port),
        python_reader(bass, port), since_reader(bass, url), basc_reader(basc))
    await bass.send("Stop")
    await acquiring.ended.wait()
    await bass.send("CloseSocket")
    await socket.ended.wait()
    assert bass.clock.now() - start >= SECONDS and socket.status == "done"

    reference = reference_frames(FRAMES + 20 * FPC, head_motion())
    for frames, lost, first in results:
        assert lost == 0
        assert first + len(frames) - 1 >= FRAMES - BLOCK              # the whole minute (basc: whole blocks)
        np.testing.assert_array_equal(frames, reference[first - 1:first - 1 + len(frames)])
