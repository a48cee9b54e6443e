"""What a request costs the gateway, counted in instructions rather than timed.

The machines these benchmarks run on are shared, and a timed figure moves with
their load; valgrind's callgrind counts the instructions a process executes,
which the load does not change.  The gateway runs under callgrind twice per
kind of request, answering ``few`` and then ``many`` of them one after another
on a kept-alive connection; the difference, divided by ``many - few``, is what
one request costs (start-up and shutdown cancel out).  With
``AIOGENOMIX_BENCH_BASELINE=DIR`` another checkout's gateway is counted the same
way, beside this one.
"""

from __future__ import annotations

import asyncio
import os
import re
import shutil
import sys
import tempfile
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


async def _count(path: str, requests: int, pythonpath: str | None) -> int:
    """The instructions of a gateway process that answered *requests* GETs of *path*."""
    port = free_port()
    env = dict(os.environ, PYTHONHASHSEED="0")  # the same dictionaries every run
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "callgrind.out"
        process = await asyncio.create_subprocess_exec(
            "valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable, "-c", _SERVER, str(port),
            env=env, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL)
        assert process.stdout is not None
        if (await asyncio.wait_for(process.stdout.readline(), 600)).strip() != b"ready":
            raise RuntimeError("the gateway did not start under valgrind")
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        request = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode()
        for _ in range(requests):
            writer.write(request)
            head = await reader.readuntil(b"\r\n\r\n")
            await reader.readexactly(int(head.lower().split(b"content-length: ")[1].split(b"\r\n")[0]))
        writer.close()
        process.terminate()
        await process.wait()
        found = re.search(rb"^(?:summary|totals): (\d+)", out.read_bytes(), re.M)
        if found is None:
            raise RuntimeError("callgrind wrote no total")
        return int(found.group(1))


async def run(few: int = 300, many: int = 2300) -> Result:
    """Instructions per request of each kind in :data:`REQUESTS` (and of the baseline's gateway)."""
    if shutil.which("valgrind") is None:
        return {"skipped": "valgrind is not installed (./run bench installs it)"}
    if many <= few:
        return {"skipped": "not counted in a quick run"}
    gateways = {"this gateway": None, **({"baseline": BASELINE} if BASELINE else {})}
    counts: dict[str, dict[str, float]] = {name: {} for name in gateways}
    for label, path in REQUESTS.items():
        for name, pythonpath in gateways.items():
            low = await _count(path, few, pythonpath)
            high = await _count(path, many, pythonpath)
            counts[name][label] = (high - low) / (many - few)
    return {"instructions": counts, "few": few, "many": many, "target": TARGET, "targeted": list(TARGETED),
            "baseline": baseline_name()}


def render(r: Result) -> str:
    """The section of docs/benchmarks.md."""
    if "skipped" in r:
        return f"## Instructions per request\n\nSkipped: {r['skipped']}\n"
    names = list(r["instructions"])
    header = " | ".join(names if len(names) == 1 else [names[0], f"baseline ({r['baseline']})"])
    lines = ["## Instructions per request", "",
             "Counted by valgrind's callgrind in the gateway's process (not timed: the machine's load does not "
             f"change them), as the difference between {r['many']} and {r['few']} requests one after another on a "
             "kept-alive connection, divided by their difference. The counts still move by up to a tenth from "
             "run to run (how many turns of the event loop a request takes depends on when its bytes arrive), so "
             "compare the columns of one run.", "",
             f"| request | {header} |", "|---|" + "---|" * len(names)]
    counted = list(r["instructions"][names[0]])  # (the requests of the run: older runs counted others)
    for label in counted:
        lines.append(f"| {label} | " + " | ".join(f"{r['instructions'][name][label]:,.0f}" for name in names) + " |")
    if len(names) > 1 and "target" in r:  # (results counted before issue 32 carry no target)
        this, before = (r["instructions"][name] for name in names)
        target = r["target"]
        verdicts = [f"{label}: {this[label] / before[label]:.2f} of the baseline's (target ≤ {target}): "
                    + ("met" if this[label] <= target * before[label] else "**MISSED**")
                    for label in r.get("targeted", (*TARGETED, "/version (routed)")) if label in this]
        lines += ["", "Issue 32's goal, at most the baseline's count less 15 %: " + "; ".join(verdicts) + "."]
    return "\n".join([*lines, ""])
