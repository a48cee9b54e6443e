"""Port data of a remote component: JSON, binary, ``since=`` and ``watch``, exact and without loss."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import time
import urllib.parse
from collections.abc import AsyncIterator

import aiohttp
import numpy as np

from aiogenomix.clients._binary import decode_binary

from ._processes import Process, start_host_and_gateway

RATE = 44100
CHUNK_FRAMES = RATE * 50 // 1000
PORT_CHUNKS = 80
#: Seconds of the since= reading (the issue's 30 s: AIOGENOMIX_REMOTE_CAPTURE_SECONDS=30).
READ_SECONDS = float(os.environ.get("AIOGENOMIX_REMOTE_CAPTURE_SECONDS", "6"))


async def _json(http: aiohttp.ClientSession, path: str) -> dict:
    async with http.get(path) as reply:
        assert reply.status == 200, await reply.text()
        return await reply.json()


async def _lines(stream: aiohttp.StreamReader) -> AsyncIterator[bytes]:
    """The lines of an event stream, however long: an event carries every chunk a slow reader has not had.

    (A busy machine slows the reader: one event then holds a window's worth of JSON, past the line
    length aiohttp's own line reader takes.)
    """
    buffer = b""
    async for data in stream.iter_any():
        *lines, buffer = (buffer + data).split(b"\n")
        for line in lines:
            yield line


async def _binary(http: aiohttp.ClientSession, path: str) -> tuple[dict, dict]:
    async with http.get(path, params={"format": "binary"}) as reply:
        assert reply.status == 200, await reply.text()
        _, data, extra = decode_binary(await reply.read())
        return data, extra


async def test_capture_read_since_for_seconds_loses_nothing(started: list[Process]) -> None:
    # Real time: the capture paces 20 chunks a second, as on the rig.
    _, url, _ = await start_host_and_gateway(started, ["capture"], extra=["--time-scale", "1"])
    async with aiohttp.ClientSession(base_url=url) as http:
        async with http.get("/load/capture") as reply:
            assert reply.status == 200
        start = {"device": "sim", "transfer_rate": RATE, "chunk_time": 50, "Port_chunks": PORT_CHUNKS}
        sent = await _json(http, f"/module/capture/send/StartCapture?input={urllib.parse.quote(json.dumps(start))}")
        assert sent["status"] == "sent"

        # Wait for the first chunks, then read what is new, alternately as JSON and binary.
        index = 0
        while index == 0:
            index = (await _json(http, "/module/capture/read/Port?since=0"))["Port"]["index"]
        left: list[np.ndarray] = []
        right: list[np.ndarray] = []
        first = index
        reads = 0
        ends = time.monotonic() + READ_SECONDS
        while time.monotonic() < ends:
            if reads % 2:
                data, extra = await _binary(http, f"/module/capture/read/Port?since={index}")
                port = data
                new_left, new_right = port["left"], port["right"]
            else:
                reply = await _json(http, f"/module/capture/read/Port?since={index}")
                port, extra = reply["Port"], reply
                new_left, new_right = np.array(port["left"], np.int32), np.array(port["right"], np.int32)
            assert extra["lost"] == 0
            got = port["index"] - index
            assert port["nbframes"] == len(new_left) == len(new_right) == got * CHUNK_FRAMES
            left.append(new_left)
            right.append(new_right)
            index = port["index"]
            reads += 1
            await asyncio.sleep(0.1)  # a reader's pace, not a synchronisation
        chunks = index - first
        assert chunks >= READ_SECONDS * 20 * 0.5, f"only {chunks} chunks in {READ_SECONDS} s"

        # The whole window is the last chunks of what the reader put together, sample for sample.
        whole, _ = await _binary(http, "/module/capture/read/Port")
        assert whole["index"] >= index
        behind = (whole["index"] - index) * CHUNK_FRAMES
        joined_left = np.concatenate(left)
        if behind == 0 and chunks >= PORT_CHUNKS:
            assert np.array_equal(whole["left"], joined_left[-PORT_CHUNKS * CHUNK_FRAMES:])
        else:
            span = min(len(joined_left), PORT_CHUNKS * CHUNK_FRAMES - behind)
            assert np.array_equal(whole["left"][-behind - span:len(whole["left"]) - behind], joined_left[-span:])
        assert len(whole["left"]) == whole["nbframes"] == PORT_CHUNKS * CHUNK_FRAMES
        # JSON and binary reads of one publication agree.
        json_whole = (await _json(http, "/module/capture/read/Port"))["Port"]
        assert json_whole["transfer_rate"] == RATE and len(json_whole["left"]) == PORT_CHUNKS * CHUNK_FRAMES

        # A watcher gets the chunks in order, none lost.
        async with http.get("/module/capture/watch/Port", params={"since": str(whole["index"])}) as stream, \
                contextlib.aclosing(_lines(stream.content)) as lines:
            seen = whole["index"]
            events = 0
            async for line in lines:
                if line.startswith(b"data: "):
                    event = json.loads(line[6:])
                    assert event["lost"] == 0
                    assert len(event["Port"]["left"]) == (event["Port"]["index"] - seen) * CHUNK_FRAMES
                    seen = event["Port"]["index"]
                    events += 1
                    if events == 5:
                        break
        await _json(http, "/module/capture/send/StopCapture")
