"""Recording: a capture, the head and two cameras kept in MCAP, through the component and over HTTP (issue 26).

The rig runs in a gateway process at real time: ``kemarcapture`` (44.1 kHz stereo, 50 ms chunks, its
head state), ``world`` (256×256 cameras at 10 frames/s) and ``recorder``.  Figures:

* the recording's CPU cost beside the capture: the gateway process's CPU in blocks with and without a
  recording, alternating (target ≤ 10 % of one core);
* a long recording through the component: 0 audio frames lost, chunk indexes contiguous, the
  gateway's resident memory flat after the first minute (growth ≤ 5 MB), the file's size against the
  raw data rate;
* the same ports recorded by ``aiogenomix-record`` over HTTP on loopback: 0 frames lost.
"""

from __future__ import annotations

import asyncio
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from aiogenomix.clients import aconnect
from aiogenomix.components.recording import RecordingReader
from aiogenomix.record import record_over_http

from ._common import Result, cpu_seconds, rss_bytes, server, verdict

PORTS = ["kemarcapture/Port", "kemarcapture/currentState", "world/kemar_camera_left", "world/kemar_camera_right"]
#: Raw bytes per second of what is recorded: int32 stereo at 44.1 kHz, two rgba8 256×256 cameras at 10 Hz.
RAW_RATE = 44100 * 8 + 2 * 10 * 256 * 256 * 4
CPU_TARGET = 0.10
RSS_TARGET = 5 << 20


def _contiguous(path: Path) -> tuple[int, bool, int]:
    """Chunks of the recording's audio, whether their numbers follow each other, and its lost frames."""
    with open(path, "rb") as stream, RecordingReader(stream, str(path)) as reader:
        numbers = np.array([(chunk.chunk, chunk.lost_frames) for chunk in reader.audio("kemarcapture/Port")])
    if not len(numbers):
        return 0, False, 0
    return len(numbers), bool(np.all(np.diff(numbers[:, 0]) == 1)), int(numbers[:, 1].sum())


async def _record(recorder: Any, path: str, seconds: float) -> dict[str, Any]:
    """Record PORTS for *seconds* through the component; return its final status."""
    status = await recorder.Start(path=path, ports=PORTS, duration=seconds, timeout=seconds + 120)
    return dict(status)


async def _cpu_blocks(recorder: Any, pid: int, block: float, blocks: int) -> dict[str, Any]:
    """The gateway's CPU (cores) in blocks without and with a recording, alternating."""
    off: list[float] = []
    on: list[float] = []
    for n in range(blocks):
        for case in (("off", "on") if n % 2 == 0 else ("on", "off")):
            before, started = cpu_seconds(pid), time.perf_counter()
            if case == "on":
                await _record(recorder, f"cpu{n}.mcap", block)
            else:
                await asyncio.sleep(block)  # the rig runs meanwhile: this block is the baseline
            cores = (cpu_seconds(pid) - before) / (time.perf_counter() - started)
            (on if case == "on" else off).append(cores)
    cost = statistics.median(on) - statistics.median(off)
    return {"block_seconds": block, "blocks": blocks, "off_cores": off, "on_cores": on, "cost_cores": cost,
            "target_cores": CPU_TARGET, "verdict": verdict(cost, CPU_TARGET)}


async def _turn_head(capture: Any, stop: asyncio.Event) -> None:
    """The head sweeps between -40° and 40° while the long recording runs."""
    target = 40.0
    while not stop.is_set():
        await capture.MoveAbsolutePosition(target=target, timeout=120)
        target = -target


async def _long(client: Any, recorder: Any, capture: Any, pid: int, seconds: float, directory: Path) -> dict[str, Any]:
    rss: list[tuple[float, int]] = []
    stop = asyncio.Event()
    mover = asyncio.create_task(_turn_head(capture, stop))
    recording = asyncio.create_task(_record(recorder, "long.mcap", seconds))
    started = time.perf_counter()
    while not recording.done():
        rss.append((time.perf_counter() - started, rss_bytes(pid)))
        await asyncio.wait({recording}, timeout=min(5.0, seconds / 20))
    stop.set()
    status = await recording
    await mover
    path = directory / "long.mcap"
    chunks, contiguous, lost_in_file = _contiguous(path)
    settle = min(60.0, seconds / 4)
    after = [value for at, value in rss if at >= settle] or [rss[-1][1]]
    growth = max(after) - after[0]
    size = path.stat().st_size
    return {"seconds": seconds, "lost_frames": status["lost_frames"], "lost_in_file": lost_in_file,
            "chunks": chunks, "expected_chunks": seconds / 0.05, "contiguous": contiguous,
            "coalesced": status["coalesced"], "messages": status["messages"], "bytes": size,
            "raw_bytes": RAW_RATE * seconds, "size_ratio": size / (RAW_RATE * seconds),
            "rss_mb": [(round(at, 1), value / 2**20) for at, value in rss], "rss_settle_s": settle,
            "rss_growth_mb": growth / 2**20, "rss_target_mb": RSS_TARGET / 2**20,
            "rss_verdict": verdict(growth, RSS_TARGET),
            "verdict": "met" if status["lost_frames"] == 0 and contiguous and not lost_in_file else "MISSED"}


async def _over_http(url: str, seconds: float, directory: Path) -> dict[str, Any]:
    path, counts, ended = await record_over_http(url, PORTS, str(directory / "http.mcap"), duration=seconds)
    chunks, contiguous, lost_in_file = _contiguous(Path(path))
    return {"seconds": seconds, "ended": ended, "lost_frames": counts.lost_frames, "chunks": chunks,
            "contiguous": contiguous, "coalesced": counts.coalesced, "bytes": counts.bytes,
            "verdict": "met" if counts.lost_frames == 0 and contiguous and not lost_in_file else "MISSED"}


async def run(seconds: float = 600.0, block: float = 20.0, blocks: int = 6, http_seconds: float = 120.0) -> Result:
    """Measure the figures: *seconds* of the long recording, *blocks* pairs of *block* seconds for the CPU."""
    with tempfile.TemporaryDirectory(prefix="aiogenomix-bench-record-") as name:
        directory = Path(name)
        async with server("gateway", args=["--record-dir", name]) as (port, pid):
            url = f"127.0.0.1:{port}"
            async with aconnect(url, timeout=120) as client:
                capture = await client.load("kemarcapture")
                await client.load("world", "-size", "256x256", "-rate", "10")
                recorder = await client.load("recorder")
                await capture.Homing(timeout=300)
                await capture.StartCapture(device="sim", transfer_rate=44100, chunk_time=50, Port_chunks=20,
                                           ack=True)
                cpu = await _cpu_blocks(recorder, pid, block, blocks)
                long = await _long(client, recorder, capture, pid, seconds, directory)
                http = await _over_http(url, http_seconds, directory)
    return {"cpu": cpu, "component": long, "http": http, "raw_rate": RAW_RATE, "ports": PORTS}


def _duration(seconds: float) -> str:
    return f"{seconds / 60:.0f}-minute" if seconds >= 60 else f"{seconds:.0f}-second"


def render(r: Result) -> str:
    """The Markdown section of docs/benchmarks.md."""
    cpu, long, http = r["cpu"], r["component"], r["http"]
    return "\n".join([
        "## Recording (MCAP)", "",
        "A gateway process at real time runs `kemarcapture` (44.1 kHz stereo int32, 50 ms chunks), `world` "
        "(256×256 cameras at 10 frames/s) and `recorder`, which records "
        + ", ".join(f"`{p}`" for p in r["ports"]) + f" (raw data {r['raw_rate'] / 1e6:.2f} MB/s).", "",
        f"CPU of the gateway process in {cpu['blocks']} pairs of {cpu['block_seconds']:.0f} s blocks, alternating "
        "without and with a recording (cores; the world renders in a process of its own, not counted):", "",
        "| | median | blocks |", "|---|---|---|",
        f"| without recording | {statistics.median(cpu['off_cores']):.3f} | "
        + ", ".join(f"{c:.3f}" for c in cpu["off_cores"]) + " |",
        f"| recording | {statistics.median(cpu['on_cores']):.3f} | "
        + ", ".join(f"{c:.3f}" for c in cpu["on_cores"]) + " |", "",
        f"The recording costs {cpu['cost_cores'] * 100:.1f} % of one core (target ≤ {cpu['target_cores'] * 100:.0f} %: "
        f"**{cpu['verdict']}**).", "",
        f"A {_duration(long['seconds'])} recording through the component while the head sweeps ±40°: "
        f"{long['chunks']} audio chunks ({long['expected_chunks']:.0f} in {long['seconds']:.0f} s), "
        f"{'contiguous' if long['contiguous'] else '**not contiguous**'}, {long['lost_frames']} frames lost "
        f"(**{long['verdict']}**); {long['coalesced']} camera or head publications coalesced. The file holds "
        f"{long['bytes'] / 1e6:.0f} MB for {long['raw_bytes'] / 1e6:.0f} MB of raw data ({long['size_ratio']:.2f}×, "
        "zstd level 1 chunks of 1 MiB). The gateway's resident memory grew "
        f"{long['rss_growth_mb']:.1f} MB after the first {long['rss_settle_s']:.0f} s (target ≤ "
        f"{long['rss_target_mb']:.0f} MB: **{long['rss_verdict']}**).", "",
        f"The same ports recorded over HTTP by `aiogenomix-record` on loopback for {http['seconds']:.0f} s: "
        f"{http['chunks']} chunks, {'contiguous' if http['contiguous'] else '**not contiguous**'}, "
        f"{http['lost_frames']} frames lost (**{http['verdict']}**), {http['coalesced']} publications coalesced.", ""])


if __name__ == "__main__":
    import json

    print(json.dumps(asyncio.run(run(seconds=20, block=4, blocks=2, http_seconds=8)), indent=1))
