"""Reading the audio window every way, against the loopback floor of the same bytes.

For ``kemarcapture``'s Port (500, 1000 and 4000 ms windows) and ``bass``'s
frame-indexed Audio port (4000 ms): genomix JSON and binary HTTP measured
from request to last byte by a raw reader (no client library, no parsing),
the dedicated socket through its Python client, each against the same number
of bytes served by a plain asyncio socket and received the same way.  The
paths run in alternating blocks (a slow moment of the shared machine weighs on
every path alike); a ratio is the median over blocks of (path median / floor
median) within a block, with the spread of the block ratios.  For reference:
the generated Python client to numpy arrays, incremental reads, and the time
orjson takes to parse the JSON reply (the client's business, not the gateway's).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import statistics
import sys
import time
from collections.abc import Awaitable, Callable
from typing import Any

import aiohttp
import orjson

from aiogenomix.clients import AsyncAudioSocketClient, AsyncFrameSocketClient, aconnect

from ._common import BASELINE, Result, baseline_name, server, summary
from ._raw import RawReader

RATE, CHUNK_MS = 44100, 50
FRAMES = RATE * CHUNK_MS // 1000
#: Window length (ms) -> chunks on the port, as in the seed's Table 6.2.
WINDOWS = {500: 10, 1000: 20, 4000: 80}
#: What the seed reports for MATLAB, ms (Table 5.2: 4000 ms through genomix; Table 6.2: dedicated socket).
SEED_MS = {"json": {"4000": 450.0}, "socket": {"500": 28.0, "1000": 32.0, "4000": 86.0}}
#: Ratio to the floor of the same bytes, every window and bass.
TARGETS = {"socket": 1.5, "binary": 1.5, "json": 1.5}
#: Ratio to the strict floor (a blocking ``sendall`` of a buffer made beforehand), for the 4000 ms windows.
STRICT_TARGETS = {"socket": 1.5, "binary": 1.5}
#: The paths also compared with the strict floor (all windows; the targets apply to the 4000 ms ones).
STRICT = ("socket", "binary", "binary_before")
#: The module whose port is read (the issue's figures are those of the merged component).
MODULE = "kemarcapture"

Read = Callable[[], Awaitable[object]]
#: Each measured path and the floor it is compared with.
PAIRS = {"socket": "floor", "binary": "floor", "json": "floor_json", "binary_fresh": "floor_fresh",
         "json_fresh": "floor_json_fresh", "binary_before": "floor", "json_before": "floor_json"}


def _http_get(path: str) -> bytes:
    return f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode()


#: Set to a directory holding another checkout as ``aiogenomix`` (``aiogenomix/gateway`` ... as
#: links) to measure that gateway's JSON and binary reads in the same blocks ("before").
BEFORE = "_before"


def _before_paths(before_port: int | None, path: str, floors: dict[str, RawReader]) -> dict[str, Read]:
    """The baseline gateway's reads (same port, same floors), when there is one."""
    if before_port is None:
        return {}
    readers: dict[str, RawReader] = {}

    async def read(name: str, query: str) -> object:
        if name not in readers:
            readers[name] = await RawReader.connect(before_port, http=True)
        return await readers[name].exchange(_http_get(path + query))

    return {"binary_before": lambda: read("binary", "?format=binary"), "json_before": lambda: read("json", "")}


#: Paths whose name ends with this wait one chunk period (untimed) before each read, so that
#: every read is of a publication nobody has read yet (no shared reply): what a client polling
#: at the port's rate gets.  Their floors wait the same.
FRESH = "_fresh"


async def _blocks(paths: dict[str, Read], reads: int, block: int) -> dict[str, list[list[float]]]:
    """Per path, the durations (s) of each block of *block* reads, paths taking turns block by block."""
    for read in paths.values():
        await read()  # warm up (and size the raw readers' buffers)
        await read()
    samples: dict[str, list[list[float]]] = {name: [] for name in paths}
    for _ in range(max(3, reads // block)):
        for name, read in paths.items():
            times = []
            for _ in range(block):
                if name.endswith(FRESH):
                    await asyncio.sleep(CHUNK_MS / 1000)
                started = time.perf_counter()
                await read()
                times.append(time.perf_counter() - started)
            samples[name].append(times)
    return samples


def _ratios(samples: dict[str, list[list[float]]], pairs: dict[str, str]) -> dict[str, dict[str, Any]]:
    """Summaries of every path, with ``ratio`` (median of block ratios) and its spread for *pairs* path -> floor."""
    out: dict[str, dict[str, Any]] = {}
    for name, blocks in samples.items():
        flat = [t for b in blocks for t in b]
        ordered = sorted(flat)
        out[name] = summary(flat) | {"p10": ordered[len(ordered) // 10] * 1e3,
                                     "p90": ordered[(9 * len(ordered)) // 10] * 1e3}
    for name, floor in pairs.items():
        ratios = [statistics.median(p) / statistics.median(f)
                  for p, f in zip(samples[name], samples[floor], strict=True)]
        out[name] |= {"floor": floor, "ratio_to_floor": statistics.median(ratios), "ratio_min": min(ratios),
                      "ratio_max": max(ratios), "block_ratios": ratios}
    return out


async def _parse_ms(body: bytes) -> float:
    """Median time orjson takes to parse *body* (reference: what a JSON client adds)."""
    times = []
    for _ in range(7):
        started = time.perf_counter()
        orjson.loads(body)
        times.append(time.perf_counter() - started)
        await asyncio.sleep(0)
    return statistics.median(times) * 1e3


def _strict_ratios(samples: dict[str, list[list[float]]]) -> dict[str, dict[str, float]]:
    """The :data:`STRICT` paths against the strict floor: median block ratio and spread, and the floor's median."""
    out: dict[str, dict[str, float]] = {}
    for name in STRICT:
        if name not in samples:
            continue
        ratios = [statistics.median(p) / statistics.median(f)
                  for p, f in zip(samples[name], samples["floor_strict"], strict=True)]
        out[name] = {"ratio": statistics.median(ratios), "ratio_min": min(ratios), "ratio_max": max(ratios),
                     "floor_median": statistics.median(x for block in samples["floor_strict"] for x in block)}
    return out


async def _capture_window(base: str, port: int, socket_port: int, floor_port: int, strict_port: int, chunks: int,
                          reads: int, block: int, before_port: int | None = None) -> dict[str, Any]:
    values = FRAMES * chunks
    path = f"/module/{MODULE}/read/Port"
    readers = {name: await RawReader.connect(port, http=True) for name in ("json", "binary")}
    floors = {name: await RawReader.connect(floor_port, http=False) for name in ("samples", "json")}
    floors["strict"] = await RawReader.connect(strict_port, http=False)
    json_body = bytes(await readers["json"].exchange(_http_get(path)))
    json_bytes = len(json_body) - json_body.index(b"\r\n\r\n") - 4
    samples_bytes = 8 * values
    audio = AsyncAudioSocketClient("127.0.0.1", socket_port, frames_per_chunk=FRAMES, positions=True)
    # The 2014 reply: [n] [left] [right] [last index] [n float32 positions], int32 little-endian.
    raw_socket = await RawReader.connect(
        socket_port, http=False, sized=lambda head: 4 * (int.from_bytes(head[:4], "little") * (2 * FRAMES + 1) + 2))
    async with aconnect(base, fast_paths=False) as json_client, aconnect(base) as binary_client, audio:
        json_port = (await json_client.module(MODULE)).Port
        binary_port = (await binary_client.module(MODULE)).Port

        async def socket_read() -> None:
            audio.seek(0)  # the whole window every time, as the seed's Port<N> reads did
            block_ = await audio.read()
            assert block_.frames.shape == (values, 2)

        async def client_json() -> None:
            data = await json_port()
            assert data.left.size == values

        async def client_binary() -> None:
            data = await binary_port()
            assert data.left.size == values

        incremental: list[float] = []

        async def client_incremental() -> None:
            # What a streaming reader does every chunk: ask only for the chunk after the one it holds.
            index = (await binary_port(since=10**9))[0].index
            started = time.perf_counter()
            newest, _ = await binary_port(since=index - 1)
            incremental.append(time.perf_counter() - started)
            assert newest.left.size >= FRAMES

        paths: dict[str, Read] = {
            "floor": lambda: floors["samples"].exchange(b"%d\n" % samples_bytes),
            "floor_strict": lambda: floors["strict"].exchange(b"%d\n" % samples_bytes),
            "socket": lambda: raw_socket.exchange(b"Read Port - Index 0\n"),
            "binary": lambda: readers["binary"].exchange(_http_get(path + "?format=binary")),
            "floor_json": lambda: floors["json"].exchange(b"%d\n" % json_bytes),
            "json": lambda: readers["json"].exchange(_http_get(path)),
            "floor_fresh": lambda: floors["samples"].exchange(b"%d\n" % samples_bytes),
            "binary_fresh": lambda: readers["binary"].exchange(_http_get(path + "?format=binary")),
            "floor_json_fresh": lambda: floors["json"].exchange(b"%d\n" % json_bytes),
            "json_fresh": lambda: readers["json"].exchange(_http_get(path)),
            **_before_paths(before_port, path, floors),
            "client_socket": socket_read,
            "client_binary": client_binary,
            "client_json": client_json,
            "client_incremental": client_incremental,
        }
        samples = await _blocks(paths, reads, block)
    for reader in (*readers.values(), *floors.values(), raw_socket):
        reader.close()
    results: dict[str, Any] = _ratios(samples, {k: v for k, v in PAIRS.items() if k in samples})
    results["strict"] = _strict_ratios(samples)
    results["client_incremental"] = summary(incremental)
    for name in ("floor", "binary", "floor_fresh", "binary_fresh", "binary_before"):
        if name in results:
            results[name]["bytes"] = samples_bytes
    results["socket"]["bytes"] = samples_bytes + 8 + 4 * chunks  # count, last index, a float32 position per chunk
    for name in ("floor_json", "json", "floor_json_fresh", "json_fresh", "json_before"):
        if name in results:
            results[name]["bytes"] = json_bytes
    results["orjson_parse_ms"] = await _parse_ms(json_body[json_body.index(b"\r\n\r\n") + 4:])
    return results


async def _wait_index(http: aiohttp.ClientSession, url: str, key: str, at_least: int) -> None:
    while True:  # the window fills in real time: poll its index (a benchmark, not a test)
        # since= beyond the newest item: a small reply that still carries the port's index.
        async with http.get(url, params={"since": str(10**12)}) as r:
            if (await r.json())[key.split(".")[0]][key.split(".")[1]] >= at_least:
                return
        await asyncio.sleep(0.2)


async def _send(http: aiohttp.ClientSession, base: str, module: str, service: str, **inputs: Any) -> dict[str, Any]:
    params = {"input": json.dumps(inputs)} if inputs else {}
    async with http.get(f"{base}/module/{module}/send/{service}", params=params) as reply:
        answer: dict[str, Any] = await reply.json()
        assert answer["status"] in ("sent", "done"), answer
        return answer


async def _start_bass(http: aiohttp.ClientSession, base: str) -> None:
    """Start bass at once: its 4000 ms port fills while the other windows are measured."""
    await http.get(f"{base}/load/bass")
    await _send(http, base, "bass", "DedicatedSocket")
    await _send(http, base, "bass", "Acquire", device="sim", sampleRate=RATE, nFramesPerChunk=FRAMES,
                nChunksOnPort=WINDOWS[4000])


async def _bass(http: aiohttp.ClientSession, base: str, port: int, floor_port: int, strict_port: int, reads: int,
                block: int, before_port: int | None = None) -> dict[str, Any]:
    chunks = WINDOWS[4000]
    print("bench: port_read bass", file=sys.stderr, flush=True)
    async with asyncio.timeout(60):
        await _wait_index(http, f"{base}/module/bass/read/Audio", "Audio.lastFrameIndex", chunks * FRAMES)
        socket_port = 0
        while not socket_port:  # the socket opens as its activity starts
            socket_port = await _bass_socket_port(http, base)
            await asyncio.sleep(0.05)
    path = "/module/bass/read/Audio"
    readers = {name: await RawReader.connect(port, http=True) for name in ("json", "binary")}
    floors = {name: await RawReader.connect(floor_port, http=False) for name in ("samples", "json")}
    floors["strict"] = await RawReader.connect(strict_port, http=False)
    json_body = bytes(await readers["json"].exchange(_http_get(path)))
    json_bytes = len(json_body) - json_body.index(b"\r\n\r\n") - 4
    samples_bytes = 8 * chunks * FRAMES
    # The 2015 reply: a 16-byte header (n frames, lost, next frame) and n left then n right int32.
    raw_socket = await RawReader.connect(socket_port, http=False,
                                         sized=lambda head: 16 + 8 * int.from_bytes(head[:4], "little"))
    async with AsyncFrameSocketClient("127.0.0.1", socket_port) as audio:
        async def socket_read() -> None:
            audio.next_frame = 0  # the whole port every time
            frames = await audio.read()
            assert frames.count == chunks * FRAMES, frames.count

        paths: dict[str, Read] = {
            "floor": lambda: floors["samples"].exchange(b"%d\n" % samples_bytes),
            "floor_strict": lambda: floors["strict"].exchange(b"%d\n" % samples_bytes),
            "socket": lambda: raw_socket.exchange(b"Read Port - N %d - nfr 0\n" % (chunks * FRAMES)),
            "client_socket": socket_read,
            "binary": lambda: readers["binary"].exchange(_http_get(path + "?format=binary")),
            "floor_json": lambda: floors["json"].exchange(b"%d\n" % json_bytes),
            "json": lambda: readers["json"].exchange(_http_get(path)),
            "floor_fresh": lambda: floors["samples"].exchange(b"%d\n" % samples_bytes),
            "binary_fresh": lambda: readers["binary"].exchange(_http_get(path + "?format=binary")),
            "floor_json_fresh": lambda: floors["json"].exchange(b"%d\n" % json_bytes),
            "json_fresh": lambda: readers["json"].exchange(_http_get(path)),
            **_before_paths(before_port, path, floors),
        }
        samples = await _blocks(paths, reads, block)
    for reader in (*readers.values(), *floors.values(), raw_socket):
        reader.close()
    await _send(http, base, "bass", "Stop")
    results: dict[str, Any] = _ratios(samples, {k: v for k, v in PAIRS.items() if k in samples})
    results["strict"] = _strict_ratios(samples)
    for name in ("floor", "binary", "socket", "floor_fresh", "binary_fresh", "binary_before"):
        if name in results:
            results[name]["bytes"] = samples_bytes
    for name in ("floor_json", "json", "floor_json_fresh", "json_fresh", "json_before"):
        if name in results:
            results[name]["bytes"] = json_bytes
    results["orjson_parse_ms"] = await _parse_ms(json_body[json_body.index(b"\r\n\r\n") + 4:])
    return results


async def _bass_socket_port(http: aiohttp.ClientSession, base: str) -> int:
    """The port bass's DedicatedSocket listens on (its refusal to open twice names it)."""
    async with http.get(f"{base}/module/bass/send/DedicatedSocket") as reply:
        answer = await reply.json()
    detail = answer.get("exception", {}).get("detail", {})
    return int(detail.get("port", 0))


async def _start_window(http: aiohttp.ClientSession, base: str, chunks: int) -> None:
    await _send(http, base, MODULE, "StartCapture", device="sim", transfer_rate=RATE, chunk_time=CHUNK_MS,
                Port_chunks=chunks)
    async with asyncio.timeout(60):
        while True:  # the window fills in real time (a benchmark, not a test: poll)
            status = (await _send(http, base, MODULE, "GetCaptureStatus"))["output"]
            if status["capturing"] and status["index"] >= chunks:  # capturing: the new window's index
                return
            await asyncio.sleep(0.2)


async def _stop_window(http: aiohttp.ClientSession, base: str) -> None:
    await _send(http, base, MODULE, "StopCapture")
    async with asyncio.timeout(30):
        while (await _send(http, base, MODULE, "GetCaptureStatus"))["output"]["capturing"]:
            await asyncio.sleep(0.05)  # the capture ends as its activity is interrupted


async def run(reads: int = 50, block: int = 10, windows: tuple[int, ...] = tuple(WINDOWS)) -> Result:
    """Measure every path for the *windows* (lengths in ms, of :data:`WINDOWS`), and bass's port."""
    results: dict[str, Any] = {}
    async with contextlib.AsyncExitStack() as stack:
        port, _ = await stack.enter_async_context(server("gateway"))
        floor_port, _ = await stack.enter_async_context(server("socket"))
        strict_port, _ = await stack.enter_async_context(server("socket_strict"))
        before_port = (await stack.enter_async_context(server("gateway", BASELINE)))[0] if BASELINE else None
        base = f"http://127.0.0.1:{port}"
        bases = [base] + ([f"http://127.0.0.1:{before_port}"] if before_port else [])
        http = await stack.enter_async_context(aiohttp.ClientSession(read_bufsize=1 << 22))
        for each in bases:
            await _start_bass(http, each)
            await http.get(f"{each}/load/{MODULE}")
        await _send(http, base, MODULE, "DedicatedSocket")
        socket_port = 0
        while not socket_port:  # the socket opens as its activity starts
            socket_port = (await _send(http, base, MODULE, "GetCaptureStatus"))["output"]["socket_port"]
            await asyncio.sleep(0.05)
        for window_ms in windows:
            chunks = WINDOWS[window_ms]
            print(f"bench: port_read {window_ms} ms", file=sys.stderr, flush=True)
            await asyncio.gather(*(_start_window(http, each, chunks) for each in bases))
            results[str(window_ms)] = await _capture_window(base, port, socket_port, floor_port, strict_port, chunks,
                                                            reads, block, before_port)
            await asyncio.gather(*(_stop_window(http, each) for each in bases))
        await _send(http, base, MODULE, "CloseSocket")
        bass = await _bass(http, base, port, floor_port, strict_port, reads, block, before_port)
    verdicts: dict[str, str] = {}
    for where, paths in [*((f"{w} ms", results[str(w)]) for w in windows), ("bass", bass)]:
        for name, target in TARGETS.items():
            verdicts[f"{where} {name}"] = "met" if paths[name]["ratio_to_floor"] <= target else "MISSED"
            if name + FRESH in paths:
                verdicts[f"{where} {name}{FRESH}"] = ("met" if paths[name + FRESH]["ratio_to_floor"] <= target
                                                      else "MISSED")
        if where in ("4000 ms", "bass"):
            for name, target in STRICT_TARGETS.items():
                verdicts[f"{where} {name} (strict floor)"] = ("met" if paths["strict"][name]["ratio"] <= target
                                                              else "MISSED")
    return {"windows": results, "bass": bass, "module": MODULE, "targets": TARGETS, "strict_targets": STRICT_TARGETS,
            "seed_ms": SEED_MS,
            "verdicts": verdicts, "baseline": baseline_name()}
