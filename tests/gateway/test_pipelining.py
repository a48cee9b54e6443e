"""Requests written back to back on one connection are all answered, in order, however many and however mixed.

Plain port reads are answered by the connection itself while aiohttp answers
the rest (``gateway/_connection.py``); a thousand pipelined requests, reads
alone or reads among routed requests and refusals, must come back complete
and in the order they were sent.  Raw sockets, as a polling client sends them.
"""

from __future__ import annotations

import asyncio
import json
import random
from collections.abc import Callable

import aiohttp
import pytest

from aiogenomix.gateway._fast_reads import FastReads
from tests.gateway._raw_http import Connection, answered_ahead

#: What each kind of request asks, and how its reply is recognised (status, body check).
KINDS: dict[str, tuple[str, int, Callable[[bytes], bool]]] = {
    "read": ("/module/demo/read/Mobile", 200, lambda body: set(json.loads(body)) == {"Mobile"}),
    "binary read": ("/module/demo/read/Mobile?format=binary", 200, lambda body: body.startswith(b"AGXB")),
    "routed read": ("/module/demo/read/%4Dobile", 200, lambda body: set(json.loads(body)) == {"Mobile"}),
    "version": ("/version", 200, lambda body: body == b"1.7.3"),
    "info": ("/module/demo/info", 200, lambda body: json.loads(body)["name"] == "demo"),
    "send": ("/module/demo/send/GetSpeed", 200, lambda body: json.loads(body)["status"] == "done"),
    "refused read": ("/module/demo/read/Mobile?bogus=1", 400,
                     lambda body: json.loads(body)["ex"] == "::genomix::bad_parameter"),
    "missing port": ("/module/demo/read/Nothing", 404,
                     lambda body: json.loads(body)["ex"] == "::genom::no_such_outport"),
}


@pytest.fixture
def fast_answers(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Whether each request the connection looked at was answered there (True) or left to the routes."""
    return answered_ahead(monkeypatch, FastReads, "reply")


async def _pipeline(gateway: str, kinds: list[str]) -> list[tuple[int, bytes]]:
    connection = await Connection.open(gateway)

    async def replies() -> list[tuple[int, bytes]]:
        return [(status, body) for status, _, body in [await connection.reply() for _ in kinds]]

    try:
        connection.writer.write(b"".join(connection.request(KINDS[kind][0]) for kind in kinds))
        _, got = await asyncio.gather(connection.writer.drain(), replies())
        return got
    finally:
        await connection.close()


def _check(kinds: list[str], got: list[tuple[int, bytes]]) -> None:
    assert len(got) == len(kinds)
    for index, (kind, (status, body)) in enumerate(zip(kinds, got, strict=True)):
        _, expected, recognise = KINDS[kind]
        assert status == expected and recognise(body), f"reply {index} is not that of a {kind}: {status} {body[:80]!r}"


async def test_a_thousand_pipelined_plain_reads(gateway: str, http: aiohttp.ClientSession,
                                                fast_answers: list[bool]) -> None:
    await http.get("/load/demo")
    kinds = ["read", "binary read"] * 500
    _check(kinds, await _pipeline(gateway, kinds))
    assert fast_answers.count(True) >= 1  # answered by the connection while nothing was queued


async def test_a_thousand_pipelined_reads_among_routed_requests(gateway: str, http: aiohttp.ClientSession,
                                                                fast_answers: list[bool]) -> None:
    await http.get("/load/demo")
    pick = random.Random(20).choice
    others = [kind for kind in KINDS if kind not in ("read", "binary read")]
    # Mostly plain reads, with runs of routed requests longer than aiohttp's queue of 32 among them.
    kinds = [pick(others) if (n // 40) % 3 == 1 else pick(["read", "binary read"]) for n in range(1000)]
    got = await _pipeline(gateway, kinds)
    _check(kinds, got)
    async with http.get("/module/demo/read/Mobile") as reply:  # the gateway still answers
        assert reply.status == 200
