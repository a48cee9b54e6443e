"""Event streams read by other people's clients: how long after a request ends each one has its event.

Several readers listen to one session at once: a raw genomix reader (no
``Accept`` header: the close-delimited genomix form), and the standard
clients asking for ``text/event-stream`` (sseclient-py over requests, httpx-sse,
aiohttp-sse-client), plus sseclient-py without the header, as it was read
before the standard form existed.  The probe's ``Stamp`` function ends with the
server's monotonic time; each reader stamps the event when its library hands
it over.  Requests are sent ``INTERVAL`` apart: a client that sees an event
only when the next one's bytes arrive shows a latency of about that interval.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable
from typing import Any

import aiohttp
import httpx
import orjson
import requests
import sseclient
from aiohttp_sse_client import client as aiohttp_sse  # type: ignore[import-untyped]
from httpx_sse import connect_sse

from ._common import Result, server, summary, verdict

#: Seconds between two events (the next event is sent this long after the last one ended).
INTERVAL = 0.2
SESSION = "bench"
STANDARD = {"Accept": "text/event-stream"}
#: Every reader must have each event before the next one is sent.
TARGET_P99_MS = INTERVAL * 1000 / 2

Record = Callable[[bytes], None]


def _recorder(latencies: list[float]) -> Record:
    def record(data: bytes) -> None:
        received = time.monotonic()
        event = orjson.loads(data)
        if event.get("status") == "done":
            latencies.append(received - event["output"]["t"])

    return record


class _RawReader(asyncio.Protocol):
    """A genomix-era reader: the socket's bytes, split into lines as they come."""

    def __init__(self, record: Record) -> None:
        self.record, self.buffer = record, b""

    def data_received(self, data: bytes) -> None:
        self.buffer += data
        *lines, self.buffer = self.buffer.split(b"\n")
        for line in lines:
            if line.startswith(b"data: {"):
                self.record(line[6:])


def _sseclient(base: str, headers: dict[str, str], record: Record, ready: threading.Event,
               stop: threading.Event) -> None:
    reply = requests.get(f"{base}/session/listen?s={SESSION}", stream=True, headers=headers, timeout=30)
    ready.set()
    for event in sseclient.SSEClient(reply.iter_content(128)).events():
        if event.event == "request":
            record(event.data.encode())
        if stop.is_set():
            break
    reply.close()


def _httpx_sse(base: str, record: Record, ready: threading.Event, stop: threading.Event) -> None:
    with httpx.Client(timeout=30) as client, connect_sse(client, "GET", f"{base}/session/listen?s={SESSION}") as es:
        ready.set()
        for event in es.iter_sse():
            if event.event == "request":
                record(event.data.encode())
            if stop.is_set():
                break


async def _aiohttp_sse(base: str, record: Record, ready: asyncio.Event) -> None:
    async with aiohttp_sse.EventSource(f"{base}/session/listen?s={SESSION}", on_open=ready.set) as events:
        async for event in events:
            if event.type == "request":
                record(event.data.encode())


async def run(events: int = 50) -> Result:
    """Measure each reader's latency over *events* request events."""
    readers = ["raw genomix reader", "sseclient-py, Accept: text/event-stream", "httpx-sse", "aiohttp-sse-client",
               "sseclient-py without Accept (genomix form)"]
    latencies: dict[str, list[float]] = {name: [] for name in readers}
    async with server("gateway") as (port, _pid):
        base = f"http://127.0.0.1:{port}"
        loop = asyncio.get_running_loop()
        async with aiohttp.ClientSession() as http:
            await http.get(f"{base}/load/probe")
            transport, _ = await loop.create_connection(
                lambda: _RawReader(_recorder(latencies[readers[0]])), "127.0.0.1", port)
            transport.write(f"GET /session/listen?s={SESSION} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
            stop = threading.Event()
            threads, readies = [], []
            blocking: list[tuple[Callable[..., None], tuple[Any, ...]]] = [
                (_sseclient, (base, STANDARD, _recorder(latencies[readers[1]]))),
                (_httpx_sse, (base, _recorder(latencies[readers[2]]))),
                (_sseclient, (base, {}, _recorder(latencies[readers[4]])))]
            for target, args in blocking:
                ready = threading.Event()
                threads.append(threading.Thread(target=target, args=(*args, ready, stop), daemon=True))
                readies.append(ready)
                threads[-1].start()
            opened = asyncio.Event()
            reader = asyncio.create_task(_aiohttp_sse(base, _recorder(latencies[readers[3]]), opened))
            await opened.wait()
            for ready in readies:
                await asyncio.to_thread(ready.wait, 30)
            for _ in range(events):
                async with http.get(f"{base}/module/probe/send/Stamp", params={"s": SESSION}) as reply:
                    request_id = (await reply.json())["id"]
                await http.get(f"{base}/module/probe/clean/{request_id}")
                await asyncio.sleep(INTERVAL)  # the spacing being measured against, not a synchronisation
            stop.set()
            await http.get(f"{base}/session/stop", params={"s": SESSION})
            for thread in threads:
                await asyncio.to_thread(thread.join, 10)
            reader.cancel()
            await asyncio.gather(reader, return_exceptions=True)
            transport.close()
    figures = {name: summary(samples) if samples else {"n": 0} for name, samples in latencies.items()}
    standard = [figures[name] for name in readers[:4]]
    worst = max(figure.get("p99", float("inf")) for figure in standard)
    return {"readers": figures, "events": events, "interval_ms": INTERVAL * 1000,
            "target_p99_ms": TARGET_P99_MS, "verdict": verdict(worst, TARGET_P99_MS)}


def render(r: Result) -> str:
    """The section of docs/benchmarks.md."""
    lines = ["## Event streams read by standard clients", "",
             f"Latency from a request's end on the server to its `request` event in each reader's hands (same "
             f"monotonic clock), {r['events']} events sent {r['interval_ms']:.0f} ms apart, every reader listening "
             "to the same session at once. A reader that gets an event only when the next one's bytes arrive "
             "shows about the interval.", "",
             "| reader | events | median ms | p99 ms |", "|---|---|---|---|"]
    for name, figure in r["readers"].items():
        if figure.get("n"):
            lines.append(f"| {name} | {figure['n']} | {figure['median']:.2f} | {figure['p99']:.2f} |")
        else:
            lines.append(f"| {name} | 0 | | |")
    lines += ["", f"Target: every standard reader (the first four) has each event before the next is sent, p99 ≤ "
              f"{r['target_p99_ms']:.0f} ms: **{r['verdict']}**. The last row is why the standard form exists "
              "(docs/decisions/0023).", ""]
    return "\n".join(lines)
