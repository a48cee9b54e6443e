"""Run the benchmarks: ``./run bench [--quick] [--only NAME ...]``.

Prints the figures, and writes them to ``docs/benchmarks.md`` (tables) and
``bench/results/latest.json`` (everything, machine-readable).
"""

from __future__ import annotations

import argparse
import asyncio
import datetime
import json
import os
import platform
import sys
import time
from collections.abc import Awaitable, Callable
from typing import Any

from . import (
    budgets, fanout, fuzz_memory, instructions, load, localisation, memory, port_read, profile, record, remote, rooms,
    scale, service, sessions, soak, sse_clients, storm, viewers, world,
)
from ._common import ROOT
from ._report import render

#: Each benchmark: its runner, its keyword arguments for the record, and for a quick run (checks that it works).
BENCHMARKS: dict[str, tuple[Callable[..., Awaitable[Any]], dict[str, Any], dict[str, Any]]] = {
    "port_read": (port_read.run, {"reads": 120, "block": 10}, {"reads": 9, "block": 3, "windows": (500, 4000)}),
    "service": (service.run, {"calls": 2000}, {"calls": 300}),
    "fanout": (fanout.run, {"seconds": 10.0}, {"seconds": 2.0}),
    "load": (load.run, {"seconds": 30.0}, {"seconds": 3.0, "rounds": 3}),
    "soak": (soak.run, {"seconds": 120.0}, {"seconds": 5.0}),
    "memory": (memory.run, {"sessions": 250, "requests": 5000}, {"sessions": 100, "requests": 1000}),
    "world": (world.run, {"seconds": 5.0, "calls": 2000, "rounds": 5}, {"seconds": 2.0, "calls": 300, "rounds": 1}),
    "remote": (remote.run, {"calls": 2000, "reads": 200, "seconds": 60.0},
               {"calls": 300, "reads": 40, "blocks": 4, "seconds": 4.0}),
    # As root (network namespaces): skipped, saying why, otherwise.
    "scale": (scale.run, {"hosts": (1, 5, 10, 20), "idle": 20.0, "calls": 2000},
              {"hosts": (1, 2), "idle": 2.0, "calls": 100, "blocks": 2}),
    "sse_clients": (sse_clients.run, {"events": 50}, {"events": 5}),
    "sessions": (sessions.run, {"sessions": 15_000, "sample": 500}, {"sessions": 1_000, "sample": 100}),
    "budgets": (budgets.run, {}, {"clients": 8, "chunks": 40, "seconds": 2.0, "rounds": 1, "size": "256x256"}),
    "storm": (storm.run, {"listens": 3000, "rounds": 3, "settle": 60.0}, {"listens": 300, "rounds": 1, "settle": 2.0}),
    "fuzz_memory": (fuzz_memory.run, {"clients": 50, "seconds": 30.0, "settle": 60.0},
                    {"clients": 10, "seconds": 4.0, "settle": 2.0}),
    "viewers": (viewers.run, {"seconds": 20.0, "crowd": 500}, {"seconds": 3.0, "crowd": 40}),
    "localisation": (localisation.run, {"seconds": 5.0, "rounds": 7}, {"seconds": 1.0, "rounds": 2}),
    "rooms": (rooms.run, {"seconds": 4.0, "rounds": 15, "repeats": 9}, {"seconds": 1.0, "rounds": 1, "repeats": 3}),
    "record": (record.run, {"seconds": 600.0, "block": 20.0, "blocks": 6, "http_seconds": 120.0},
               {"seconds": 20.0, "block": 4.0, "blocks": 2, "http_seconds": 8.0}),
    # Not in a quick run: starting a gateway under valgrind, uninstrumented, still takes half a minute.
    "instructions": (instructions.run, {"requests": 200, "dumps": 9}, {"requests": 0}),
    "profile": (profile.run, {"reads": 100}, {"reads": 10}),
}


async def _one(name: str, quick: bool) -> Any:
    runner, full, short = BENCHMARKS[name]
    print(f"bench: {name} ...", file=sys.stderr, flush=True)
    started = time.monotonic()
    result = await runner(**(short if quick else full))
    print(f"bench: {name} took {time.monotonic() - started:.1f} s", file=sys.stderr, flush=True)
    result["measured"] = {"date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                          "python": platform.python_version(), "quick": quick}
    print(json.dumps(result, indent=1, default=float), flush=True)
    return result


async def _run(names: list[str], quick: bool) -> dict[str, Any]:
    if quick:
        # A quick run checks that every benchmark works (its figures are not for the record):
        # the benchmarks run side by side, so that it takes under a minute.
        return dict(zip(names, await asyncio.gather(*(_one(name, quick) for name in names)), strict=True))
    # A full run measures one benchmark at a time: nothing else of ours competes for the CPUs.
    return {name: await _one(name, quick) for name in names}


def main(argv: list[str] | None = None) -> int:
    """Run the chosen benchmarks and write the report."""
    parser = argparse.ArgumentParser(prog="./run bench", description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=list(BENCHMARKS), default=list(BENCHMARKS))
    parser.add_argument("--quick", action="store_true",
                        help="short runs side by side, to check the benchmarks work (under a minute)")
    parser.add_argument("--no-write", action="store_true", help="print only; leave docs/benchmarks.md alone")
    parser.add_argument("--render", action="store_true",
                        help="only rewrite docs/benchmarks.md from bench/results/latest.json")
    args = parser.parse_args(argv)
    path = ROOT / "bench" / "results" / "latest.json"
    if args.render:
        saved = json.loads(path.read_text())
        (ROOT / "docs" / "benchmarks.md").write_text(render(saved["machine"], saved["results"]))
        return 0
    results = asyncio.run(_run(args.only, args.quick))
    machine = {"date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
               "python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count(),
               "quick": args.quick}
    if not args.no_write:
        previous = json.loads(path.read_text()) if path.exists() else {"results": {}}
        merged = previous.get("results", {}) | results
        path.write_text(json.dumps({"machine": machine, "results": merged}, indent=1, default=float) + "\n")
        (ROOT / "docs" / "benchmarks.md").write_text(render(machine, merged))
        print(f"bench: wrote {path.relative_to(ROOT)} and docs/benchmarks.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
