"""The dedicated-socket server with real TCP connections, and the sync and async clients."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

import numpy as np
import pytest

from aiogenomix.clients.audio_socket import AsyncAudioSocketClient, AudioSocketClient, AudioSocketError
from aiogenomix.components.audio import ChunkWindow, DedicatedSocketServer

FPC = 8


def fill(window: ChunkWindow, upto: int) -> None:
    """Append chunks until the window's last index is *upto*; chunk i holds i (left) and -i (right)."""
    while window.last_index < upto:
        i = window.last_index + 1
        position = {"position": float(i) / 2} if window.with_positions else {}
        window.append(np.full(FPC, i), np.full(FPC, -i), **position)


@pytest.fixture
async def window_and_server() -> AsyncIterator[tuple[ChunkWindow, DedicatedSocketServer]]:
    window = ChunkWindow(5, FPC, with_positions=True)
    async with DedicatedSocketServer(lambda: window, port=0, with_positions=True) as server:
        yield window, server


async def test_clients_get_new_chunks_and_their_losses(window_and_server: tuple[ChunkWindow,
                                                                                DedicatedSocketServer]) -> None:
    window, server = window_and_server
    assert server.port > 0
    async with AsyncAudioSocketClient(port=server.port, frames_per_chunk=FPC, positions=True) as client:
        empty = await client.read()
        assert (empty.count, empty.last_index, empty.lost, empty.frames.shape) == (0, 0, 0, (0, 2))
        fill(window, 3)
        block = await client.read()
        assert (block.count, block.first_index, block.last_index, block.lost) == (3, 1, 3, 0)
        np.testing.assert_array_equal(block.frames[:, 0], np.repeat([1, 2, 3], FPC))
        np.testing.assert_array_equal(block.right, np.repeat([-1, -2, -3], FPC))
        assert block.positions is not None and block.positions.tolist() == [0.5, 1.0, 1.5]
        fill(window, 12)                                  # 9 new, the port holds 5
        block = await client.read()
        assert (block.count, block.first_index, block.last_index, block.lost) == (5, 8, 12, 4)
        assert client.index == 12


async def test_many_clients_at_once(window_and_server: tuple[ChunkWindow, DedicatedSocketServer]) -> None:
    window, server = window_and_server
    fill(window, 4)
    clients = [AsyncAudioSocketClient(port=server.port, frames_per_chunk=FPC, positions=True) for _ in range(6)]
    blocks = await asyncio.gather(*(c.read() for c in clients))
    assert server.clients == 6
    assert all(b.count == 4 and b.last_index == 4 for b in blocks)
    await asyncio.gather(*(c.aclose() for c in clients))


async def test_a_bad_request_gets_an_error_line_and_the_server_goes_on(
        window_and_server: tuple[ChunkWindow, DedicatedSocketServer]) -> None:
    window, server = window_and_server
    fill(window, 2)
    reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
    writer.write(b"Read Port - Index -4\n")
    assert (await reader.readline()).startswith(b"ERROR expected 'Read Port - Index <k>'")
    assert await reader.read() == b""                   # closed by the server
    writer.close()
    reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
    writer.write(b"Read Port - Index 1\n")
    reply = await reader.readexactly(4 * (2 + 2 * FPC) + 4)
    assert np.frombuffer(reply[:4], "<i4")[0] == 1
    writer.close()


async def test_an_endless_request_line_is_refused(window_and_server: tuple[ChunkWindow,
                                                                             DedicatedSocketServer]) -> None:
    _, server = window_and_server
    reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
    writer.write(b"x" * 700)                             # no newline, too long
    assert (await reader.readline()).startswith(b"ERROR request line longer")
    writer.close()


async def test_client_of_a_restarted_capture_starts_over() -> None:
    window = ChunkWindow(5, FPC)
    async with DedicatedSocketServer(lambda: window, port=0) as server:
        async with AsyncAudioSocketClient(port=server.port, frames_per_chunk=FPC) as client:
            fill(window, 9)
            await client.read()
            window = ChunkWindow(5, FPC)                 # a new capture, index back to 0
            fill(window, 2)
            block = await client.read()
    assert block.restarted and (block.count, block.first_index, block.last_index, block.lost) == (2, 1, 2, 0)


async def test_closing_the_server_disconnects_clients() -> None:
    window = ChunkWindow(5, FPC)
    server = DedicatedSocketServer(lambda: window, port=0)
    await server.start()
    client = AsyncAudioSocketClient(port=server.port, frames_per_chunk=FPC, timeout=5)
    await client.read()
    await server.aclose()
    assert server.port == 0 and server.clients == 0
    with pytest.raises(AudioSocketError):
        await client.read()
    await server.aclose()                                # idempotent


async def test_no_window_yet_means_no_chunks() -> None:
    async with DedicatedSocketServer(lambda: None, port=0) as server:
        async with AsyncAudioSocketClient(port=server.port, frames_per_chunk=FPC) as client:
            block = await client.read()
    assert (block.count, block.last_index) == (0, 0)


async def test_sync_client_and_its_stream(window_and_server: tuple[ChunkWindow, DedicatedSocketServer]) -> None:
    window, server = window_and_server
    fill(window, 3)

    def read_twice() -> list[tuple[int, int, int]]:
        with AudioSocketClient(port=server.port, frames_per_chunk=FPC, positions=True, index=1) as client:
            stream = client.stream(interval=0.001)
            first = next(stream)
            return [(first.count, first.first_index, first.last_index)]

    assert await asyncio.to_thread(read_twice) == [(2, 2, 3)]


async def test_async_stream_yields_only_new_chunks(window_and_server: tuple[ChunkWindow,
                                                                            DedicatedSocketServer]) -> None:
    window, server = window_and_server
    seen: list[int] = []
    async with AsyncAudioSocketClient(port=server.port, frames_per_chunk=FPC, positions=True) as client:
        fill(window, 2)
        async for block in client.stream(interval=0.001):
            seen.extend(range(block.first_index, block.last_index + 1))
            if block.last_index == 2:
                fill(window, 4)
            else:
                break
    assert seen == [1, 2, 3, 4]


async def test_unreachable_server() -> None:
    with pytest.raises(AudioSocketError, match="cannot reach"):
        await AsyncAudioSocketClient(port=1, frames_per_chunk=FPC).read()
    with pytest.raises(AudioSocketError, match="cannot reach"):
        AudioSocketClient(port=1).read()


class _AnsweringServer(DedicatedSocketServer):
    """Says when it has answered: the reply is handed to the transport before the server next awaits."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.answered = asyncio.Event()

    def reply_to(self, index: int) -> bytes:
        reply = super().reply_to(index)
        self.answered.set()
        return reply


async def test_a_slow_reader_gets_the_window_as_it_was_when_it_asked() -> None:
    """Issue 14, defect 1: on Python 3.12+ a transport keeps the buffer it was handed until the client drains it.

    An 8 MiB reply cannot leave at once to a client that does not read; the
    window turns over twice before the client reads, and every byte must still
    be the window of the request, not what later chunks wrote in its place.
    """
    fpc, capacity = 16384, 64
    window = ChunkWindow(capacity, fpc)
    for i in range(1, capacity + 1):
        window.append(np.full(fpc, i), np.full(fpc, -i))
    async with _AnsweringServer(lambda: window, port=0) as server:
        reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
        writer.write(b"Read Port - Index 0\n")
        await server.answered.wait()
        for i in range(capacity + 1, 3 * capacity + 1):     # overwrite every row of the ring
            window.append(np.full(fpc, 10_000 + i), np.full(fpc, -10_000 - i))
        reply = np.frombuffer(await reader.readexactly(4 * (2 + 2 * capacity * fpc)), "<i4")
        writer.close()
    assert reply[0] == capacity and reply[-1] == capacity
    np.testing.assert_array_equal(reply[1:1 + capacity * fpc], np.repeat(np.arange(1, capacity + 1), fpc))
    np.testing.assert_array_equal(reply[1 + capacity * fpc:-1], -np.repeat(np.arange(1, capacity + 1), fpc))
