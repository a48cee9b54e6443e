"""Reading the audio window into numpy, every way, against the loopback floor.

genomix JSON, the dedicated socket, binary and incremental HTTP, each against the
same bytes over a plain asyncio loopback socket (the seed's Tables 5.2 and 6.2).
"""

from __future__ import annotations

import asyncio
import json
import struct
import time
from collections.abc import Awaitable, Callable
from typing import Any

import aiohttp
import numpy as np
import orjson

from aiogenomix.clients import AsyncAudioSocketClient

from ._common import Result, server, summary

RATE, CHUNK_MS = 44100, 50
FRAMES = RATE * CHUNK_MS // 1000
#: Window length (ms) -> chunks on the port, as in the seed's Table 6.2.
WINDOWS = {500: 10, 1000: 20, 4000: 80}
#: What the seed reports for MATLAB, ms (Table 5.2: 4000 ms through genomix; Table 6.2: dedicated socket).
SEED_MS = {"json": {4000: 450.0}, "socket": {500: 28.0, 1000: 32.0, 4000: 86.0}}
TARGETS = {"socket": 1.5, "binary": 2.0, "json": 12.0}


def decode_binary(body: bytes) -> dict[str, Any]:
    """Rebuild the data of a binary port reply (docs/protocol.md, 'Fast paths')."""
    (length,) = struct.unpack_from("<I", body, 4)
    header = orjson.loads(body[8:8 + length])
    payload = memoryview(body)[8 + length:]
    data = header["data"]
    for key in ("left", "right"):
        spec = header["arrays"][data[key]["$array"]]
        data[key] = np.frombuffer(payload, spec["dtype"], int(np.prod(spec["shape"])), spec["offset"])
    return data


async def _timed(read: Callable[[], Awaitable[int]], reads: int) -> tuple[list[float], int]:
    samples, nbytes = [], 0
    for _ in range(reads):
        started = time.perf_counter()
        nbytes = await read()
        samples.append(time.perf_counter() - started)
    return samples, nbytes


async def _window(http: aiohttp.ClientSession, base: str, socket_port: int, floor_port: int, chunks: int,
                  reads: int) -> dict[str, Any]:
    values = FRAMES * chunks

    async def json_read() -> int:
        async with http.get(f"{base}/module/capture/read/Port") as reply:
            body = await reply.read()
        port = orjson.loads(body)["Port"]
        left, right = np.asarray(port["left"], np.int32), np.asarray(port["right"], np.int32)
        assert left.size == right.size == values
        return len(body)

    async def binary_read() -> int:
        async with http.get(f"{base}/module/capture/read/Port", params={"format": "binary"}) as reply:
            body = await reply.read()
        port = decode_binary(body)
        assert port["left"].size == values
        return len(body)

    async def incremental_read() -> int:
        # What a streaming reader does every chunk: ask only for the chunk after the one it holds.
        async with http.get(f"{base}/module/capture/read/Port", params={"format": "binary"}) as reply:
            index = decode_binary(await reply.read())["index"]
        started = time.perf_counter()
        async with http.get(f"{base}/module/capture/read/Port",
                            params={"format": "binary", "since": str(index - 1)}) as reply:
            body = await reply.read()
        decode_binary(body)
        incremental_samples.append(time.perf_counter() - started)
        return len(body)

    incremental_samples: list[float] = []
    audio = AsyncAudioSocketClient("127.0.0.1", socket_port, frames_per_chunk=FRAMES)

    async def socket_read() -> int:
        audio.seek(0)  # the whole window every time, as the seed's Port<N> reads did
        block = await audio.read()
        assert block.frames.shape == (values, 2)
        return 4 * (2 + 2 * values)

    reader, writer = await asyncio.open_connection("127.0.0.1", floor_port)

    async def floor_read() -> int:
        writer.write(b"%d\n" % (8 * values))
        size = int.from_bytes(await reader.readexactly(4), "little")
        frames = np.frombuffer(await reader.readexactly(size), np.int32).reshape(2, -1)
        assert frames.shape[1] == values
        return size + 4

    async with audio:
        results = {}
        for name, read in [("floor", floor_read), ("socket", socket_read), ("binary", binary_read),
                           ("json", json_read)]:
            await read()  # warm up
            samples, nbytes = await _timed(read, reads)
            results[name] = summary(samples) | {"bytes": nbytes}
        await _timed(incremental_read, reads)
        results["incremental"] = summary(incremental_samples)
    writer.close()
    floor = results["floor"]["median"]
    for name in ("socket", "binary", "json"):
        results[name]["ratio_to_floor"] = results[name]["median"] / floor
    return results


async def _start(http: aiohttp.ClientSession, base: str, chunks: int) -> None:
    request = {"device": "sim", "transfer_rate": RATE, "chunk_time": CHUNK_MS, "Port_chunks": chunks}
    async with http.get(f"{base}/module/capture/send/StartCapture", params={"input": json.dumps(request)}) as reply:
        assert (await reply.json())["status"] == "sent", await reply.text()
    while True:  # the window fills in real time: poll its index (a benchmark, not a test)
        async with http.get(f"{base}/module/capture/read/Port", params={"since": "0", "format": "binary"}) as r:
            if decode_binary(await r.read())["index"] >= chunks:
                return
        await asyncio.sleep(0.2)


async def run(reads: int = 50) -> Result:
    """Measure every path for every window length."""
    results: dict[str, Any] = {}
    async with server("gateway") as (port, _), server("socket") as (floor_port, _):
        base = f"http://127.0.0.1:{port}"
        async with aiohttp.ClientSession() as http:
            await http.get(f"{base}/load/capture")
            async with http.get(f"{base}/module/capture/send/DedicatedSocket") as reply:
                assert (await reply.json())["status"] in ("sent", "done")
            async with http.get(f"{base}/module/capture/send/GetCaptureStatus") as reply:
                socket_port = (await reply.json())["output"]["socket_port"]
            for window_ms, chunks in WINDOWS.items():
                await _start(http, base, chunks)
                results[str(window_ms)] = await _window(http, base, socket_port, floor_port, chunks, reads)
                await http.get(f"{base}/module/capture/send/StopCapture")
    verdicts = {}
    long_window = results["4000"]
    for name, target in TARGETS.items():
        ratio = long_window[name]["ratio_to_floor"]
        faster_than_seed = long_window[name]["median"] < SEED_MS["socket"][500]
        verdicts[name] = "met" if ratio <= target and faster_than_seed else "MISSED"
    return {"windows": results, "targets": TARGETS, "seed_ms": SEED_MS, "verdicts": verdicts}
