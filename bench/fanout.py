"""Event fan-out: 100 readers watching a port, and 100 sessions listening while requests run."""

from __future__ import annotations

import asyncio
import time

import aiohttp
import orjson

from ._common import Result, server, summary, verdict

READERS = 100


class _WatchReader(asyncio.Protocol):
    """A lean reader of one watch stream: splits lines as bytes arrive and stamps each event."""

    def __init__(self, latencies: list[float]) -> None:
        self.latencies = latencies
        self.buffer = b""

    def data_received(self, data: bytes) -> None:
        received = time.monotonic()
        self.buffer += data
        *lines, self.buffer = self.buffer.split(b"\n")
        for line in lines:
            if line.startswith(b"data: "):
                self.latencies.append(received - orjson.loads(line[6:])["Ticks"]["t"])


async def _watch_all(port: int, readers: int, seconds: float, latencies: list[float]) -> None:
    loop = asyncio.get_running_loop()
    transports = []
    for _ in range(readers):
        transport, _protocol = await loop.create_connection(lambda: _WatchReader(latencies), "127.0.0.1", port)
        transport.write(b"GET /module/probe/watch/Ticks HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        transports.append(transport)
    await asyncio.sleep(seconds)  # the benchmark's measuring window, not a synchronisation
    for transport in transports:
        transport.close()


async def _listen(http: aiohttp.ClientSession, base: str, session: str, ready: asyncio.Event,
                  latencies: list[float]) -> None:
    async with http.get(f"{base}/session/listen", params={"s": session}) as stream:
        ready.set()
        async for line in stream.content:
            if line.startswith(b"data: "):
                received = time.monotonic()
                event = orjson.loads(line[6:])
                if event["status"] == "done":
                    latencies.append(received - event["output"]["t"])


async def _drive(http: aiohttp.ClientSession, base: str, sessions: int, until: float) -> int:
    """Send Stamp requests one after another, each to the next session in turn."""
    sent = 0
    while time.monotonic() < until:
        async with http.get(f"{base}/module/probe/send/Stamp", params={"s": f"fan{sent % sessions}"}) as reply:
            request_id = (await reply.json())["id"]
        await http.get(f"{base}/module/probe/clean/{request_id}")
        sent += 1
    return sent


async def run(seconds: float = 10.0) -> Result:
    """Measure publication-to-receipt latency with READERS concurrent readers."""
    async with server("gateway") as (port, _pid):
        base = f"http://127.0.0.1:{port}"
        connector = aiohttp.TCPConnector(limit=0)
        async with aiohttp.ClientSession(connector=connector) as http:
            await http.get(f"{base}/load/probe")
            watch_latencies: list[float] = []
            await _watch_all(port, READERS, seconds, watch_latencies)
            session_latencies: list[float] = []
            readies = [asyncio.Event() for _ in range(READERS)]
            listeners = [asyncio.create_task(_listen(http, base, f"fan{i}", readies[i], session_latencies))
                         for i in range(READERS)]
            await asyncio.gather(*(ready.wait() for ready in readies))
            await _drive(http, base, READERS, time.monotonic() + seconds)
            for listener in listeners:
                listener.cancel()
            await asyncio.gather(*listeners, return_exceptions=True)
    watch, sessions = summary(watch_latencies), summary(session_latencies)
    return {
        "watch": watch, "sessions": sessions,
        "target_p99_ms": 10.0,
        "verdict": verdict(max(watch["p99"], sessions["p99"]), 10.0),
    }
