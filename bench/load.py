"""Load: 50 concurrent clients calling a function service, against a bare aiohttp handler (wrk).

The two servers run side by side and are measured in alternating rounds, so a
noisy neighbour on the shared machine weighs on both; the ratio reported is
the median of the per-round ratios.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
import shutil
import statistics
import time

import aiohttp

from aiogenomix.components.core import ComponentHost, ScaledClock

from ._common import BASELINE, Result, baseline_name, cpu_seconds, server

CONNECTIONS = 50
#: The gateway's throughput as a share of bare aiohttp's on the same handler shape (issue 32).
TARGET = 0.85
#: The gateway's CPU time per request as a multiple of bare aiohttp's, at most (issue 32).
CPU_TARGET = 1.2


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
    async with contextlib.AsyncExitStack() as stack:
        servers = {"gateway": await stack.enter_async_context(server("gateway")),
                   "bare": await stack.enter_async_context(server("aiohttp"))}
        if BASELINE:
            servers["baseline"] = await stack.enter_async_context(server("gateway", BASELINE))
        async with aiohttp.ClientSession() as http:
            for name in ("gateway", "baseline"):
                if name in servers:
                    await http.get(f"http://127.0.0.1:{servers[name][0]}/load/demo")
        runs: dict[str, list[dict[str, float]]] = {name: [] for name in servers}
        for _ in range(rounds):
            for name, (port, pid) in servers.items():
                used = cpu_seconds(pid)
                result = await _wrk(f"http://127.0.0.1:{port}/module/demo/send/GetSpeed", seconds / rounds)
                # CPU time per request: what the server itself spends, whatever else the machine runs.
                result["cpu_us_per_request"] = 1e6 * (cpu_seconds(pid) - used) / max(1, result["requests"])
                runs[name].append(result)
    gateway_runs, bare_runs = runs["gateway"], runs["bare"]
    ratios = [g["requests_per_s"] / b["requests_per_s"] for g, b in zip(gateway_runs, bare_runs, strict=True)]
    errors = sum(run["errors"] for run in gateway_runs)
    ratio = statistics.median(ratios)
    # CPU per request, gateway over bare aiohttp, median of the rounds' ratios.
    cpu_ratio = statistics.median(g["cpu_us_per_request"] / b["cpu_us_per_request"]
                                  for g, b in zip(gateway_runs, bare_runs, strict=True))
    baseline = {}
    if "baseline" in runs:
        before = [g["requests_per_s"] / b["requests_per_s"] for g, b in zip(runs["baseline"], bare_runs, strict=True)]
        baseline = {"baseline": baseline_name(),
                    "baseline_requests_per_s": statistics.median(r["requests_per_s"] for r in runs["baseline"]),
                    "baseline_ratios": before, "baseline_ratio": statistics.median(before),
                    "baseline_cpu_us_per_request": statistics.median(r["cpu_us_per_request"] for r in runs["baseline"]),
                    "baseline_cpu_ratio": statistics.median(
                        g["cpu_us_per_request"] / b["cpu_us_per_request"]
                        for g, b in zip(runs["baseline"], bare_runs, strict=True))}
    return baseline | {
        "gateway_requests_per_s": statistics.median(r["requests_per_s"] for r in gateway_runs),
        "bare_requests_per_s": statistics.median(r["requests_per_s"] for r in bare_runs),
        "gateway_requests": sum(r["requests"] for r in gateway_runs),
        "errors": errors, "ratios": ratios, "ratio": ratio, "target_ratio": TARGET,
        "gateway_cpu_us_per_request": statistics.median(r["cpu_us_per_request"] for r in gateway_runs),
        "bare_cpu_us_per_request": statistics.median(r["cpu_us_per_request"] for r in bare_runs),
        "cpu_ratio": cpu_ratio,
        "runtime_send_us": await _runtime_send_us(),
        "target_cpu_ratio": CPU_TARGET,
        "verdict": "met" if ratio >= TARGET and errors == 0 and cpu_ratio <= CPU_TARGET else "MISSED",
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
