"""Pre-encoded port reads are byte for byte the encoding of the joined data, and never a torn window.

The gateway writes an audio window from its chunks (their bytes, or their JSON
texts made once per chunk) instead of copying and encoding the window on every
read.  These tests compare that with a direct orjson encoding of the same data,
for JSON and binary, whole reads and ``since=`` reads, and read a window that
turns over many times while its reply is still being written.
"""

from __future__ import annotations

import asyncio
import contextlib
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
from aiogenomix.gateway._gather import write_gathered
from aiogenomix.gateway._pieces import PiecesPayload, json_pieces
from aiogenomix.gateway._routes_ports import read_body

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
        async with serve(GatewayConfig.of(port=0), host=host) as url:
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
    from aiogenomix.gateway import _gather

    gathered: list[int] = []

    def counted(fd: int, buffers: Any) -> int:
        written = write_gathered(fd, buffers)
        gathered.append(written)
        return written

    monkeypatch.setattr(_gather, "write_gathered", counted)
    component, url = served
    view = PortView(window(40, 2205, 40, seed=3), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    assert await get(url, "/module/windowed/read/Port") == expected_json(view)
    assert await get(url, "/module/windowed/read/Port?format=binary") == expected_binary(view)
    assert len(gathered) >= 2 and all(gathered)  # both went (mostly) straight to the socket


@pytest.mark.parametrize("path", ["socket", "writer"])
async def test_pipelined_reads_of_a_slow_reader_come_back_whole_and_in_order(
        served: tuple[Windowed, str], monkeypatch: pytest.MonkeyPatch, path: str) -> None:
    # Each reply goes out as the reader takes it, beside the transport ("socket"), or through
    # aiohttp's writer when the transport holds bytes of its own ("writer": made so here for
    # every reply, which the routes then answer); the bytes must be exact, in order.
    from aiogenomix.gateway import _fast_reads, _pieces

    if path == "writer":
        monkeypatch.setattr(_pieces, "direct_socket", lambda transport: None)
        monkeypatch.setattr(_fast_reads, "direct_socket", lambda transport: None)
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


class Waits:
    """Each time a reply waits for its reader (``drained_of``, watched): what the transport held then."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        from aiogenomix.gateway import _connection, _pieces

        self.queued: list[tuple[int, int]] = []  # (bytes the transport held, its high-water mark)
        self.waiting = asyncio.Event()
        self.gave_up = asyncio.Event()
        original = _connection.drained_of

        def watched(protocol: Any) -> Any:
            drained = original(protocol)

            async def wait() -> None:
                transport = protocol.transport
                self.queued.append((transport.get_write_buffer_size(), transport.get_write_buffer_limits()[1]))
                self.waiting.set()
                try:
                    await drained()
                except ConnectionResetError:
                    self.gave_up.set()
                    raise
            return wait

        for module in (_connection, _pieces):
            monkeypatch.setattr(module, "drained_of", watched)


async def _stalled(url: str, path: str) -> tuple[socket.socket, bytes]:
    """A reader with a 4 KiB receive buffer that asks for *path*, takes the reply's first bytes and stops."""
    host, port = url.removeprefix("http://").split(":")
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.setblocking(False)
    loop = asyncio.get_running_loop()
    await loop.sock_connect(sock, (host, int(port)))
    await loop.sock_sendall(sock, f"GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n".encode())
    first = await loop.sock_recv(sock, 1024)
    assert first.startswith(b"HTTP/1.1 200")
    return sock, first


@pytest.mark.parametrize("query", ["", "?format=binary", "?format=%6Ason"])  # the last one: the routes' way
async def test_a_reader_that_stops_reading_makes_the_gateway_hold_no_copy_of_its_reply(
        served: tuple[Windowed, str], monkeypatch: pytest.MonkeyPatch, query: str) -> None:
    # asyncio's transport of Python 3.11 copies what it is given: a reply handed to it whole made
    # the gateway hold a copy of the window's JSON text (150 MB for the 59 MiB window) for every
    # client that asked and stopped reading.  It holds the reply's shared pieces, and one at most more.
    waits = Waits(monkeypatch)
    component, url = served
    view = PortView(window(32, 20_000, 40, seed=6), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    binary = "binary" in query
    body = read_body(None, "Port", component.Port, view, None, None, binary)
    assert isinstance(body, PiecesPayload)
    largest = max(len(piece) for piece in body.pieces)
    sock, first = await _stalled(url, "/module/windowed/read/Port" + query)
    await waits.waiting.wait()  # the gateway waits for the reader: what it holds now is all it holds for it
    assert waits.queued and all(held <= high + largest for held, high in waits.queued), (waits.queued, largest)
    assert largest + (1 << 16) < body.size / 10
    received = bytearray(first)
    while data := await asyncio.get_running_loop().sock_recv(sock, 1 << 16):  # the reader goes on: all of it
        received += data
    sock.close()
    assert bytes(received).partition(b"\r\n\r\n")[2] == (expected_binary(view) if binary else expected_json(view))
    assert all(held <= high + largest for held, high in waits.queued)


async def test_a_reader_that_takes_nothing_for_the_keep_alive_time_is_disconnected(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    # Its reply holds the publication it answers: the port's chunks since let go included.
    waits = Waits(monkeypatch)
    async with ComponentHost(clock=ScaledClock(1), factories={"windowed": Windowed}) as host:
        component = await host.load("windowed")
        assert isinstance(component, Windowed)
        view = PortView(window(32, 20_000, 40, seed=7), 44100, 0.0, KemarPortData)
        component.Port.publish(view)
        async with serve(GatewayConfig.of(port=0, keep_alive=0.5), host=host) as url:
            sock, first = await _stalled(url, "/module/windowed/read/Port")
            await waits.gave_up.wait()
            received = bytearray(first)
            with contextlib.suppress(ConnectionResetError):
                while data := await asyncio.get_running_loop().sock_recv(sock, 1 << 16):
                    received += data
            sock.close()
            assert len(received) < len(expected_json(view)) / 2  # cut off, not sent whole
            assert await get(url, "/module/windowed/read/Port") == expected_json(view)  # others are served
    assert not [r for r in caplog.records if r.levelname in ("ERROR", "WARNING", "CRITICAL") or r.exc_info]


@pytest.mark.parametrize("accept", ["", "text/event-stream"])
async def test_a_watch_of_the_whole_window_is_the_encoding_of_the_window(served: tuple[Windowed, str],
                                                                         accept: str) -> None:
    # Written from the chunks' shared texts, piece by piece as the watcher takes them (never one
    # copy of the window per watcher): byte for byte what encoding the joined window gives.
    component, url = served
    view = PortView(window(32, 20_000, 40, seed=8), 44100, 0.0, KemarPortData)
    component.Port.publish(view)
    host, port = url.removeprefix("http://").split(":")
    reader, writer = await asyncio.open_connection(host, int(port), limit=1 << 26)
    headers = f"Accept: {accept}\r\n" if accept else ""
    writer.write(f"GET /module/windowed/watch/Port?since=0 HTTP/1.1\r\nHost: {host}\r\n{headers}\r\n".encode())
    try:
        head = await reader.readuntil(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 200"), head
        if accept:  # chunked: the event's bytes are the chunks' contents
            stream = bytearray()
            while not stream.endswith(b"\n\n"):
                size = int((await reader.readuntil(b"\r\n")).strip(), 16)
                stream += (await reader.readexactly(size + 2))[:-2]
        else:
            stream = bytearray(await reader.readuntil(b"\n\n"))
    finally:
        writer.close()
        await writer.wait_closed()
    event = bytes(stream).split(b"\ndata: ", 1)
    assert event[0].endswith(b"event: port") and (not accept or event[0].startswith(b"id: 40\n"))
    assert event[1] == expected_json(view, 0) + b"\n\n"
