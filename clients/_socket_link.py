"""The connection under both dedicated-socket clients: connect with the token line, exact receives, error lines.

Both generations of the socket (2014 chunk-indexed, 2015 frame-indexed) are
text requests answered by binary replies of known length, or by one ``ERROR
...`` line; what differs is the request and the reply layout, which the
clients in ``audio_socket`` and ``frame_socket`` add on top of these links.
"""

from __future__ import annotations

import asyncio
import socket
from typing import Self

from ._errors import TransportError
from ._receiver import Receiver

__all__ = ["AudioSocketError", "BlockingLink", "AsyncLink", "DEFAULT_PORT", "ERROR_MARK"]

DEFAULT_PORT = 8081
#: The first bytes of a refusal (``ERROR <why>``), where a binary reply would start.
ERROR_MARK = b"ERRO"


class AudioSocketError(TransportError):
    """The audio socket refused a request, closed the connection, or sent something unreadable."""


def refusal(first: bytes, rest: bytes) -> AudioSocketError:
    """The error for a reply that starts with :data:`ERROR_MARK` (*rest*: the rest of its line)."""
    text = (first + rest).decode("utf-8", "replace").strip()
    return AudioSocketError(f"the audio socket refused the request: {text}")


class _Link:
    """Where the socket is, how long to wait for it, and the token to present."""

    #: A line sent before closing (the 2015 protocol's ``Close``), or nothing.
    goodbye = b""

    def __init__(self, host: str, port: int, token: str | None, timeout: float) -> None:
        self.host, self.port, self.token, self.timeout = host, port, token, timeout

    def _greeting(self) -> bytes:
        """The first line, on a gateway with a token: ``Token <token>``."""
        return f"Token {self.token}\n".encode() if self.token else b""

    def _unreachable(self, exc: BaseException) -> AudioSocketError:
        return AudioSocketError(f"cannot reach the audio socket at {self.host}:{self.port}: {exc}")


class BlockingLink(_Link):
    """A blocking connection (scripts, notebooks)."""

    _sock: socket.socket | None = None

    def connect(self) -> None:
        """Open the connection (done by the first read if needed).

        Raises:
            AudioSocketError: when the server cannot be reached.
        """
        if self._sock is None:
            try:
                sock = socket.create_connection((self.host, self.port), timeout=self.timeout)
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                sock.sendall(self._greeting())
            except OSError as exc:
                raise self._unreachable(exc) from exc
            self._sock = sock

    def close(self) -> None:
        """Close the connection, saying goodbye where the protocol has a word for it (idempotent)."""
        sock, self._sock = self._sock, None
        if sock is not None:
            try:
                sock.sendall(self.goodbye)
            except OSError:
                pass  # already gone: closing is all that is left
            sock.close()

    def _drop(self) -> None:
        """Close without a word (after a failure, the stream cannot be trusted)."""
        sock, self._sock = self._sock, None
        if sock is not None:
            sock.close()

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _send(self, data: bytes) -> None:
        assert self._sock is not None
        self._sock.sendall(data)

    def _receive_into(self, view: memoryview) -> None:
        assert self._sock is not None
        got = 0
        while got < len(view):
            n = self._sock.recv_into(view[got:])
            if n == 0:
                raise AudioSocketError("the audio socket closed the connection")
            got += n

    def _refused(self, first: bytes) -> AudioSocketError:
        """The error for a reply starting with :data:`ERROR_MARK`; reads the rest of its line."""
        assert self._sock is not None
        return refusal(first, self._sock.makefile("rb").readline())


class AsyncLink(_Link):
    """An asyncio connection that receives replies straight into the caller's buffers."""

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
                    _, receiver = await loop.create_connection(Receiver, self.host, self.port)
            except (OSError, TimeoutError) as exc:
                raise self._unreachable(exc) from exc
            assert receiver.transport is not None
            receiver.transport.write(self._greeting())
            self._receiver = receiver

    async def aclose(self) -> None:
        """Close the connection, saying goodbye where the protocol has a word for it (idempotent)."""
        receiver, self._receiver = self._receiver, None
        if receiver is not None and receiver.transport is not None:
            if self.goodbye and not receiver.transport.is_closing():
                receiver.transport.write(self.goodbye)
            receiver.transport.close()

    async def __aenter__(self) -> Self:
        await self.connect()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    def _send(self, data: bytes) -> None:
        assert self._receiver is not None and self._receiver.transport is not None
        self._receiver.transport.write(data)

    async def _receive_into(self, view: memoryview) -> None:
        assert self._receiver is not None
        await self._receiver.receive_into(view)

    async def _refused(self, first: bytes) -> AudioSocketError:
        assert self._receiver is not None
        return refusal(first, await self._receiver.receive_line())
