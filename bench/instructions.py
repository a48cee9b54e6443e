"""What a request costs the gateway, counted in instructions rather than timed.

The machines these benchmarks run on are shared, and a timed figure moves with
their load; valgrind's callgrind counts the instructions a process executes,
which the load does not change.  Each gateway starts once under callgrind with
its instrumentation off (``--instr-atstart=no``: importing the package and
starting the gateway run at valgrind's plain speed, uncounted), answers a few
hundred requests of each kind to warm up, and only then has its instrumentation
turned on (``callgrind_control -i on``).  A count is then: zero the counters
(``-z``), answer ``requests`` requests of one kind one after another on a
kept-alive connection, dump the counters (``--dump``); instructions per request are
the dump's total divided by ``requests``.  The counts of a kind are repeated
``dumps`` times, and the figure is their median.  With
``AIOGENOMIX_BENCH_BASELINE=DIR`` another checkout's gateway runs under
callgrind beside this one, and the two are counted in turn, round after round.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import re
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

from ._common import BASELINE, Result, baseline_name, free_port

#: What is counted: a send of a function, a port read and the version (all plain: answered ahead of the
#: routes), and a module's description (through the router, the guard and the route).
REQUESTS = {"send of a function (plain, ahead of the routes)": "/module/demo/send/GetSpeed",
            "plain port read (ahead of the routes)": "/module/demo/read/Mobile",
            "/version (plain, ahead of the routes)": "/version",
            "/module/demo/info (routed)": "/module/demo/info"}
#: The requests whose count must fall by 15 % from the baseline's (issue 32), and that share.
TARGETED = ("send of a function (plain, ahead of the routes)", "/version (plain, ahead of the routes)")
TARGET = 0.85
#: How long a gateway may take to start under valgrind (uninstrumented) on a busy machine.
START_TIMEOUT = 900.0

_SERVER = """
import asyncio, sys
from aiogenomix.gateway import GatewayConfig, serve
async def main():
    build = getattr(GatewayConfig, "of", GatewayConfig)  # a baseline that predates settings groups
    async with serve(build(port=int(sys.argv[1]), audio_socket_port=0, preload=["demo"])):
        print("ready", flush=True)
        await asyncio.Event().wait()
asyncio.run(main())
"""


class _Counted:
    """One gateway process under callgrind, counted only between a zero and a dump."""

    def __init__(self, name: str, pythonpath: str | None, folder: Path) -> None:
        self.name = name
        self._pythonpath = pythonpath
        self._out = folder / f"callgrind.{name.replace(' ', '_')}.out"
        self._log = folder / f"valgrind.{name.replace(' ', '_')}.log"
        self._dumps = 0
        self._process: asyncio.subprocess.Process | None = None
        self._streams: tuple[asyncio.StreamReader, asyncio.StreamWriter] | None = None
        #: The seconds it took to start (uninstrumented).
        self.start_seconds = 0.0

    async def start(self) -> None:
        """Start the gateway under callgrind, instrumentation off, and connect to it."""
        port = free_port()
        env = dict(os.environ, PYTHONHASHSEED="0")  # the same dictionaries every run
        if self._pythonpath:
            env["PYTHONPATH"] = self._pythonpath
        started = time.monotonic()
        with self._log.open("wb") as log:
            self._process = await asyncio.create_subprocess_exec(
                "valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={self._out}",
                sys.executable, "-c", _SERVER, str(port), env=env, stdout=asyncio.subprocess.PIPE, stderr=log)
        assert self._process.stdout is not None
        line = await asyncio.wait_for(self._process.stdout.readline(), START_TIMEOUT)
        if line.strip() != b"ready":
            raise RuntimeError(f"{self.name}: the gateway did not start under valgrind: "
                               f"{self._log.read_text(errors='replace')[-2000:]}")
        self.start_seconds = time.monotonic() - started
        self._streams = await asyncio.open_connection("127.0.0.1", port)

    async def control(self, *args: str) -> None:
        """``callgrind_control ARGS PID``: instrumentation on or off, zero, dump."""
        assert self._process is not None
        control = await asyncio.create_subprocess_exec(
            "callgrind_control", *args, str(self._process.pid),
            stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT)
        said, _ = await control.communicate()
        if control.returncode != 0 or b"OK" not in said:
            raise RuntimeError(f"{self.name}: callgrind_control {' '.join(args)} failed: {said.decode()[-500:]}")

    async def answer(self, path: str, requests: int) -> None:
        """Send *requests* GETs of *path* one after another, each after the previous reply (all 200)."""
        assert self._streams is not None
        reader, writer = self._streams
        request = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode()
        for _ in range(requests):
            writer.write(request)
            head = await reader.readuntil(b"\r\n\r\n")
            if not head.startswith(b"HTTP/1.1 200 "):
                status = head.partition(b"\r\n")[0]
                raise RuntimeError(f"{self.name}: GET {path} answered {status!r}")
            await reader.readexactly(int(head.lower().split(b"content-length: ")[1].split(b"\r\n")[0]))

    async def count(self, path: str | None, requests: int, idle: float = 0.0) -> tuple[int, float]:
        """The instructions of *requests* GETs of *path* (or of *idle* seconds of nothing), and the seconds taken."""
        await self.control("-z")
        started = time.monotonic()
        if path is None:
            await asyncio.sleep(idle)
        else:
            await self.answer(path, requests)
        seconds = time.monotonic() - started
        await self.control("--dump=" + ("idle" if path is None else "requests"))
        self._dumps += 1
        return await self._total(Path(f"{self._out}.{self._dumps}")), seconds

    async def _total(self, dump: Path) -> int:
        """The total of *dump* (callgrind writes it before ``--dump`` returns; waited for all the same)."""
        deadline = time.monotonic() + 60
        while True:
            with contextlib.suppress(FileNotFoundError):
                found = re.search(rb"^(?:summary|totals): (\d+)", dump.read_bytes(), re.M)
                if found is not None:
                    return int(found.group(1))
            if time.monotonic() > deadline:
                raise RuntimeError(f"{self.name}: callgrind wrote no total in {dump}")
            await asyncio.sleep(0.05)

    async def stop(self) -> None:
        """Close the connection and end the process."""
        if self._streams is not None:
            self._streams[1].close()
        if self._process is not None and self._process.returncode is None:
            self._process.terminate()
            try:
                await asyncio.wait_for(self._process.wait(), 60)
            except TimeoutError:
                self._process.kill()
                await self._process.wait()


async def run(requests: int = 200, dumps: int = 9, warm: int = 300, idle: float = 2.0) -> Result:
    """Instructions per request of each kind in :data:`REQUESTS` (and of the baseline's gateway), medians."""
    if shutil.which("valgrind") is None or shutil.which("callgrind_control") is None:
        return {"skipped": "valgrind is not installed (./run bench installs it)"}
    if requests <= 0:
        return {"skipped": "not counted in a quick run"}
    with tempfile.TemporaryDirectory() as folder:
        gateways = [_Counted("this gateway", None, Path(folder)),
                    *([_Counted("baseline", BASELINE, Path(folder))] if BASELINE else [])]
        try:
            await asyncio.gather(*(gateway.start() for gateway in gateways))
            for gateway in gateways:  # uncounted: every path's code warmed up (imports, caches, specialisation)
                for path in REQUESTS.values():
                    await gateway.answer(path, warm)
                await gateway.control("-i", "on")
            counts: dict[str, dict[str, list[float]]] = {g.name: {label: [] for label in REQUESTS} for g in gateways}
            dumped: dict[str, list[tuple[int, float]]] = {g.name: [] for g in gateways}  # (total, seconds)
            quiet: dict[str, list[float]] = {g.name: [] for g in gateways}
            for _ in range(dumps):  # the gateways take turns, dump after dump
                for gateway in gateways:
                    for label, path in REQUESTS.items():
                        total, took = await gateway.count(path, requests)
                        counts[gateway.name][label].append(total / requests)
                        dumped[gateway.name].append((total, took))
                    total, took = await gateway.count(None, 0, idle)
                    quiet[gateway.name].append(total / took)
        finally:
            await asyncio.gather(*(gateway.stop() for gateway in gateways))
    medians = {name: {label: statistics.median(values) for label, values in kinds.items()}
               for name, kinds in counts.items()}
    spreads = {name: {label: [min(values), max(values)] for label, values in kinds.items()}
               for name, kinds in counts.items()}
    # The largest share of a dump that its gateway's own timers could account for, had they run as when idle.
    background = {name: max(statistics.median(quiet[name]) * took / total for total, took in dumped[name])
                  for name in medians}
    return {"instructions": medians, "spread": spreads, "requests": requests, "dumps": dumps, "warm": warm,
            "idle_seconds": idle,
            "idle_per_second": {name: statistics.median(rates) for name, rates in quiet.items()},
            "background_share": background,
            "dump_seconds": {name: statistics.median(took for _, took in d) for name, d in dumped.items()},
            "start_seconds": {g.name: g.start_seconds for g in gateways},
            "target": TARGET, "targeted": list(TARGETED), **({"baseline": baseline_name()} if BASELINE else {})}


def _method(r: Result) -> str:
    """How the counts of *r* were made (results counted before one start per checkout differ)."""
    if "few" in r:
        return (f"as the difference between {r['many']} and {r['few']} requests one after another on a kept-alive "
                "connection (a gateway started under valgrind for each), divided by their difference. The counts "
                "still move by up to a tenth from run to run, so compare the columns of one run.")
    starts = ", ".join(f"{name} {seconds:.0f} s" for name, seconds in r["start_seconds"].items())
    idle = "; ".join(f"{name} {rate:,.0f} a second, at most {100 * r['background_share'][name]:.1f} % of a count"
                     for name, rate in r["idle_per_second"].items())
    return (f"one gateway process per checkout, started once with the instrumentation off (start-up: {starts}), "
            f"{r['warm']} requests of each kind answered uncounted, then counted: the counters zeroed, "
            f"{r['requests']} requests of one kind answered one after another on a kept-alive connection, the "
            f"counters dumped, and the dump's total divided by {r['requests']}. The kinds and the checkouts take "
            f"turns, {r['dumps']} dumps each; the table gives the medians (lowest–highest dump in brackets). "
            f"Left without requests for {r['idle_seconds']:g} s after each round, each gateway still ran "
            f"instructions of its own, its timers' ({idle}): what they can add to a count.")


def render(r: Result) -> str:
    """The section of docs/benchmarks.md."""
    if "skipped" in r:
        return f"## Instructions per request\n\nSkipped: {r['skipped']}\n"
    names = list(r["instructions"])
    header = " | ".join(names if len(names) == 1 else [names[0], f"baseline ({r['baseline']})"])
    lines = ["## Instructions per request", "",
             "Counted by valgrind's callgrind in the gateway's process (not timed: the machine's load does not "
             f"change them), {_method(r)}", "",
             f"| request | {header} |", "|---|" + "---|" * len(names)]
    spread = r.get("spread", {})

    def cell(name: str, label: str) -> str:
        low_high = spread.get(name, {}).get(label)
        figure = f"{r['instructions'][name][label]:,.0f}"
        return figure if low_high is None else f"{figure} ({low_high[0]:,.0f}–{low_high[1]:,.0f})"

    counted = list(r["instructions"][names[0]])  # (the requests of the run: older runs counted others)
    for label in counted:
        lines.append(f"| {label} | " + " | ".join(cell(name, label) for name in names) + " |")
    if len(names) > 1 and "target" in r:  # (results counted before issue 32 carry no target)
        this, before = (r["instructions"][name] for name in names)
        target = r["target"]
        verdicts = [f"{label}: {this[label] / before[label]:.2f} of the baseline's (target ≤ {target}): "
                    + ("met" if this[label] <= target * before[label] else "**MISSED**")
                    for label in r.get("targeted", (*TARGETED, "/version (routed)")) if label in this]
        lines += ["", "Issue 32's goal, at most the baseline's count less 15 %: " + "; ".join(verdicts) + "."]
    return "\n".join([*lines, ""])
