"""Remote components: a gateway hosting the components beside one fronting a component host, and the relay floor.

Measured in the same run, taking turns in blocks:

* a service call from a raw HTTP client (no client library): in-process, remote, and the relay floor F
  (a bare aiohttp server forwarding each request through one Zenoh query to a queryable answered from
  an event loop in another process: the three processes of a remote call and nothing else).
  Target: (remote − in-process) ≤ 1.2 × F, block by block;
* the same call through the generated client (reported, no target);
* 4000 ms window of ``capture`` read as binary, request to last byte: remote ÷ in-process ≤ 1.1×;
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

from aiogenomix.clients import aconnect
from aiogenomix.clients._binary import decode_binary

from ._common import ROOT, Result, cpu_seconds, free_port, summary
from ._raw import RawReader

#: (remote − in-process) ÷ F, the relay floor: what the remote layer may add beyond a bare relay.
RELAY_TARGET = 1.2
READ_TARGET = 1.1
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
        _process(["-m", "aiogenomix.remote._host_main", "demo", "capture", "--host-id", "bench",
                  "--audio-socket-port", "0", "--zenoh-listen", endpoint], r"offering", "stderr"),
        _process([*gateway, "--zenoh-connect", endpoint], r"listening on (http://\S+)", "stdout") as (remote, pid),
    ):
        yield local.group(1), remote.group(1), pid


@contextlib.asynccontextmanager
async def _relay_floor() -> AsyncIterator[int]:
    """The relay floor: a bare aiohttp relay process and the Zenoh floor's answering process; yields its port."""
    async with (
        _process(["-m", "bench._server", "zenoh"], r"ready (\S+)", "stdout") as (answerer, _),
        _process(["-m", "bench._server", "relay", "--connect", answerer.group(1)], r"ready (\d+)",
                 "stdout") as (relay, _),
    ):
        yield int(relay.group(1))


def _port_of(url: str) -> int:
    return int(url.rsplit(":", 1)[1])


async def _raw_call(port: int, path: str) -> Callable[[], Awaitable[None]]:
    """A call of *path* on 127.0.0.1:*port* over one kept-alive connection, read by a raw HTTP client."""
    reader = await RawReader.connect(port, http=True)
    request = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode()

    async def call() -> None:
        reply = await reader.exchange(request)
        if bytes(reply[9:12]) != b"200":
            raise RuntimeError(f"GET {path}: {bytes(reply[:200])!r}")

    return call


async def _relay_blocks(urls: tuple[str, str], relay: int, calls: int, blocks: int) -> dict[str, Any]:
    """A service call from a raw HTTP client: in-process, remote, and the relay floor, in the same blocks."""
    async with aiohttp.ClientSession() as http:
        for url in urls:
            async with http.get(f"{url}/load/demo") as reply:
                assert reply.status == 200, await reply.text()
    path = "/module/demo/send/GetSpeed"
    calls_of = [await _raw_call(_port_of(urls[0]), path), await _raw_call(_port_of(urls[1]), path),
                await _raw_call(relay, path)]
    for call in calls_of:
        for _ in range(calls // 5):  # warm-up
            await call()
    local_blocks, remote_blocks, floor_blocks = await _in_turns(calls_of, calls // blocks, blocks)
    medians = [[statistics.median(block) for block in case] for case in (local_blocks, remote_blocks, floor_blocks)]
    ratios = [(r - m) / f for m, r, f in zip(*medians, strict=True)]
    ratio = statistics.median(ratios)
    return {"in_process": summary(_flat(local_blocks)), "remote": summary(_flat(remote_blocks)),
            "relay_floor": summary(_flat(floor_blocks)), "ratio": ratio, "spread": [min(ratios), max(ratios)],
            "added_ms": statistics.median(r - m for m, r, _ in zip(*medians, strict=True)) * 1e3,
            "target_ratio": RELAY_TARGET, "verdict": "met" if ratio <= RELAY_TARGET else "MISSED"}


async def _client_blocks(urls: tuple[str, str], calls: int, blocks: int) -> dict[str, Any]:
    """The same call through the generated client (reported beside the raw figures, no target)."""
    async with aconnect(urls[0]) as local, aconnect(urls[1]) as remote:
        demos = (await local.load("demo"), await remote.load("demo"))
        calls_of = (demos[0].GetSpeed, demos[1].GetSpeed)
        for call in calls_of:
            for _ in range(calls // 5):  # warm-up
                await call()
        local_blocks, remote_blocks = await _in_turns(calls_of, calls // blocks, blocks)
    return {"in_process": summary(_flat(local_blocks)), "remote": summary(_flat(remote_blocks))}


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
    """The measurements, on one pair of gateways and one relay floor."""
    async with _gateways() as (local, remote, pid), _relay_floor() as relay:
        service = await _relay_blocks((local, remote), relay, calls, blocks)
        client = await _client_blocks((local, remote), calls, blocks)
        read = await _read_blocks((local, remote), reads, blocks)
        readers = await _since_readers(remote, pid, seconds)
    ms = "{:.2f}".format
    print(f"bench: remote: (remote − in-process) ÷ relay floor F = {service['ratio']:.2f} "
          f"(target ≤ {RELAY_TARGET:g}: {service['verdict']}; blocks {service['spread'][0]:.2f}–"
          f"{service['spread'][1]:.2f}); p50/p99 ms: in-process {ms(service['in_process']['median'])}/"
          f"{ms(service['in_process']['p99'])}, remote {ms(service['remote']['median'])}/"
          f"{ms(service['remote']['p99'])}, F {ms(service['relay_floor']['median'])}/"
          f"{ms(service['relay_floor']['p99'])}", file=sys.stderr, flush=True)
    return {"service": service, "client": client, "read_4000ms_binary": read, "since_readers": readers,
            "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "load_average": os.getloadavg()[0]}


def render(r: dict[str, Any]) -> str:
    """The Markdown section of docs/benchmarks.md."""
    s, b, w = r["service"], r["read_4000ms_binary"], r["since_readers"]
    c = r.get("client")

    def ms(x: float) -> str:
        return f"{x:.2f}"

    def cell(figures: dict[str, float]) -> str:
        return f"{ms(figures['median'])} / {ms(figures['p99'])}"

    rows = [
        "## Remote components (Zenoh)", "",
        "A gateway hosting `demo` and `capture` itself, a gateway fronting an `aiogenomix-component demo "
        "capture` process over Zenoh on loopback, and the relay floor F: a bare aiohttp server that forwards "
        "each request through one Zenoh query to a queryable answered from an event loop in another process "
        "(the three processes of a remote call, and nothing else). All three are measured in the same run, "
        "taking turns in blocks, from a raw HTTP client (one kept-alive connection, no client library). "
        f"Measured {r.get('date', '')} (load average {r.get('load_average', 0):.1f}).",
        "",
        "| what | median / p99 ms |",
        "|---|---|",
        f"| `demo` `GetSpeed`, in-process | {cell(s['in_process'])} |",
        f"| `demo` `GetSpeed`, remote | {cell(s['remote'])} |",
        f"| the relay floor F | {cell(s['relay_floor'])} |",
        "",
        f"What the remote layer adds, block by block: (remote − in-process) ÷ F = **{s['ratio']:.2f}** (blocks "
        f"{s['spread'][0]:.2f}–{s['spread'][1]:.2f}; {ms(s['added_ms'])} ms added), target ≤ "
        f"{s['target_ratio']:g}: **{s['verdict']}**. The old target (remote ≤ 2× in-process) is retired: a bare "
        "relay alone costs more than an in-process call on this machine.",
        "",
    ]
    if c is not None:
        rows += [f"Through the generated client (`await demo.GetSpeed()`, a session's bookkeeping included): "
                 f"in-process {cell(c['in_process'])} ms, remote {cell(c['remote'])} ms (median / p99).", ""]
    rows += [
        f"A 4000 ms `capture` window, binary, request to last byte ({b['bytes']} bytes): in-process "
        f"{cell(b['in_process'])} ms, remote {cell(b['remote'])} ms: remote ÷ in-process **{b['ratio']:.2f}** "
        f"(blocks {b['spread'][0]:.2f}–{b['spread'][1]:.2f}), target ≤ {b['target_ratio']:g}: {b['verdict']} "
        "(the gateway answers from its copy).",
        "",
        f"{w['readers']} `since=` readers of the remote `capture` (binary, every 100 ms) for {w['seconds']:g} s: "
        f"{', '.join(str(c) for c in w['chunks'])} chunks read, **{w['lost']} lost** ({w['verdict']}). "
        f"The gateway used {w['gateway_cpu_idle_percent']:.1f}% of a core mirroring the capture with no reader, "
        f"{w['gateway_cpu_percent']:.1f}% with the readers: "
        f"**{w['gateway_cpu_per_reader_percent']:.1f}% of a core per reader**.",
        ""]
    return "\n".join(rows)
