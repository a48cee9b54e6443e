"""Session admission: what starting a session costs with thousands of sessions already there.

Any client can start sessions, so admitting one must not cost more as they pile up (the cap,
``--max-sessions``, bounds their number; a session nobody listens to expires after
``--session-idle``).  A raw client starts sessions one after another on one kept-alive
connection, up to ``sessions``, and the first and the last ``sample`` starts are compared.
"""

from __future__ import annotations

import asyncio
import statistics
import time

from ._common import Result, server, verdict

#: The last starts may cost at most this many times the first ones.
TARGET_RATIO = 2.0


async def run(sessions: int = 15_000, sample: int = 500) -> Result:
    """Time each ``/session/start?s=`` (the gateway picks the name) from the first to the *sessions*-th."""
    async with server("gateway", args=["--max-sessions", str(sessions + 10)]) as (port, _pid):
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        request = b"GET /session/start?s= HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"
        times = []
        try:
            for _ in range(sessions):
                started = time.perf_counter()
                writer.write(request)
                head = await reader.readuntil(b"\r\n\r\n")
                length = int(head.lower().split(b"content-length: ")[1].split(b"\r\n")[0])
                await reader.readexactly(length)
                times.append(time.perf_counter() - started)
                if not head.startswith(b"HTTP/1.1 200"):
                    raise RuntimeError(f"session start refused: {head!r}")
        finally:
            writer.close()
    first = statistics.median(times[:sample]) * 1e3
    last = statistics.median(times[-sample:]) * 1e3
    ratio = last / first
    return {"sessions": sessions, "sample": sample, "first_ms": first, "last_ms": last, "ratio": ratio,
            "target_ratio": TARGET_RATIO, "verdict": verdict(ratio, TARGET_RATIO)}


def render(r: Result) -> str:
    """The section of docs/benchmarks.md."""
    return "\n".join([
        "## Session admission", "",
        f"Starting sessions one after another on one connection, up to {r['sessions']:,} (the gateway started "
        f"with `--max-sessions` above that): the median start of the first {r['sample']} against that of the "
        f"last {r['sample']}.", "",
        "| first starts, median ms | last starts, median ms | ratio |", "|---|---|---|",
        f"| {r['first_ms']:.3f} | {r['last_ms']:.3f} | {r['ratio']:.2f} |", "",
        f"Target: the last within {r['target_ratio']:g}× the first: **{r['verdict']}**.", ""])
