"""The gateway's HTTP connections: each reads its requests' heads first, answers plain reads, hands the rest on.

aiohttp serves the routes; this layer sits between the socket and aiohttp's
connection handler, as the asyncio protocol of every connection, and uses
aiohttp only through its public faces (a ``web.Server`` makes the handler, an
asyncio protocol like this one; the server's ``request_handler`` is wrapped).
For every request it

* reads the head and checks it (``_request_head``): what is malformed, too
  long or of another HTTP version is refused here, in the documented JSON
  (``::genomix::http``), logged in one line at DEBUG; the connection then
  closes once the client has read the refusal (a client still sending a
  20 MB URL gets the answer, not a reset), or after :data:`LINGER` seconds;
* answers a plain port read itself (``_fast_reads``) when aiohttp has nothing
  of this connection in hand and the socket has nothing left to send: its
  reply then cannot overtake another, and a client that does not read holds
  one reply at most;
* passes everything else to aiohttp, request by request (a body by its
  ``Content-Length``), and counts what aiohttp has in hand: the handler
  wrapped around the guard finishes each reply and says so
  (:func:`answering`), so that the next plain read is answered here again.

It also times what aiohttp would wait for forever: a request head not
complete :attr:`ConnectionLimits.header_timeout` seconds after the connection
opened or after its first byte gets 408; a connection idle for
:attr:`ConnectionLimits.keep_alive` seconds is closed (aiohttp's own idle timer
is set beyond reach, since it cannot see the reads answered here).
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
from http import HTTPStatus
from collections.abc import Awaitable, Callable

from aiohttp import web
from aiohttp.helpers import rfc822_formatted_time

from ._fast_reads import FastReads
from ._gather import direct_socket, unsent, write_gathered
from ._guard import Handler
from ._replies import SERVER_HEADER, dumps
from ._request_head import HeadRefusal, RequestHead, check_partial, head_end, parse_head

__all__ = ["ConnectionLimits", "Connections", "GatewayConnection", "answering", "LINGER"]

log = logging.getLogger(__name__)

#: Seconds a refused client may still send (the rest of a huge URL) while it reads the refusal.
LINGER = 5.0
_REFUSAL_HEADERS = "".join(f"{name}: {value}\r\n" for name, value in
                           {"Content-Type": "application/json", **SERVER_HEADER}.items())


@dataclasses.dataclass(frozen=True)
class ConnectionLimits:
    """What a connection allows a client.

    Attributes:
        max_url_bytes: The longest request line, in bytes (414 beyond).
        header_timeout: Seconds to send a request head, from the connection's start or the
            head's first byte (408 after; 0: no limit).
        keep_alive: Seconds an idle kept-alive connection stays open.
    """

    max_url_bytes: int = 65536
    header_timeout: float = 10.0
    keep_alive: float = 75.0


class Connections:
    """The open connections, by the aiohttp handler each hands requests to (what a request knows)."""

    def __init__(self) -> None:
        self._by_handler: dict[asyncio.BaseProtocol, GatewayConnection] = {}

    def add(self, handler: asyncio.BaseProtocol, connection: GatewayConnection) -> None:
        """Record *connection*, whose requests aiohttp handles with *handler*."""
        self._by_handler[handler] = connection

    def discard(self, handler: asyncio.BaseProtocol) -> None:
        """Forget the connection of *handler* (closed)."""
        self._by_handler.pop(handler, None)

    def of(self, request: web.BaseRequest) -> GatewayConnection | None:
        """The connection *request* came on (None when it has closed meanwhile)."""
        return self._by_handler.get(request.protocol)


def answering(handler: Handler, connections: Connections) -> Callable[[web.BaseRequest],
                                                                       Awaitable[web.StreamResponse]]:
    """Wrap the server's *handler* so that each reply is finished, then its connection told.

    A handler's reply is usually written by aiohttp after the handler returns;
    finishing it here (``prepare``, ``write_eof``: both do nothing the second
    time) puts every byte of it in the transport before the connection may
    answer the next read itself.
    """
    of = connections.of

    async def answer(request: web.BaseRequest) -> web.StreamResponse:
        assert isinstance(request, web.Request)  # what an application's runner makes
        connection = of(request)
        try:
            try:
                response = await handler(request)
            except web.HTTPException as exc:  # a redirect the guard lets through: written here as well
                response = web.Response(status=exc.status, reason=exc.reason, text=exc.text, headers=exc.headers)
            try:
                if not response.prepared:
                    await response.prepare(request)
                await response.write_eof()
            except ConnectionError:
                pass  # the client left: aiohttp sees the same when it finishes the reply, and says nothing
            return response
        finally:
            if connection is not None:
                connection.answered()

    return answer


class GatewayConnection(asyncio.Protocol):
    """One HTTP connection (see the module's description).

    Args:
        make_handler: Makes the aiohttp handler of the connection (the ``web.Server``).
        connections: Where the connection is recorded while it is open.
        fast_reads: Answers plain port reads (None: every request goes to aiohttp).
        limits: The connection's limits.
    """

    def __init__(self, make_handler: Callable[[], asyncio.Protocol], connections: Connections,
                 fast_reads: FastReads | None, limits: ConnectionLimits) -> None:
        self._inner = make_handler()
        self._connections = connections
        self._fast_reads = fast_reads
        self._limits = limits
        self._loop = asyncio.get_running_loop()
        self._transport: asyncio.Transport | None = None
        self._buffer = b""  # the start of a request not complete yet
        self._body_left = 0  # bytes of a body passed on still to come
        self._in_hand = 0  # requests passed to aiohttp and not answered yet
        self._closing = False  # refused: what the client still sends is read and dropped
        self._refusal: HeadRefusal | None = None  # written once aiohttp has answered what it holds
        self._head_timer: asyncio.TimerHandle | None = None
        self._idle_timer: asyncio.TimerHandle | None = None
        self._last_reply = 0.0  # when the last reply was finished (the loop's clock)

    # -- the connection ---------------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:  # noqa: D102
        assert isinstance(transport, asyncio.Transport)
        self._transport = transport
        self._connections.add(self._inner, self)
        self._inner.connection_made(transport)
        self._arm_head_timer()

    def connection_lost(self, exc: Exception | None) -> None:  # noqa: D102
        self._cancel_timers()
        self._connections.discard(self._inner)
        self._transport = None
        self._inner.connection_lost(exc)

    def eof_received(self) -> bool | None:  # noqa: D102
        if self._closing:
            # The refused client read its answer and closed its side.
            if self._transport is not None:
                self._transport.close()
            return None
        return self._inner.eof_received()

    def pause_writing(self) -> None:  # noqa: D102
        self._inner.pause_writing()

    def resume_writing(self) -> None:  # noqa: D102
        self._inner.resume_writing()

    # -- requests ---------------------------------------------------------------------------

    def data_received(self, data: bytes) -> None:  # noqa: D102
        if self._closing:
            return
        passed: list[bytes] = []
        if self._body_left:
            piece = data[:self._body_left]
            passed.append(piece)
            self._body_left -= len(piece)
            data = data[len(piece):]
        buffer = self._buffer + data if self._buffer else data
        start = 0
        try:
            while not self._body_left:
                # Empty lines before a request are ignored (RFC 9112, 2.2): after a body, say.
                while buffer.startswith(b"\r\n", start):
                    start += 2
                if start == len(buffer):
                    break
                end = head_end(buffer, start)
                if end < 0:
                    check_partial(buffer, start, self._limits.max_url_bytes)
                    break
                head = parse_head(buffer, start, end)
                start = end
                if (not passed and not self._in_hand and self._fast_reads is not None
                        and self._fast_reads.may_answer(head) and self._answer_fast(head)):
                    continue
                passed.append(head.raw)
                self._in_hand += 1
                if head.body_length:
                    body = buffer[start:start + head.body_length]
                    passed.append(body)
                    start += len(body)
                    self._body_left = head.body_length - len(body)
        except HeadRefusal as refusal:
            self._refuse(refusal)
        self._buffer = b"" if self._closing else buffer[start:]
        if passed:
            self._inner.data_received(passed[0] if len(passed) == 1 else b"".join(passed))
        if not self._closing and (self._buffer or self._body_left or self._head_timer is not None):
            self._time_what_is_awaited()

    def answered(self) -> None:
        """Called once aiohttp has written the whole reply to one of the requests it was given."""
        self._in_hand -= 1
        if self._in_hand:
            return
        if self._refusal is not None:
            self._write_refusal(self._refusal)
        elif not self._closing:
            self._replied()
            if self._buffer or self._head_timer is not None:
                self._time_what_is_awaited()

    def _answer_fast(self, head: RequestHead) -> bool:
        """Answer *head*, a plain read (``FastReads.may_answer``), here if the socket has nothing else to send."""
        fast_reads, transport = self._fast_reads, self._transport
        assert fast_reads is not None
        fd = direct_socket(transport)
        if fd is None or transport is None:
            return False
        reply = fast_reads.reply(head)
        if reply is None:
            return False
        written = write_gathered(fd, reply)
        for piece in unsent(reply, written):
            transport.write(piece)
        self._replied()
        return True

    # -- refusals ---------------------------------------------------------------------------

    def _refuse(self, refusal: HeadRefusal) -> None:
        """Answer *refusal* after what aiohttp holds, then close; what the client still sends is dropped."""
        self._closing = True
        self._cancel_timers()
        log.debug("refused a request from %s: %d %s", self._peer(), refusal.status, refusal.message)
        if self._in_hand:
            self._refusal = refusal
        else:
            self._write_refusal(refusal)

    def _write_refusal(self, refusal: HeadRefusal) -> None:
        self._refusal = None
        transport = self._transport
        if transport is None or transport.is_closing():
            return
        body = dumps({"ex": "::genomix::http", "message": refusal.message})
        head = (f"HTTP/1.1 {refusal.status} {HTTPStatus(refusal.status).phrase}\r\n{_REFUSAL_HEADERS}"
                f"Content-Length: {len(body)}\r\nDate: {rfc822_formatted_time()}\r\nConnection: close\r\n\r\n")
        transport.write(head.encode() + body)
        # Closing while the client still sends would make the kernel reset the connection, and
        # the client would never read the answer: half-close, and close when it closes its side.
        if transport.can_write_eof():
            transport.write_eof()
        self._head_timer = self._loop.call_later(LINGER, transport.close)

    def _peer(self) -> str:
        peer = self._transport.get_extra_info("peername") if self._transport is not None else None
        return str(peer[0]) if isinstance(peer, tuple) else "?"

    # -- timers -----------------------------------------------------------------------------

    def _time_what_is_awaited(self) -> None:
        """Time the request being received, if any (the idle timer looks at the connection when it fires)."""
        if self._buffer or self._body_left:
            self._arm_head_timer()
        elif self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None

    def _arm_head_timer(self) -> None:
        if self._head_timer is None and self._limits.header_timeout > 0:
            self._head_timer = self._loop.call_later(self._limits.header_timeout, self._head_timed_out)

    def _head_timed_out(self) -> None:
        self._head_timer = None
        transport = self._transport
        if transport is None or self._closing:
            return
        if self._body_left:
            # aiohttp's handler waits for a body that does not come: nothing can be answered in order.
            transport.close()
        elif self._in_hand:
            # A request is being answered: the head after it is timed once that one is.
            self._arm_head_timer()
        else:
            self._refuse(HeadRefusal(408, f"the request head took more than {self._limits.header_timeout:g} s"))

    def _replied(self) -> None:
        """A reply is finished: the connection is idle from now until its next request.

        One timer per connection, moved on lazily: a timer made and cancelled at every
        request of 50 busy connections costs asyncio more than the rest of this layer.
        """
        self._last_reply = self._loop.time()
        if self._idle_timer is None:
            self._idle_timer = self._loop.call_at(self._last_reply + self._limits.keep_alive, self._idle_timed_out)

    def _idle_timed_out(self) -> None:
        self._idle_timer = None
        transport = self._transport
        if transport is None or self._in_hand or self._buffer or self._body_left:
            return  # busy: timed again after its next reply
        left = self._last_reply + self._limits.keep_alive - self._loop.time()
        if left > 0:
            self._idle_timer = self._loop.call_later(left, self._idle_timed_out)
        else:
            transport.close()

    def _cancel_timers(self) -> None:
        for timer in (self._head_timer, self._idle_timer):
            if timer is not None:
                timer.cancel()
        self._head_timer = self._idle_timer = None
