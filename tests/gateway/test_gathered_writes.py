"""Gathered writes: many buffers to a socket in order with writev, and the part it did not take handed back."""

from __future__ import annotations

import asyncio
import os
import socket
from collections.abc import Iterator

import pytest

from aiogenomix.gateway._gather import direct_socket, unsent, write_draining, write_gathered


@pytest.fixture
def pair() -> Iterator[tuple[socket.socket, socket.socket]]:
    sender, receiver = socket.socketpair()
    sender.setblocking(False)
    receiver.setblocking(False)
    yield sender, receiver
    sender.close()
    receiver.close()


def drain(sock: socket.socket) -> bytes:
    """Everything *sock* holds now."""
    received = bytearray()
    while True:
        try:
            data = sock.recv(1 << 16)
        except BlockingIOError:
            return bytes(received)
        received += data


def test_more_pieces_than_one_writev_takes_go_out_in_order(pair: tuple[socket.socket, socket.socket]) -> None:
    sender, receiver = pair
    pieces = [b"%d," % i for i in range(3 * os.sysconf("SC_IOV_MAX") + 7)]
    whole = b"".join(pieces)
    assert write_gathered(sender.fileno(), pieces) == len(whole)
    assert drain(receiver) == whole


def test_a_full_socket_takes_a_part_and_the_rest_is_what_it_did_not_take(
        pair: tuple[socket.socket, socket.socket]) -> None:
    sender, receiver = pair
    sender.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)
    pieces: list[bytes | memoryview] = [bytes([i]) * 5000 for i in range(200)]
    pieces[7] = memoryview(pieces[7])
    whole = b"".join(pieces)
    written = write_gathered(sender.fileno(), pieces)
    assert 0 < written < len(whole)
    assert drain(receiver) == whole[:written]
    assert b"".join(unsent(pieces, written)) == whole[written:]
    # A socket that takes nothing now: nothing is written, nothing is lost.
    while write_gathered(sender.fileno(), [b"x" * 65536]):
        pass
    assert write_gathered(sender.fileno(), pieces) == 0


def test_unsent_cuts_a_piece_as_a_view() -> None:
    pieces = [b"abc", b"de", b"fgh"]
    assert unsent(pieces, 0) == pieces
    assert unsent(pieces, 3) == [b"de", b"fgh"]
    cut = unsent(pieces, 4)
    assert [bytes(p) for p in cut] == [b"e", b"fgh"]
    assert isinstance(cut[0], memoryview) and cut[0].obj is pieces[1]  # not copied
    assert unsent(pieces, 8) == []


def test_unsent_at_every_offset_is_the_rest_of_the_whole() -> None:
    pieces: list[bytes | memoryview] = [b"a", memoryview(b"bcd"), b"efghij", b"k", memoryview(b"lmnopq")]
    whole = b"".join(pieces)
    for written in range(len(whole) + 1):
        assert b"".join(unsent(pieces, written)) == whole[written:], written


async def test_a_reply_of_known_size_the_socket_takes_in_part_is_written_whole() -> None:
    """The size given spares a whole reply a second look; a partial write still goes on where it stopped."""
    loop = asyncio.get_running_loop()
    received = bytearray()
    pieces: list[bytes | memoryview] = [bytes([i % 256]) * 7000 for i in range(300)]
    pieces[11] = memoryview(pieces[11])
    whole = b"".join(pieces)
    complete: asyncio.Future[None] = loop.create_future()

    class Reader(asyncio.Protocol):
        def data_received(self, data: bytes) -> None:
            received.extend(data)
            if len(received) == len(whole):
                complete.set_result(None)

    class Writer(asyncio.Protocol):
        """Flow control as aiohttp's: the transport says when it holds too much and when it is drained."""

        def __init__(self) -> None:
            self.resumed = asyncio.Event()
            self.resumed.set()

        def pause_writing(self) -> None:
            self.resumed.clear()

        def resume_writing(self) -> None:
            self.resumed.set()

    server = await loop.create_server(Reader, "127.0.0.1", 0)
    try:
        port = server.sockets[0].getsockname()[1]
        transport, writer = await loop.create_connection(Writer, "127.0.0.1", port)
        transport.get_extra_info("socket").setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)
        await write_draining(transport, pieces, writer.resumed.wait, size=len(whole))
        async with asyncio.timeout(30):  # a reply cut short never completes: fail, not hang
            await complete
        assert bytes(received) == whole
        transport.close()
    finally:
        server.close()
        await server.wait_closed()


async def test_only_an_idle_plain_connection_is_written_beside_its_transport() -> None:
    loop = asyncio.get_running_loop()
    accepted: asyncio.Future[asyncio.Transport] = loop.create_future()

    class Silent(asyncio.Protocol):
        def connection_made(self, transport: asyncio.BaseTransport) -> None:
            transport.pause_reading()  # reads nothing: the client's bytes stay queued
            accepted.set_result(transport)  # type: ignore[arg-type]

    server = await loop.create_server(Silent, "127.0.0.1", 0)
    try:
        port = server.sockets[0].getsockname()[1]
        transport, _ = await loop.create_connection(asyncio.Protocol, "127.0.0.1", port)
        peer = await accepted
        assert direct_socket(transport) == transport.get_extra_info("socket").fileno()
        while not transport.get_write_buffer_size():  # fill both kernel buffers
            transport.write(b"x" * (1 << 20))
        assert direct_socket(transport) is None  # bytes queued: they must go first
        transport.abort()
        assert direct_socket(transport) is None
        assert direct_socket(None) is None
        peer.close()
    finally:
        server.close()
        await server.wait_closed()


def test_a_tls_connection_is_never_written_beside_its_transport() -> None:
    class Tls(asyncio.WriteTransport):
        """What asyncio's TLS transport says of itself: its socket is under TLS."""

        def __init__(self, sock: socket.socket) -> None:
            super().__init__({"socket": sock, "sslcontext": object()})

        def is_closing(self) -> bool:
            return False

        def get_write_buffer_size(self) -> int:
            return 0

    with socket.socket() as sock:
        assert direct_socket(Tls(sock)) is None
