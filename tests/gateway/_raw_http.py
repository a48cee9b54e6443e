"""Raw HTTP/1.1 over a socket, as the gateway's intake tests speak it: no client library in between.

The tests of the fast paths, the door and the protocol's refusals write their
requests' bytes themselves (pipelined, malformed, with duplicate fields...)
and read the replies' bytes back.  What they share is here: where a gateway's
URL points, a kept-alive :class:`Connection`, one request on a connection of its
own read to the end (:func:`exchange_once`), and a spy on the fast paths'
choices (:func:`answered_ahead`).
"""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

__all__ = ["Connection", "address", "answered_ahead", "exchange_once", "open_raw"]

#: The most a reply's head and body may hold in the reader's buffer (a 4000 ms window's JSON is ~2 MB).
READ_LIMIT = 1 << 24
#: How long a test waits for a reply before failing (the gateway answers in milliseconds).
REPLY_TIMEOUT = 10.0


def address(url: str) -> tuple[str, int]:
    """The host and port of a gateway's URL (``http://127.0.0.1:8080``) or address (``127.0.0.1:8080``)."""
    host, port = url.removeprefix("http://").rsplit(":", 1)
    return host, int(port)


async def open_raw(url: str, limit: int = READ_LIMIT) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    """A new TCP connection to the gateway at *url* (or address)."""
    host, port = address(url)
    return await asyncio.open_connection(host, port, limit=limit)


class Connection:
    """One kept-alive raw HTTP connection: requests written as bytes, replies read by their ``Content-Length``.

    Attributes:
        reader: The connection's stream, for a test that reads replies its own way.
        writer: The connection's stream, for a test that writes bytes its own way.
        host: The ``host:port`` the gateway serves at, what a request's ``Host`` says.
    """

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, host: str) -> None:
        self.reader, self.writer, self.host = reader, writer, host

    @classmethod
    async def open(cls, url: str) -> Connection:
        """Connect to the gateway at *url*."""
        reader, writer = await open_raw(url)
        host, port = address(url)
        return cls(reader, writer, f"{host}:{port}")

    def request(self, path: str, *headers: str, version: str = "1.1") -> bytes:
        """The bytes of ``GET path`` with ``Host`` naming the gateway, then *headers* (``Name: value``)."""
        lines = [f"GET {path} HTTP/{version}", f"Host: {self.host}", *headers]
        return ("\r\n".join(lines) + "\r\n\r\n").encode()

    async def reply(self) -> tuple[int, dict[str, str], bytes]:
        """The next reply: its status, its fields (in order) and its body."""
        head = await asyncio.wait_for(self.reader.readuntil(b"\r\n\r\n"), REPLY_TIMEOUT)
        status_line, *lines = head.decode("latin-1").rstrip("\r\n").split("\r\n")
        fields = dict(line.split(": ", 1) for line in lines)
        body = await self.reader.readexactly(int(fields["Content-Length"]))
        return int(status_line.split()[1]), fields, body

    async def get(self, path: str, *headers: str, version: str = "1.1") -> tuple[int, dict[str, str], bytes]:
        """``GET path`` with *headers*; its reply, as :meth:`reply` gives it."""
        self.writer.write(self.request(path, *headers, version=version))
        return await self.reply()

    async def exchange(self, request: bytes) -> tuple[list[str], bytes]:
        """Write *request*; the head lines of its reply (in order, without its ``Date``) and its body."""
        self.writer.write(request)
        head = await asyncio.wait_for(self.reader.readuntil(b"\r\n\r\n"), REPLY_TIMEOUT)
        lines = [line for line in head.decode("latin-1").split("\r\n") if not line.startswith("Date: ")]
        length = next(int(line.split(": ")[1]) for line in lines if line.lower().startswith("content-length: "))
        return lines, await self.reader.readexactly(length)

    async def close(self) -> None:
        """Close the connection and wait until it is closed."""
        self.writer.close()
        await self.writer.wait_closed()


async def exchange_once(url: str, raw: bytes) -> tuple[int, bytes, bytes]:
    """Write *raw* on a connection of its own and read until the gateway closes it (or *raw* asked it to).

    Returns:
        The first reply's status, its head (up to the blank line) and everything after that head.
    """
    reader, writer = await open_raw(url)
    try:
        writer.write(raw)
        await writer.drain()
        reply = await asyncio.wait_for(reader.read(), REPLY_TIMEOUT)
    finally:
        writer.close()
    head, _, body = reply.partition(b"\r\n\r\n")
    return int(head.split(b" ", 2)[1]), head, body


def answered_ahead(monkeypatch: pytest.MonkeyPatch, owner: type[Any], method: str) -> list[bool]:
    """Spy on a fast path's choice: for each call of ``owner.method``, whether it answered (True) or passed (None).

    The fast paths (plain reads, plain sends, ``/`` and ``/version``, replies written
    whole) each have one method that returns what it answers with, or None to leave the
    request to the next way; the spy keeps what it returned, and changes nothing of it.
    """
    answered: list[bool] = []
    original = getattr(owner, method)

    def spied(self: Any, *args: Any, **kwargs: Any) -> Any:
        result = original(self, *args, **kwargs)
        answered.append(result is not None)
        return result

    monkeypatch.setattr(owner, method, spied)
    return answered
