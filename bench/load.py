"""Load: 50 concurrent clients calling a function service, against a bare aiohttp handler (wrk)."""

from __future__ import annotations

import asyncio
import re
import shutil

import aiohttp

from ._common import Result, server, verdict

CONNECTIONS = 50


async def _wrk(url: str, seconds: float) -> dict[str, float]:
    process = await asyncio.create_subprocess_exec(
        "wrk", "-t1", f"-c{CONNECTIONS}", f"-d{int(seconds)}s", "--latency", url,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT,
    )
    out = (await process.communicate())[0].decode()
    rate = float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1))  # type: ignore[union-attr]
    total = int(re.search(r"(\d+) requests in", out).group(1))  # type: ignore[union-attr]
    errors = 0
    if match := re.search(r"Non-2xx or 3xx responses: (\d+)", out):
        errors += int(match.group(1))
    if match := re.search(r"Socket errors: connect (\d+), read (\d+), write (\d+), timeout (\d+)", out):
        errors += sum(int(n) for n in match.groups())
    return {"requests_per_s": rate, "requests": total, "errors": errors}


async def run(seconds: float = 30.0) -> Result:
    """Throughput of ``send`` of a function (its reply is already ``done``) vs a bare handler."""
    if shutil.which("wrk") is None:
        return {"skipped": "wrk is not installed (./run bench installs it)"}
    async with server("gateway") as (port, _):
        base = f"http://127.0.0.1:{port}"
        async with aiohttp.ClientSession() as http:
            await http.get(f"{base}/load/demo")
        gateway = await _wrk(f"{base}/module/demo/send/GetSpeed", seconds)
    async with server("aiohttp") as (port, _):
        bare = await _wrk(f"http://127.0.0.1:{port}/module/demo/send/GetSpeed", seconds)
    ratio = gateway["requests_per_s"] / bare["requests_per_s"]
    return {"gateway": gateway, "bare_aiohttp": bare, "ratio": ratio, "target_ratio": 0.5,
            "verdict": "met" if ratio >= 0.5 and gateway["errors"] == 0 else "MISSED"}


__all__ = ["run", "verdict"]
