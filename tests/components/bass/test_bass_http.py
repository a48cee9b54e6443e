"""bass's Audio port over HTTP: JSON, binary and incremental reads by frame index, and the watch stream."""

from __future__ import annotations

import aiohttp
import numpy as np
import orjson

from aiogenomix.clients import aconnect
from aiogenomix.components.bass import Bass

from .conftest import wait_for_frame

FPC = 2205


async def test_incremental_reads_count_frames_in_json_and_binary(bass: Bass, url: str) -> None:
    acquire = await bass.send("Acquire", {"device": "sim", "nChunksOnPort": 40})
    await wait_for_frame(bass, 6 * FPC)
    # Stopped, the port keeps its frames: both reads below see the same window. (Running, the
    # 34 chunks left before frame 2 * FPC + 8 drops out are 170 ms of real time, which a loaded
    # machine can spend opening the client.)
    await bass.send("Stop")
    await acquire.ended.wait()
    newest = bass.snapshot.last_frame_index
    async with aiohttp.ClientSession() as http:
        async with http.get(f"{url}/module/bass/read/Audio", params={"since": str(2 * FPC + 7)}) as reply:
            body = orjson.loads(await reply.read())
    audio = body["Audio"]
    first = audio["lastFrameIndex"] - len(audio["left"]) + 1
    assert (first, audio["lastFrameIndex"], body["lost"]) == (2 * FPC + 8, newest, 0)
    async with aconnect(url) as client:                       # the generated client reads the binary form
        data, lost = await (await client.module("bass")).Audio(since=2 * FPC + 7)
    held = bass.snapshot.frames(first, len(audio["left"]))
    np.testing.assert_array_equal(np.asarray(audio["left"], np.int32), held.left)
    np.testing.assert_array_equal(data.left, held.left)
    assert lost == 0 and isinstance(data.left, np.ndarray)


async def test_a_watch_starts_with_the_newest_chunk_and_misses_nothing(bass: Bass, url: str) -> None:
    await bass.send("Acquire", {"device": "sim", "nChunksOnPort": 40})
    await wait_for_frame(bass, 2 * FPC)
    events = []
    async with aiohttp.ClientSession() as http:
        async with http.get(f"{url}/module/bass/watch/Audio") as stream:
            async for line in stream.content:
                if line.startswith(b"data: "):
                    events.append(orjson.loads(line[6:]))
                    if len(events) == 5:
                        break
    firsts = [e["Audio"]["lastFrameIndex"] - len(e["Audio"]["left"]) + 1 for e in events]
    lasts = [e["Audio"]["lastFrameIndex"] for e in events]
    assert len(events[0]["Audio"]["left"]) == FPC                 # the newest chunk, not one frame
    assert firsts[1:] == [last + 1 for last in lasts[:-1]]        # then every frame once
    assert all(e["lost"] == 0 for e in events)
    await bass.send("Stop")
