"""A TCP relay between a client and a gateway whose connections a test can cut, as a network failure would."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator


class CuttableLink:
    """Relays TCP connections to *target* (``host``, ``port``); :meth:`cut` drops every open one at once.

    Attributes:
        url: The gateway's URL through the relay.
        connections: How many connections it has relayed so far.
    """

    def __init__(self, target: tuple[str, int]) -> None:
        self._target = target
        self._open: set[asyncio.StreamWriter] = set()
        self._server: asyncio.Server | None = None
        self._pipes: set[asyncio.Task[None]] = set()
        self.url = ""
        self.connections = 0
        self._arrived = asyncio.Event()

    async def start(self) -> None:
        """Listen on a free loopback port."""
        self._server = await asyncio.start_server(self._relay, "127.0.0.1", 0)
        port = self._server.sockets[0].getsockname()[1]
        self.url = f"http://127.0.0.1:{port}"

    async def close(self) -> None:
        """Cut everything and stop listening."""
        self.cut()
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()
        for pipe in list(self._pipes):
            pipe.cancel()
        await asyncio.gather(*self._pipes, return_exceptions=True)

    def cut(self) -> int:
        """Drop every open connection (both sides see it reset); return how many were cut."""
        cut = len(self._open) // 2
        for writer in list(self._open):
            writer.transport.abort()
        self._open.clear()
        return cut

    async def connected(self, count: int) -> None:
        """Wait until the relay has relayed *count* connections in all."""
        while self.connections < count:
            self._arrived.clear()
            await self._arrived.wait()

    async def _relay(self, client_reader: asyncio.StreamReader, client_writer: asyncio.StreamWriter) -> None:
        try:
            gateway_reader, gateway_writer = await asyncio.open_connection(*self._target)
        except OSError:
            client_writer.transport.abort()
            return
        self._open |= {client_writer, gateway_writer}
        self.connections += 1
        self._arrived.set()
        pipes = [asyncio.create_task(self._pipe(client_reader, gateway_writer)),
                 asyncio.create_task(self._pipe(gateway_reader, client_writer))]
        self._pipes.update(pipes)
        await asyncio.gather(*pipes, return_exceptions=True)
        self._pipes.difference_update(pipes)
        for writer in (client_writer, gateway_writer):
            self._open.discard(writer)
            writer.transport.abort()

    @staticmethod
    async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        with contextlib.suppress(ConnectionError, OSError):
            while data := await reader.read(65536):
                writer.write(data)
                await writer.drain()
        writer.transport.abort()


@contextlib.asynccontextmanager
async def cuttable(url: str) -> AsyncIterator[CuttableLink]:
    """A :class:`CuttableLink` to the gateway at *url* (``http://host:port``)."""
    host, _, port = url.removeprefix("http://").rstrip("/").rpartition(":")
    link = CuttableLink((host, int(port)))
    await link.start()
    try:
        yield link
    finally:
        await link.close()
