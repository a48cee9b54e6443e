"""Service round trips through the generated Python client, against a bare aiohttp GET round trip."""

from __future__ import annotations

import time

import aiohttp

from aiogenomix.clients import aconnect

from ._common import Result, server, summary

CALLS = 2000


async def run(calls: int = CALLS) -> Result:
    """Blocking call of a function (send, ``request`` event, clean); an activity's ``done`` latency."""
    async with server("gateway") as (port, _), server("aiohttp") as (bare_port, _):
        async with aconnect(f"127.0.0.1:{port}") as client:
            probe = await client.load("probe")
            round_trips, done_latencies = [], []
            for _ in range(calls // 10):  # warm-up
                await probe.Stamp()
            for _ in range(calls):
                started = time.perf_counter()
                await probe.Stamp()
                round_trips.append(time.perf_counter() - started)
            for _ in range(calls // 2):
                request = await probe.StampActivity(ack=True)
                stamped = await request.result()
                done_latencies.append(time.monotonic() - _output(stamped))
            # gateway -> driver -> python-can virtual bus -> simulated Elmo drive, and back.
            kemar = await client.load("kemar")
            head_reads = []
            for _ in range(calls // 10):
                await kemar.GetPosition()
            for _ in range(calls):
                started = time.perf_counter()
                await kemar.GetPosition()
                head_reads.append(time.perf_counter() - started)
        bare = []
        async with aiohttp.ClientSession() as http:
            url = f"http://127.0.0.1:{bare_port}/module/probe/send/Stamp"
            for _ in range(calls // 10):
                async with http.get(url) as reply:
                    await reply.read()
            for _ in range(calls):
                started = time.perf_counter()
                async with http.get(url) as reply:
                    await reply.read()
                bare.append(time.perf_counter() - started)
    client_rt, bare_rt = summary(round_trips), summary(bare)
    ratio = client_rt["median"] / bare_rt["median"]
    return {"client_call": client_rt, "bare_aiohttp_get": bare_rt, "ratio": ratio, "target_ratio": 3.0,
            "activity_done_event": summary(done_latencies), "rosbridge_service_median_ms": 12.4,
            "kemar_get_position": summary(head_reads), "seed_drive_reply_ms": 1.5,
            "verdict": "met" if ratio <= 3.0 else "MISSED"}


def _output(result: object) -> float:
    """The ``t`` output, whether the client returns the value itself or a record of outputs."""
    if isinstance(result, (int, float)):
        return float(result)
    return float(getattr(result, "t", None) or result["t"])  # type: ignore[index]
