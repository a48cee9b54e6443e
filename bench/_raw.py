"""Raw loopback readers for the port-read benchmark: no client library, the same receive path for every server.

:class:`RawReader` sends a request and receives the reply straight into a new
buffer, as a client that keeps the data must; it knows the reply is complete
from a 4-byte length prefix (the plain-socket floor), from the HTTP head's
``Content-Length`` (the gateway), or from the count at the head of a
dedicated-socket reply (``sized``).  Both floors and HTTP paths therefore pay
the same client-side costs, and what differs is only what the server does.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

import numpy as np

__all__ = ["RawReader"]


class RawReader(asyncio.BufferedProtocol):
    """One keep-alive connection; :meth:`exchange` returns the reply's bytes (head included for HTTP).

    Args:
        http: Replies are HTTP/1.1 with a Content-Length (else: a u32 length prefix).
        sized: Else, the reply's whole size from its first 16 bytes (a dedicated socket's header).
    """

    def __init__(self, http: bool, sized: Callable[[bytes], int] | None = None) -> None:
        self.http = http
        self.sized = sized
        self.buffer = np.empty(1 << 16, np.uint8)
        self.received = 0
        self.total: int | None = None
        self.done: asyncio.Future[memoryview] | None = None
        self.transport: asyncio.Transport | None = None
        self.expected = 1 << 16

    @classmethod
    async def connect(cls, port: int, *, http: bool, sized: Callable[[bytes], int] | None = None,
                      host: str = "127.0.0.1") -> RawReader:
        """Connect to *host*:*port*."""
        loop = asyncio.get_running_loop()
        _, protocol = await loop.create_connection(lambda: cls(http, sized), host, port)
        return protocol

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]

    def get_buffer(self, sizehint: int) -> memoryview:
        if self.received == len(self.buffer):  # longer than expected: grow (a copy, rare)
            self.buffer = np.concatenate([self.buffer, np.empty(len(self.buffer), np.uint8)])
        return memoryview(self.buffer)[self.received:]

    def buffer_updated(self, nbytes: int) -> None:
        self.received += nbytes
        if self.total is None:
            self._find_length()
        if self.total is not None and self.received >= self.total and self.done is not None:
            self.done.set_result(memoryview(self.buffer)[:self.total])

    def _find_length(self) -> None:
        if self.sized is not None:
            if self.received >= 16:
                self.total = self.sized(self.buffer[:16].tobytes())
            return
        if not self.http:
            if self.received >= 4:
                self.total = 4 + int.from_bytes(self.buffer[:4].tobytes(), "little")
            return
        head = self.buffer[:min(self.received, 4096)].tobytes()
        end = head.find(b"\r\n\r\n")
        if end < 0:
            return
        for line in head[:end].split(b"\r\n"):
            name, _, value = line.partition(b":")
            if name.strip().lower() == b"content-length":
                self.total = end + 4 + int(value)
                return
        raise RuntimeError(f"no Content-Length in {head[:end]!r}")

    def connection_lost(self, exc: Exception | None) -> None:
        if self.done is not None and not self.done.done():
            self.done.set_exception(ConnectionError(f"closed after {self.received} bytes"))

    async def exchange(self, request: bytes) -> memoryview:
        """Send *request*; return the whole reply, received into a new buffer."""
        # A fresh buffer per read, sized from the previous reply: the caller keeps the data.
        self.buffer = np.empty(self.expected + 4096, np.uint8)
        self.received, self.total = 0, None
        self.done = asyncio.get_running_loop().create_future()
        assert self.transport is not None
        self.transport.write(request)
        async with asyncio.timeout(30):  # a reply that never completes is a bug: say so
            reply = await self.done
        self.expected = len(reply)
        return reply

    def close(self) -> None:
        """Close the connection."""
        if self.transport is not None:
            self.transport.close()
