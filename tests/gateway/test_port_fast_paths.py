"""Binary and incremental port reads, and the port-watch stream with explicit loss reports."""

from __future__ import annotations

import asyncio
import json
import socket
import struct
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import numpy as np
import pytest

from aiogenomix.components.core import (
    Component, ComponentHost, Long, OutPort, ScaledClock, ULong, function, idl_struct, sequence,
)
from aiogenomix.gateway import GatewayConfig, serve
from tests.gateway._raw_http import address

WINDOW = 5


@idl_struct("ticker::window")
class TickWindow:
    """The last WINDOW items of `size` values each, numbered from 1 (an Incremental port value)."""

    index: ULong = 0
    size: ULong = 1
    values: sequence(Long, numpy=True) = None  # type: ignore[valid-type,assignment]

    def since(self, index: int) -> tuple[TickWindow, int]:
        held = len(self.values) // self.size
        first_held = self.index - held + 1
        start = max(index + 1, first_held)
        lost = max(0, first_held - (index + 1)) if index < self.index else 0
        return TickWindow(self.index, self.size, self.values[(start - first_held) * self.size:]), lost


class Ticker(Component, name="ticker"):
    """Publishes numbered items on demand."""

    Items = OutPort(TickWindow, doc="The last items")
    Scalar = OutPort(ULong, doc="A plain value")

    async def on_start(self) -> None:
        self.count = 0
        self.Items.publish(TickWindow(0, 1, np.zeros(0, np.int32)))

    @function
    def Push(self, n: ULong = 1, size: ULong = 1) -> None:
        """Publish n items of `size` values (item i holds 10*i), one publication each."""
        for _ in range(n):
            self.count += 1
            held = np.arange(max(1, self.count - WINDOW + 1), self.count + 1, dtype=np.int32)
            self.Items.publish(TickWindow(self.count, size, np.repeat(held * 10, size)))
            self.Scalar.publish(self.count)


@pytest.fixture
async def gateway() -> AsyncIterator[str]:
    host = ComponentHost(clock=ScaledClock(20), factories={"ticker": Ticker})
    async with host, serve(GatewayConfig.of(port=0, ping_interval=5), host=host) as url:
        yield url


def decode_binary(body: bytes) -> dict[str, Any]:
    assert body[:4] == b"AGXB"
    (length,) = struct.unpack("<I", body[4:8])
    header = json.loads(body[8:8 + length])
    payload = memoryview(body)[8 + length:]
    arrays = [np.frombuffer(payload, a["dtype"], int(np.prod(a["shape"])), a["offset"]).reshape(a["shape"])
              for a in header["arrays"]]

    def rebuild(value: Any) -> Any:
        if isinstance(value, dict):
            return arrays[value["$array"]] if set(value) == {"$array"} else {k: rebuild(v) for k, v in value.items()}
        return value

    return {header["port"]: rebuild(header["data"])} | {k: v for k, v in header.items()
                                                      if k not in ("port", "data", "arrays")}


async def test_binary_read_holds_the_same_data_as_json(http: aiohttp.ClientSession) -> None:
    await http.get("/load/ticker")
    await http.get("/module/ticker/send/Push", params={"input": '{"n":7}'})
    async with http.get("/module/ticker/read/Items") as reply:
        as_json = await reply.json()
    async with http.get("/module/ticker/read/Items", params={"format": "binary"}) as reply:
        assert reply.headers["Content-Type"] == "application/x-aiogenomix-binary"
        body = await reply.read()
        assert int(reply.headers["Content-Length"]) == len(body)
    as_binary = decode_binary(body)
    assert as_json == {"Items": {"index": 7, "size": 1, "values": [30, 40, 50, 60, 70]}}
    assert as_binary["Items"]["index"] == 7
    assert as_binary["Items"]["values"].dtype == np.dtype("<i4")
    assert as_binary["Items"]["values"].tolist() == [30, 40, 50, 60, 70]
    async with http.get("/module/ticker/read/Items",
                        headers={"Accept": "application/x-aiogenomix-binary"}) as reply:
        assert decode_binary(await reply.read())["Items"]["index"] == 7


async def test_incremental_reads_return_only_new_items_and_count_losses(http: aiohttp.ClientSession) -> None:
    await http.get("/load/ticker")
    await http.get("/module/ticker/send/Push", params={"input": '{"n":3}'})
    async with http.get("/module/ticker/read/Items", params={"since": "1"}) as reply:
        assert await reply.json() == {"Items": {"index": 3, "size": 1, "values": [20, 30]}, "lost": 0}
    await http.get("/module/ticker/send/Push", params={"input": '{"n":9}'})
    async with http.get("/module/ticker/read/Items", params={"since": "3"}) as reply:
        # Items 4..12 were published; the window holds 8..12: 4 of them were lost.
        assert await reply.json() == {"Items": {"index": 12, "size": 1, "values": [80, 90, 100, 110, 120]},
                                      "lost": 4}
    async with http.get("/module/ticker/read/Items", params={"since": "12", "format": "binary"}) as reply:
        read = decode_binary(await reply.read())
        assert read["lost"] == 0 and read["Items"]["values"].size == 0


@pytest.mark.parametrize("query, message", [
    ({"since": "x"}, "since must be an item index"),
    ({"since": "-1"}, "a whole number, 0 or more"),
    ({"since": "9" * 5000}, "of at most 19 digits"),
    ({"format": "xml"}, "format must be json or binary"),
])
async def test_bad_fast_path_queries(http: aiohttp.ClientSession, query: dict[str, str], message: str) -> None:
    await http.get("/load/ticker")
    async with http.get("/module/ticker/read/Items", params=query) as reply:
        assert reply.status == 400 and message in (await reply.json())["message"]


async def test_since_on_a_plain_port_is_refused(http: aiohttp.ClientSession) -> None:
    await http.get("/load/ticker")
    async with http.get("/module/ticker/read/Scalar", params={"since": "0"}) as reply:
        assert reply.status == 400 and "no numbered chunks" in (await reply.json())["message"]


async def events(reply: aiohttp.ClientResponse) -> AsyncIterator[dict[str, Any]]:
    # Lines split here: older aiohttp clients refuse lines longer than their read buffer.
    name, pending = "", b""
    while chunk := await reply.content.readany():
        *lines, pending = (pending + chunk).split(b"\n")
        for raw in lines:
            line = raw.decode()
            if line.startswith("event: "):
                name = line[7:]
            elif line.startswith("data: ") and name == "port":
                yield json.loads(line[6:])


async def test_watch_streams_every_item_once_to_a_fast_reader(http: aiohttp.ClientSession) -> None:
    await http.get("/load/ticker")
    async with http.get("/module/ticker/watch/Items", params={"since": "0"}) as reply:
        assert "transfer-encoding" not in reply.headers
        seen: list[int] = []
        stream = events(reply)
        first = await anext(stream)
        assert first == {"Items": {"index": 0, "size": 1, "values": []}, "lost": 0}
        for _ in range(3):
            await http.get("/module/ticker/send/Push", params={"input": '{"n":1}'})
            event = await anext(stream)
            seen.extend(event["Items"]["values"])
            assert event["lost"] == 0
        assert seen == [10, 20, 30]


async def test_a_stalled_watcher_gets_an_explicit_loss_and_does_not_delay_others(
        gateway: str, http: aiohttp.ClientSession) -> None:
    await http.get("/load/ticker")
    size = 120_000  # ~400 kB of JSON per item: a reader that stops reading soon fills the socket buffers
    host, port = address(gateway)
    stalled = socket.create_connection((host, port))
    stalled.sendall(f"GET /module/ticker/watch/Items?since=0 HTTP/1.1\r\nHost: {host}\r\n\r\n".encode())
    try:
        async with http.get("/module/ticker/watch/Items", params={"since": "0"}) as fast:
            fast_events = events(fast)
            await anext(fast_events)
            fast_seen: list[int] = []
            for _ in range(60):
                await http.get("/module/ticker/send/Push", params={"input": json.dumps({"n": 1, "size": size})})
                event = await anext(fast_events)
                assert event["lost"] == 0
                fast_seen.extend(event["Items"]["values"][::size])
            assert fast_seen == [10 * i for i in range(1, 61)]  # never held back by the stalled reader

        # The stalled reader now drains its stream: the window's newest items, and the count it missed.
        stalled.setblocking(False)
        reader, writer = await asyncio.open_connection(sock=stalled, limit=2**24)
        await reader.readuntil(b"\r\n\r\n")
        got, lost = [], 0
        while not got or got[-1] != 600:
            line = await asyncio.wait_for(reader.readline(), 10)
            if line.startswith(b"data: "):
                event = json.loads(line[6:])
                got.extend(event["Items"]["values"][::size])
                lost += event["lost"]
        assert lost > 0
        assert got == sorted(set(got))  # nothing twice, nothing out of order
        assert got[-WINDOW:] == [10 * i for i in range(61 - WINDOW, 61)]  # the newest window
        assert lost == 60 - len(got)  # every item missed is counted
        writer.close()
    finally:
        stalled.close()
