"""A TCP server for the dedicated sockets: text request lines in, binary replies out, many clients at once.

Both generations of the Two!Ears dedicated socket (2014 ``Read Port - Index
<k>``, 2015 ``Read Port - N <n> - nfr <i>``) are conversations of the same
shape, so one server carries both; what differs is a :class:`Conversation`
that turns the bytes a client sends into replies.

Each connection is an asyncio task that answers its requests in order; a slow
client only waits for its own socket (``drain``), never delays another or the
capture.  Every reply is a buffer of its own that nothing writes afterwards:
since Python 3.12 a transport may keep the buffer it was handed until the
client drains it, so handing it a view of the live audio window would send
whatever the next chunk wrote there.

With a token (the gateway's ``--token``), a client's first line must be
``Token <token>``; anything else gets one ``ERROR ...`` line and the connection
is closed, so a client without credentials never reads audio.

What clients make the server hold is bounded (:class:`~aiogenomix.components.core.Budgets`):
at most ``socket_clients`` clients (one more gets an ``ERROR`` line naming the bound); a reply
is cut to ``socket_client_bytes`` by the protocol's own means (each server's ``reply_to``); and
the replies every client of the host leaves unsent are held against the host's ``socket_bytes``
ledger, which drops the clients that have waited longest without reading when a new one does not fit.
A reply is handed to the transport piece by piece as the client drains it, so a client that
never reads holds its reply (shared with the other readers of the same publication) and one
piece, not a copy of the whole reply in its transport.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import logging
import os
import socket
import time
from collections.abc import Callable, Hashable
from typing import Protocol

from ..core import Budgets, HostSettings, Ledger, OverBudget, ThrottledLog
from ._errors import RequestError

__all__ = ["Conversation", "LineServer", "LastReply", "CLOSE", "TOKEN_PREFIX", "ERROR_PREFIX", "MAX_REQUEST_LINE",
           "encode_error", "split_lines"]

log = logging.getLogger(__name__)
#: What clients set off (refused, dropped, a fault while answering one): rate-limited.
_client_log = ThrottledLog(log)

#: A reply goes to the transport in pieces of this size, each once the client drained the one before.
PIECE = 256 * 2**10

#: The original servers read requests into a 512-byte buffer; longer lines are refused.
MAX_REQUEST_LINE = 512
ERROR_PREFIX = b"ERROR "
#: The first line a client sends to a server that has a token: ``Token <token>``.
TOKEN_PREFIX = b"Token "
#: A reply that ends the conversation (the client said ``Close``).
CLOSE = None


class Conversation(Protocol):
    """One client's side of a dedicated-socket protocol, sans I/O: a reply to each request line."""

    def answer(self, line: bytes) -> bytes | bytearray | None:
        """The reply to one request line (without its line ending), or ``None`` (:data:`CLOSE`) to hang up.

        The reply must be a buffer that nothing changes afterwards: the transport
        may hold it until the client has drained it.

        Raises:
            RequestError: for a request that cannot be served (the stream cannot be
                trusted after it, so the connection is closed).
        """


def split_lines(pending: bytearray, data: bytes) -> list[bytes]:
    """Add *data* to *pending* and take out the complete lines (without LF or CRLF).

    Raises:
        RequestError: for a line longer than :data:`MAX_REQUEST_LINE` bytes.
    """
    pending += data
    lines = []
    while (end := pending.find(b"\n")) >= 0:
        line = bytes(pending[:end]).rstrip(b"\r")
        del pending[:end + 1]
        if len(line) > MAX_REQUEST_LINE:
            raise RequestError(f"request line longer than {MAX_REQUEST_LINE} bytes")
        lines.append(line)
    if len(pending) > MAX_REQUEST_LINE:
        raise RequestError(f"request line longer than {MAX_REQUEST_LINE} bytes")
    return lines


def encode_error(message: str) -> bytes:
    """The one-line reply to a request that cannot be served (readable with ``nc``)."""
    return ERROR_PREFIX + message.replace("\n", " ").encode("utf-8", "replace") + b"\n"


class LastReply:
    """The last reply a server made, shared while the publication and the request's placement are the same.

    Readers of one publication asking for the same chunks (several clients, or one
    polling faster than the chunks come) get one buffer, which nothing writes
    after it is made.
    """

    def __init__(self) -> None:
        self._last: tuple[object, Hashable, bytearray] | None = None

    def get(self, publication: object, placement: Hashable, make: Callable[[], bytearray]) -> bytearray:
        """The reply for *placement* in *publication* (compared by identity), made by ``make()`` when new."""
        last = self._last
        if last is not None and last[0] is publication and last[1] == placement:
            return last[2]
        reply = make()
        self._last = (publication, placement, reply)
        return reply


#: The host's defaults give the socket's (one default each, in HostSettings).
_RIG = HostSettings()


class LineServer:
    """Serve a line-request protocol to TCP clients, as many as the budgets allow.

    Args:
        conversation: Makes the protocol state of one new client.
        host: The address to bind (``0.0.0.0`` for every interface).
        port: The TCP port; 0 picks a free one (read :attr:`port` after :meth:`start`).
        token: When set, every client must first send ``Token <token>``.
        budgets: The bounds on clients and their unsent replies (``socket_clients``,
            ``socket_client_bytes``); the host's, from its settings.
        ledger: The unsent replies of every dedicated socket of the host (``host.ledgers.sockets``);
            by default one of this server's own, of ``budgets.socket_bytes``.
    """

    def __init__(self, conversation: Callable[[], Conversation], *, host: str = _RIG.audio_socket_host,
                 port: int = _RIG.audio_socket_port, token: str | None = None, budgets: Budgets = _RIG.budgets,
                 ledger: Ledger | None = None) -> None:
        self._conversation = conversation
        self.host = host
        self.requested_port = port
        self.token = token
        self.budgets = budgets
        self.ledger = ledger or Ledger("socket_bytes", budgets.socket_bytes, budgets.flag("socket_bytes"))
        self._server: asyncio.Server | None = None
        self._connections: set[asyncio.Task[None]] = set()
        #: Replies sent since the start (all clients).
        self.replies = 0
        #: Clients refused because the server had ``socket_clients`` already.
        self.refused = 0
        #: Clients dropped because their unsent replies passed the ledger's bound.
        self.dropped = 0

    @property
    def client_bytes(self) -> int:
        """The most reply bytes one client may hold unsent (``socket_client_bytes``, at most the ledger's bound).

        Replies are cut to it.
        """
        return min(self.budgets.socket_client_bytes, self.ledger.limit)

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
            OSError: when the address cannot be bound (port taken, ...), saying which
                address (:class:`SocketPorts` says what to do about it).
        """
        if self._server is None:
            try:
                self._server = await asyncio.start_server(
                    self._serve_client, self.host, self.requested_port, reuse_address=True)
            except OSError as exc:
                reason = os.strerror(exc.errno).lower() if exc.errno is not None and exc.errno > 0 else str(exc)
                raise OSError(exc.errno, f"cannot listen on {self.host}:{self.requested_port}: {reason}") from exc
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

    async def __aenter__(self) -> LineServer:
        await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    async def _serve_client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        if len(self._connections) >= self.budgets.socket_clients:
            await self._refuse(writer)
            return
        self._connections.add(task)
        sock = writer.get_extra_info("socket")
        if sock is not None:
            # Replies are single writes; never hold one back waiting for an ACK.
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conversation = self._conversation()
        pending = bytearray()
        # With a token, the first line must carry it before anything is answered.
        admitted = not self.token
        try:
            while data := await reader.read(4096):
                try:
                    for line in split_lines(pending, data):
                        if not admitted:
                            admitted = self._admits(line)
                            continue
                        reply = conversation.answer(line)
                        if reply is CLOSE:
                            return
                        await self._send(writer, reply)
                        self.replies += 1
                except RequestError as exc:
                    writer.write(encode_error(str(exc)))
                    await writer.drain()
                    return
        except ConnectionError:
            # The client went away mid-reply (or was dropped): its connection ends, the server goes on.
            pass
        except asyncio.CancelledError:
            # aclose ends the connection (the gateway stopping, CloseSocket).  Ending
            # quietly matters on Python 3.11, whose start_server logs a traceback for
            # a cancelled client task.
            pass
        except Exception as exc:  # noqa: BLE001  # a fault of ours: the client hears of it, the log once
            _client_log.error("dedicated socket on port %d: answering a client failed: %s", self.port,
                              f"{type(exc).__name__}: {exc}", exc=exc)
            with contextlib.suppress(ConnectionError):
                writer.write(encode_error("the server failed to answer this request (see the gateway's log)"))
        finally:
            self._connections.discard(task)
            reply = b""  # see _send: this frame may outlive the call
            writer.close()
            with contextlib.suppress(ConnectionError):
                await writer.wait_closed()

    async def _refuse(self, writer: asyncio.StreamWriter) -> None:
        """Tell a client past ``socket_clients`` why it is not served, and hang up."""
        self.refused += 1
        limit, flag = self.budgets.socket_clients, self.budgets.flag("socket_clients")
        _client_log.warning("dedicated socket on port %d: refused a client: it serves %d clients (%s)",
                            self.port, limit, flag)
        writer.write(encode_error(f"this socket serves at most {limit} clients at once ({flag}): "
                                  "try again when one has left"))
        writer.close()
        with contextlib.suppress(ConnectionError):
            await writer.wait_closed()

    async def _send(self, writer: asyncio.StreamWriter, reply: bytes | bytearray) -> None:
        """Hand *reply* to the client piece by piece, held against the ledger until it has all left.

        Raises:
            ConnectionError: when the client went away, or was dropped to make room for others.
        """
        size = len(reply)
        started = time.monotonic()

        def drop() -> None:
            # Evicted by the ledger: this client's reply waited longest.  Aborting frees its
            # transport's buffer now; the drain below then ends with ConnectionResetError.
            self.dropped += 1
            _client_log.warning("dedicated socket on port %d: dropped a client that left %d bytes unread for "
                                "%.1f s: the clients' unsent replies reached %s", self.port, size,
                                time.monotonic() - started, self.ledger.flag)
            writer.transport.abort()

        try:
            reservation = self.ledger.reserve(size, f"client of port {self.port}", f"a reply of {size} bytes",
                                              evict=drop)
        except OverBudget as exc:  # only a reply larger than the bound in all: the server's budgets disagree
            raise RequestError(str(exc)) from None
        view = memoryview(reply)
        try:
            for start in range(0, size, PIECE):
                if writer.transport.is_closing():
                    raise ConnectionResetError("the client was dropped or went away")
                writer.write(view[start:start + PIECE])
                try:
                    await writer.drain()
                except ConnectionError as exc:
                    # The waiter that *exc* ended keeps it, and its traceback this frame with the
                    # reply (up to the whole port): a cycle only a full collection frees.
                    exc.__traceback__ = None
                    raise ConnectionResetError(f"the client went away: {exc}") from None
                # Drained: this client reads.  The ledger drops those that have waited longest since
                # they last read, never a reader of a large reply for the age of its request.
                reservation.progressed()
        finally:
            reservation.release()
            # This frame may outlive the call, held by a traceback in a cycle with its task (a
            # client that went away): it must not hold the reply (up to the whole port) then.
            view = memoryview(b"")
            reply = b""

    def _admits(self, line: bytes) -> bool:
        """Check the first line of a client of a server with a token.

        Raises:
            RequestError: unless it is ``Token <token>``.
        """
        assert self.token is not None
        if not hmac.compare_digest(line, TOKEN_PREFIX + self.token.encode("utf-8")):
            raise RequestError("this socket needs 'Token <token>' (the gateway's --token) as its first line")
        return True
