"""Budgets (issue 24): the gateway's memory with clients that never read, and its stop with a large world.

Three runs of the gateway's own command line (``python -m aiogenomix.gateway``), with its default
budgets:

* **2014 socket.** ``capture`` at 384 kHz, 50 ms chunks, 400 on the port (59 MiB); 50 clients that
  each ask for the whole port once and never read (a 4 KiB receive buffer), beside 2 readers that
  read every new chunk.  The gateway's resident memory is sampled throughout; the figure is its
  peak above what it held before the clients came, against the budget the docs state
  (``docs/protocol.md``, Budgets): the unsent replies of every client (``--max-socket-bytes``), one
  last reply kept per socket (``--max-socket-client-bytes``) and a piece of a reply in each
  client's transport.  The readers must lose nothing.
* **2015 socket and basc.** ``bass`` likewise (19200-frame chunks at 384 kHz, 400 on the port), its
  socket with 50 clients asking for every frame and never reading, 2 readers beside them, and
  ``basc`` collecting blocks of the largest size it accepts (``--max-block-frames``) for long enough
  to complete two.  Its budget adds the blocks (two of them: one filled, one published).
* **Stop.** A world with 2048x2048 cameras at 50 Hz, rendering: SIGTERM, then the time until the
  process has exited, five times; no render process may be left.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import re
import signal
import socket
import statistics
import sys
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp

from aiogenomix.clients import AsyncAudioSocketClient, AsyncFrameSocketClient
from aiogenomix.components.core import Budgets

from ._common import ROOT, Result, free_port, rss_bytes, verdict

MIB = 2**20
#: The stop's bound (README, docs/protocol.md Shutdown).
STOP_WITHIN = 2.0
#: What a client's transport holds beyond the ledger: a piece of a reply, and the buffer's high-water mark.
PER_CLIENT = 256 * 2**10 + 64 * 2**10


@contextlib.asynccontextmanager
async def _gateway(*args: str, pythonpath: str | None = None,
                   ) -> AsyncIterator[tuple[str, int, int, asyncio.subprocess.Process]]:
    """``python -m aiogenomix.gateway`` on free ports; yields its URL, its socket port, its pid and the process.

    *pythonpath* comes first on the gateway's import path (another checkout's ``aiogenomix``, to
    measure it beside this one).
    """
    socket_port = free_port()
    env = None
    if pythonpath:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [pythonpath, os.environ.get("PYTHONPATH")])))
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "aiogenomix.gateway", "--port", "0", "--audio-socket-port", str(socket_port),
        "--log-level", "warning", *args, cwd=ROOT, env=env, stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.DEVNULL)
    try:
        assert process.stdout is not None
        line = (await asyncio.wait_for(process.stdout.readline(), 120)).decode()
        found = re.search(r"listening on (http://\S+)", line)
        if found is None:
            raise RuntimeError(f"the gateway did not start: {line!r}")
        yield found.group(1), socket_port, process.pid, process
    finally:
        if process.returncode is None:
            process.kill()
        await process.wait()


async def _send(http: aiohttp.ClientSession, path: str, inputs: dict[str, Any] | None = None) -> Any:
    params = {"input": json.dumps(inputs)} if inputs is not None else None
    async with http.get(path, params=params) as reply:
        return await reply.json()


class _Peak:
    """Samples a process's resident memory every 50 ms while the context is open."""

    def __init__(self, pid: int) -> None:
        self.pid, self.peak = pid, 0
        self._task: asyncio.Task[None] | None = None

    async def _sample(self) -> None:
        while True:
            self.peak = max(self.peak, rss_bytes(self.pid))
            await asyncio.sleep(0.05)

    async def __aenter__(self) -> _Peak:
        self._task = asyncio.create_task(self._sample())
        return self

    async def __aexit__(self, *exc: object) -> None:
        assert self._task is not None
        self._task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self._task


async def _never_reading(port: int, request: bytes) -> socket.socket:
    """A client with a 4 KiB receive buffer that sends *request* once and never reads."""
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.setblocking(False)
    await asyncio.get_running_loop().sock_connect(sock, ("127.0.0.1", port))
    await asyncio.get_running_loop().sock_sendall(sock, request)
    return sock


async def _until_full(http: aiohttp.ClientSession, read: str, full: int, key: str) -> None:
    """Poll *read* (its JSON member *key*) until it reaches *full* (the port has filled)."""
    while True:
        async with http.get(read, params={"format": "binary"}) as reply:
            body = await reply.read()
        header = json.loads(body[8:8 + int.from_bytes(body[4:8], "little")])
        if header["data"][key] >= full:
            return
        await asyncio.sleep(0.5)


async def _sockets_2014(clients: int, chunks: int, seconds: float) -> Result:
    budgets = Budgets()
    rate, chunk_ms = 384_000, 50
    fpc = rate * chunk_ms // 1000
    async with _gateway("--load", "capture") as (url, socket_port, pid, _):
        async with aiohttp.ClientSession(url) as http:
            await _send(http, "/module/capture/send/StartCapture", {
                "device": "sim", "transfer_rate": rate, "chunk_time": chunk_ms, "Port_chunks": chunks})
            await _send(http, "/module/capture/send/DedicatedSocket")
            await _until_full(http, "/module/capture/read/Port", chunks, "index")
            before = rss_bytes(pid)
            readers = [AsyncAudioSocketClient(port=socket_port, frames_per_chunk=fpc, timeout=30) for _ in range(2)]
            for reader in readers:
                await reader.read()                    # the first read: everything before it counts as lost
            lost, got, stop = [0, 0], [0, 0], asyncio.Event()

            async def read(n: int) -> None:
                while not stop.is_set():
                    block = await readers[n].read()
                    lost[n] += block.lost
                    got[n] += block.count
                    await asyncio.sleep(chunk_ms / 2000)   # twice a chunk: never more than the port's length apart

            async with _Peak(pid) as peak:
                reading = [asyncio.create_task(read(n)) for n in range(2)]
                stalled = []
                for _ in range(clients):
                    stalled.append(await _never_reading(socket_port, b"Read Port - Index 0\n"))
                    await asyncio.sleep(0.1)
                await asyncio.sleep(seconds)
                stop.set()
                await asyncio.gather(*reading)
            status = await _send(http, "/module/capture/send/GetCaptureStatus")
            for reader in readers:
                await reader.aclose()
            for sock in stalled:
                sock.close()
    port_bytes = 8 * fpc * chunks
    budget = budgets.socket_bytes + budgets.socket_client_bytes + (clients + 2) * PER_CLIENT
    grew = peak.peak - before
    return {"clients": clients, "port_mib": port_bytes / MIB, "reply_mib": (8 * fpc * chunks + 8) / MIB,
            "before_mib": before / MIB, "peak_mib": peak.peak / MIB, "grew_mib": grew / MIB,
            "budget_mib": budget / MIB, "connected_at_end": status["output"]["socket_clients"],
            "readers_lost": lost, "readers_got": got, "without_budgets_mib": clients * 117.0,
            "verdict": verdict(grew, budget) if sum(lost) == 0 else "MISSED"}


async def _sockets_2015_and_basc(clients: int, chunks: int, seconds: float) -> Result:
    budgets = Budgets()
    rate, fpc = 384_000, 19_200
    block = budgets.block_frames
    async with _gateway("--load", "bass", "--load", "basc") as (url, socket_port, pid, _):
        async with aiohttp.ClientSession(url) as http:
            await _send(http, "/module/bass/send/Acquire", {
                "device": "sim", "sampleRate": rate, "nFramesPerChunk": fpc, "nChunksOnPort": chunks})
            await _send(http, "/module/bass/send/DedicatedSocket")
            await _send(http, "/module/basc/send/connect_port", {"local": "Audio", "remote": "bass/Audio"})
            await _until_full(http, "/module/bass/read/Audio", fpc * chunks, "lastFrameIndex")
            before = rss_bytes(pid)
            refused = await _send(http, "/module/basc/send/GetBlocks", {"nFramesPerBlock": block + 1})
            getting = await _send(http, "/module/basc/send/GetBlocks",
                                  {"nBlocks": 0, "nFramesPerBlock": block, "startOffs": 0})
            readers = [AsyncFrameSocketClient(port=socket_port, timeout=30) for _ in range(2)]
            for reader in readers:
                first = await reader.read(1)
                reader.next_frame = first.next_frame + fpc * chunks // 2   # mid-port: skipped, not lost
            lost, got, stop = [0, 0], [0, 0], asyncio.Event()

            async def read(n: int) -> None:
                while not stop.is_set():
                    frames = await readers[n].read()
                    lost[n] += frames.lost
                    got[n] += frames.count
                    await asyncio.sleep(0.025)

            async with _Peak(pid) as peak:
                reading = [asyncio.create_task(read(n)) for n in range(2)]
                stalled = []
                for _ in range(clients):
                    stalled.append(await _never_reading(socket_port, b"Read Port - N 2147483647 - nfr 0\n"))
                    await asyncio.sleep(0.1)
                await asyncio.sleep(seconds)
                stop.set()
                await asyncio.gather(*reading)
            async with http.get("/module/basc/read/Blocks", params={"format": "binary"}) as reply:
                body = await reply.read()
            blocks = json.loads(body[8:8 + int.from_bytes(body[4:8], "little")])["data"]
            await _send(http, "/module/basc/send/Stop")
            for reader in readers:
                await reader.aclose()
            for sock in stalled:
                sock.close()
    budget = (budgets.socket_bytes + budgets.socket_client_bytes + (clients + 2) * PER_CLIENT
              + 2 * 8 * block)
    grew = peak.peak - before
    return {"clients": clients, "port_mib": 8 * fpc * chunks / MIB, "block_frames": block,
            "block_refused": refused.get("exception", {}).get("ex", ""), "getting": getting["status"],
            "blocks": blocks["blocks"], "block_lost": blocks["lost"],
            "before_mib": before / MIB, "peak_mib": peak.peak / MIB, "grew_mib": grew / MIB,
            "budget_mib": budget / MIB, "readers_lost": lost, "readers_got": got,
            "verdict": verdict(grew, budget) if sum(lost) == 0 and blocks["blocks"] >= 1 else "MISSED"}


def _children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(OSError):
            found += [int(child) for child in (task / "children").read_text().split()]
    return found


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


async def _stop(size: str, rounds: int) -> Result:
    took, left = [], 0
    for _ in range(rounds):
        async with _gateway("--load", f"world:-size {size} -rate 50") as (url, _, pid, process):
            async with aiohttp.ClientSession(url) as http:
                first = None
                while True:   # until frames come: two laser sweeps with different numbers
                    async with http.get("/module/world/read/pr2_scan") as reply:
                        seq = (await reply.json())["pr2_scan"]["header"]["seq"]
                    if first is None:
                        first = seq
                    elif seq != first:
                        break
                    await asyncio.sleep(0.2)
            render = _children(pid)
            sent = time.monotonic()
            process.send_signal(signal.SIGTERM)
            await process.wait()
            took.append(time.monotonic() - sent)
            await asyncio.sleep(0.2)  # a render process still there now would be one left behind
            left += sum(_running(child) for child in render)
    median = statistics.median(took)
    return {"size": size, "rounds": rounds, "seconds": took, "median_s": median, "max_s": max(took),
            "children_left": left, "target_s": STOP_WITHIN,
            "verdict": verdict(median, STOP_WITHIN) if left == 0 else "MISSED"}


async def run(clients: int = 50, chunks: int = 400, seconds: float = 10.0, rounds: int = 5,
              size: str = "2048x2048") -> Result:
    """The three runs (see the module's description)."""
    return {"sockets_2014": await _sockets_2014(clients, chunks, seconds),
            "sockets_2015_basc": await _sockets_2015_and_basc(clients, chunks, max(seconds, 25.0)),
            "stop": await _stop(size, rounds)}


def render(r: Result) -> str:
    """The section of docs/benchmarks.md."""
    s14, s15, stop = r["sockets_2014"], r["sockets_2015_basc"], r["stop"]
    return "\n".join([
        "## Budgets: clients that never read, and the stop", "",
        f"The gateway's command line with its default budgets. **2014 socket:** `capture` at 384 kHz, 50 ms chunks, "
        f"{s14['port_mib']:.0f} MiB on the port; {s14['clients']} clients each ask for the whole port once "
        f"({s14['reply_mib']:.0f} MiB) and never read, beside 2 readers of every chunk. **2015 socket and basc:** "
        f"`bass` likewise ({s15['port_mib']:.0f} MiB), {s15['clients']} clients asking for every frame and never "
        f"reading, 2 readers beside them, and `basc` collecting blocks of {s15['block_frames']:,} frames, the "
        f"largest it accepts (one more is `{s15['block_refused']}`). Memory is the gateway's resident set, "
        "sampled every 50 ms: its peak above what it held before the clients came, against the budget "
        "`docs/protocol.md` states (unsent replies in all, one last reply per socket, a piece of a reply per "
        "client; and basc's two blocks).", "",
        "| run | before, MiB | peak, MiB | grew, MiB | budget, MiB | clients left connected | readers' frames lost |",
        "|---|---|---|---|---|---|---|",
        f"| 2014 socket | {s14['before_mib']:.0f} | {s14['peak_mib']:.0f} | {s14['grew_mib']:.0f} | "
        f"{s14['budget_mib']:.0f} | {s14['connected_at_end'] - 2} of {s14['clients']} | "
        f"{sum(s14['readers_lost'])} of {sum(s14['readers_got'])} chunks |",
        f"| 2015 socket and basc ({s15['blocks']} blocks, {s15['block_lost']} frames lost) | {s15['before_mib']:.0f} "
        f"| {s15['peak_mib']:.0f} | {s15['grew_mib']:.0f} | {s15['budget_mib']:.0f} | | "
        f"{sum(s15['readers_lost'])} of {sum(s15['readers_got'])} frames |", "",
        f"Target: within the budget, the readers losing nothing: 2014 **{s14['verdict']}**, 2015 and basc "
        f"**{s15['verdict']}**. Before the budgets (issue 24), each such client pinned about 117 MB: "
        f"{s14['without_budgets_mib']:,.0f} MB for {s14['clients']}.", "",
        f"**Stop:** a world of {stop['size']} cameras at 50 Hz, rendering; SIGTERM until the process has exited, "
        f"{stop['rounds']} times: median {stop['median_s']:.2f} s, longest {stop['max_s']:.2f} s, render processes "
        f"left: {stop['children_left']}. Target: within {stop['target_s']:g} s and none left: **{stop['verdict']}**.",
        ""])
