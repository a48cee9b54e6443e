"""A client of the dedicated audio socket (2014 format): numpy frames, indices, head positions, losses.

The server of the ``capture`` component answers ``Read Port - Index <k>`` with
little-endian int32 ``[n][left n·FPC][right n·FPC][last index]``; the merged
``kemarcapture`` component appends ``[n positions as float32 degrees]``.  The
reply does not carry the chunk size, so the client must be told it
(``transfer_rate * chunk_time / 1000``, see ``GetCaptureConfig``) and whether
positions follow.

The client keeps the index of the last chunk it holds and asks only for newer
ones, so consecutive reads give a gap-free stream unless it reads less often
than the port's length, in which case each block says how many chunks were
lost.  Two flavours share one decoder: :class:`AudioSocketClient` (blocking,
for scripts and notebooks) and :class:`AsyncAudioSocketClient` (asyncio)::

    with AudioSocketClient("localhost", 8081) as audio:
        block = audio.read()              # block.frames: (N, 2) int32

    async with AsyncAudioSocketClient("localhost", 8081, positions=True) as audio:
        async for block in audio.stream():
            ...
"""

from __future__ import annotations

import asyncio
import dataclasses
import time
from collections.abc import AsyncIterator, Iterator

import numpy as np
import numpy.typing as npt

from ._socket_link import DEFAULT_PORT, ERROR_MARK, AsyncLink, AudioSocketError, BlockingLink

__all__ = ["AudioBlock", "AudioSocketError", "AudioSocketClient", "AsyncAudioSocketClient", "DEFAULT_PORT"]

#: A reply announcing more chunks than this is not a reply of this protocol.
_MAX_CHUNKS = 1 << 20


@dataclasses.dataclass(frozen=True)
class AudioBlock:
    """The new chunks of one read.

    Attributes:
        frames: ``(count * frames_per_chunk, 2)`` int32 frames, left then right, oldest first: a
            view of the received reply, not C-contiguous (``np.ascontiguousarray`` makes it so).
        count: How many chunks arrived.
        first_index: Index of the first chunk in *frames* (``last_index + 1`` when none).
        last_index: The server's newest chunk, now the client's index.
        lost: Chunks between the previous read and this one that the server no
            longer held.
        positions: Head position in degrees at the end of each chunk (float32,
            shape ``(count,)``), or None from a server without positions.
        restarted: The server's index went backwards (a new capture started); the
            client started over from index 0.
    """

    frames: npt.NDArray[np.int32]
    count: int
    first_index: int
    last_index: int
    lost: int
    positions: npt.NDArray[np.float32] | None
    restarted: bool = False

    @property
    def left(self) -> npt.NDArray[np.int32]:
        """The left channel."""
        return self.frames[:, 0]

    @property
    def right(self) -> npt.NDArray[np.int32]:
        """The right channel."""
        return self.frames[:, 1]


class _Protocol:
    """What both clients share: the request, the reply layout and the index bookkeeping."""

    def __init__(self, frames_per_chunk: int, positions: bool, index: int) -> None:
        if frames_per_chunk < 1:
            raise ValueError(f"frames_per_chunk must be >= 1, not {frames_per_chunk}")
        if index < 0:
            raise ValueError(f"index must be >= 0, not {index}")
        self.frames_per_chunk = frames_per_chunk
        self.positions = positions
        self.index = index

    def request(self) -> bytes:
        return f"Read Port - Index {self.index}\n".encode("ascii")

    def count_of(self, header: bytes) -> int:
        """The chunk count from the first 4 bytes of a reply (which must not be an error line)."""
        count = int.from_bytes(header, "little", signed=True)
        if not 0 <= count <= _MAX_CHUNKS:
            raise AudioSocketError(f"the server announced {count} chunks: not a dedicated-socket reply")
        return count

    def body_buffer(self, count: int) -> npt.NDArray[np.int32]:
        """A fresh array for the words after the count word, to receive the reply into."""
        return np.empty(2 * count * self.frames_per_chunk + 1 + (count if self.positions else 0), dtype="<i4")

    def decode(self, count: int, body: npt.NDArray[np.int32]) -> AudioBlock:
        """Decode the body of a reply (received into :meth:`body_buffer`) and move the index forward."""
        samples = count * self.frames_per_chunk
        # The reply holds all left samples, then all right ones: the (N, 2) frames are a
        # view of it, with no copy (np.ascontiguousarray(block.frames) if a C-order array is needed).
        frames = body[:2 * samples].reshape(2, samples).T
        last = int(body[2 * samples])
        positions = None
        if self.positions:
            positions = body[2 * samples + 1:].view("<f4")
        lost = max(0, last - self.index - count)
        self.index = max(self.index, last)
        return AudioBlock(frames, count, last - count + 1, last, lost, positions)


class _ClientBase:
    """What both clients share: the protocol state, the index they hold."""

    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, *, frames_per_chunk: int = 2205,
                 positions: bool = False, index: int = 0, token: str | None = None, timeout: float = 10.0) -> None:
        super().__init__(host, port, token, timeout)  # type: ignore[call-arg]
        self._protocol = _Protocol(frames_per_chunk, positions, index)

    @property
    def index(self) -> int:
        """The index of the last chunk the client holds."""
        return self._protocol.index

    def seek(self, index: int) -> None:
        """Make the next read ask for the chunks after *index* (0: the whole port)."""
        if index < 0:
            raise ValueError(f"a chunk index is never negative, not {index}")
        self._protocol.index = index


class AudioSocketClient(_ClientBase, BlockingLink):
    """A blocking dedicated-socket client.

    Args:
        host: The server's address.
        port: Its port (``audio_socket_port`` of the gateway, 8081 by default).
        frames_per_chunk: Frames per chunk of the running capture.
        positions: Whether the server appends head positions (``kemarcapture``).
        index: The last chunk index already held (0: none).
        token: The gateway's ``--token``, sent first, when it has one.
        timeout: Seconds to wait for the server before :class:`AudioSocketError`.
    """

    def read(self) -> AudioBlock:
        """Ask for the chunks newer than :attr:`index` and return them.

        Raises:
            AudioSocketError: on a refused request or a broken connection.
        """
        self.connect()
        protocol = self._protocol
        restarted = False
        while True:
            previous = protocol.index
            try:
                self._send(protocol.request())
                header = bytearray(4)
                self._receive_into(memoryview(header))
                if header == ERROR_MARK:
                    raise self._refused(bytes(header))
                count = protocol.count_of(bytes(header))
                body = protocol.body_buffer(count)
                self._receive_into(memoryview(body).cast("B"))
                block = protocol.decode(count, body)
            except AudioSocketError:
                self._drop()
                raise
            except OSError as exc:
                self._drop()
                raise AudioSocketError(f"audio socket connection failed: {exc}") from exc
            if block.last_index >= previous:
                return dataclasses.replace(block, restarted=True) if restarted else block
            # The server's index went back: a new capture.  Start over from its beginning.
            protocol.index, restarted = 0, True

    def stream(self, interval: float = 0.01) -> Iterator[AudioBlock]:
        """Yield blocks of new chunks forever, polling every *interval* seconds when none is new."""
        while True:
            block = self.read()
            if block.count:
                yield block
            else:
                time.sleep(interval)


class AsyncAudioSocketClient(_ClientBase, AsyncLink):
    """An asyncio dedicated-socket client (same arguments as :class:`AudioSocketClient`)."""

    async def _exchange(self) -> AudioBlock:
        protocol = self._protocol
        self._send(protocol.request())
        header = bytearray(4)
        await self._receive_into(memoryview(header))
        if header == ERROR_MARK:
            raise await self._refused(bytes(header))
        count = protocol.count_of(bytes(header))
        body = protocol.body_buffer(count)
        await self._receive_into(memoryview(body).cast("B"))
        return protocol.decode(count, body)

    async def read(self) -> AudioBlock:
        """Ask for the chunks newer than :attr:`index` and return them.

        Raises:
            AudioSocketError: on a refused request, a broken connection or a timeout.
        """
        await self.connect()
        protocol = self._protocol
        restarted = False
        while True:
            previous = protocol.index
            try:
                # asyncio.timeout rather than wait_for, which on Python 3.11 may lose a
                # cancellation that races with the reply.
                async with asyncio.timeout(self.timeout):
                    block = await self._exchange()
            except AudioSocketError:
                await self.aclose()
                raise
            except (OSError, asyncio.IncompleteReadError, TimeoutError) as exc:
                await self.aclose()
                raise AudioSocketError(f"audio socket connection failed: {exc!r}") from exc
            if block.last_index >= previous:
                return dataclasses.replace(block, restarted=True) if restarted else block
            # The server's index went back: a new capture.  Start over from its beginning.
            protocol.index, restarted = 0, True

    async def stream(self, interval: float = 0.01) -> AsyncIterator[AudioBlock]:
        """Yield blocks of new chunks forever, polling every *interval* seconds when none is new."""
        while True:
            block = await self.read()
            if block.count:
                yield block
            else:
                await asyncio.sleep(interval)
