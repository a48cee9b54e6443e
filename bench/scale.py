"""Component hosts behind one router: what each costs at N = 1, 5, 10, 20 hosts (network namespaces, as root).

Deployed as docs/remote.md says: a Zenoh router, each component host on a machine of its own with
its own user and password, one gateway connected only to the router. Each is a network namespace
here (``bench/_netns.py``: linked by a bridge in the router's), Zenoh's shared memory off as between
machines, ``INSTANCES`` ``demo`` instances per host. For each N, in the same run and taking turns
with this checkout, ``AIOGENOMIX_BENCH_BASELINE``'s code (the "before") runs the same deployment:

* idle: each process's CPU over ``idle`` seconds once every instance is loaded, and the packets each
  host received meanwhile (the heartbeats it hears). Goals: a host's idle CPU at N = 20 within 1.2 × its
  idle CPU at N = 1; the router's at most 1 % of a core;
* calls: ``demo`` ``GetSpeed`` from a raw HTTP client beside the gateway, in blocks that take turns:
  interleaved over every host, and to the first host alone. Goals: the interleaved median at most 1.1 ×
  the first host's alone, p99 at most 1.5 ×;
* memory (RSS) and the time to load every instance.

``python -m bench.scale client ...`` is the HTTP client, run inside the gateway's namespace.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import re
import signal
import statistics
import sys
import tempfile
import time
from collections.abc import AsyncIterator, Sequence
from pathlib import Path
from typing import Any

from . import _netns
from ._common import BASELINE, ROOT, Result, baseline_name, rss_bytes, summary

#: ``demo`` instances per host.
INSTANCES = 5
#: The gateway's HTTP port (in its own namespace).
HTTP_PORT = 8080
#: A host's idle CPU at N = 20 ÷ at N = 1; the router's idle CPU (% of a core) at N = 20.
HOST_IDLE_TARGET = 1.2
ROUTER_IDLE_TARGET = 1.0
#: Calls interleaved over every host ÷ calls to the first host alone: median, p99.
SPREAD_MEDIAN_TARGET = 1.1
SPREAD_P99_TARGET = 1.5
#: Milliseconds within which the requests of a killed host end.
KILLED_TARGET_MS = 100
#: Seconds the other hosts are called around the kill of the first (it comes half-way).
FAULT_SECONDS = 4.0

_ROUTER = """
import json, sys, threading, zenoh
config = zenoh.Config.from_file(sys.argv[1])
session = zenoh.open(config)
print("router ready", flush=True)
threading.Event().wait()
"""


def _cpu_seconds(pid: int) -> float:
    """CPU seconds process *pid*'s threads have run so far, to the nanosecond (an idle process uses little)."""
    total = 0
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(OSError):  # a thread that just ended
            total += int((task / "schedstat").read_text().split()[0])
    return total / 1e9


def _machine_busy_seconds() -> float:
    """CPU seconds every core of the machine has run anything so far (user, system, interrupts; not steal)."""
    fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]
    user, nice, system, _idle, _iowait, irq, softirq = (int(f) for f in fields[:7])
    return (user + nice + system + irq + softirq) / os.sysconf("SC_CLK_TCK")


def _name(number: int) -> str:
    return f"h{number:02d}"


def _instances(host: str) -> list[str]:
    return [f"{host}d{k}" for k in range(1, INSTANCES + 1)]


class _Configs:
    """Zenoh's configuration files of the deployment: the router's with its users, and each client's."""

    def __init__(self, folder: Path, router: str, hosts: int) -> None:
        self.folder = folder
        self.router_endpoint = f"tcp/{router}:7447"
        users = {"gateway": "gateway-secret", **{_name(n): f"{_name(n)}-secret" for n in range(1, hosts + 1)}}
        dictionary = folder / "users.txt"
        dictionary.write_text("".join(f"{user}:{password}\n" for user, password in users.items()))
        dictionary.chmod(0o600)
        no_shm = {"enabled": False}  # as between machines (each namespace is one here)
        self._write("router", {"mode": "router", "listen": {"endpoints": [self.router_endpoint]},
                               "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
                               "transport": {"auth": {"usrpwd": {"dictionary_file": str(dictionary)}},
                                             "shared_memory": no_shm}})
        for user, password in users.items():
            self._write(user, {"mode": "client", "connect": {"endpoints": [self.router_endpoint]},
                               "transport": {"auth": {"usrpwd": {"user": user, "password": password}},
                                             "shared_memory": no_shm}})

    def _write(self, name: str, config: dict[str, Any]) -> None:
        path = self.path(name)
        path.write_text(json.dumps(config))  # JSON is JSON5
        path.chmod(0o600)

    def path(self, name: str) -> Path:
        """The configuration file of *name* (``router``, ``gateway``, or a host)."""
        return self.folder / f"{name}.json5"


class _Process:
    """A process in a namespace; its output kept until it says it is ready, then drained."""

    def __init__(self, process: asyncio.subprocess.Process, name: str) -> None:
        self.process = process
        self.name = name
        self._drains: list[asyncio.Task[None]] = []

    @property
    def pid(self) -> int:
        return self.process.pid

    async def ready(self, pattern: str, stream: str) -> re.Match[str]:
        reader = self.process.stdout if stream == "stdout" else self.process.stderr
        assert reader is not None
        seen: list[str] = []
        async with asyncio.timeout(180):  # 20 hosts starting together on a busy machine
            while True:
                line = (await reader.readline()).decode()
                if not line:
                    raise RuntimeError(f"{self.name} ended before it was ready:\n{''.join(seen[-20:])}")
                seen.append(line)
                if found := re.search(pattern, line):
                    for pipe in (self.process.stdout, self.process.stderr):
                        if pipe is not None:
                            self._drains.append(asyncio.create_task(_drain(pipe)))
                    return found

    async def end(self) -> None:
        if self.process.returncode is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                await asyncio.wait_for(self.process.wait(), 20)
            except TimeoutError:
                self.process.kill()
                await self.process.wait()
        await asyncio.gather(*self._drains, return_exceptions=True)


async def _drain(reader: asyncio.StreamReader) -> None:
    with contextlib.suppress(Exception):
        while await reader.read(65536):
            pass


async def _start(lab: _netns.Star, machine: str, args: Sequence[str], code: str | None, ready: str,
                 stream: str) -> tuple[_Process, re.Match[str]]:
    """Run ``python ARGS`` on *machine* with *code* first on its import path (None: this checkout)."""
    env = dict(os.environ)
    if code:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [code, os.environ.get("PYTHONPATH")]))
    process = await asyncio.create_subprocess_exec(
        *lab.on(machine), sys.executable, *args, cwd=ROOT, env=env, stdin=asyncio.subprocess.DEVNULL,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    started = _Process(process, machine)
    try:
        return started, await started.ready(ready, stream)
    except BaseException:
        await started.end()
        raise


@contextlib.asynccontextmanager
async def _deployment(lab: _netns.Star, configs: _Configs, hosts: int,
                      code: str | None) -> AsyncIterator[dict[str, _Process]]:
    """The router, *hosts* component hosts and the gateway, running *code*; yields them by machine name."""
    running: dict[str, _Process] = {}
    try:
        running["hub"], _ = await _start(lab, "hub", ["-c", _ROUTER, str(configs.path("router"))], None,
                                         r"router ready", "stdout")

        async def host(number: int) -> None:
            name = _name(number)
            args = ["-m", "aiogenomix.remote._host_main", *(f"demo:-i {i}" for i in _instances(name)),
                    "--host-id", name, "--zenoh-config", str(configs.path(name)), "--audio-socket-port", "0",
                    "--log-level", "warning"]
            running[name], _ = await _start(lab, name, args, code, r"offering", "stderr")

        await asyncio.gather(*(host(n) for n in range(1, hosts + 1)))
        args = ["-m", "aiogenomix.gateway", "--host", lab.machines["gw"], "--port", str(HTTP_PORT),
                "--audio-socket-port", "0", "--log-level", "warning", "--zenoh-config", str(configs.path("gateway")),
                "--max-instances", str(hosts * INSTANCES + 10)]
        running["gw"], _ = await _start(lab, "gw", args, code, r"listening on", "stdout")
        yield running
    finally:
        await asyncio.gather(*(p.end() for p in running.values()), return_exceptions=True)


async def _kill_one(lab: _netns.Star, victim: _Process, names: list[str]) -> dict[str, Any]:
    """SIGKILL the first host while it runs a motion and the others are called; what the clients saw."""
    process = await asyncio.create_subprocess_exec(
        *lab.on("gw"), sys.executable, "-m", "bench.scale", "client", f"http://{lab.machines['gw']}:{HTTP_PORT}",
        "fault", *(f"{name}d1" for name in names), cwd=ROOT, stdin=asyncio.subprocess.PIPE,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    assert process.stdin is not None and process.stdout is not None
    line = await asyncio.wait_for(process.stdout.readline(), 120)
    if not line.startswith(b"moving"):
        _, err = await process.communicate()
        raise RuntimeError(f"bench client fault: {line!r}: {err.decode()[-2000:]}")
    await asyncio.sleep(FAULT_SECONDS / 2)  # the others are called before the kill as after it
    victim.process.send_signal(signal.SIGKILL)
    process.stdin.write(f"{time.monotonic()}\n".encode())  # one clock for every namespace of the machine
    await process.stdin.drain()
    out, err = await asyncio.wait_for(process.communicate(), 120)
    if process.returncode != 0:
        raise RuntimeError(f"bench client fault failed: {err.decode()[-2000:]}")
    found: dict[str, Any] = json.loads(out.decode().splitlines()[-1])
    return found


async def _client(lab: _netns.Star, *args: str) -> Any:
    """Run this module's HTTP client beside the gateway; return the JSON it prints."""
    process = await asyncio.create_subprocess_exec(
        *lab.on("gw"), sys.executable, "-m", "bench.scale", "client", f"http://{lab.machines['gw']}:{HTTP_PORT}",
        *args, cwd=ROOT, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    out, err = await asyncio.wait_for(process.communicate(), 1800)
    if process.returncode != 0:
        raise RuntimeError(f"bench client {args[0]} failed: {err.decode()[-2000:]}")
    return json.loads(out.decode().splitlines()[-1])


async def _round(lab: _netns.Star, configs: _Configs, hosts: int, code: str | None, idle: float,
                 calls: int, blocks: int) -> dict[str, Any]:
    """One deployment of *hosts* hosts running *code*: its idle costs, its calls, its memory."""
    names = [_name(n) for n in range(1, hosts + 1)]
    async with _deployment(lab, configs, hosts, code) as running:
        loaded = await _client(lab, "load", *(i for name in names for i in _instances(name)))
        await asyncio.sleep(2.0)  # the loads' after-effects (snapshots, facts) settle before the idle window
        cpu = {name: _cpu_seconds(p.pid) for name, p in running.items()}
        packets = {name: lab.received(name)[0] for name in names}
        machine, own = _machine_busy_seconds(), _cpu_seconds(os.getpid())
        began = time.monotonic()
        await asyncio.sleep(idle)
        elapsed = time.monotonic() - began
        idle_cpu = {name: 100 * (_cpu_seconds(p.pid) - cpu[name]) / elapsed for name, p in running.items()}
        # What ran on the machine meanwhile besides the deployment and this process: other work, which
        # makes the figures provisional (the load average counts the deployment's own processes too).
        other = 100 * (_machine_busy_seconds() - machine - (_cpu_seconds(os.getpid()) - own)) / elapsed \
            - sum(idle_cpu.values())
        heard = {name: (lab.received(name)[0] - packets[name]) / elapsed for name in names}
        rss = {name: rss_bytes(p.pid) / 1e6 for name, p in running.items()}
        timed = await _client(lab, "calls", str(calls), str(blocks), *(f"{name}d1" for name in names))
        fault = await _kill_one(lab, running["h01"], names) if hosts > 1 else None
    host_cpu = [idle_cpu[name] for name in names]
    return {
        "hosts": hosts, "load_seconds": loaded["seconds"],
        "idle_cpu_percent": {"host_mean": statistics.mean(host_cpu), "host_max": max(host_cpu),
                             "hosts_total": sum(host_cpu), "h01": idle_cpu["h01"], "router": idle_cpu["hub"],
                             "gateway": idle_cpu["gw"]},
        "packets_per_s": {"h01": heard["h01"], "host_mean": statistics.mean(heard.values())},
        "rss_mb": {"gateway": rss["gw"], "router": rss["hub"], "host_mean": statistics.mean(rss[n] for n in names)},
        "calls": timed, "fault": fault, "other_cpu_percent": other,
    }


async def run(hosts: Sequence[int] = (1, 5, 10, 20), idle: float = 10.0, calls: int = 2000,
              blocks: int = 10) -> Result:
    """Every N of *hosts*, this checkout and the baseline's taking turns."""
    why = _netns.unavailable()
    if why is not None:
        return {"skipped": why}
    codes = {"after": None, **({"before": BASELINE} if BASELINE else {})}
    rounds: dict[str, list[dict[str, Any]]] = {code: [] for code in codes}
    with _netns.star() as lab, tempfile.TemporaryDirectory(prefix="agx-scale-") as folder:
        for machine in ["gw", *map(_name, range(1, max(hosts) + 1))]:
            lab.add(machine)
        configs = _Configs(Path(folder), lab.hub_address, max(hosts))
        for n in hosts:
            for code, path in codes.items():
                print(f"bench: scale: {n} hosts, {code}", file=sys.stderr, flush=True)
                rounds[code].append(await _round(lab, configs, n, path, idle, calls, blocks))
    result: dict[str, Any] = {code: _verdicts(found) for code, found in rounds.items()}
    result["baseline"] = baseline_name()
    result["instances_per_host"] = INSTANCES
    result["load_average"] = os.getloadavg()[0]
    result["cpus"] = os.cpu_count()
    result["other_cpu_percent"] = max(f["other_cpu_percent"] for found in rounds.values() for f in found)
    return result


def _verdicts(rounds: list[dict[str, Any]]) -> dict[str, Any]:
    """The rounds of one code, with the goals checked between its smallest and largest N."""
    first, last = rounds[0], rounds[-1]
    host_ratio = last["idle_cpu_percent"]["host_mean"] / max(first["idle_cpu_percent"]["host_mean"], 1e-9)
    spread = last["calls"]
    return {"rounds": rounds, "host_idle_ratio": host_ratio, "router_idle_percent": last["idle_cpu_percent"]["router"],
            "spread_median_ratio": spread["median_ratio"], "spread_p99_ratio": spread["p99_ratio"],
            "verdicts": {
                "host_idle": "met" if host_ratio <= HOST_IDLE_TARGET else "MISSED",
                "router_idle": "met" if last["idle_cpu_percent"]["router"] <= ROUTER_IDLE_TARGET else "MISSED",
                "spread_median": "met" if spread["median_ratio"] <= SPREAD_MEDIAN_TARGET else "MISSED",
                "spread_p99": "met" if spread["p99_ratio"] <= SPREAD_P99_TARGET else "MISSED"}}


# -- the HTTP client, beside the gateway ------------------------------------------------------------------


async def _load(url: str, names: list[str]) -> dict[str, Any]:
    """Wait until the gateway hears every offer of *names*, then load them all; how long the loads took."""
    import aiohttp

    async with aiohttp.ClientSession(base_url=url) as http:
        async with asyncio.timeout(180):
            while True:
                async with http.get("/") as reply:
                    index = await reply.json()
                offered = {i for host in index.get("zenoh", {}).get("hosts", []) for i in host["offers"]}
                if offered >= set(names):
                    break
                await asyncio.sleep(0.2)  # polling the gateway's own view: there is no event to wait on here
        began = time.monotonic()
        replies = await asyncio.gather(*(http.get(f"/load/{name}") for name in names))
        statuses = [reply.status for reply in replies]
        for reply in replies:
            reply.release()
        if set(statuses) != {200}:
            raise RuntimeError(f"loads answered {sorted(set(statuses))}")
        return {"seconds": time.monotonic() - began}


async def _calls(url: str, calls: int, blocks: int, names: list[str]) -> dict[str, Any]:
    """``GetSpeed`` of each of *names* in turn, and of the first alone, in blocks that take turns."""
    from ._raw import RawReader

    host, port = url.removeprefix("http://").rsplit(":", 1)
    reader = await RawReader.connect(int(port), http=True, host=host)
    requests = [f"GET /module/{name}/send/GetSpeed HTTP/1.1\r\nHost: {host}\r\n\r\n".encode() for name in names]

    async def call(request: bytes) -> float:
        began = time.perf_counter()
        reply = await reader.exchange(request)
        if bytes(reply[9:12]) != b"200":
            raise RuntimeError(f"{request[:60]!r}: {bytes(reply[:200])!r}")
        return time.perf_counter() - began

    for request in requests * max(1, 200 // len(requests)):  # warm-up: every host, every path
        await call(request)
    per_block = max(1, calls // blocks)
    spread: list[list[float]] = []
    one: list[list[float]] = []
    for _ in range(blocks):
        spread.append([await call(requests[k % len(requests)]) for k in range(per_block)])
        one.append([await call(requests[0]) for _ in range(per_block)])
    reader.close()
    flat_spread = [t for block in spread for t in block]
    flat_one = [t for block in one for t in block]
    spread_summary, one_summary = summary(flat_spread), summary(flat_one)
    return {"spread": spread_summary, "one": one_summary,
            "median_ratio": spread_summary["median"] / one_summary["median"],
            "p99_ratio": spread_summary["p99"] / one_summary["p99"],
            "block_ratios": [statistics.median(s) / statistics.median(o) for s, o in zip(spread, one, strict=True)]}


async def _fault(url: str, names: list[str]) -> dict[str, Any]:
    """A motion on the first of *names*, the others called in turn until its host's death ends it."""
    import aiohttp

    async with aiohttp.ClientSession(base_url=url) as http:
        async with http.get(f"/module/{names[0]}/send/GotoPosition", params={"input": '{"posRef": 0.9}'}) as reply:
            sent = await reply.json()
        waiting = asyncio.ensure_future(http.get(f"/module/{names[0]}/wait/{sent['id']}", params={"timeout": "60"}))
        print("moving", flush=True)
        killed = asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
        began, ended = time.monotonic(), None
        calls = errors = 0
        while ended is None or time.monotonic() - began < FAULT_SECONDS:
            async with http.get(f"/module/{names[1 + calls % (len(names) - 1)]}/send/GetSpeed") as reply:
                errors += reply.status != 200
            calls += 1
            if ended is None and waiting.done():
                ended = time.monotonic()  # within one call of the wait's reply
        async with await waiting as reply:
            status = await reply.json()
        killed_at = float(await killed)
        return {"ended_ms": 1e3 * (ended - killed_at), "calls_to_others": calls, "errors_of_others": errors,
                "ex": (status.get("exception") or {}).get("ex"),
                "what": ((status.get("exception") or {}).get("detail") or {}).get("what")}


def _client_main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.scale client")
    parser.add_argument("url")
    sub = parser.add_subparsers(dest="what", required=True)
    load = sub.add_parser("load")
    load.add_argument("names", nargs="+")
    calls = sub.add_parser("calls")
    calls.add_argument("calls", type=int)
    calls.add_argument("blocks", type=int)
    calls.add_argument("names", nargs="+")
    fault = sub.add_parser("fault")
    fault.add_argument("names", nargs="+")
    args = parser.parse_args(argv)
    if args.what == "load":
        result = asyncio.run(_load(args.url, args.names))
    elif args.what == "calls":
        result = asyncio.run(_calls(args.url, args.calls, args.blocks, args.names))
    else:
        result = asyncio.run(_fault(args.url, args.names))
    print(json.dumps(result))


# -- the report -------------------------------------------------------------------------------------------


#: Other work on the machine during an idle window, % of a core, above which the figures are provisional.
OTHER_WORK_PERCENT = 10.0


def _busy(r: dict[str, Any]) -> str:
    """What the machine carried besides the benchmark, and whether that makes the figures provisional.

    Judged by the other work measured in the idle windows; results from before that measure, by the
    load average at the end of the run (which counts the deployment's own processes as well).
    """
    other = r.get("other_cpu_percent")
    if other is None:
        shared = r.get("load_average", 0) > 0.5 * (r.get("cpus") or 1)
        said = f"load average {r.get('load_average', 0):.1f}"
    else:
        shared = other > OTHER_WORK_PERCENT
        said = (f"other work in the idle windows at most {max(other, 0.0):.1f} % of a core; load average at the end "
                f"{r.get('load_average', 0):.1f}, the deployment's own processes included")
    return said + (": **provisional** figures, other work shared the machine; latencies most of all" if shared else "")


def render(r: dict[str, Any]) -> str:
    """The Markdown section of docs/benchmarks.md."""
    rows = ["## Component hosts behind one router (network namespaces)", ""]
    if "skipped" in r:
        return "\n".join([*rows, f"Not measured: {r['skipped']}.", ""])
    codes = [code for code in ("before", "after") if code in r]
    rows += [
        f"A Zenoh router, N component hosts each in a network namespace of its own with its own user and "
        f"password, one gateway connected only to the router, shared memory off (as between machines), "
        f"{r['instances_per_host']} `demo` instances per host, all loaded (`bench/scale.py`; run as root: "
        f"`./run bench --only scale`). Before (`{r.get('baseline') or 'no baseline given'}`) and after take turns "
        f"at each N in the same run ({_busy(r)}). Idle: % of a core "
        "over the idle window; calls: `demo` `GetSpeed` from a raw HTTP client beside the gateway, interleaved "
        "over every host and to the first host alone, in blocks that take turns (median / p99 ms).",
        "",
        "| N | code | host idle % (mean) | all hosts % | router % | gateway % | packets/s a host receives "
        "| interleaved | first host alone | ratio median / p99 | RSS MB gateway / router / host | load all s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    by_n: dict[int, list[tuple[str, dict[str, Any]]]] = {}
    for code in codes:
        for found in r[code]["rounds"]:
            by_n.setdefault(found["hosts"], []).append((code, found))
    for n, found_by_code in sorted(by_n.items()):
        for which, f in found_by_code:
            idle, calls, rss = f["idle_cpu_percent"], f["calls"], f["rss_mb"]
            rows.append(
                f"| {n} | {which} | {idle['host_mean']:.2f} | {idle['hosts_total']:.1f} | {idle['router']:.2f} | "
                f"{idle['gateway']:.2f} | {f['packets_per_s']['h01']:.1f} | {calls['spread']['median']:.2f} / "
                f"{calls['spread']['p99']:.2f} | {calls['one']['median']:.2f} / {calls['one']['p99']:.2f} | "
                f"{calls['median_ratio']:.2f} / {calls['p99_ratio']:.2f} | {rss['gateway']:.0f} / "
                f"{rss['router']:.0f} / {rss['host_mean']:.0f} | {f['load_seconds']:.2f} |")
    rows += [
        "",
        "What the after code does (decisions 38 and 46): a host hears the beats only of the hosts it reads from, and "
        "beats as often as those who hear it ask (every 0.5 s for the gateway's default stale bound of 2 s, where "
        "every host beat every 0.25 s), so the router forwards N beats per half-second to the gateway and none to "
        "the hosts (d5f1c87 sent every host every other host's beats); the gateway imports the audio library "
        "only when the live view shows an audio port (it had doubled its resident memory). Calls interleaved "
        "over the hosts reach a host that slept since its last "
        "call: at most half of that extra time is the hand-off to its event loop and its code run cold, the rest "
        "is Zenoh's threads and the machine (decision 46 measures each part).",
    ]
    rows.append("")
    for code in codes:
        v = r[code]
        rows.append(
            f"* **{code}**: a host's idle CPU at the largest N ÷ at the smallest {v['host_idle_ratio']:.2f} (goal ≤ "
            f"{HOST_IDLE_TARGET:g}: {v['verdicts']['host_idle']}); the router's {v['router_idle_percent']:.2f}% of "
            f"a core (goal ≤ {ROUTER_IDLE_TARGET:g}%: {v['verdicts']['router_idle']}); calls interleaved over "
            f"every host ÷ to one host: median {v['spread_median_ratio']:.2f} (goal ≤ {SPREAD_MEDIAN_TARGET:g}: "
            f"{v['verdicts']['spread_median']}), p99 {v['spread_p99_ratio']:.2f} (goal ≤ {SPREAD_P99_TARGET:g}: "
            f"{v['verdicts']['spread_p99']}).")
        fault = v["rounds"][-1].get("fault")
        if fault:
            rows.append(
                f"  The first host killed (SIGKILL) during a motion, at {v['rounds'][-1]['hosts']} hosts: its request "
                f"ended {fault['ended_ms']:.0f} ms after the kill (goal ≤ {KILLED_TARGET_MS} ms: "
                f"{'met' if fault['ended_ms'] <= KILLED_TARGET_MS else 'MISSED'}), `{fault['ex']}`: "
                f"\"{fault['what']}\"; "
                f"the other hosts' clients got {fault['errors_of_others']} errors in {fault['calls_to_others']} "
                f"calls meanwhile.")
    rows.append("")
    return "\n".join(rows)


if __name__ == "__main__":
    if sys.argv[1:2] == ["client"]:
        _client_main(sys.argv[2:])
    else:
        print(json.dumps(asyncio.run(run()), indent=1, default=float))
