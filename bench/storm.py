"""A reconnect storm (issue 29, item 7): listens that replay a session's latest events and drop, and the memory after.

The gateway's command line, ``demo`` loaded, a session holding 1,000 events (the most it keeps).
Each round, ``listens`` standard listens (``Accept: text/event-stream``, ``Last-Event-ID: 0``: the
whole replay) connect at once from clients with a 4 KiB receive buffer that read nothing and drop
50 ms after asking.  The gateway's resident memory is sampled every 50 ms: its peak, after each
round, and a minute after the last.  Before issue 29, 3,000 such listens raised it by 343 MiB, and
it levelled at about +290 MB over repeated rounds: each listen held the whole replay joined into one
write, and its own copy of every event with its id.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket

import aiohttp

from ._common import Result, rss_bytes, verdict
from .budgets import _gateway, _Peak

MB = 1e6
#: The target: a minute after the storm, the gateway holds at most this much more than before it.
WITHIN_MB = 50.0
EVENTS = 1000
#: What the same storm made the gateway grow before issue 29 (``main`` at d5f1c87, this machine, MB).
BEFORE_MB = 20.3
REQUEST = (b"GET /session/listen?s=storm HTTP/1.1\r\nHost: 127.0.0.1\r\nAccept: text/event-stream\r\n"
           b"Last-Event-ID: 0\r\n\r\n")


async def _listen_and_drop(port: int) -> None:
    loop = asyncio.get_running_loop()
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.setblocking(False)
    try:
        await loop.sock_connect(sock, ("127.0.0.1", port))
        await loop.sock_sendall(sock, REQUEST)
        await asyncio.sleep(0.05)  # the client's own life: it drops 50 ms into the replay
    except OSError:
        pass  # a connection the machine refused under the storm: it asked for nothing
    finally:
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")  # reset
        sock.close()


async def run(listens: int = 3000, rounds: int = 3, settle: float = 60.0) -> Result:
    """The storm (see the module's description)."""
    async with _gateway("--load", "demo") as (url, _, pid, _process):
        port = int(url.rsplit(":", 1)[1].rstrip("/"))
        async with aiohttp.ClientSession(url, connector=aiohttp.TCPConnector(limit=16)) as http:
            async with http.get("/session/start", params={"s": "storm"}):
                pass

            async def send() -> None:
                async with http.get("/module/demo/send/GetSpeed", params={"s": "storm"}) as reply:
                    await reply.read()
            await asyncio.gather(*(send() for _ in range(EVENTS)))
        await asyncio.sleep(1.0)  # settled: the requests' own allocations gone
        before = rss_bytes(pid)
        after_rounds = []
        async with _Peak(pid) as peak:
            for _ in range(rounds):
                await asyncio.gather(*(_listen_and_drop(port) for _ in range(listens)))
                await asyncio.sleep(1.0)  # the gateway's side of the last ones ends
                after_rounds.append(rss_bytes(pid))
        await asyncio.sleep(settle)  # the requirement is about a minute after: the measure is of time
        settled = rss_bytes(pid)
    grew = (settled - before) / MB
    return {"listens": listens, "rounds": rounds, "events": EVENTS, "before_mb": before / MB,
            "peak_mb": peak.peak / MB, "after_rounds_mb": [r / MB for r in after_rounds], "settle_s": settle,
            "settled_mb": settled / MB, "grew_mb": grew, "target_mb": WITHIN_MB, "verdict": verdict(grew, WITHIN_MB)}


def render(r: Result) -> str:
    """The section of docs/benchmarks.md."""
    rounds = ", ".join(f"{m:.0f}" for m in r["after_rounds_mb"])
    return "\n".join([
        "## A reconnect storm: listens that replay and drop", "",
        f"The gateway's command line, `demo` loaded, a session holding {r['events']:,} events (the most it keeps). "
        f"Each of {r['rounds']} rounds, {r['listens']:,} standard listens with `Last-Event-ID: 0` (the whole "
        "replay) connect at once from clients with a 4 KiB receive buffer that read nothing and drop 50 ms after "
        "asking. Memory is the gateway's resident set (MB).", "",
        "| before | peak | after each round | a minute after | grew | target |",
        "|---|---|---|---|---|---|",
        f"| {r['before_mb']:.0f} | {r['peak_mb']:.0f} | {rounds} | {r['settled_mb']:.0f} | {r['grew_mb']:+.1f} | "
        f"within {r['target_mb']:.0f}: **{r['verdict']}** |", "",
        f"The code before issue 29 grew {BEFORE_MB:.0f} MB in this storm on the same machine: these events are "
        "small (about 100 bytes, a 100 kB replay), and what stays is the allocator's keep after 3,000 connections "
        "at once, not the replays. The issue's storm (larger events) grew 343 MiB, levelling at about +290 MB. "
        "tracemalloc found each listen holding the whole replay joined into one write, and its own copy of every "
        "event with its id: 300 stalled listens of this session held 17.3 MB, now 7.3 MB (the rest is aiohttp's "
        "state of each connection). The events are now framed once in both forms, a listen holds references, "
        "and a replay goes out in 16 KiB slices: what a dying listen holds no longer grows with the events.", ""])
