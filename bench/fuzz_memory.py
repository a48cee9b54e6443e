"""The gateway's memory under a hostile fuzz (issue 29, item 7): its peak, and what it returns.

The gateway's command line with its default budgets, ``capture`` at 384 kHz, 50 ms chunks, 400 on
the port (59 MiB, as the budgets section starts it), its 2014 socket open, and ``demo``.  ``clients``
hostile clients (50) run at once for ``seconds``, each drawing one act after another from a seeded
mix of what the suite's fuzzers send (``tests/gateway/test_fuzz.py``, ``test_fuzz_newer_surfaces.py``)
and what the hostile reviews of issue 29 tried:

* odd heads (a field given twice, HTTP/0.9 and 2.0, a field line past the limit, too many fields, an
  unknown method, a URL past ``--max-url-bytes``, ``Expect: 100-continue`` announcing 64 MiB);
* bad JSON inputs (deep nesting, truncated text, 5,000-digit numbers, NaN, lone surrogates, duplicate
  keys) and huge parameters (a port past ``--max-port-bytes``, ``since`` of 6,000 digits, 60 kB strings);
* whole reads of the audio window, in JSON, in binary and ``since=0``, from a client with a 4 KiB
  receive buffer that never reads and drops (a reset) 1 to 8 s later;
* listens (``Last-Event-ID: 0``) and watches of the window that never read; the 2014 socket asked for
  the whole port and never read; connections dropped halfway through a head.

A witness polls the window's new chunks in binary twice a second meanwhile.  The gateway's resident
memory is sampled every 50 ms: before the clients, its peak, just after, and ``settle`` seconds (a
minute) after.  The budget is what the docs let clients make the gateway hold on top of what it held
before (see :func:`budget`).  With ``AIOGENOMIX_BENCH_BASELINE`` the same fuzz runs against that
checkout's gateway, after this one's.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import random
import socket
import time
import urllib.parse

import aiohttp

from aiogenomix.components.core import Budgets

from ._common import BASELINE, Result, baseline_name, rss_bytes, verdict
from .budgets import PER_CLIENT, _gateway, _Peak, _send, _until_full

MIB = 2**20
RATE, CHUNK_MS, CHUNKS = 384_000, 50, 400
FPC = RATE * CHUNK_MS // 1000
PORT_BYTES = 8 * FPC * CHUNKS
#: The JSON text of a chunk against its bytes, as the docs state it (Budgets: "about 3x their bytes").
JSON_RATIO = 3.0
#: The peak the issue reports for the earlier hostile fuzz (56 MB before, 526 MB after), MB.
ISSUE_PEAK_MB = 1200
#: This fuzz against ``main`` before the change of issue 29 (8e17479, this machine, two runs), MiB.
MAIN_BEFORE = {"peak": "2,101-2,511", "settled": "1,044-1,121"}

_RESET = b"\x01\x00\x00\x00\x00\x00\x00\x00"  # SO_LINGER on, 0 s: close() resets the connection
_ODD_HEADS = [
    b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nHost: evil.example\r\n\r\n",
    b"GET /module/demo/info HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: a\r\nContent-Type: b\r\n\r\n",
    b"GET /module/demo/info HTTP/1.1\r\nHost: 127.0.0.1\r\nUser-Agent: a\r\nUser-Agent: b\r\n\r\n",
    b"GET /\r\n\r\n",
    b"GET / HTTP/2.0\r\nHost: 127.0.0.1\r\n\r\n",
    b"FOO / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n",
    b"GET /\x00 HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n",
    b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Long: " + b"a" * 9000 + b"\r\n\r\n",
    b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n" + b"".join(b"X-%d: 1\r\n" % n for n in range(120)) + b"\r\n",
    b"GET /module/demo/read/Mobile?x=" + b"y" * 70_000 + b" HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n",
    b"POST /module/demo/send/GotoPosition HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
    b"Content-Length: 67108864\r\nExpect: 100-continue\r\n\r\n",
    b"GET /module/capture/read/Port HTTP/1.1\r\nHost: evil.example\r\nOrigin: https://evil.example\r\n\r\n",
    b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nTransfer-Encoding: chunked\r\nContent-Length: 5\r\n\r\n0\r\n\r\n",
]
_BAD_INPUTS = [
    "[" * 3000 + "]" * 3000, '{"posRef":0.3', "1" + "0" * 5000, "-" + "9" * 4400, "NaN", '"\\ud800"',
    '{"posRef":0.3,"posRef":0.6}', '{"posRef":' + "[" * 500 + "]" * 500 + "}", '{"x":"' + "x" * 5000 + '"}',
    '{"posRef":1e99999}', "\u202e", "",
]
_HUGE = [
    ("/module/capture/send/StartCapture", '{"device":"sim","transfer_rate":384000,"chunk_time":50,'
                                          '"Port_chunks":1000000}'),
    ("/module/capture/send/StartCapture", '{"device":"sim","transfer_rate":' + "9" * 400 + "}"),
    ("/module/demo/send/GotoPosition", '"' + "x" * 60_000 + '"'),
    ("/module/capture/read/Port", None),  # with since= of 6,000 digits, below
]
_ENDPOINTS = ["/module/%00/status/%C2%B2", "/module/demo/wait/1" + "1" * 5000, "/module/../info", "/load/world?argv="
              "-size%20%D9%A3x2%20-rate%201", "/session/start?s=%E2%80%AE", "/module/demo/abort/-0",
              "/module/capture/read/Nope", "/usage/%F0%9F%98%80", "/module/basc/read/Blocks", "/console",
              "/module/capture/read/Port?format=xml", "/module/capture/read/Port?since=%C2%B2"]
#: The acts and how often each is drawn.
MIX = {"odd_head": 4, "bad_input": 4, "huge": 2, "endpoint": 3, "drop": 2, "read_json": 3, "read_binary": 2,
       "read_since": 1, "listen": 2, "watch": 1, "socket": 1}


def _request(path: str, *headers: str) -> bytes:
    return (f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n" + "".join(f"{h}\r\n" for h in headers) + "\r\n").encode()


async def _open(port: int, small: bool) -> socket.socket:
    sock = socket.socket()
    if small:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.setblocking(False)
    await asyncio.get_running_loop().sock_connect(sock, ("127.0.0.1", port))
    return sock


def _reset(sock: socket.socket) -> None:
    with contextlib.suppress(OSError):
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, _RESET)
    sock.close()


async def _ask(port: int, request: bytes) -> int:
    """Send *request*, read the reply's status line (up to 5 s), drop; the status (0: none)."""
    loop = asyncio.get_running_loop()
    sock = await _open(port, small=False)
    try:
        await loop.sock_sendall(sock, request)
        async with asyncio.timeout(5.0):
            head = await loop.sock_recv(sock, 65536)
        return int(head.split(b" ", 2)[1]) if head.startswith(b"HTTP/1.") else 0
    except (OSError, TimeoutError, ValueError, IndexError):
        return 0
    finally:
        _reset(sock)


async def _never_read(port: int, request: bytes, hold: float) -> None:
    """Send *request* from a 4 KiB receive buffer, read nothing, reset *hold* seconds later."""
    sock = await _open(port, small=True)
    try:
        await asyncio.get_running_loop().sock_sendall(sock, request)
        await asyncio.sleep(hold)
    finally:
        _reset(sock)


async def _act(kind: str, draw: random.Random, http_port: int, socket_port: int) -> int:
    """One hostile act; the HTTP status it got, when it waited for one (else 0)."""
    hold = draw.uniform(1.0, 8.0)
    if kind == "odd_head":
        return await _ask(http_port, draw.choice(_ODD_HEADS))
    if kind == "bad_input":
        text = urllib.parse.quote(draw.choice(_BAD_INPUTS), safe="")
        return await _ask(http_port, _request(f"/module/demo/send/GotoPosition?s=fuzz&input={text}"))
    if kind == "huge":
        path, body = draw.choice(_HUGE)
        query = f"input={urllib.parse.quote(body, safe='')}" if body else "since=" + "9" * 6000
        return await _ask(http_port, _request(f"{path}?{query}"))
    if kind == "endpoint":
        return await _ask(http_port, _request(draw.choice(_ENDPOINTS)))
    if kind == "drop":
        sock = await _open(http_port, small=False)
        await asyncio.get_running_loop().sock_sendall(sock, b"GET /module/capture/read/Port HTTP/1.1\r\nHos")
        _reset(sock)
        return 0
    if kind in ("read_json", "read_binary", "read_since"):
        query = {"read_json": "", "read_binary": "?format=binary", "read_since": "?since=0"}[kind]
        await _never_read(http_port, _request(f"/module/capture/read/Port{query}"), hold)
    elif kind == "listen":
        await _never_read(http_port, _request("/session/listen?s=fuzz", "Accept: text/event-stream",
                                              "Last-Event-ID: 0"), hold)
    elif kind == "watch":
        await _never_read(http_port, _request("/module/capture/watch/Port?since=0"), hold)
    elif kind == "socket":
        await _never_read(socket_port, b"Read Port - Index 0\n", hold)
    return 0


async def _client(n: int, until: float, http_port: int, socket_port: int, tally: collections.Counter[str]) -> None:
    draw = random.Random(n)
    kinds, weights = list(MIX), list(MIX.values())
    while time.monotonic() < until:
        kind = draw.choices(kinds, weights)[0]
        try:
            status = await _act(kind, draw, http_port, socket_port)
        except OSError:
            tally["refused_connections"] += 1  # the machine's own limits under the storm: nothing was asked
            continue
        tally[kind] += 1
        if status >= 500 and status != 505:  # 505: the documented refusal of HTTP/0.9 and 2.0
            tally["5xx"] += 1
            tally[f"5xx {kind} {status}"] += 1


async def _witness(http: aiohttp.ClientSession, stop: asyncio.Event, got: list[int]) -> None:
    """A user of the window: its new chunks in binary twice a second; counts replies and failures."""
    since = None
    while not stop.is_set():
        params = {"format": "binary", **({"since": str(since)} if since is not None else {})}
        try:
            async with http.get("/module/capture/read/Port", params=params) as reply:
                body = await reply.read()
                if reply.status != 200:
                    got[1] += 1
                else:
                    got[0] += 1
                    since = _index(body)
        except (aiohttp.ClientError, TimeoutError):
            got[1] += 1
        await asyncio.sleep(0.5)


def _index(body: bytes) -> int:
    import orjson

    header = orjson.loads(body[8:8 + int.from_bytes(body[4:8], "little")])
    return int(header["data"]["index"])


def budget(before: int, clients: int) -> dict[str, float]:
    """What the docs let the clients make the gateway hold on top of *before* (its idle size, port full), MiB.

    * the JSON texts of the port's chunks once read as JSON: about 3x the port (docs/protocol.md,
      Budgets), and as much again for a publication a reply still holds after the port moved on (a
      window's worth at most while replies go out as the clients drain);
    * the 2014 socket: ``--max-socket-bytes``, one last reply (``--max-socket-client-bytes``) and
      :data:`~bench.budgets.PER_CLIENT` a client;
    * each HTTP connection's reply in the making: :data:`~bench.budgets.PER_CLIENT` (a piece of a reply
      and the transport's high-water mark), for every client at once.
    """
    budgets = Budgets()
    parts = {"idle": before / MIB, "json_texts": 2 * JSON_RATIO * PORT_BYTES / MIB,
             "socket": (budgets.socket_bytes + budgets.socket_client_bytes + clients * PER_CLIENT) / MIB,
             "connections": clients * PER_CLIENT / MIB}
    return parts | {"total": sum(parts.values())}


async def _fuzz(pythonpath: str | None, clients: int, seconds: float, settle: float) -> Result:
    async with _gateway("--load", "capture", "--load", "demo", pythonpath=pythonpath) as (url, socket_port, pid, _):
        http_port = int(url.rsplit(":", 1)[1].rstrip("/"))
        async with aiohttp.ClientSession(url) as http:
            await _send(http, "/module/capture/send/StartCapture", {
                "device": "sim", "transfer_rate": RATE, "chunk_time": CHUNK_MS, "Port_chunks": CHUNKS})
            await _send(http, "/module/capture/send/DedicatedSocket")
            async with http.get("/session/start", params={"s": "fuzz"}):
                pass
            await _until_full(http, "/module/capture/read/Port", CHUNKS, "index")
            await asyncio.sleep(1.0)  # settled: the set-up's own allocations gone
            before = rss_bytes(pid)
            tally: collections.Counter[str] = collections.Counter()
            got, stop = [0, 0], asyncio.Event()
            started = time.monotonic()
            async with _Peak(pid) as peak:
                witness = asyncio.create_task(_witness(http, stop, got))
                await asyncio.gather(*(_client(n, started + seconds, http_port, socket_port, tally)
                                       for n in range(clients)))
                took = time.monotonic() - started
                await asyncio.sleep(1.0)  # the gateway's side of the last acts ends
                after = rss_bytes(pid)
                stop.set()
                await witness
            await asyncio.sleep(settle)  # the requirement is about a minute after: the measure is of time
            settled = rss_bytes(pid)
            witnessed = got[0]
            got[0] = 0
            stop.clear()
            await _witness_once(http, got)
    bound = budget(before, clients)
    ok = tally["5xx"] == 0 and witnessed > 0 and got[0] > 0
    return {"clients": clients, "seconds": round(took, 1), "acts": dict(tally), "acts_total": sum(
                v for k, v in tally.items() if k in MIX),
            "before_mib": before / MIB, "peak_mib": peak.peak / MIB, "after_mib": after / MIB, "settle_s": settle,
            "settled_mib": settled / MIB, "witness_reads": witnessed, "witness_failures": got[1],
            "budget_mib": bound, "verdict": verdict(peak.peak / MIB, bound["total"]) if ok else "MISSED"}


async def _witness_once(http: aiohttp.ClientSession, got: list[int]) -> None:
    """The witness's read after the settle: the gateway still serves the window."""
    async with http.get("/module/capture/read/Port", params={"format": "binary"}) as reply:
        await reply.read()
        got[0 if reply.status == 200 else 1] += 1


async def run(clients: int = 50, seconds: float = 30.0, settle: float = 60.0) -> Result:
    """The fuzz (see the module's description), of this gateway and of the baseline's."""
    result: Result = {"after": await _fuzz(None, clients, seconds, settle)}
    if BASELINE:
        result["before"] = await _fuzz(BASELINE, clients, seconds, settle)
        result["baseline"] = baseline_name()
    return result


def render(r: Result) -> str:
    """The section of docs/benchmarks.md."""
    now = r["after"]
    rows = []
    for key, what in (("after", "this gateway"), ("before", f"before ({r.get('baseline', '')})")):
        x = r.get(key)
        if x is None:
            continue
        rows.append(f"| {what} | {x['acts_total']:,} | {x['before_mib']:.0f} | {x['peak_mib']:.0f} | "
                    f"{x['after_mib']:.0f} | {x['settled_mib']:.0f} | {x['budget_mib']['total']:.0f} | "
                    f"{x['acts'].get('5xx', 0)} | {x['witness_reads']} ({x['witness_failures']} failed) | "
                    f"**{x['verdict']}** |")
    b = now["budget_mib"]
    return "\n".join([
        "## A hostile fuzz: the gateway's memory", "",
        f"The gateway's command line with its default budgets, `capture` at 384 kHz, 50 ms chunks, {CHUNKS} on the "
        f"port ({PORT_BYTES / MIB:.0f} MiB), its 2014 socket, and `demo`. {now['clients']} hostile clients at once for "
        f"{now['seconds']:.0f} s, each drawing act after act from a seeded mix of the suite's fuzz corpora: odd heads, "
        "bad JSON inputs and huge parameters, whole reads of the window in JSON, binary and `since=0` from clients "
        "with a 4 KiB receive buffer that never read and reset 1 to 8 s later, listens (`Last-Event-ID: 0`) and "
        "watches that never read, the 2014 socket asked for the whole port and never read, heads dropped halfway. "
        "A witness reads the window's new chunks twice a second meanwhile. Memory is the gateway's resident set "
        f"(MiB), sampled every 50 ms; `a minute after` is {now['settle_s']:.0f} s after the clients ended.", "",
        "| gateway | acts | before | peak | just after | a minute after | budget | 5xx | witness's reads | verdict |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *rows, "",
        f"The budget is the gateway's size before the clients came ({b['idle']:.0f} MiB, the port full) plus what "
        f"the docs let clients add (docs/protocol.md, Budgets): the JSON texts of the port's chunks, about 3x its "
        f"bytes, twice (the window and a publication a reply still holds): {b['json_texts']:.0f} MiB; the 2014 "
        f"socket's `--max-socket-bytes`, one last reply and 320 KiB a client: {b['socket']:.0f} MiB; and a piece "
        f"of a reply and the transport's high-water mark for each HTTP client at once: {b['connections']:.0f} MiB. "
        f"The issue's earlier hostile fuzz took the gateway to {ISSUE_PEAK_MB:,} MB from 56 MB (526 MB after). What "
        "stays a minute after is the 2014 socket's last reply (kept for the next client of the same chunks, up to "
        "`--max-socket-client-bytes`) and memory the allocator keeps for reuse (in a trial, glibc's `malloc_trim` "
        "gave back 176 MiB of it); nothing the clients left grows with the fuzz's length. These figures come from a "
        "machine shared with other developers' runs: they are provisional until measured on a quiet one (memory "
        "less so than the count of acts, which the CPU bounds).", "",
        "What the fuzz found, and what changed (issue 29): on `main` before the change (8e17479, this machine, "
        f"two runs) the peak was {MAIN_BEFORE['peak']}, and a minute after {MAIN_BEFORE['settled']} MiB. On Python "
        "3.11 asyncio's transport copies what it is given: a whole read of the window left unread was handed to it "
        "whole, 150 MB of JSON copied for each such client; a watch from `since=0` was one 150 MB text per watcher, "
        "copied likewise. Replies now go out as the client takes them, from the chunks' shared texts (a client "
        "that never reads holds 64 KiB and a piece beyond the shared reply, and is cut after the keep-alive time). "
        "After the fuzz, a full garbage collection freed 410 MiB: connections that ended in a reset left their "
        "replies (the 2014 socket's whole-port replies, 58 MiB each) in reference cycles through the exception "
        "that ended them, which the collector seldom looks at in a process of a million long-lived objects; they "
        "no longer do. Read bodies and watch frames of a port nobody reads or watches are let go. The fuzz also "
        "found a refusal to a client that had reset answered with a traceback and a 500, and thousands of "
        "asyncio warnings for writes after a reset: both gone.", ""])
