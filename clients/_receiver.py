"""An asyncio protocol that receives replies of known length straight into caller-given buffers.

``asyncio.StreamReader`` copies every byte twice (into its buffer, then out of
it) and pauses the socket every 128 kB; for the megabytes of an audio window
that costs more than the transfer itself.  This receiver hands the kernel the
destination buffer directly (``BufferedProtocol``), so a reply lands in the
numpy array it will be read from.
"""

from __future__ import annotations

import asyncio

__all__ = ["Receiver"]


class Receiver(asyncio.BufferedProtocol):
    """Request/reply receiving: :meth:`receive_into` fills one buffer exactly, :meth:`receive_line` a line."""

    def __init__(self) -> None:
        self.transport: asyncio.Transport | None = None
        self._target: memoryview | None = None
        self._filled = 0
        self._waiter: asyncio.Future[None] | None = None
        self._spare = memoryview(bytearray(4096))
        self._extra = bytearray()  # bytes that arrived with no buffer waiting (an error line)
        self._line_waiter: asyncio.Future[bytes] | None = None
        self._lost: Exception | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)  # a stream connection's
        self.transport = transport

    def connection_lost(self, exc: Exception | None) -> None:
        self._lost = exc or ConnectionResetError("the connection was closed")
        for waiter in (self._waiter, self._line_waiter):
            if waiter is not None and not waiter.done():
                waiter.set_exception(self._lost)

    def get_buffer(self, sizehint: int) -> memoryview:
        if self._target is not None:
            return self._target[self._filled:]
        return self._spare

    def buffer_updated(self, nbytes: int) -> None:
        if self._target is None:
            self._extra += self._spare[:nbytes]
            if self._line_waiter is not None and b"\n" in self._extra:
                line, _, rest = self._extra.partition(b"\n")
                self._extra = bytearray(rest)
                self._line_waiter.set_result(bytes(line) + b"\n")
            return
        self._filled += nbytes
        if self._filled == len(self._target):
            self._target = None
            assert self._waiter is not None
            self._waiter.set_result(None)

    async def receive_into(self, buffer: memoryview) -> None:
        """Fill *buffer* (a writable byte view) with the next bytes of the stream.

        Raises:
            ConnectionError: when the connection ends first.
        """
        if self._lost is not None:
            raise self._lost
        already = min(len(self._extra), len(buffer))
        buffer[:already] = self._extra[:already]
        del self._extra[:already]
        if already == len(buffer):
            return
        self._target, self._filled = buffer, already
        self._waiter = asyncio.get_running_loop().create_future()
        try:
            await self._waiter
        finally:
            self._target, self._waiter = None, None

    async def receive_line(self) -> bytes:
        """The rest of the current line, newline included."""
        if b"\n" in self._extra:
            line, _, rest = self._extra.partition(b"\n")
            self._extra = bytearray(rest)
            return bytes(line) + b"\n"
        if self._lost is not None:
            raise self._lost
        self._line_waiter = asyncio.get_running_loop().create_future()
        try:
            return await self._line_waiter
        finally:
            self._line_waiter = None
