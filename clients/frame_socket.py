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
import socket
import struct
from collections.abc import AsyncIterator, Iterator
from typing import Self

import numpy as np
import numpy.typing as npt

from ._receiver import Receiver
from .audio_socket import DEFAULT_PORT, AudioSocketError

__all__ = ["FrameBlock", "FrameSocketClient", "AsyncFrameSocketClient"]

_HEADER = struct.Struct("<iiq")
_ERROR_MARK = b"ERRO"
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
    """What both clients share: the address, the token and the next frame to read."""

    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, *, next_frame: int = 0,
                 max_frames: int = ALL_FRAMES, token: str | None = None, timeout: float = 10.0) -> None:
        if next_frame < 0 or not 0 <= max_frames <= ALL_FRAMES:
            raise ValueError(f"next_frame >= 0 and 0 <= max_frames <= {ALL_FRAMES}, not {next_frame} and "
                             f"{max_frames}")
        self.host, self.port, self.timeout, self.token = host, port, timeout, token
        #: The index of the next frame the client asks for.
        self.next_frame = next_frame
        #: The most frames a read asks for unless told otherwise.
        self.max_frames = max_frames

    def _greeting(self) -> bytes:
        return f"Token {self.token}\n".encode() if self.token else b""

    def _ask(self, max_frames: int | None) -> bytes:
        frames = self.max_frames if max_frames is None else max_frames
        if not 0 <= frames <= ALL_FRAMES:
            raise ValueError(f"max_frames must be within 0…{ALL_FRAMES}, not {frames}")
        return _request(frames, self.next_frame)

    def _advance(self, block: FrameBlock) -> FrameBlock:
        self.next_frame = block.next_frame
        return block


class FrameSocketClient(_FrameClientBase):
    """A blocking client of the 2015 dedicated socket.

    Args:
        host: The server's address.
        port: Its port (``audio_socket_port`` of the gateway, 8081 by default).
        next_frame: The first frame to ask for (0: the oldest the port holds).
        max_frames: The most frames one read asks for (default: all the port holds).
        token: The gateway's ``--token``, sent first, when it has one.
        timeout: Seconds to wait for the server before :class:`AudioSocketError`.
    """

    _sock: socket.socket | None = None

    def connect(self) -> None:
        """Open the connection (done by the first read if needed).

        Raises:
            AudioSocketError: when the server cannot be reached.
        """
        if self._sock is None:
            try:
                self._sock = socket.create_connection((self.host, self.port), timeout=self.timeout)
                self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self._sock.sendall(self._greeting())
            except OSError as exc:
                self._sock = None
                raise AudioSocketError(f"cannot reach the audio socket at {self.host}:{self.port}: {exc}") from exc

    def close(self) -> None:
        """Say ``Close`` and close the connection (idempotent)."""
        sock, self._sock = self._sock, None
        if sock is not None:
            try:
                sock.sendall(b"Close\n")
            except OSError:
                pass  # already gone: closing is all that is left
            sock.close()

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _receive_into(self, view: memoryview) -> None:
        assert self._sock is not None
        got = 0
        while got < len(view):
            n = self._sock.recv_into(view[got:])
            if n == 0:
                raise AudioSocketError("the audio socket closed the connection")
            got += n

    def read(self, max_frames: int | None = None) -> FrameBlock:
        """Ask for the frames from :attr:`next_frame` on (at most *max_frames*) and return them.

        Raises:
            AudioSocketError: on a refused request or a broken connection.
        """
        self.connect()
        assert self._sock is not None
        try:
            self._sock.sendall(self._ask(max_frames))
            header = bytearray(_HEADER.size)
            self._receive_into(memoryview(header)[:4])
            if header[:4] == _ERROR_MARK:
                rest = self._sock.makefile("rb").readline()
                raise AudioSocketError(f"the audio socket refused the request: "
                                       f"{(bytes(header[:4]) + rest).decode('utf-8', 'replace').strip()}")
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

    def _drop(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            sock.close()

    def stream(self, max_frames: int | None = None) -> Iterator[FrameBlock]:
        """Yield the blocks of every read, forever (empty ones included: the caller paces the reads)."""
        while True:
            yield self.read(max_frames)


class AsyncFrameSocketClient(_FrameClientBase):
    """An asyncio client of the 2015 dedicated socket (same arguments as :class:`FrameSocketClient`)."""

    _receiver: Receiver | None = None

    async def connect(self) -> None:
        """Open the connection (done by the first read if needed).

        Raises:
            AudioSocketError: when the server cannot be reached.
        """
        if self._receiver is None:
            loop = asyncio.get_running_loop()
            try:
                async with asyncio.timeout(self.timeout):
                    _, self._receiver = await loop.create_connection(Receiver, self.host, self.port)
            except (OSError, TimeoutError) as exc:
                raise AudioSocketError(f"cannot reach the audio socket at {self.host}:{self.port}: {exc}") from exc
            assert self._receiver.transport is not None
            self._receiver.transport.write(self._greeting())

    async def aclose(self) -> None:
        """Say ``Close`` and close the connection (idempotent)."""
        receiver, self._receiver = self._receiver, None
        if receiver is not None and receiver.transport is not None:
            if not receiver.transport.is_closing():
                receiver.transport.write(b"Close\n")
            receiver.transport.close()

    async def __aenter__(self) -> Self:
        await self.connect()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    async def _exchange(self, max_frames: int | None) -> FrameBlock:
        assert self._receiver is not None and self._receiver.transport is not None
        receiver = self._receiver
        receiver.transport.write(self._ask(max_frames))
        header = bytearray(_HEADER.size)
        await receiver.receive_into(memoryview(header)[:4])
        if header[:4] == _ERROR_MARK:
            rest = await receiver.receive_line()
            raise AudioSocketError(f"the audio socket refused the request: "
                                   f"{(bytes(header[:4]) + rest).decode('utf-8', 'replace').strip()}")
        await receiver.receive_into(memoryview(header)[4:])
        count, lost, next_frame = _parse_header(bytes(header))
        body = np.empty(2 * count, dtype="<i4")
        await receiver.receive_into(memoryview(body).cast("B"))
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
