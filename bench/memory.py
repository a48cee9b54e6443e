"""The gateway's memory: resident size at start, with ten components loaded, per session and per uncleaned request."""

from __future__ import annotations

import asyncio
from typing import Any

import aiohttp

from ._common import Result, server, tree_rss_bytes

#: Ten components besides demo (loaded first): every one installed.
COMPONENTS = ["countserver", "countclient", "kemar", "capture", "kemarcapture", "bass", "basc", "pr2",
              "morse_kemar", "world"]
TARGET_START_MB = 60.0
#: A session costs at most this much (the sessions are bounded by --max-sessions: 256).
TARGET_SESSION_KB = 16.0


async def _settled_rss(pid: int) -> int:
    """RSS of the gateway and its children once it stops moving (allocations settle within a few loop turns)."""
    await asyncio.sleep(0.5)
    return tree_rss_bytes(pid)


async def run(sessions: int = 250, requests: int = 5000) -> Result:
    """Measure RSS at start, after loading COMPONENTS, and the cost of sessions and uncleaned requests."""
    async with server("gateway") as (port, pid):
        base = f"http://127.0.0.1:{port}"
        start = await _settled_rss(pid)
        loaded, failed = [], {}
        async with aiohttp.ClientSession() as http:
            # Sessions and requests first, with only demo loaded: the other components'
            # simulations allocate as they run, which would blur a few kilobytes per session.
            await http.get(f"{base}/load/demo")
            before = await _settled_rss(pid)
            for i in range(sessions):
                async with http.get(f"{base}/session/start", params={"s": f"bench-{i}"}) as reply:
                    await reply.read()
            per_session = (await _settled_rss(pid) - before) / sessions
            # Requests never cleaned: each stays readable (status, wait) until its session ends.
            before = await _settled_rss(pid)
            for _ in range(requests):
                async with http.get(f"{base}/module/demo/send/GetSpeed", params={"s": "bench-0"}) as reply:
                    await reply.read()
            per_request = (await _settled_rss(pid) - before) / requests
            for name in COMPONENTS:
                async with http.get(f"{base}/load/{name}") as reply:
                    if reply.status == 200:
                        loaded.append(name)
                    else:
                        failed[name] = (await reply.text())[:200]
            with_components = await _settled_rss(pid)
    result: dict[str, Any] = {
        "rss_start_mb": start / 2**20, "rss_loaded_mb": with_components / 2**20, "components": loaded,
        "failed": failed, "per_session_bytes": per_session, "sessions": sessions, "per_request_bytes": per_request,
        "requests": requests, "target_start_mb": TARGET_START_MB, "target_session_kb": TARGET_SESSION_KB,
    }
    result["verdict"] = ("met" if start / 2**20 <= TARGET_START_MB and per_session <= TARGET_SESSION_KB * 1024
                         else "MISSED")
    return result
