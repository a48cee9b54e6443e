"""Streaming soak: 8 dedicated-socket readers and 8 incremental HTTP readers for minutes, at real time."""

from __future__ import annotations

import asyncio
import json
import time
from typing import Any

import aiohttp

from aiogenomix.clients import AsyncAudioSocketClient, aconnect

from ._common import Result, cpu_seconds, rss_bytes, server
from .port_read import CHUNK_MS, FRAMES, RATE

READERS = 8
PORT_CHUNKS = 20


async def _socket_reader(port: int, until: float, stats: dict[str, int]) -> None:
    async with AsyncAudioSocketClient("127.0.0.1", port, frames_per_chunk=FRAMES) as audio:
        first = True
        while time.monotonic() < until:
            block = await audio.read()
            if not first:  # the first read starts wherever the window is
                stats["lost"] += block.lost
            first = False
            stats["chunks"] += block.count
            await asyncio.sleep(0.1)  # a reader that polls every 100 ms (2 chunks)


async def _http_reader(base: str, until: float, stats: dict[str, int]) -> None:
    """The generated client asking for the chunks after the last one it holds (binary form)."""
    async with aconnect(base) as client:
        port = (await client.module("capture")).Port
        index = (await port()).index  # start wherever the window is
        while time.monotonic() < until:
            await asyncio.sleep(0.1)  # a reader that polls every 100 ms (2 chunks)
            data, lost = await port(since=index)
            stats["lost"] += lost
            stats["chunks"] += data.left.size // FRAMES
            index = data.index


async def run(seconds: float = 120.0) -> Result:
    """Report chunks lost, the gateway's CPU share and its memory at start and end."""
    async with server("gateway") as (port, pid):
        base = f"http://127.0.0.1:{port}"
        async with aiohttp.ClientSession(read_bufsize=1 << 22) as http:
            await http.get(f"{base}/load/capture")
            await http.get(f"{base}/module/capture/send/DedicatedSocket")
            socket_port = 0
            while not socket_port:  # the socket opens as its activity starts
                async with http.get(f"{base}/module/capture/send/GetCaptureStatus") as reply:
                    socket_port = (await reply.json())["output"]["socket_port"]
                await asyncio.sleep(0.05)
            request = {"device": "sim", "transfer_rate": RATE, "chunk_time": CHUNK_MS, "Port_chunks": PORT_CHUNKS}
            await http.get(f"{base}/module/capture/send/StartCapture", params={"input": json.dumps(request)})
            await asyncio.sleep(2 * PORT_CHUNKS * CHUNK_MS / 1000)  # let the window fill
            socket_stats = [{"chunks": 0, "lost": 0} for _ in range(READERS)]
            http_stats = [{"chunks": 0, "lost": 0} for _ in range(READERS)]
            rss_start, cpu_start, wall_start = rss_bytes(pid), cpu_seconds(pid), time.monotonic()
            until = wall_start + seconds
            await asyncio.gather(*(_socket_reader(socket_port, until, s) for s in socket_stats),
                                 *(_http_reader(base, until, s) for s in http_stats))
            cpu_share = (cpu_seconds(pid) - cpu_start) / (time.monotonic() - wall_start)
            rss_end = rss_bytes(pid)
    lost = sum(s["lost"] for s in socket_stats + http_stats)
    growth = rss_end / rss_start - 1
    expected = seconds * 1000 / CHUNK_MS
    result: dict[str, Any] = {
        "seconds": seconds, "chunks_lost": lost,
        "chunks_per_socket_reader": [s["chunks"] for s in socket_stats],
        "chunks_per_http_reader": [s["chunks"] for s in http_stats], "chunks_expected_per_reader": expected,
        "gateway_cpu_share_of_one_core": cpu_share, "rss_start_mb": rss_start / 2**20,
        "rss_end_mb": rss_end / 2**20, "rss_growth": growth,
        "targets": {"chunks_lost": 0, "cpu_share": 0.15, "rss_growth": 0.10},
    }
    result["verdict"] = "met" if lost == 0 and cpu_share <= 0.15 and growth <= 0.10 else "MISSED"
    return result
