"""Issue 24: what dedicated-socket clients make the server hold is bounded; readers beside the slow ones lose nothing.

The memory figures (50 clients that never read on a 384 kHz port of 400 chunks) are in the
benchmarks (``bench/budgets.py``); here the bounds themselves, without timing: the backlog of clients
that never read is capped by dropping the oldest, a reply is cut to a client's budget with the
losses counted as the protocol counts them, one client too many is told which flag to change.
"""

from __future__ import annotations

import asyncio
import logging
import socket

import numpy as np
import pytest

from aiogenomix.clients.audio_socket import AsyncAudioSocketClient
from aiogenomix.components.audio import ChunkWindow, DedicatedSocketServer, reply_size
from aiogenomix.components.bass import ChunkHistory
from aiogenomix.components.bass._socket_server import FrameSocketServer
from aiogenomix.components.bass._socket_wire import HEADER, frame_reply_size
from aiogenomix.components.core import Budgets

MIB = 2**20


def fill(window: ChunkWindow, upto: int) -> None:
    """Append chunks until the window's newest index is *upto*; chunk i holds i (left) and -i (right)."""
    while window.last_index < upto:
        i = window.last_index + 1
        window.append(np.full(window.frames_per_chunk, i), np.full(window.frames_per_chunk, -i))


class _AnsweringServer(DedicatedSocketServer):
    """Says when it has answered a request: its reply is then held against the ledger, being sent."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.answered = asyncio.Event()

    def reply_to(self, index: int) -> bytearray:
        reply = super().reply_to(index)
        self.answered.set()
        return reply


async def _client_that_never_reads(port: int) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    """A connection with a tiny receive window, which asks for the whole port once and never reads."""
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.setblocking(False)
    await asyncio.get_running_loop().sock_connect(sock, ("127.0.0.1", port))
    reader, writer = await asyncio.open_connection(sock=sock)
    writer.write(b"Read Port - Index 0\n")
    return reader, writer


async def test_clients_that_never_read_are_dropped_oldest_first_and_a_reader_beside_them_loses_nothing() -> None:
    fpc, capacity = 16384, 64                              # an 8 MiB window: a whole-port reply is 8 MiB
    whole = reply_size(capacity, fpc)
    budgets = Budgets(socket_bytes=3 * whole + MIB)        # three such replies fit, a fourth does not
    window = ChunkWindow(capacity, fpc)
    fill(window, capacity)
    stalled = []
    async with _AnsweringServer(lambda: window, port=0, budgets=budgets) as server:
        async with AsyncAudioSocketClient(port=server.port, frames_per_chunk=fpc, index=capacity) as reader:
            got, lost = [], 0
            for _ in range(10):
                server.answered.clear()
                stalled.append(await _client_that_never_reads(server.port))
                await server.answered.wait()
                assert server.ledger.held <= budgets.socket_bytes
                fill(window, window.last_index + 1)
                block = await reader.read()               # the reader beside them: every chunk, none lost
                got.extend(range(block.first_index, block.last_index + 1))
                lost += block.lost
                assert server.ledger.held <= budgets.socket_bytes
            assert got == list(range(capacity + 1, capacity + 11)) and lost == 0
            assert server.dropped == 7 and server.ledger.evictions == 7
            assert server.clients == 1 + 3                # the reader and the three newest that never read
        for _, writer in stalled:
            writer.close()


async def test_a_reply_larger_than_a_clients_budget_carries_the_newest_chunks_and_counts_the_rest_lost() -> None:
    fpc = 64
    window = ChunkWindow(10, fpc)
    budgets = Budgets(socket_client_bytes=reply_size(3, fpc))
    async with DedicatedSocketServer(lambda: window, port=0, budgets=budgets) as server:
        async with AsyncAudioSocketClient(port=server.port, frames_per_chunk=fpc) as client:
            fill(window, 8)
            block = await client.read()
            assert (block.count, block.first_index, block.last_index, block.lost) == (3, 6, 8, 5)
            np.testing.assert_array_equal(block.frames[:, 0], np.repeat([6, 7, 8], fpc))
            fill(window, 10)
            block = await client.read()                     # within the budget: nothing more lost
            assert (block.count, block.first_index, block.lost) == (2, 9, 0)


async def test_one_client_too_many_is_told_the_bound_and_its_flag() -> None:
    window = ChunkWindow(4, 8)
    async with DedicatedSocketServer(lambda: window, port=0, budgets=Budgets(socket_clients=2)) as server:
        first = AsyncAudioSocketClient(port=server.port, frames_per_chunk=8)
        second = AsyncAudioSocketClient(port=server.port, frames_per_chunk=8)
        await first.read()
        await second.read()
        reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
        line = await reader.readline()
        assert line == (b"ERROR this socket serves at most 2 clients at once (--max-socket-clients): "
                        b"try again when one has left\n")
        assert await reader.read() == b""
        writer.close()
        assert server.refused == 1 and server.clients == 2
        await first.aclose()
        # A place is free once the server has seen the first one leave: each attempt is answered.
        for _ in range(200):
            third = AsyncAudioSocketClient(port=server.port, frames_per_chunk=8, timeout=10)
            try:
                await third.read()
                break
            except Exception:  # noqa: BLE001  # refused: the server has not yet seen the first leave
                await third.aclose()
        else:
            pytest.fail("no place was freed")
        await third.aclose()
        await second.aclose()


# -- the 2015 socket ----------------------------------------------------------------------------

async def _exchange(port: int, *lines: bytes) -> tuple[bytes, asyncio.StreamReader, asyncio.StreamWriter]:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(b"".join(lines))
    return await reader.read(HEADER.size), reader, writer


async def test_a_2015_reply_larger_than_a_clients_budget_carries_fewer_frames_and_loses_none() -> None:
    history = ChunkHistory(10, 1000, 44100)
    for chunk in range(8):
        snapshot = history.append(np.full(1000, chunk), np.full(1000, -chunk))
    budgets = Budgets(socket_client_bytes=frame_reply_size(2500))
    async with FrameSocketServer(lambda: snapshot, port=0, budgets=budgets) as server:
        head, reader, writer = await _exchange(server.port, b"Read Port - N 5000 - nfr 1\n")
        count, lost, next_frame = HEADER.unpack(head)
        assert (count, lost, next_frame) == (2500, 0, 2501)
        await reader.readexactly(8 * count)
        writer.write(b"Read Port - N 5000 - nfr 2501\nClose\n")
        count, lost, next_frame = HEADER.unpack(await reader.readexactly(HEADER.size))
        assert (count, lost, next_frame) == (2500, 0, 5001)
        writer.close()


@pytest.mark.parametrize("line", [b"Read Port - N 10 - nfr 9223372036854775808",
                                  b"Read Port - N 10 - nfr 9999999999999999999",
                                  b"Read Port - N 2147483648 - nfr 0",
                                  b"Read Port - N 10 - nfr 99999999999999999999"])
async def test_2015_numbers_out_of_range_get_an_error_line_and_no_traceback(
        line: bytes, caplog: pytest.LogCaptureFixture) -> None:
    history = ChunkHistory(4, 100, 44100)
    snapshot = history.append(np.zeros(100), np.zeros(100))
    with caplog.at_level(logging.DEBUG):
        async with FrameSocketServer(lambda: snapshot, port=0) as server:
            reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
            writer.write(line + b"\n")
            answer = await reader.readline()
            assert answer.startswith(b"ERROR ") and answer.endswith(b"\n"), answer
            assert await reader.read() == b""
            writer.close()
            # The largest frame index there is, and the largest N, are answered.
            head, reader, writer = await _exchange(server.port, b"Read Port - N 2147483647 - nfr 9223372036854775807\n")
            assert HEADER.unpack(head) == (0, 0, 2**63 - 1)
            writer.close()
    assert not [r for r in caplog.records if r.exc_info or r.levelno >= logging.ERROR]


async def test_a_fault_while_answering_is_an_error_line_and_one_log_line(caplog: pytest.LogCaptureFixture) -> None:
    def broken() -> ChunkWindow:
        raise RuntimeError("the window is broken")

    with caplog.at_level(logging.ERROR):
        async with DedicatedSocketServer(broken, port=0) as server:
            for _ in range(3):
                reader, writer = await asyncio.open_connection("127.0.0.1", server.port)
                writer.write(b"Read Port - Index 0\n")
                assert (await reader.readline()).startswith(b"ERROR the server failed to answer")
                writer.close()
    failures = [r for r in caplog.records if "answering a client failed" in r.getMessage()]
    assert len(failures) == 3 and [bool(r.exc_info) for r in failures] == [True, False, False]
