"""Benchmark GetPosition round trips: driver → python-can virtual bus → simulated Harmonica → driver.

Not a test: it prints the median and 99th percentile of a position query beside
the 1.5 ms the seed measured for the real drive to answer (section 6.4.5)::

    .venv/bin/python -m bench.bench_kemar --count 5000

:func:`run` returns the figures as a result dict, like the other benchmarks.

The gateway-level round trip (HTTP → component → bus) belongs to the main
benchmark; this one isolates the CAN path.
"""

from __future__ import annotations

import argparse
import asyncio
import time
from collections.abc import Awaitable, Callable

from aiogenomix.components.core import RealClock
from aiogenomix.components.kemar import HarmonicaDriver, KemarHead, NmtCommand, SimulatedHarmonica

from ._common import Result, summary, verdict

__all__ = ["run", "SEED_REPLY_MS"]

#: The seed's measured drive reply time for the current position (report section 6.4.5).
SEED_REPLY_MS = 1.5


async def _measure(call: Callable[[], Awaitable[object]], count: int) -> list[float]:
    """Time *count* sequential awaits of *call*, in seconds."""
    for _ in range(min(200, count)):  # warm up the reader threads and caches
        await call()
    timings = []
    for _ in range(count):
        started = time.perf_counter()
        await call()
        timings.append(time.perf_counter() - started)
    return timings


async def run(count: int = 3000) -> Result:
    """Round trips of a position query at three layers, and the throughput of concurrent queries."""
    clock = RealClock()
    async with SimulatedHarmonica(clock=clock) as sim, HarmonicaDriver.open("virtual", sim.channel) as driver:
        await driver.nmt(NmtCommand.START)
        head = KemarHead(driver, clock)
        await head.start()
        result: Result = {
            "query_px": summary(await _measure(lambda: driver.query("PX"), count)),
            "get_position": summary(await _measure(head.read_position, count)),
            "read_state": summary(await _measure(head.read_state, count)),
        }
        mnemonics = ("PX", "VX", "SR", "MF", "IP", "SP", "AC", "DC", "UM", "MO")
        started = time.perf_counter()
        for _ in range(count // len(mnemonics)):
            await asyncio.gather(*(driver.query(m) for m in mnemonics))
        result["concurrent_replies_per_s"] = count // len(mnemonics) * len(mnemonics) / (time.perf_counter() - started)
    result["seed_reply_ms"] = SEED_REPLY_MS
    result["verdict"] = verdict(result["get_position"]["median"], SEED_REPLY_MS)
    return result


def _print(result: Result, count: int) -> None:
    print(f"{count} sequential round trips each: python-can virtual bus, simulated drive on its own thread")
    for key, name in (("query_px", "driver.query('PX')"), ("get_position", "head.read_position() = GetPosition"),
                      ("read_state", "head.read_state() (PX and VX)")):
        figures = result[key]
        print(f"  {name:<36} median {figures['median']:6.3f} ms   p99 {figures['p99']:6.3f} ms   "
              f"({figures['median'] / SEED_REPLY_MS:4.2f} x the seed's {SEED_REPLY_MS} ms drive reply)")
    print(f"  {'10 different queries in flight':<36} {result['concurrent_replies_per_s']:8.0f} replies/s")
    print(f"  GetPosition median below the seed's drive reply time: {result['verdict']}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="GetPosition round trips over the virtual CAN bus")
    parser.add_argument("--count", type=int, default=3000, help="round trips per measurement (default 3000)")
    arguments = parser.parse_args()
    _print(asyncio.run(run(arguments.count)), arguments.count)
