"""Pre-encoded port reads are byte for byte the encoding of the joined data, and never a torn window.

The gateway writes an audio window from its chunks (their bytes, or their JSON
texts made once per chunk) instead of copying and encoding the window on every
read.  These tests compare that with a direct orjson encoding of the same data,
for JSON and binary, whole reads and ``since=`` reads, and read a window that
turns over many times while its reply is still being written.
"""

from __future__ import annotations

import asyncio
import math
import socket
import struct
from collections.abc import AsyncIterator
from typing import Any

import numpy as np
import orjson
import pytest

from aiogenomix.components.audio import ChunkWindow
from aiogenomix.components.capture import PortView
from aiogenomix.components.core import Chunk, ChunkedArray, Component, ComponentHost, OutPort, ScaledClock
from aiogenomix.components.core.runtime import idl_type
from aiogenomix.components.kemarcapture import KemarPortData
from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.components.core.runtime import encode_binary
from aiogenomix.gateway._gather import direct_socket, write_gathered
from aiogenomix.gateway._pieces import PiecesPayload, json_pieces

NUMPY = orjson.OPT_SERIALIZE_NUMPY


def chunk(values: Any, dtype: Any = np.int32) -> Chunk:
    array = np.array(values, dtype=dtype)
    array.flags.writeable = False
    return Chunk(array)


def joined(pieces: list[Any]) -> bytes:
    return b"".join(bytes(piece) for piece in pieces)


def test_json_of_chunked_arrays_is_the_json_of_the_joined_arrays() -> None:
    rng = np.random.default_rng(7)
    ints = [chunk(rng.integers(-2**31, 2**31, n)) for n in (5, 0, 1, 17, 0, 3)]
    floats = [chunk([0.1, -0.0, math.nan, math.inf, -math.inf, 1e-300, 2.5e22], np.float64), chunk([], np.float64),
              chunk([1 / 3], np.float64)]
    left, right = ChunkedArray(ints, np.int32), ChunkedArray(floats, np.float64)
    data = {"Port": {"name": "a\x00b \u00e9\n", "left": left, "n": [1, 2.5, None, {"x": right}], "right": left,
                     "arr": np.arange(3, dtype=np.int64), "empty": ChunkedArray([], np.int32)}}
    direct = {"Port": {"name": "a\x00b \u00e9\n", "left": left.numpy(), "n": [1, 2.5, None, {"x": right.numpy()}],
                       "right": left.numpy(), "arr": np.arange(3, dtype=np.int64), "empty": np.zeros(0, np.int32)}}
    assert joined(json_pieces(data)) == orjson.dumps(direct, option=NUMPY)
    assert json_pieces({"plain": [1, 2]}) == [b'{"plain":[1,2]}']


def test_binary_of_chunked_arrays_is_the_binary_of_the_joined_arrays() -> None:
    rng = np.random.default_rng(8)
    left = ChunkedArray([chunk(rng.integers(-9, 9, n)) for n in (3, 0, 5)], np.int32)
    positions = np.array([1.5, math.nan])
    data = {"left": left, "positions": positions, "right": left, "index": 3}
    direct = {"left": left.numpy(), "positions": positions, "right": left.numpy(), "index": 3}
    assert joined(encode_binary("Port", data, lost=2)) == joined(encode_binary("Port", direct, lost=2))


def test_a_payload_is_its_pieces() -> None:
    payload = PiecesPayload([b"ab", memoryview(b"cd"), b"", b"e"], "application/json")
    assert payload.size == 5 and payload.decode() == "abcde"


def window(capacity: int, frames: int, chunks: int, *, seed: int = 0) -> ChunkWindow:
    rng = np.random.default_rng(seed)
    held = ChunkWindow(capacity, frames, with_positions=True)
    for i in range(chunks):
        held.append(rng.integers(-2**23, 2**23, frames), rng.integers(-2**23, 2**23, frames), 0.5 * i - 3)
    return held


class Windowed(Component, name="windowed"):
    """A port of the merged capture component's type, published by the test."""

    Port = OutPort(KemarPortData, doc="A window published by hand")


@pytest.fixture
async def served() -> AsyncIterator[tuple[Windowed, str]]:
    async with ComponentHost(clock=ScaledClock(1), factories={"windowed": Windowed}) as host:
        component = await host.load("windowed")
        assert isinstance(component, Windowed)
        async with serve(GatewayConfig(port=0), host=host) as url:
            yield component, url


async def get(url: str, path: str, *, rcvbuf: int | None = None, after_first_bytes: Any = None) -> bytes:
    """GET *path* over a raw socket; return the body.  *after_first_bytes* runs once the reply has begun."""
    host, port = url.removeprefix("http://").split(":")
    sock = socket.socket()
    if rcvbuf:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)  # keeps most of a reply in the server
    sock.setblocking(False)
    loop = asyncio.get_running_loop()
    await loop.sock_connect(sock, (host, int(port)))
    try:
        await loop.sock_sendall(sock, f"GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n".encode())
        received = bytearray(await loop.sock_recv(sock, 1024))
        if after_first_bytes is not None:
            after_first_bytes()
        while data := await loop.sock_recv(sock, 1 << 16):
            received += data
    finally:
        sock.close()
    head, _, body = bytes(received).partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 200"), head
    lengths = [line.split(b":")[1] for line in head.split(b"\r\n") if line.lower().startswith(b"content-length")]
    length = int(lengths[0])
    assert len(body) == length
    return body


def expected_json(view: PortView, since: int | None = None) -> bytes:
    port_type = idl_type(KemarPortData)
    if since is None:
        return orjson.dumps({"Port": port_type.encode(view.data)}, option=NUMPY)
    data, lost = view.since(since)
    return orjson.dumps({"Port": port_type.encode(data), "lost": lost}, option=NUMPY)


def expected_binary(view: PortView, since: int | None = None) -> bytes:
    port_type = idl_type(KemarPortData)
    if since is None:
        return joined(encode_binary("Port", port_type.encode(view.data)))
    data, lost = view.since(since)
    return joined(encode_binary("Port", port_type.encode(data), lost=lost))


async def test_reads_are_the_direct_encoding_of_the_publication(served: tuple[Windowed, str]) -> None:
    component, url = served
    view = PortView(window(8, 300, 13), 44100, 12.25, KemarPortData)
    component.Port.publish(view)
    path = "/module/windowed/read/Port"
    for _ in range(2):  # the second read of a publication shares the first one's body
        assert await get(url, path) == expected_json(view)
        assert await get(url, path + "?format=binary") == expected_binary(view)
    for since in (0, 4, 5, 6, 12, 13, 40):
        assert await get(url, f"{path}?since={since}") == expected_json(view, since)
        assert await get(url, f"{path}?since={since}&format=binary") == expected_binary(view, since)
    empty = PortView(None, make=KemarPortData)
    component.Port.publish(empty)
    assert await get(url, path) == expected_json(empty)
    assert await get(url, f"{path}?since=3") == expected_json(empty, 3)


@pytest.mark.parametrize("form", ["json", "binary"])
async def test_a_window_turning_over_during_the_reply_is_not_torn(served: tuple[Windowed, str], form: str) -> None:
    component, url = served
    held = window(32, 20_000, 40, seed=1)  # 5 MB of samples: far more than the socket buffers
    view = PortView(held, 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    rng = np.random.default_rng(2)

    def turn_over() -> None:
        # The whole window is replaced, twice, while the reply is being written.
        for i in range(64):
            held.append(rng.integers(0, 9, 20_000), rng.integers(0, 9, 20_000), float(i))
            component.Port.publish(PortView(held, 44100, 0.0, KemarPortData))

    query = "?format=binary" if form == "binary" else ""
    body = await get(url, "/module/windowed/read/Port" + query, rcvbuf=4096, after_first_bytes=turn_over)
    assert body == (expected_binary(view) if form == "binary" else expected_json(view))
    assert held.last_index == 104


async def test_a_large_reply_goes_to_the_socket_unjoined(served: tuple[Windowed, str],
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    from aiogenomix.gateway import _pieces

    gathered: list[int] = []

    def counted(fd: int, buffers: Any) -> int:
        written = write_gathered(fd, buffers)
        gathered.append(written)
        return written

    monkeypatch.setattr(_pieces, "write_gathered", counted)
    component, url = served
    view = PortView(window(40, 2205, 40, seed=3), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    assert await get(url, "/module/windowed/read/Port") == expected_json(view)
    assert await get(url, "/module/windowed/read/Port?format=binary") == expected_binary(view)
    assert len(gathered) == 2 and all(gathered)  # both went (mostly) straight to the socket


async def test_pipelined_reads_of_a_slow_reader_come_back_whole_and_in_order(
        served: tuple[Windowed, str], monkeypatch: pytest.MonkeyPatch) -> None:
    # A reply that starts while the one before it is still queued in the transport goes
    # through aiohttp's writer, after it; the bytes must still be exact, in order.  (The first
    # is answered ahead of the routes; the next find it still queued.)
    from aiogenomix.gateway import _connection, _fast_reads, _pieces

    sockets: list[int | None] = []

    def seen(transport: Any) -> int | None:
        sockets.append(direct_socket(transport))
        return sockets[-1]

    monkeypatch.setattr(_pieces, "direct_socket", seen)
    monkeypatch.setattr(_connection, "direct_socket", seen)
    monkeypatch.setattr(_fast_reads, "direct_socket", seen)
    component, url = served
    view = PortView(window(32, 20_000, 40, seed=4), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    host, port = url.removeprefix("http://").split(":")
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # set before connecting, as the window is agreed
    sock.setblocking(False)
    await asyncio.get_running_loop().sock_connect(sock, (host, int(port)))
    reader, writer = await asyncio.open_connection(sock=sock, limit=1 << 24)
    forms = ["", "?format=binary", "", "?format=binary"]
    writer.write(b"".join(f"GET /module/windowed/read/Port{q} HTTP/1.1\r\nHost: {host}\r\n\r\n".encode()
                          for q in forms))
    try:
        for query in forms:
            head = await reader.readuntil(b"\r\n\r\n")
            assert head.startswith(b"HTTP/1.1 200"), head
            length = int(next(line.split(b":")[1] for line in head.split(b"\r\n")
                              if line.lower().startswith(b"content-length")))
            body = await reader.readexactly(length)
            assert body == (expected_binary(view) if query else expected_json(view))
        assert sockets[0] is not None and None in sockets  # some replies found the one before still queued
    finally:
        writer.close()
        await writer.wait_closed()


async def test_a_reader_that_leaves_mid_reply_costs_the_gateway_nothing(
        served: tuple[Windowed, str], caplog: pytest.LogCaptureFixture) -> None:
    component, url = served
    view = PortView(window(32, 20_000, 40, seed=5), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    host, port = url.removeprefix("http://").split(":")
    for query in ("", "?format=binary"):
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        sock.setblocking(False)
        loop = asyncio.get_running_loop()
        await loop.sock_connect(sock, (host, int(port)))
        await loop.sock_sendall(sock, f"GET /module/windowed/read/Port{query} HTTP/1.1\r\nHost: {host}\r\n\r\n"
                                .encode())
        assert (await loop.sock_recv(sock, 1024)).startswith(b"HTTP/1.1 200")
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # close with a reset
        sock.close()  # with most of the reply unsent
    assert await get(url, "/module/windowed/read/Port") == expected_json(view)
    assert not [r for r in caplog.records if r.levelname in ("ERROR", "WARNING", "CRITICAL")]
