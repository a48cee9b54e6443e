"""The dedicated-socket TCP server: serves the chunk window to any number of clients.

Each connection is an asyncio task that answers its requests in order; a slow
client only waits for its own socket (``drain``), never delays another.  A
malformed request gets one ``ERROR ...`` line and its connection is closed;
nothing a client sends can stop the server.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
from collections.abc import Callable

import numpy as np

from ._errors import RequestError
from ._socket_wire import RequestParser, encode_error, reply_parts
from ._window import ChunkWindow, WindowRead

__all__ = ["DedicatedSocketServer", "DEFAULT_PORT"]

log = logging.getLogger(__name__)

DEFAULT_PORT = 8081
_NO_CHUNKS = WindowRead(left=np.zeros((0, 0), np.int32), right=np.zeros((0, 0), np.int32),
                        positions=np.zeros(0), first_index=1, last_index=0, lost=0)


class DedicatedSocketServer:
    """Answer ``Read Port - Index <k>`` requests from the current chunk window.

    Args:
        window: Returns the window to serve (None while no capture has started:
            clients then get zero chunks and index 0).
        host: The address to bind (``0.0.0.0`` for every interface).
        port: The TCP port; 0 picks a free one (read :attr:`port` after :meth:`start`).
        with_positions: Append the head positions (the merged component's format).
    """

    def __init__(self, window: Callable[[], ChunkWindow | None], *, host: str = "127.0.0.1",
                 port: int = DEFAULT_PORT, with_positions: bool = False) -> None:
        self._window = window
        self.host = host
        self.requested_port = port
        self.with_positions = with_positions
        self._server: asyncio.Server | None = None
        self._connections: set[asyncio.Task[None]] = set()
        #: Replies sent since the start (all clients).
        self.replies = 0

    @property
    def port(self) -> int:
        """The port actually listened on (0 before :meth:`start`)."""
        if self._server is None or not self._server.sockets:
            return 0
        return int(self._server.sockets[0].getsockname()[1])

    @property
    def clients(self) -> int:
        """How many clients are connected."""
        return len(self._connections)

    @property
    def serving(self) -> bool:
        """Whether the server listens."""
        return self._server is not None

    async def start(self) -> int:
        """Start listening and return the actual port.

        Raises:
            OSError: when the address cannot be bound (port taken, ...).
        """
        if self._server is None:
            self._server = await asyncio.start_server(
                self._serve_client, self.host, self.requested_port, reuse_address=True)
            log.info("dedicated audio socket listening on %s:%d", self.host, self.port)
        return self.port

    async def aclose(self) -> None:
        """Stop listening and close every client connection (idempotent)."""
        server, self._server = self._server, None
        if server is not None:
            server.close()
        connections = list(self._connections)
        for task in connections:
            task.cancel()
        await asyncio.gather(*connections, return_exceptions=True)
        if server is not None:
            await server.wait_closed()

    async def __aenter__(self) -> DedicatedSocketServer:
        await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    def reply_to(self, index: int) -> list[bytes | memoryview]:
        """The reply to a request for the chunks after *index*, as buffers to write at once."""
        window = self._window()
        # Views are enough: every part is handed to the transport before the window can change.
        chunks = window.since(index, copy=False) if window is not None else _NO_CHUNKS
        return reply_parts(chunks, with_positions=self.with_positions)

    async def _serve_client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        self._connections.add(task)
        sock = writer.get_extra_info("socket")
        if sock is not None:
            # Replies are single writes; never hold one back waiting for an ACK.
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        parser = RequestParser()
        try:
            while data := await reader.read(4096):
                try:
                    indices = parser.feed(data)
                except RequestError as exc:
                    writer.write(encode_error(str(exc)))
                    await writer.drain()
                    break
                for index in indices:
                    for part in self.reply_to(index):
                        writer.write(part)  # the kernel (or the transport's buffer) takes it now
                    self.replies += 1
                    await writer.drain()
        except ConnectionError:
            # The client went away mid-reply: its connection ends, the server goes on.
            pass
        finally:
            self._connections.discard(task)
            writer.close()
            with contextlib.suppress(ConnectionError):
                await writer.wait_closed()
