"""A client of the frame-indexed dedicated audio socket of 2015 (``bass``): numpy frames, frame indices, losses.

Two generations of the Two!Ears dedicated socket exist, and a client speaks
one of them, chosen by its class:

* :class:`~aiogenomix.clients.AudioSocketClient` speaks the 2014 protocol of
  ``capture`` and ``kemarcapture`` (``Read Port - Index <k>``, chunk indices);
* :class:`FrameSocketClient` and :class:`AsyncFrameSocketClient` speak the 2015
  protocol of ``bass`` (``Read Port - N <n> - nfr <i>``, frame indices), the one
  the public Two!Ears MATLAB client speaks.

A request asks for at most *n* frames from frame *i* on; the reply is a
16-byte little-endian header (int32 frames sent, int32 frames lost, int64 the
next frame to read) and the samples, all left then all right, as int32.  The
client keeps the next frame to read, so consecutive reads are gap-free unless
it reads less often than the port's length, and then each block says how many
frames were lost::

    with FrameSocketClient("localhost", 8081) as audio:
        block = audio.read()            # block.frames: (N, 2) int32, block.first_frame, block.lost

With a gateway started with ``--token``, pass ``token=`` (both clients send it
as their first line).
"""

from __future__ import annotations

import asyncio
import dataclasses
import struct
from collections.abc import AsyncIterator, Iterator

import numpy as np
import numpy.typing as npt

from ._socket_link import DEFAULT_PORT, ERROR_MARK, AsyncLink, AudioSocketError, BlockingLink

__all__ = ["FrameBlock", "FrameSocketClient", "AsyncFrameSocketClient"]

_HEADER = struct.Struct("<iiq")
#: Ask for everything the port holds (the header's count is an int32).
ALL_FRAMES = 2**31 - 1


@dataclasses.dataclass(frozen=True)
class FrameBlock:
    """The frames of one read.

    Attributes:
        frames: ``(count, 2)`` int32 frames, left then right, oldest first: a view of
            the received reply (``np.ascontiguousarray`` makes it C-contiguous).
        first_frame: Index of the first frame (the next frame to read when none came).
        lost: Frames between the previous read and this one that the port no longer held.
    """

    frames: npt.NDArray[np.int32]
    first_frame: int
    lost: int

    @property
    def count(self) -> int:
        """How many frames arrived."""
        return int(self.frames.shape[0])

    @property
    def next_frame(self) -> int:
        """The index of the frame after the last one of this block."""
        return self.first_frame + self.count

    @property
    def left(self) -> npt.NDArray[np.int32]:
        """The left channel."""
        return self.frames[:, 0]

    @property
    def right(self) -> npt.NDArray[np.int32]:
        """The right channel."""
        return self.frames[:, 1]


def _request(frames: int, next_frame: int) -> bytes:
    return f"Read Port - N {frames} - nfr {next_frame}\n".encode("ascii")


def _parse_header(header: bytes) -> tuple[int, int, int]:
    count, lost, next_frame = _HEADER.unpack(header)
    if count < 0 or lost < 0 or next_frame < count:
        raise AudioSocketError(f"unreadable reply header {header.hex()}: not a 2015 dedicated-socket reply")
    return count, lost, next_frame


def _decode(count: int, lost: int, next_frame: int, body: npt.NDArray[np.int32]) -> FrameBlock:
    # Two blocks, left then right: the (count, 2) frames are a view of them.
    return FrameBlock(body.reshape(2, count).T, next_frame - count, lost)


class _FrameClientBase:
    """What both clients share: the next frame to read and the request for it."""

    #: The 2015 protocol's last word (``dedicatedSocketClose.m``).
    goodbye = b"Close\n"

    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, *, next_frame: int = 0,
                 max_frames: int = ALL_FRAMES, token: str | None = None, timeout: float = 10.0) -> None:
        if next_frame < 0 or not 0 <= max_frames <= ALL_FRAMES:
            raise ValueError(f"next_frame >= 0 and 0 <= max_frames <= {ALL_FRAMES}, not {next_frame} and "
                             f"{max_frames}")
        super().__init__(host, port, token, timeout)  # type: ignore[call-arg]
        #: The index of the next frame the client asks for.
        self.next_frame = next_frame
        #: The most frames a read asks for unless told otherwise.
        self.max_frames = max_frames

    def _ask(self, max_frames: int | None) -> bytes:
        frames = self.max_frames if max_frames is None else max_frames
        if not 0 <= frames <= ALL_FRAMES:
            raise ValueError(f"max_frames must be within 0…{ALL_FRAMES}, not {frames}")
        return _request(frames, self.next_frame)

    def _advance(self, block: FrameBlock) -> FrameBlock:
        self.next_frame = block.next_frame
        return block


class FrameSocketClient(_FrameClientBase, BlockingLink):
    """A blocking client of the 2015 dedicated socket.

    Args:
        host: The server's address.
        port: Its port (``audio_socket_port`` of the gateway, 8081 by default).
        next_frame: The first frame to ask for (0: the oldest the port holds).
        max_frames: The most frames one read asks for (default: all the port holds).
        token: The gateway's ``--token``, sent first, when it has one.
        timeout: Seconds to wait for the server before :class:`AudioSocketError`.
    """

    def read(self, max_frames: int | None = None) -> FrameBlock:
        """Ask for the frames from :attr:`next_frame` on (at most *max_frames*) and return them.

        Raises:
            AudioSocketError: on a refused request or a broken connection.
        """
        self.connect()
        try:
            self._send(self._ask(max_frames))
            header = bytearray(_HEADER.size)
            self._receive_into(memoryview(header)[:4])
            if header[:4] == ERROR_MARK:
                raise self._refused(bytes(header[:4]))
            self._receive_into(memoryview(header)[4:])
            count, lost, next_frame = _parse_header(bytes(header))
            body = np.empty(2 * count, dtype="<i4")
            self._receive_into(memoryview(body).cast("B"))
        except AudioSocketError:
            self._drop()
            raise
        except OSError as exc:
            self._drop()
            raise AudioSocketError(f"audio socket connection failed: {exc}") from exc
        return self._advance(_decode(count, lost, next_frame, body))

    def stream(self, max_frames: int | None = None) -> Iterator[FrameBlock]:
        """Yield the blocks of every read, forever (empty ones included: the caller paces the reads)."""
        while True:
            yield self.read(max_frames)


class AsyncFrameSocketClient(_FrameClientBase, AsyncLink):
    """An asyncio client of the 2015 dedicated socket (same arguments as :class:`FrameSocketClient`)."""

    async def _exchange(self, max_frames: int | None) -> FrameBlock:
        self._send(self._ask(max_frames))
        header = bytearray(_HEADER.size)
        await self._receive_into(memoryview(header)[:4])
        if header[:4] == ERROR_MARK:
            raise await self._refused(bytes(header[:4]))
        await self._receive_into(memoryview(header)[4:])
        count, lost, next_frame = _parse_header(bytes(header))
        body = np.empty(2 * count, dtype="<i4")
        await self._receive_into(memoryview(body).cast("B"))
        return _decode(count, lost, next_frame, body)

    async def read(self, max_frames: int | None = None) -> FrameBlock:
        """Ask for the frames from :attr:`next_frame` on (at most *max_frames*) and return them.

        Raises:
            AudioSocketError: on a refused request, a broken connection or a timeout.
        """
        await self.connect()
        try:
            async with asyncio.timeout(self.timeout):
                block = await self._exchange(max_frames)
        except AudioSocketError:
            await self.aclose()
            raise
        except (OSError, asyncio.IncompleteReadError, TimeoutError) as exc:
            await self.aclose()
            raise AudioSocketError(f"audio socket connection failed: {exc!r}") from exc
        return self._advance(block)

    async def stream(self, max_frames: int | None = None) -> AsyncIterator[FrameBlock]:
        """Yield the blocks of every read, forever (empty ones included: the caller paces the reads)."""
        while True:
            yield await self.read(max_frames)
