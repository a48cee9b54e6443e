"""Where a port read's time goes: the gateway under cProfile while a raw reader reads a new publication each time.

The benchmark gateway runs with ``--profile`` (cProfile, stats written when it
is stopped) while a raw reader reads ``kemarcapture``'s 4000 ms window, each
read one chunk period after the last (so each read is of a publication nobody
has read yet), in JSON and in binary, then asks ``/version?s=profile`` as many
times (a request through aiohttp's routes, with nothing to build: a plain
``/version`` is answered ahead of them, and the routes alone take a session).  The figures are
per call of the gateway's functions, in ms.  cProfile slows Python code about
twofold and C calls (the kernel copy, orjson) not at all: the Python figures
are upper bounds, and what matters is their share.
"""

from __future__ import annotations

import asyncio
import pstats
import tempfile
from pathlib import Path
from typing import Any

import aiohttp

from ._common import Result, server
from ._raw import RawReader
from .port_read import CHUNK_MS, MODULE, WINDOWS, _http_get, _start_window

#: (label, file name ending, function name): the functions whose time per call is reported.
FUNCTIONS = [
    ("aiohttp: a request's bytes received and parsed (every request)", "web_protocol.py", "data_received"),
    ("aiohttp: a request handled (its task, request object and reply; every request)", "web_protocol.py",
     "_handle_request"),
    ("the server's handler: a plain read answered, or the routes", "gateway/_ahead.py", "handle"),
    ("a plain read answered ahead of the routes (all below but the write)", "gateway/_fast_reads.py", "reply"),
    ("the door's decision", "gateway/_door.py", "decide"),
    ("the read's body (made ahead for a polled form: found ready)", "gateway/_routes_ports.py", "read_body"),
    ("a body made ahead, when the publication came", "gateway/_read_bodies.py", "_make_ahead"),
    ("the publication's struct with chunked arrays", "capture/_port_view.py", "chunked"),
    ("build a JSON body (splice the chunks' texts)", "gateway/_pieces.py", "json_pieces"),
    ("a new chunk's JSON text (orjson)", "core/_chunked.py", "json"),
    ("build a binary body (list the chunks' memory)", "core/_binary.py", "encode_binary"),
    ("the gathered write (writev: the kernel's copy)", "gateway/_gather.py", "write_gathered"),
    ("the guard, route and handler (/version)", "gateway/_guard.py", "guard"),
    ("the /version handler", "gateway/_routes_admin.py", "version"),
]

#: ``/version`` through the routes (a plain one is answered ahead of them: ``gateway/_fast_answers.py``).
ROUTED_VERSION = "/version?s=profile"


def _per_call(stats: pstats.Stats) -> dict[str, dict[str, float]]:
    found: dict[str, dict[str, float]] = {}
    for (filename, _, name), (_, calls, _, cumulative, _) in stats.stats.items():  # type: ignore[attr-defined]
        for label, ending, function in FUNCTIONS:
            if name == function and filename.endswith(ending) and calls:
                found[label] = {"calls": calls, "ms_per_call": 1e3 * cumulative / calls}
    return found


async def run(reads: int = 100) -> Result:
    """Profile *reads* fresh JSON reads, as many binary ones and as many routed ``/version`` requests."""
    chunks = WINDOWS[4000]
    with tempfile.TemporaryDirectory() as directory:
        stats_file = Path(directory) / "gateway.prof"
        async with server("gateway", args=["--profile", str(stats_file)]) as (port, _):
            base = f"http://127.0.0.1:{port}"
            async with aiohttp.ClientSession() as http:
                await http.get(f"{base}/load/{MODULE}")
                await _start_window(http, base, chunks)
            reader = await RawReader.connect(port, http=True)
            path = f"/module/{MODULE}/read/Port"
            for request in (_http_get(path), _http_get(path + "?format=binary"), _http_get(ROUTED_VERSION)):
                for _ in range(reads):
                    await asyncio.sleep(CHUNK_MS / 1000)
                    await reader.exchange(request)
            reader.close()
        stats = pstats.Stats(str(stats_file))
    functions: dict[str, Any] = _per_call(stats)
    return {"reads": reads, "window_ms": 4000, "functions": functions,
            "labels": [label for label, _, _ in FUNCTIONS if label in functions]}


def render(r: Result) -> str:
    """The table of the profile, for docs/benchmarks.md."""
    lines = ["### Profile of a read of a new publication (4000 ms window)", "",
             f"{r['reads']} JSON reads, {r['reads']} binary reads and {r['reads']} `{ROUTED_VERSION}` requests "
             "(through the routes), each one chunk period after the last, against the gateway under cProfile "
             "(`./run bench --only profile`). Time per call, cumulative (a function's figure includes those it "
             "calls); Python figures are upper bounds (cProfile slows Python code about twofold, C calls not).", "",
             "| function | calls | ms per call |", "|---|---|---|"]
    for label in r["labels"]:
        figure = r["functions"][label]
        lines.append(f"| {label} | {figure['calls']} | {figure['ms_per_call']:.3f} |")
    return "\n".join(lines + [""])
