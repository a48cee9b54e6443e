"""Helpers shared by the benchmarks: server processes, statistics, CPU and memory readings."""

from __future__ import annotations

import asyncio
import contextlib
import os
import socket
import statistics
import subprocess
import sys
from collections.abc import AsyncIterator, Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
#: Another checkout measured beside this one: a folder whose ``aiogenomix`` is that checkout's package
#: (``AIOGENOMIX_BENCH_BASELINE``, put first on the baseline servers' import path).
BASELINE = os.environ.get("AIOGENOMIX_BENCH_BASELINE")


def baseline_name() -> str | None:
    """The baseline's commit as the results and docs/benchmarks.md name it, never a path of this machine.

    ``AIOGENOMIX_BENCH_BASELINE_NAME`` when it is set; else ``git describe --always --dirty`` of
    the repository the baseline's package lives in (``aiogenomix`` may be a link into a clone:
    it is followed); else, for a tree that is not a git checkout, the folder's own name.
    """
    if not BASELINE:
        return None
    named = os.environ.get("AIOGENOMIX_BENCH_BASELINE_NAME")
    if named:
        return named
    package = (Path(BASELINE) / "aiogenomix").resolve()
    try:
        described = subprocess.run(["git", "-C", str(package), "describe", "--always", "--dirty"],
                                   capture_output=True, text=True, check=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        described = ""
    return described or f"an unversioned tree ({Path(BASELINE).name})"


def free_port() -> int:
    """A TCP port of 127.0.0.1 free now (for a server that must be told its port)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@contextlib.asynccontextmanager
async def server(kind: str, pythonpath: str | None = None, args: Sequence[str] = ()) -> AsyncIterator[tuple[int, int]]:
    """Start ``bench._server KIND [ARGS]`` in its own process; yield ``(port, pid)``.

    *pythonpath* comes first on the server's import path (another checkout's
    ``aiogenomix``, to measure it beside this one).
    """
    env = None
    if pythonpath:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [pythonpath, os.environ.get("PYTHONPATH")])))
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "bench._server", kind, *args, cwd=ROOT, env=env,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL,
    )
    try:
        assert process.stdout is not None
        line = (await asyncio.wait_for(process.stdout.readline(), 60)).decode().split()
        if not line or line[0] != "ready":
            raise RuntimeError(f"bench server {kind} did not start: {line}")
        yield int(line[1]), process.pid
    finally:
        process.terminate()
        await process.wait()


def summary(samples: Sequence[float], scale: float = 1e3) -> dict[str, float]:
    """Median, p99, min and count of *samples* (seconds, reported in ms by default)."""
    ordered = sorted(samples)
    p99 = ordered[min(len(ordered) - 1, int(round(0.99 * (len(ordered) - 1))))]
    return {"median": statistics.median(ordered) * scale, "p99": p99 * scale, "min": ordered[0] * scale,
            "n": len(ordered)}


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds used so far by process *pid*."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def rss_bytes(pid: int) -> int:
    """Resident memory of process *pid*."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise RuntimeError(f"no VmRSS for {pid}")


def tree_rss_bytes(pid: int) -> int:
    """Resident memory of process *pid* and of its children (the world's render process)."""
    children = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(OSError):
            children += [int(child) for child in (task / "children").read_text().split()]
    total = rss_bytes(pid)
    for child in children:
        with contextlib.suppress(OSError, RuntimeError):  # a child that just ended
            total += rss_bytes(child)
    return total


def verdict(value: float, target: float, lower_is_better: bool = True) -> str:
    """``met`` or ``MISSED`` for a figure against its target."""
    ok = value <= target if lower_is_better else value >= target
    return "met" if ok else "MISSED"


Result = dict[str, Any]
