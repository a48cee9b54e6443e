"""The gateway's HTTP connections: aiohttp's own, with the refusals, limits and timeouts the protocol documents.

Every request is read once, by aiohttp's parser (llhttp, in C): there is no
other reader of requests to disagree with it (docs/decisions/0037).  Each
connection is a :class:`GatewayConnection`, aiohttp's connection handler
(``web.RequestHandler``, made for the server the application's runner built)
with what the gateway's protocol adds to it, in one place:

* **Refusals of malformed requests** in the documented JSON
  (``::genomix::http``) with their status: 400 for a malformed request line or
  field, an unknown method, a field that may appear once given twice; 414 for a
  request line past ``--max-url-bytes``; 431 for a field line past
  :data:`MAX_FIELD_LINE` bytes or more than :data:`MAX_FIELDS` fields; 505 for
  an HTTP version other than 1.0 and 1.1 (HTTP/0.9 above all).  Each is logged
  in one line at DEBUG, never with a traceback: the client's mistake is not the
  gateway's fault, and a client must not be able to fill the log.  The
  connection then closes once the client has read the refusal (a client still
  sending a 20 MB URL gets the answer, not a reset), or after :data:`LINGER`
  seconds.
* **A head timeout**: a request head not complete
  :attr:`ConnectionLimits.header_timeout` seconds after the connection opened
  (or after the first byte that followed a reply) gets 408, and the connection
  ends.  aiohttp waits for a head forever.
* **The limits** (:func:`handler_arguments`): the request line, field lines and
  their number, and the idle timeout of a kept-alive connection (aiohttp's own).

aiohttp is used through its public faces: the handler class and its
``data_received``/``handle_error`` methods, the server's ``request_handler``.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
from collections.abc import Awaitable, Callable
from http import HTTPStatus
from typing import Any

from aiohttp import StreamReader, web
from aiohttp.base_protocol import BaseProtocol
from aiohttp.http_exceptions import BadStatusLine, HttpProcessingError, LineTooLong

from ..components.core import SettingsGroup, at_least, setting, whole_at_least
from ._gather import write_draining
from ._refusal_log import SERVER_LOG
from ._replies import SERVER_HEADER, dumps, http_date

__all__ = ["ConnectionLimits", "GatewayConnection", "Written", "drained_of", "handler_arguments", "LINGER",
           "MAX_FIELD_LINE", "MAX_FIELDS", "UNSUPPORTED_VERSION"]

log = logging.getLogger(__name__)

#: Seconds a refused client may still send (the rest of a huge URL) while it reads the refusal.
LINGER = 5.0
#: The longest field (header) line, in bytes (aiohttp's own default).
MAX_FIELD_LINE = 8190
#: The most fields a request may carry.
MAX_FIELDS = 100
#: The refusal of a request of another HTTP version than 1.0 and 1.1 (505).
UNSUPPORTED_VERSION = "this HTTP version is not supported (HTTP/0.9 included): send HTTP/1.1 or HTTP/1.0"
_REFUSAL_HEADERS = "".join(f"{name}: {value}\r\n" for name, value in
                           {"Content-Type": "application/json", **SERVER_HEADER}.items())


@dataclasses.dataclass(frozen=True)
class ConnectionLimits(SettingsGroup, section="limits", about="what one client can hold or send"):
    """What a connection allows a client (a settings group: ``--header-timeout``, ``--max-url-bytes``).

    Attributes:
        max_url_bytes: The longest request line, in bytes (414 beyond; at least 8192).
        header_timeout: Seconds to send a request head, from the connection's start or the
            head's first byte (408 after).
        keep_alive: Seconds an idle kept-alive HTTP connection stays open.
    """

    header_timeout: float = setting(10.0, flag="--header-timeout", unit="seconds", refuse=at_least(0.001),
                                    help="time a client has to send a request's line and headers, else 408")
    max_url_bytes: int = setting(65536, flag="--max-url-bytes", metavar="N", refuse=whole_at_least(8192),
                                 help="longest request line (URL with input=), else 414")
    keep_alive: float = 75.0


def handler_arguments(limits: ConnectionLimits) -> dict[str, Any]:
    """The arguments of aiohttp's connection handler that set the gateway's limits.

    Given to the application (``handler_args``) so that any runner serving it applies them,
    and to each :class:`GatewayConnection`.
    """
    return {"max_line_size": limits.max_url_bytes, "max_field_size": MAX_FIELD_LINE, "max_headers": MAX_FIELDS,
            "keepalive_timeout": limits.keep_alive, "logger": SERVER_LOG}


class Written(web.StreamResponse):
    """A reply whose bytes are all given (its HTTP head included), written at once when aiohttp prepares it.

    The pieces go to the socket in one gathered write when the transport has nothing
    queued (:mod:`._gather`), else to the transport.  aiohttp's writer is not used: its
    head and framing are in the pieces already.

    Args:
        pieces: The whole reply, in order.
        keep_alive: Whether the connection stays open after it (its head says so).
        size: The pieces' total length, when known (spares adding up a few hundred pieces).
    """

    def __init__(self, pieces: list[Any], keep_alive: bool = True, size: int | None = None) -> None:
        super().__init__()
        self._pieces = pieces
        self._keeps_alive = keep_alive
        self._size = size

    @property
    def keep_alive(self) -> bool:  # noqa: D102
        return self._keeps_alive

    async def prepare(self, request: web.BaseRequest) -> None:
        """Write the reply (aiohttp calls this once the handler has returned it), as the client takes it."""
        transport = request.transport
        if transport is None or transport.is_closing():
            return
        await write_draining(transport, self._pieces, drained_of(request.protocol), self._size)

    async def write_eof(self, data: bytes = b"") -> None:  # noqa: D102
        return None


class GatewayConnection(web.RequestHandler):
    """One HTTP connection (see the module's description).

    Args:
        server: The server the application's runner made (its request handler and factory).
        limits: The connection's limits.
        kwargs: The handler's other arguments (:func:`handler_arguments`, ``access_log``...).
    """

    def __init__(self, server: web.Server, limits: ConnectionLimits, **kwargs: Any) -> None:
        loop = asyncio.get_running_loop()
        super().__init__(server, loop=loop, **{**handler_arguments(limits), **kwargs})
        self._limits = limits
        self._event_loop = loop
        self._refused = False  # refused: what the client still sends is dropped
        self._head_timer: asyncio.TimerHandle | None = None
        self._linger: asyncio.TimerHandle | None = None
        self._lingering: asyncio.Transport | None = None  # refused, closed after LINGER or the client's end
        self._busy = 0  # requests in the handler
        self._unread = False  # bytes came while a request was in the handler
        self._head_since: float | None = None  # when the head being received began (the loop's clock)
        self._unread_body: StreamReader | None = None  # of the last request, being read to its end by aiohttp

    # -- the connection ---------------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:  # noqa: D102
        super().connection_made(transport)
        self._time_head()  # a connection is opened to send a request: its head is timed from now

    def connection_lost(self, exc: BaseException | None) -> None:  # noqa: D102
        for timer in (self._head_timer, self._linger):
            if timer is not None:
                timer.cancel()
        self._head_timer = self._linger = None
        self._lingering = None
        super().connection_lost(exc)
        body, self._unread_body = self._unread_body, None
        if body is not None and not body.is_eof():
            body.feed_eof()  # nothing more can come

    async def shutdown(self, timeout: float | None = 15.0) -> None:
        """Close the connection as the server stops: aiohttp's way, and a refused one still lingering at once."""
        if self._linger is not None:
            self._linger.cancel()
            self._linger = None
            if self._lingering is not None:
                self._lingering.close()
        await super().shutdown(timeout)

    def data_received(self, data: bytes) -> None:  # noqa: D102
        if self._refused:
            return  # the rest of a refused request, read and dropped while the client reads the refusal
        super().data_received(data)
        body = self._unread_body
        if body is not None:
            if not body.is_eof():
                return  # the rest of the body of a request answered already: aiohttp reads it, no head yet
            self._unread_body = None
        if self._busy:
            self._unread = True  # a head after the request being answered: timed once that one is
        elif self._head_since is None:
            self._time_head()

    async def drained(self) -> None:
        """Wait until the client has taken what the transport holds, down to its low-water mark.

        A reply written as its client reads (``_gather.write_draining``) holds its
        publication as long as it waits: the chunks the port has since let go included.
        A client that takes nothing of it for as long as an idle connection may stay open
        (:attr:`ConnectionLimits.keep_alive`) is disconnected.

        Raises:
            ConnectionResetError: The connection was lost, or is closed here.
        """
        try:
            async with asyncio.timeout(self._limits.keep_alive or None):
                await self._drain_helper()
        except TimeoutError:
            transport = self.transport
            log.debug("disconnected %s: it took nothing of its reply for %g s", _peer(transport),
                      self._limits.keep_alive)
            if transport is not None:
                transport.abort()
            raise ConnectionResetError("the client took nothing of its reply") from None

    # -- requests (told by the server's request handler: see ``_run``) ----------------------

    def request_began(self) -> None:
        """A request's head is complete and its handler runs."""
        self._busy += 1
        self._unread = False
        self._head_since = None

    def request_ended(self, request: web.BaseRequest) -> None:
        """The handler of *request* returned: bytes received meanwhile start the next head's time."""
        self._busy -= 1
        if not self._busy and self._unread:
            self._unread = False
            self._time_head()
        # aiohttp reads what is left of a body nobody read (for up to its lingering time), so
        # that the client reads the reply rather than a reset.  It does not stop when the
        # connection is lost: :meth:`connection_lost` ends that body.
        self._unread_body = None if request.content.is_eof() else request.content

    # -- refusals ---------------------------------------------------------------------------

    def handle_error(self, request: web.BaseRequest, status: int = 500, exc: BaseException | None = None,
                     message: str | None = None) -> web.StreamResponse:
        """Refuse, in the documented JSON, a request that aiohttp could not read (its own answer otherwise).

        A fault of the gateway itself (no parser's refusal) keeps aiohttp's answer and its
        logged traceback.
        """
        if not isinstance(exc, HttpProcessingError):
            return super().handle_error(request, status, exc, message)
        return self.refuse(*self._refusal(exc))

    def refuse(self, status: int, message: str) -> web.StreamResponse:
        """Refuse the request being read with *status* and *message* (see :meth:`_refuse`); the reply to return."""
        self._refuse(status, message)
        return Written([], keep_alive=False)

    def _refusal(self, exc: HttpProcessingError) -> tuple[int, str]:
        """The status and sentence of the refusal of a request that aiohttp's parser refused with *exc*."""
        said = str(exc.message).strip().split("\n", 1)[0]
        if isinstance(exc, LineTooLong):
            if exc.args[1:2] == (self.max_field_size,):
                return 431, f"a request header line is longer than {self.max_field_size} bytes"
            return 414, (f"the request line (the URL with its query, input= included) is longer than "
                         f"{self._limits.max_url_bytes} bytes, this gateway's limit")
        if said.startswith("Too many headers"):
            return 431, f"a request may carry at most {self.max_headers} header fields"
        if isinstance(exc, BadStatusLine) and ("version" in said.lower() or "Expected HTTP/" in str(exc.message)):
            return 505, UNSUPPORTED_VERSION
        return 400, f"malformed HTTP request: {said.removeprefix('Bad status line:').strip() or 'unreadable'}"

    def _refuse(self, status: int, message: str) -> None:
        """Answer *status* and close once the client has read it; what it still sends is dropped.

        aiohttp is left without the transport, so that it does not close it at once: a
        client still sending (a huge URL) would get a reset rather than the answer.
        """
        self._refused = True
        if self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None
        transport = self.transport
        log.debug("refused a request from %s: %d %s", _peer(transport), status, message)
        if transport is None or transport.is_closing():
            return
        body = dumps({"ex": "::genomix::http", "message": message})
        head = (f"HTTP/1.1 {status} {HTTPStatus(status).phrase}\r\n{_REFUSAL_HEADERS}"
                f"Content-Length: {len(body)}\r\nDate: {http_date()}\r\nConnection: close\r\n\r\n")
        transport.write(head.encode() + body)
        # Closing while the client still sends would make the kernel reset the connection, and
        # the client would never read the answer: half-close, and close when it closes its side
        # (asyncio closes a transport whose protocol's eof_received answers None) or after LINGER.
        try:
            if transport.can_write_eof():
                transport.write_eof()
        except OSError:  # the client has gone already (a reset): nobody is left to read the refusal
            transport.abort()
        self._linger = self._event_loop.call_later(LINGER, transport.close)
        self._lingering = transport
        self.transport = None
        self.force_close()

    # -- the head timer ---------------------------------------------------------------------

    def _time_head(self) -> None:
        """Time a head from now: its first byte came, or the request before it has been answered.

        One timer per connection, moved on lazily: a timer made and cancelled at every request
        of 50 busy connections would cost asyncio more than the rest of the connection.
        """
        if self._limits.header_timeout <= 0 or self._refused:
            return
        self._head_since = self._event_loop.time()
        if self._head_timer is None:
            self._head_timer = self._event_loop.call_at(self._head_since + self._limits.header_timeout,
                                                        self._head_timed_out)

    def _head_timed_out(self) -> None:
        self._head_timer = None
        since = self._head_since
        if self.transport is None or self._refused or since is None:
            return  # closed, or no head being received (timed again from the next one's first byte)
        deadline = since + self._limits.header_timeout
        if self._event_loop.time() < deadline:
            self._head_timer = self._event_loop.call_at(deadline, self._head_timed_out)
        else:
            self._refuse(408, f"the request head took more than {self._limits.header_timeout:g} s")


def drained_of(protocol: object) -> Callable[[], Awaitable[None]]:
    """How a reply written on *protocol*'s connection waits for its client (:meth:`GatewayConnection.drained`).

    A connection served some other way waits with aiohttp's own flow control, without a bound.
    """
    if isinstance(protocol, GatewayConnection):
        return protocol.drained
    if isinstance(protocol, BaseProtocol):
        return protocol._drain_helper  # aiohttp's writer waits with it (StreamWriter.drain)
    raise TypeError(f"no flow control on {type(protocol).__name__}")


def _peer(transport: asyncio.BaseTransport | None) -> str:
    peer = transport.get_extra_info("peername") if transport is not None else None
    return str(peer[0]) if isinstance(peer, tuple) else "?"
