"""Reading the audio window into numpy, every way, against the loopback floor.

genomix JSON, the dedicated socket, binary and incremental HTTP, each against the
same bytes over a plain asyncio loopback socket (the seed's Tables 5.2 and 6.2).
"""

from __future__ import annotations

import asyncio
import json
import time
from typing import Any

import aiohttp
import numpy as np

from aiogenomix.clients import AsyncAudioSocketClient, AsyncClient, aconnect

from ._common import Result, server, summary

RATE, CHUNK_MS = 44100, 50
FRAMES = RATE * CHUNK_MS // 1000
#: Window length (ms) -> chunks on the port, as in the seed's Table 6.2.
WINDOWS = {500: 10, 1000: 20, 4000: 80}
#: What the seed reports for MATLAB, ms (Table 5.2: 4000 ms through genomix; Table 6.2: dedicated socket).
SEED_MS = {"json": {"4000": 450.0}, "socket": {"500": 28.0, "1000": 32.0, "4000": 86.0}}
TARGETS = {"socket": 1.5, "binary": 2.0, "json": 12.0}


class _FloorReader(asyncio.BufferedProtocol):
    """The floor: a reply of known size received straight into a new numpy array, as a client must."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.buffer = np.empty(0, np.uint8)
        self.view = memoryview(self.buffer)
        self.received = 0
        self.done: asyncio.Future[np.ndarray] | None = None
        self.transport: asyncio.Transport | None = None

    @classmethod
    async def connect(cls, port: int, size: int) -> _FloorReader:
        loop = asyncio.get_running_loop()
        _, protocol = await loop.create_connection(lambda: cls(size), "127.0.0.1", port)
        return protocol

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]

    def get_buffer(self, sizehint: int) -> memoryview:
        return self.view[self.received:]

    def buffer_updated(self, nbytes: int) -> None:
        self.received += nbytes
        if self.received == self.size and self.done is not None:
            self.done.set_result(self.buffer)

    async def exchange(self, request: bytes) -> np.ndarray:
        # A fresh array per read: the caller keeps the data, as with every other path.
        self.buffer = np.empty(self.size, np.uint8)
        self.view = memoryview(self.buffer)
        self.received = 0
        self.done = asyncio.get_running_loop().create_future()
        assert self.transport is not None
        self.transport.write(request)
        return await self.done

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()


async def _window(json_client: AsyncClient, binary_client: AsyncClient, socket_port: int, floor_port: int,
                  chunks: int, reads: int) -> dict[str, Any]:
    values = FRAMES * chunks
    json_port = (await json_client.module("capture")).Port
    binary_port = (await binary_client.module("capture")).Port

    async def json_read() -> int:
        port = await json_port()
        assert port.left.size == port.right.size == values
        return 0

    async def binary_read() -> int:
        port = await binary_port()
        assert port.left.size == values
        return 0

    async def incremental_read() -> int:
        # What a streaming reader does every chunk: ask only for the chunk after the one it holds.
        index = (await binary_port(since=10**9))[0].index
        started = time.perf_counter()
        newest, _ = await binary_port(since=index - 1)
        incremental_samples.append(time.perf_counter() - started)
        assert newest.left.size >= FRAMES
        return 0

    incremental_samples: list[float] = []
    audio = AsyncAudioSocketClient("127.0.0.1", socket_port, frames_per_chunk=FRAMES)

    async def socket_read() -> int:
        audio.seek(0)  # the whole window every time, as the seed's Port<N> reads did
        block = await audio.read()
        assert block.frames.shape == (values, 2)
        return 4 * (2 + 2 * values)

    floor = await _FloorReader.connect(floor_port, 4 + 8 * values)

    async def floor_read() -> int:
        body = await floor.exchange(b"%d\n" % (8 * values))
        frames = body[4:].view(np.int32).reshape(2, -1)
        assert frames.shape[1] == values
        return len(body)

    async with audio:
        paths = {"floor": floor_read, "socket": socket_read, "binary": binary_read, "json": json_read,
                 "incremental": incremental_read}
        samples: dict[str, list[float]] = {name: [] for name in paths}
        for read in paths.values():
            await read()  # warm up
        incremental_samples.clear()
        # Alternating blocks of reads: a slow moment of the shared machine weighs on every path
        # alike, while each path still runs several reads in a row, as a real reader would
        # (a 3.5 MB JSON parse right before each binary read would otherwise weigh on it).
        block = 10
        for _ in range(max(1, reads // block)):
            for name, read in paths.items():
                for _ in range(block):
                    started = time.perf_counter()
                    await read()
                    samples[name].append(time.perf_counter() - started)
        samples["incremental"] = incremental_samples
        results = {name: summary(values) | {"bytes": _wire_bytes(name, chunks)} for name, values in samples.items()}
    floor.close()
    floor = results["floor"]["median"]
    for name in ("socket", "binary", "json"):
        results[name]["ratio_to_floor"] = results[name]["median"] / floor
    return results


def _wire_bytes(path: str, chunks: int) -> int:
    """Bytes of samples a path moves (JSON is measured by the caller: its size depends on the digits)."""
    samples = 2 * FRAMES * 4 * (1 if path == "incremental" else chunks)
    return samples + 8 if path == "socket" else samples


async def _start(http: aiohttp.ClientSession, base: str, chunks: int) -> None:
    request = {"device": "sim", "transfer_rate": RATE, "chunk_time": CHUNK_MS, "Port_chunks": chunks}
    async with http.get(f"{base}/module/capture/send/StartCapture", params={"input": json.dumps(request)}) as reply:
        assert (await reply.json())["status"] == "sent", await reply.text()
    while True:  # the window fills in real time: poll its index (a benchmark, not a test)
        # since= beyond the newest chunk: a small reply that still carries the port's index.
        async with http.get(f"{base}/module/capture/read/Port", params={"since": str(10**9)}) as r:
            if (await r.json())["Port"]["index"] >= chunks:
                return
        await asyncio.sleep(0.2)


async def run(reads: int = 50) -> Result:
    """Measure every path for every window length."""
    results: dict[str, Any] = {}
    async with server("gateway") as (port, _), server("socket") as (floor_port, _):
        base = f"http://127.0.0.1:{port}"
        async with aiohttp.ClientSession(read_bufsize=1 << 22) as http:
            await http.get(f"{base}/load/capture")
            async with http.get(f"{base}/module/capture/send/DedicatedSocket") as reply:
                assert (await reply.json())["status"] in ("sent", "done")
            async with http.get(f"{base}/module/capture/send/GetCaptureStatus") as reply:
                socket_port = (await reply.json())["output"]["socket_port"]
            async with aconnect(base, fast_paths=False) as json_client, aconnect(base) as binary_client:
                for window_ms, chunks in WINDOWS.items():
                    await _start(http, base, chunks)
                    results[str(window_ms)] = await _window(json_client, binary_client, socket_port, floor_port,
                                                            chunks, reads)
                    async with http.get(f"{base}/module/capture/read/Port") as reply:
                        results[str(window_ms)]["json"]["bytes"] = len(await reply.read())
                    await http.get(f"{base}/module/capture/send/StopCapture")
    verdicts = {}
    long_window = results["4000"]
    for name, target in TARGETS.items():
        ratio = long_window[name]["ratio_to_floor"]
        faster_than_seed = long_window[name]["median"] < SEED_MS["socket"]["500"]
        verdicts[name] = "met" if ratio <= target and faster_than_seed else "MISSED"
    return {"windows": results, "targets": TARGETS, "seed_ms": SEED_MS, "verdicts": verdicts}
