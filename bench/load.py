"""Load: 50 concurrent clients calling a function service, against a bare aiohttp handler (wrk).

The two servers run side by side and are measured in alternating rounds, so a
noisy neighbour on the shared machine weighs on both; the ratio reported is
the median of the per-round ratios.
"""

from __future__ import annotations

import asyncio
import re
import shutil
import statistics
import time

import aiohttp

from aiogenomix.components.core import ComponentHost, ScaledClock

from ._common import Result, cpu_seconds, server

CONNECTIONS = 50
#: The gateway's throughput as a share of bare aiohttp's on the same handler shape.
TARGET = 0.7


async def _wrk(url: str, seconds: float) -> dict[str, float]:
    process = await asyncio.create_subprocess_exec(
        "wrk", "-t1", f"-c{CONNECTIONS}", f"-d{int(seconds)}s", url,
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


async def run(seconds: float = 30.0, rounds: int = 5) -> Result:
    """Throughput of ``send`` of a function (its reply is already ``done``) vs a bare handler."""
    if shutil.which("wrk") is None:
        return {"skipped": "wrk is not installed (./run bench installs it)"}
    async with server("gateway") as (gateway_port, gateway_pid), server("aiohttp") as (bare_port, bare_pid):
        async with aiohttp.ClientSession() as http:
            await http.get(f"http://127.0.0.1:{gateway_port}/load/demo")
        gateway_runs, bare_runs = [], []
        for _ in range(rounds):
            for runs, port, pid in ((gateway_runs, gateway_port, gateway_pid), (bare_runs, bare_port, bare_pid)):
                used = cpu_seconds(pid)
                runs.append(await _wrk(f"http://127.0.0.1:{port}/module/demo/send/GetSpeed", seconds / rounds))
                # CPU time per request: what the server itself spends, whatever else the machine runs.
                runs[-1]["cpu_us_per_request"] = 1e6 * (cpu_seconds(pid) - used) / max(1, runs[-1]["requests"])
    ratios = [g["requests_per_s"] / b["requests_per_s"] for g, b in zip(gateway_runs, bare_runs, strict=True)]
    errors = sum(run["errors"] for run in gateway_runs)
    ratio = statistics.median(ratios)
    return {
        "gateway_requests_per_s": statistics.median(r["requests_per_s"] for r in gateway_runs),
        "bare_requests_per_s": statistics.median(r["requests_per_s"] for r in bare_runs),
        "gateway_requests": sum(r["requests"] for r in gateway_runs),
        "errors": errors, "ratios": ratios, "ratio": ratio, "target_ratio": TARGET,
        "gateway_cpu_us_per_request": statistics.median(r["cpu_us_per_request"] for r in gateway_runs),
        "bare_cpu_us_per_request": statistics.median(r["cpu_us_per_request"] for r in bare_runs),
        "runtime_send_us": await _runtime_send_us(),
        "verdict": "met" if ratio >= TARGET and errors == 0 else "MISSED",
    }


async def _runtime_send_us(sends: int = 20000) -> float:
    """What the component runtime alone spends on one ``send`` of ``demo.GetSpeed`` (µs; no HTTP, in this process)."""
    async with ComponentHost(clock=ScaledClock(1.0)) as host:
        demo = await host.load("demo")
        for _ in range(sends // 10):  # warm-up
            await demo.send("GetSpeed")
        started = time.perf_counter()
        for _ in range(sends):
            await demo.send("GetSpeed")
        return 1e6 * (time.perf_counter() - started) / sends
