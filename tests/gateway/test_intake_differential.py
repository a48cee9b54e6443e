"""One verdict per request head, whichever way the gateway would answer it, and no traceback for any (issue 32).

Plain port reads, plain sends and plain GETs of ``/version`` are answered ahead
of the routes (``gateway/_fast_reads.py``, ``gateway/_fast_sends.py``,
``gateway/_fast_answers.py``); everything else, and every request those decline,
by the routes.  All are fed by one parser, aiohttp's, and judged by one door.
This test generates request heads the way the suite's fuzzers and the issues'
reports built them (repeated fields, folded lines, odd versions and methods,
absolute forms, bodies, hostile Host, Origin and token fields, parameters of every
kind), each aimed at a port read, a send or the version, and sends each twice over
real sockets: once naming the target as a plain request would
(``/module/demo/read/Mobile``, ``/module/demo/send/GetSpeed``, ``/version``), once
with a letter percent-encoded (``.../%4Dobile``, ``.../%47etSpeed``,
``/versio%6E``), which only the routes decode.  Both must get the same status,
the same error, and for an answer the same body (a send's request number apart);
and the log must hold no line above DEBUG and no traceback.

10,000 heads on the default Python (``AIOGENOMIX_HEAVY`` unset), 1,000 on the others.
Each exchange is a plain non-blocking socket (no stream objects, one timeout for
the whole exchange): opening connections is most of what the test costs.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import random
import re
import socket
from collections.abc import AsyncIterator

import pytest

from aiogenomix.gateway import GatewayConfig, serve
from tests.conftest import TEST_TIME_SCALE

HEADS = 1000 if os.environ.get("AIOGENOMIX_HEAVY") == "0" else 10_000
TOKEN = "s3cret"
#: The targets of each kind of head: as a plain request names them, and percent-encoded (the routes' alone).
TARGETS = {"read": ("/module/demo/read/Mobile", "/module/demo/read/%4Dobile"),
           "send": ("/module/demo/send/GetSpeed", "/module/demo/send/%47etSpeed"),
           "version": ("/version", "/versio%6E")}
#: The number of a send's request, which differs between its two sendings.
_REQUEST_NUMBER = re.compile(rb'"id":"demo::\d+"')
pytestmark = pytest.mark.timeout(900)


@pytest.fixture
async def gateway() -> AsyncIterator[str]:
    config = GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, preload=["demo"], token=TOKEN,
                           allowed_origins=["http://app.example:3000"], header_timeout=5)
    async with serve(config) as url:
        yield url.removeprefix("http://")


def _heads(count: int, address: str, seed: int) -> list[tuple[str, str, bytes]]:
    """*count* request heads: a label, the kind of target (a key of :data:`TARGETS`), and the head's bytes.

    Each has ``{T}`` where the target's path goes.
    """
    pick = random.Random(seed)
    kinds = random.Random(seed + 1)  # (apart: the heads are those the reads alone had)
    queries = ["", "?format=binary", "?format=json", "?since=3", "?format=", "?format=xml", "?name=x", "?_=1",
               "?s=a", "?s=a&s=b", "?format=binary&format=json", "?input=1", "?format=%62inary", "?format=bin+ary",
               "?since=-1", "?since=" + "9" * 25, "?since=%C2%B2", "?#frag", "?&", "?=", "?format", "?%ZZ=1",
               "?s=" + "x" * 300]
    methods = ["GET"] * 12 + ["HEAD", "POST", "PUT", "DELETE", "OPTIONS", "PATCH", "get", "GeT", "CONNECT",
                              "TRACE", "PRI", "G\tET", "GET\x00", "ÄGET", ""]
    versions = ["HTTP/1.1"] * 12 + ["HTTP/1.0"] * 3 + ["HTTP/2.0", "HTTP/0.9", "HTTP/1.2", "HTTP/3", "http/1.1",
                                                       "HTTP/1.1 ", "HTTP/11", "HTTP/1.", "", "HTTP/1.01"]
    hosts = [f"Host: {address}"] * 10 + [
        "Host: localhost", "Host: evil.example", f"Host: {address}\r\nHost: evil.example",
        f"Host: evil.example\r\nHost: {address}", "Host:", "Host: [::1]", "Host: 127.0.0.1:1",
        "host: LOCALHOST", f"Host : {address}", f"Host:\t{address}\t", f" Host: {address}", "", "Host: \x01",
        f"Host: {address}\r\n folded.example"]
    origins = [""] * 8 + [f"Origin: http://{address}", "Origin: https://evil.example", "Origin: null",
                          "Origin: http://app.example:3000",
                          f"Origin: http://{address}\r\nOrigin: https://evil.example",
                          "Sec-Fetch-Site: cross-site", "Sec-Fetch-Site: same-site", "Sec-Fetch-Site: same-origin",
                          "Origin: http://app.example:3000\r\nSec-Fetch-Site: cross-site"]
    tokens = [f"Authorization: Bearer {TOKEN}"] * 8 + [
        "", "Authorization: Bearer wrong", f"Authorization: bearer {TOKEN}", f"Authorization: Bearer {TOKEN} ",
        f"Authorization: Bearer {TOKEN}\r\nAuthorization: Bearer wrong",
        f"Authorization: Bearer wrong\r\nAuthorization: Bearer {TOKEN}", f"Cookie: aiogenomix_console={TOKEN}",
        "Authorization:"]
    extras = [""] * 10 + [
        "Accept: application/x-aiogenomix-binary", "Accept: */*", "Connection: close", "Connection: keep-alive",
        "Connection: Upgrade\r\nUpgrade: websocket", "Upgrade: h2c", "Content-Type: a\r\nContent-Type: b",
        "User-Agent: a\r\nUser-Agent: b", "X-Folded: a\r\n b", "X-Folded: a\r\n\tb", "No colon here",
        "X-Bad\x01Name: 1", "X-Nul: a\x00b", "X-Ctl: a\x7fb", "X-Latin: \xe9t\xe9", ": empty name",
        "X-Long: " + "a" * 9000, "\r\n".join(f"X-{n}: {n}" for n in range(120)), "Expect: 100-continue",
        "Expect: other", "Transfer-Encoding: chunked", "Transfer-Encoding: gzip, chunked", "Content-Length: 0",
        "Content-Length: 5", "Content-Length: 5\r\nContent-Length: 5", "Content-Length: -1", "Content-Length: x",
        "Content-Length: 99999999999999999999", "Last-Event-ID: 3", "Cache-Control: no-cache"]
    plain = {"Accept: application/x-aiogenomix-binary", "Accept: */*", "Last-Event-ID: 3", "Cache-Control: no-cache"}
    bodies = [b""] * 6 + [b"12345", b"0\r\n\r\n", b"5\r\nhello\r\n0\r\n\r\n", b"zz\r\n", b"{}"]
    found: list[tuple[str, str, bytes]] = []
    while len(found) < count:
        method, version = pick.choice(methods), pick.choice(versions)
        absolute = pick.random() < 0.1
        authority = pick.choice([address, "evil.example", "localhost", address])
        target = (f"http://{authority}{{T}}" if absolute else "{T}") + pick.choice(queries)
        line = " ".join(part for part in (method, target, version) if part) if pick.random() > 0.02 else method
        fields = [field for field in (pick.choice(hosts), pick.choice(origins), pick.choice(tokens),
                                      pick.choice(extras), pick.choice(extras)) if field]
        end = "\n" if pick.random() < 0.02 else "\r\n"
        body = pick.choice(bodies)
        if kinds.random() < 0.25:
            # A client's own request, its query aside: the heads a plain read, send or GET answers must be many.
            method, version, line = "GET", "HTTP/1.1", f"GET {target} HTTP/1.1"
            fields, end, body = [hosts[0], tokens[0], *(field for field in fields if field in plain)], "\r\n", b""
        head = end.join([line, *fields, "", ""]).encode("latin-1", "replace")
        found.append((f"{method} {target} {version} | {' | '.join(fields)}"[:300], kinds.choice(list(TARGETS)),
                      head + body))
    return found


async def _exchange(address: str, raw: bytes) -> tuple[int, str, bytes]:
    """Send *raw* on a new connection; its first final reply's status, its error (if any) and its body."""
    host, port = address.rsplit(":", 1)
    loop = asyncio.get_running_loop()
    received = bytearray()

    async def more() -> bool:
        """Read what came; False at the end of the stream."""
        data = await loop.sock_recv(sock, 1 << 16)
        received.extend(data)
        return bool(data)

    with socket.socket() as sock:
        sock.setblocking(False)
        async with asyncio.timeout(15):
            await loop.sock_connect(sock, (host, int(port)))
            try:
                await loop.sock_sendall(sock, raw)
            except OSError:  # refused and closed while the rest was being sent: its reply is read below
                pass
            status = 100
            while status == 100:  # an interim 100 Continue: the final reply is the one compared
                while (end := received.find(b"\r\n\r\n")) < 0:
                    try:
                        if not await more():
                            return 0, "no reply", bytes(received[:100])
                    except ConnectionResetError:
                        return 0, "no reply", bytes(received[:100])
                head = received[:end].decode("latin-1")
                del received[:end + 4]
                status_line, *lines = head.split("\r\n")
                status = int(status_line.split()[1])
            fields = {name.lower(): value for name, _, value in (line.partition(": ") for line in lines if line)}
            if "content-length" not in fields or raw.startswith(b"HEAD "):  # a HEAD's reply: its head is compared
                return status, "", b""
            length = int(fields["content-length"])
            while len(received) < length and await more():
                pass
    body = bytes(received[:length])
    json_error = status >= 400 and fields.get("content-type") == "application/json"
    # An error's message may quote the target, which differs: its status and name are compared.
    return status, json.loads(body)["ex"] if json_error else "", body if status < 400 else b""


@pytest.mark.parametrize("seed", [32])
async def test_every_head_gets_one_verdict_whichever_path_would_answer_it(
        gateway: str, caplog: pytest.LogCaptureFixture, seed: int) -> None:
    caplog.set_level(logging.DEBUG)
    heads = _heads(HEADS, gateway, seed)
    results: dict[int, tuple[tuple[int, str, bytes], tuple[int, str, bytes]]] = {}
    work = list(enumerate(heads))

    async def worker() -> None:
        while work:
            index, (_, kind, raw) = work.pop()
            plain, encoded = TARGETS[kind]
            fast = await _exchange(gateway, raw.replace(b"{T}", plain.encode()))
            routed = await _exchange(gateway, raw.replace(b"{T}", encoded.encode()))
            results[index] = (fast[:2] + (_REQUEST_NUMBER.sub(b'"id":"demo::N"', fast[2]),),
                              routed[:2] + (_REQUEST_NUMBER.sub(b'"id":"demo::N"', routed[2]),))

    await asyncio.gather(*(worker() for _ in range(8)))
    differing = [(heads[index][:2], fast[:2], routed[:2]) for index, (fast, routed) in sorted(results.items())
                 if fast != routed]
    assert differing == [], f"{len(differing)} heads got two verdicts, the first: {differing[:5]}"
    statuses = {fast[0] for fast, _ in results.values()}
    assert {200, 400, 401, 403}.issubset(statuses)  # the corpus reaches every verdict of the door and parser
    loud = [r for r in caplog.records if r.levelno > logging.DEBUG and not r.name.startswith("aiogenomix.components")
            or r.exc_info is not None or r.exc_text]
    assert loud == [], [r.getMessage()[:200] for r in loud[:5]]
