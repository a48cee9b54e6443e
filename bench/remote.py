"""Remote components (issue 11): a gateway hosting the components beside one fronting a component host.

Both are measured in the same run, taking turns in blocks:

* service round trip through the generated client (``demo.GetSpeed``): remote ÷ in-process ≤ 2×;
* 4000 ms window of ``capture`` read as binary, request to last byte: remote ÷ in-process ≤ 3×;
* a remote ``capture`` read by 4 ``since=`` readers for a minute: lost chunks (0) and the gateway's CPU.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import os
import re
import statistics
import sys
import time
from collections.abc import AsyncIterator, Awaitable, Callable, Sequence
from typing import Any

import aiohttp
import zenoh

from aiogenomix.clients import aconnect
from aiogenomix.clients._binary import decode_binary
from aiogenomix.components.core.runtime import RemoteUnreachable
from aiogenomix.remote._session import ZenohSettings, ask, open_session

from ._common import ROOT, Result, cpu_seconds, free_port, summary

SERVICE_TARGET = 2.0
READ_TARGET = 3.0
CAPTURE = {"device": "sim", "transfer_rate": 44100, "chunk_time": 50, "Port_chunks": 80}  # 4000 ms


@contextlib.asynccontextmanager
async def _process(args: list[str], ready: str, stream: str) -> AsyncIterator[tuple[re.Match[str], int]]:
    process = await asyncio.create_subprocess_exec(
        sys.executable, *args, cwd=ROOT, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    reader = process.stdout if stream == "stdout" else process.stderr
    drains: list[asyncio.Task[None]] = []
    try:
        assert reader is not None
        while not (found := re.search(ready, (await asyncio.wait_for(reader.readline(), 60)).decode())):
            pass
        for pipe in (process.stdout, process.stderr):
            drains.append(asyncio.create_task(_drain(pipe)))  # type: ignore[arg-type]
        yield found, process.pid
    finally:
        process.terminate()
        await process.wait()
        await asyncio.gather(*drains, return_exceptions=True)


async def _drain(reader: asyncio.StreamReader) -> None:
    while await reader.read(65536):
        pass


@contextlib.asynccontextmanager
async def _gateways() -> AsyncIterator[tuple[str, str, int]]:
    """An in-process gateway, and a gateway fronting a component host (demo, capture); yields URLs and its pid."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    gateway = ["-m", "aiogenomix.gateway", "--port", "0", "--audio-socket-port", "0", "--log-level", "warning"]
    async with (
        _process(gateway, r"listening on (http://\S+)", "stdout") as (local, _),
        _process(["-m", "aiogenomix.remote._host_main", "demo", "capture", "--audio-socket-port", "0",
                  "--zenoh-listen", endpoint], r"offering", "stderr"),
        _process([*gateway, "--zenoh-connect", endpoint], r"listening on (http://\S+)", "stdout") as (remote, pid),
    ):
        yield local.group(1), remote.group(1), pid


@contextlib.asynccontextmanager
async def _zenoh_floor() -> AsyncIterator[zenoh.Session]:
    """A session connected to a process that answers bare Zenoh queries from its event loop."""
    async with _process(["-m", "bench._server", "zenoh"], r"ready (\S+)", "stdout") as (found, _):
        session, _ = await asyncio.to_thread(open_session, ZenohSettings(connect=[found.group(1)]))
        try:
            while True:  # connected once a query is answered
                with contextlib.suppress(RemoteUnreachable):
                    await ask(session, "bench/floor", None, 1.0, what="the floor")
                    break
            yield session
        finally:
            await asyncio.to_thread(session.close)


async def _service_blocks(urls: tuple[str, str], floor: zenoh.Session, calls: int, blocks: int) -> dict[str, Any]:
    """The round trips in-process and remote, and the floor: a bare Zenoh query answered from a loop."""
    async with aconnect(urls[0]) as local, aconnect(urls[1]) as remote:
        demos = (await local.load("demo"), await remote.load("demo"))

        async def floor_call() -> None:
            await ask(floor, "bench/floor", {"service": "GetSpeed"}, 5.0, what="the floor")

        calls_of = (demos[0].GetSpeed, demos[1].GetSpeed, floor_call)
        for call in calls_of:
            for _ in range(calls // 5):  # warm-up
                await call()
        local_blocks, remote_blocks, floor_blocks = await _in_turns(calls_of, calls // blocks, blocks)
    local_medians, remote_medians, floor_medians = (
        [statistics.median(block) for block in case] for case in (local_blocks, remote_blocks, floor_blocks))
    ratios = [r / m for r, m in zip(remote_medians, local_medians, strict=True)]
    bounds = [(m + f) / m for m, f in zip(local_medians, floor_medians, strict=True)]
    ratio = statistics.median(ratios)
    return {"in_process": summary(_flat(local_blocks)), "remote": summary(_flat(remote_blocks)), "ratio": ratio,
            "spread": [min(ratios), max(ratios)], "target_ratio": SERVICE_TARGET,
            "verdict": "met" if ratio <= SERVICE_TARGET else "MISSED",
            "zenoh_floor": summary(_flat(floor_blocks)), "floor_ratio": statistics.median(bounds)}


async def _in_turns(calls: Sequence[Callable[[], Awaitable[Any]]], per_block: int,
                    blocks: int) -> list[list[list[float]]]:
    """Per call, the durations (s) of each of *blocks* blocks of *per_block* calls.

    The calls take turns block by block, so that all of them see the same machine.
    """
    timed: list[list[list[float]]] = [[] for _ in calls]
    for _ in range(blocks):
        for call, kept in zip(calls, timed, strict=True):
            block = []
            for _ in range(per_block):
                started = time.perf_counter()
                await call()
                block.append(time.perf_counter() - started)
            kept.append(block)
    return timed


def _flat(blocks: list[list[float]]) -> list[float]:
    return [t for block in blocks for t in block]


async def _start_capture(http: aiohttp.ClientSession, url: str) -> None:
    async with http.get(f"{url}/load/capture"):
        pass
    async with http.get(f"{url}/module/capture/send/StartCapture", params={"input": _json(CAPTURE)}) as reply:
        assert (await reply.json())["status"] == "sent"
    # Until the window is full, reads are of zero padding: wait for 4 s of chunks.
    while True:
        async with http.get(f"{url}/module/capture/read/Port", params={"format": "binary"}) as reply:
            _, data, _ = decode_binary(await reply.read())
        if data["index"] >= CAPTURE["Port_chunks"]:
            return
        await asyncio.sleep(0.25)


def _json(value: Any) -> str:
    import json

    return json.dumps(value)


async def _read_blocks(urls: tuple[str, str], reads: int, blocks: int) -> dict[str, Any]:
    async with aiohttp.ClientSession() as http:
        await asyncio.gather(*(_start_capture(http, url) for url in urls))
        size = 0

        def reader(url: str) -> Callable[[], Awaitable[None]]:
            async def read() -> None:
                nonlocal size
                async with http.get(f"{url}/module/capture/read/Port", params={"format": "binary"}) as reply:
                    size = len(await reply.read())
            return read

        local_blocks, remote_blocks = await _in_turns([reader(url) for url in urls], reads // blocks, blocks)
    ratios = [statistics.median(r) / statistics.median(m) for r, m in zip(remote_blocks, local_blocks, strict=True)]
    ratio = statistics.median(ratios)
    return {"bytes": size, "in_process": summary(_flat(local_blocks)), "remote": summary(_flat(remote_blocks)),
            "ratio": ratio, "spread": [min(ratios), max(ratios)], "target_ratio": READ_TARGET,
            "verdict": "met" if ratio <= READ_TARGET else "MISSED"}


async def _since_readers(url: str, pid: int, seconds: float, readers: int = 4) -> dict[str, Any]:
    """*readers* clients reading what is new every 100 ms from the remote capture; lost chunks, gateway CPU."""
    async with aiohttp.ClientSession() as http:
        idle_from, idle_cpu = time.monotonic(), cpu_seconds(pid)
        await asyncio.sleep(min(10.0, seconds / 4))
        idle = (cpu_seconds(pid) - idle_cpu) / (time.monotonic() - idle_from)

        async def reader() -> tuple[int, int]:
            index, lost, chunks = None, 0, 0
            ends = time.monotonic() + seconds
            while time.monotonic() < ends:
                params = {"format": "binary", "since": str(index if index is not None else 0)}
                async with http.get(f"{url}/module/capture/read/Port", params=params) as reply:
                    _, data, extra = decode_binary(await reply.read())
                if index is not None:
                    lost += extra["lost"]
                    chunks += data["index"] - index
                index = data["index"]
                await asyncio.sleep(0.1)
            return chunks, lost

        began, cpu = time.monotonic(), cpu_seconds(pid)
        results = await asyncio.gather(*(reader() for _ in range(readers)))
        busy = (cpu_seconds(pid) - cpu) / (time.monotonic() - began)
    return {"seconds": seconds, "readers": readers, "chunks": [c for c, _ in results],
            "lost": sum(lost for _, lost in results), "gateway_cpu_idle_percent": 100 * idle,
            "gateway_cpu_percent": 100 * busy, "gateway_cpu_per_reader_percent": 100 * (busy - idle) / readers,
            "verdict": "met" if sum(lost for _, lost in results) == 0 else "MISSED"}


async def run(calls: int = 2000, reads: int = 200, blocks: int = 10, seconds: float = 60.0) -> Result:
    """The three measurements, on one pair of gateways."""
    async with _gateways() as (local, remote, pid), _zenoh_floor() as floor:
        service = await _service_blocks((local, remote), floor, calls, blocks)
        read = await _read_blocks((local, remote), reads, blocks)
        readers = await _since_readers(remote, pid, seconds)
    return {"service": service, "read_4000ms_binary": read, "since_readers": readers,
            "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "load_average": os.getloadavg()[0]}


def render(r: dict[str, Any]) -> str:
    """The Markdown section of docs/benchmarks.md."""
    s, b, w = r["service"], r["read_4000ms_binary"], r["since_readers"]

    def ms(x: float) -> str:
        return f"{x:.2f}"

    return "\n".join([
        "## Remote components (Zenoh)", "",
        "A gateway hosting `demo` and `capture` itself, and a gateway fronting an `aiogenomix-component demo "
        "capture` process over Zenoh on loopback, measured in the same run, taking turns in blocks; a ratio "
        "is the median over blocks of (remote median ÷ in-process median), the spread its lowest and highest. "
        f"Measured {r.get('date', '')} (load average {r.get('load_average', 0):.1f} on the shared machine: "
        "absolute times are noisy, the ratios less so).",
        "",
        "| what | in-process median ms (p99) | remote median ms (p99) | remote ÷ in-process | block spread | target |",
        "|---|---|---|---|---|---|",
        f"| service round trip, generated client (`demo.GetSpeed`) | {ms(s['in_process']['median'])} "
        f"({ms(s['in_process']['p99'])}) | {ms(s['remote']['median'])} ({ms(s['remote']['p99'])}) | "
        f"**{s['ratio']:.2f}** | {s['spread'][0]:.2f}–{s['spread'][1]:.2f} | ≤ {s['target_ratio']:g}× {s['verdict']} |",
        f"| the floor: a bare Zenoh query between two processes, answered from the event loop | | "
        f"{ms(s['zenoh_floor']['median'])} ({ms(s['zenoh_floor']['p99'])}) | | | |",
        f"| 4000 ms `capture` window, binary, request to last byte ({b['bytes']} bytes) | "
        f"{ms(b['in_process']['median'])} ({ms(b['in_process']['p99'])}) | {ms(b['remote']['median'])} "
        f"({ms(b['remote']['p99'])}) | **{b['ratio']:.2f}** | {b['spread'][0]:.2f}–{b['spread'][1]:.2f} | "
        f"≤ {b['target_ratio']:g}× {b['verdict']} |",
        "",
        f"A remote call cannot cost less than the in-process call plus that floor: "
        f"**{s['floor_ratio']:.2f}×** the in-process call, measured in the same blocks. What the remote call "
        f"costs beyond both ({ms(s['remote']['median'] - s['in_process']['median'] - s['zenoh_floor']['median'])} "
        "ms, medians) is the proxy's and the component host's share: the request's encoding and the host's task "
        "and reply, and three processes taking turns on two cores.",
        "",
        f"{w['readers']} `since=` readers of the remote `capture` (binary, every 100 ms) for {w['seconds']:g} s: "
        f"{', '.join(str(c) for c in w['chunks'])} chunks read, **{w['lost']} lost** ({w['verdict']}). "
        f"The gateway used {w['gateway_cpu_idle_percent']:.1f}% of a core mirroring the capture with no reader, "
        f"{w['gateway_cpu_percent']:.1f}% with the readers: "
        f"**{w['gateway_cpu_per_reader_percent']:.1f}% of a core per reader**.",
        ""])
