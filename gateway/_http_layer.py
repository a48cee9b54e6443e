"""The HTTP layer under the routes: request-head limits and timeout, and refusals in genomix JSON.

aiohttp's own parser refuses malformed request lines and oversized heads
before any route or middleware runs.  Left to itself it answers those in plain
text, logs each with a full traceback at ERROR (any client could flood the log),
closes at once on a client that is still sending (a 20 MB URL: the client gets
a connection reset instead of the answer), answers HTTP/0.9 request lines, and
waits an hour for a head sent one byte at a time.  Here every such refusal is
the documented JSON error (``::genomix::http``) with its status, logged in one
line at DEBUG, and the connection closes only once the client has read the
answer (or after a bounded linger):

* 400 for a malformed request line or header,
* 414 for a request line longer than ``max_url_bytes``,
* 431 for a header line longer than 8190 bytes,
* 408 when a request head is not complete ``header_timeout`` seconds after
  the connection opened or after its first byte arrived,
* 505 for an HTTP version other than 1.0 and 1.1 (HTTP/0.9 above all).

It also answers plain port reads as soon as they are parsed (``_fast_reads``),
when the connection is idle: nothing queued before them, nothing of an earlier
reply still to send.  And it calls the gateway's guard (``_guard``) in front of
the routes rather than as aiohttp middleware: the same checks and error
replies, without the middleware chain aiohttp wraps around every handler.

This leans on aiohttp's ``RequestHandler`` internals (its message queue, the
waiter of its task, its keep-alive fields and error-handler hook): they are the
one place where a refusal can be queued in order with the requests before it,
and where a request can be answered before the task wakes.  The tests of this
behaviour pin it; with an aiohttp whose handler lacks those fields, reads take
the routes.
"""

from __future__ import annotations

import asyncio
import functools
import logging
from typing import Any

from aiohttp import HttpVersion10, HttpVersion11, web
from aiohttp.http_exceptions import HttpProcessingError, LineTooLong
from aiohttp.streams import EMPTY_PAYLOAD
from aiohttp.web_protocol import RequestHandler, _ErrInfo

from ._fast_reads import FastReads
from ._gather import direct_socket, unsent, write_gathered
from ._keys import CONFIG, GUARD
from ._replies import SERVER_HEADER, dumps

__all__ = ["GatewayRunner", "MAX_HEADER_LINE", "LINGER"]

log = logging.getLogger(__name__)

#: The longest header line, in bytes (aiohttp's default; the request line has its own limit).
MAX_HEADER_LINE = 8190
#: Seconds a refused client may still send (the rest of a huge URL) while it reads the refusal.
LINGER = 5.0

_JSON = {"Content-Type": "application/json", **SERVER_HEADER}
_VERSIONS = (HttpVersion10, HttpVersion11)
#: The fields of aiohttp's handler that answering a request before its task wakes touches.
_FAST_FIELDS = ("_waiter", "_messages", "_keepalive", "_keepalive_handle", "_keepalive_timeout",
                "_next_keepalive_close_time", "_manager")
_FAST_SUPPORTED = all(field in getattr(RequestHandler, "__slots__", ()) for field in _FAST_FIELDS)


class GatewayRunner(web.AppRunner):
    """An ``AppRunner`` whose connections apply the gateway's limits on request heads.

    The limits come from the application's configuration (``max_url_bytes``,
    ``header_timeout``).

    Raises:
        ValueError: when ``max_url_bytes`` is not above the header line limit
            (8190): the two must differ for a refusal to say which was passed.
    """

    __slots__ = ("_header_timeout", "_guard")

    def __init__(self, app: web.Application, **kwargs: Any) -> None:
        config = app[CONFIG]
        if config.max_url_bytes <= MAX_HEADER_LINE:
            raise ValueError(f"max_url_bytes must be more than {MAX_HEADER_LINE}, not {config.max_url_bytes}")
        super().__init__(app, max_line_size=config.max_url_bytes, max_field_size=MAX_HEADER_LINE, **kwargs)
        self._header_timeout = config.header_timeout
        guard = app.get(GUARD)
        self._guard = guard if guard in app.middlewares and not app.frozen else None
        if self._guard is not None:
            # Called in front of the routes instead (see _make_server).
            app.middlewares.remove(self._guard)

    async def _make_server(self) -> web.Server:
        server = await super()._make_server()
        handler = server.request_handler
        if self._guard is not None:
            # The guard, handed the routes as the handler it guards (no frame of our own in between).
            handler = functools.partial(self._guard, handler=handler)
        return _Server(handler, request_factory=server.request_factory,
                       handler_cancellation=server.handler_cancellation, loop=asyncio.get_running_loop(),
                       header_timeout=self._header_timeout,
                       fast_reads=FastReads(self.app) if _FAST_SUPPORTED else None, **server._kwargs)


class _Server(web.Server):
    """aiohttp's low-level server, making :class:`_Connection` protocols."""

    def __init__(self, *args: Any, header_timeout: float, fast_reads: FastReads | None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.header_timeout = header_timeout
        self.fast_reads = fast_reads

    def __call__(self) -> RequestHandler:
        return _Connection(self, loop=self._loop, header_timeout=self.header_timeout, fast_reads=self.fast_reads,
                           **self._kwargs)


class _Connection(RequestHandler):
    """One HTTP connection: aiohttp's handler, plus the head timeout, the refusals and the fast reads above."""

    def __init__(self, manager: web.Server, *, header_timeout: float, fast_reads: FastReads | None,
                 **kwargs: Any) -> None:
        super().__init__(manager, **kwargs)
        self._header_timeout = header_timeout
        self._fast_reads = fast_reads
        self._header_timer: asyncio.TimerHandle | None = None
        # A request head is expected and not complete (from the connection's start, or its first bytes).
        self._awaiting_head = False
        # A refusal is queued: what the client still sends is read and dropped.
        self._refused = False
        self._peer_done: asyncio.Future[None] | None = None

    # -- the connection ---------------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        super().connection_made(transport)
        self._peer_done = self._loop.create_future()
        self._awaiting_head = True
        self._arm_header_timer()

    def connection_lost(self, exc: BaseException | None) -> None:
        self._disarm_header_timer()
        self._peer_finished()
        super().connection_lost(exc)

    def eof_received(self) -> None:
        self._peer_finished()
        super().eof_received()

    def _peer_finished(self) -> None:
        if self._peer_done is not None and not self._peer_done.done():
            self._peer_done.set_result(None)

    def data_received(self, data: bytes) -> None:
        if self._refused:
            return
        queued = len(self._messages)
        # The task of an idle connection waits for the next request, and aiohttp wakes it as soon
        # as a request is parsed.  For what may be a port read, it is held back here, and woken
        # only if a request is left to it.
        waiter = self._waiter
        if (waiter is None or waiter.done() or queued or self._fast_reads is None
                or not self._fast_reads.may_answer(data)):
            waiter = None
        else:
            self._waiter = None
        try:
            super().data_received(data)
        finally:
            if waiter is not None:
                self._waiter = waiter
        if len(self._messages) > queued:
            self._awaiting_head = False
            self._disarm_header_timer()
            self._screen(queued)
            if waiter is not None:
                if not self._refused:
                    self._answer_fast_reads()
                if self._messages and not waiter.done():
                    waiter.set_result(None)
        elif data:
            self._awaiting_head = True
            self._arm_header_timer()

    # -- fast reads ---------------------------------------------------------------------------

    def _answer_fast_reads(self) -> None:
        """Answer the queued requests that are plain port reads, in order, up to the first that is not."""
        assert self._fast_reads is not None
        transport = self.transport
        while self._messages and transport is not None:
            message, payload = self._messages[0]
            if isinstance(message, _ErrInfo) or payload is not EMPTY_PAYLOAD:
                return
            # Only on a socket with nothing left to send: a reply written beside the transport must
            # not overtake an earlier one, and a client that does not read gets one reply queued at most.
            fd = direct_socket(transport)
            reply = self._fast_reads.reply(message) if fd is not None else None
            if fd is None or reply is None:
                return
            self._messages.popleft()
            self._took_message()
            written = write_gathered(fd, reply)
            for piece in unsent(reply, written):
                transport.write(piece)
            self._kept_alive()

    def _took_message(self) -> None:
        """What aiohttp's task does on taking a request from the queue (as of aiohttp 3.14)."""
        parser = getattr(self, "_parser", None)
        if parser is not None and hasattr(parser, "message_consumed"):
            parser.message_consumed()  # frees a slot of the parser's queue of requests
        manager = self._manager
        if manager is not None:
            manager.requests_count += 1

    def _kept_alive(self) -> None:
        """What aiohttp's task does after a reply on a kept-alive connection: restart the idle timer."""
        self._keepalive = True
        if self._keepalive_timeout > 0:
            close_time = self._loop.time() + self._keepalive_timeout
            self._next_keepalive_close_time = close_time
            if self._keepalive_handle is None:
                self._keepalive_handle = self._loop.call_at(close_time, self._process_keepalive)

    # -- what the parser queued -------------------------------------------------------------

    def _screen(self, first: int) -> None:
        """Refuse HTTP versions other than 1.0 and 1.1; after any refusal, drop what follows it."""
        for index in range(first, len(self._messages)):
            message, _ = self._messages[index]
            if not isinstance(message, _ErrInfo) and message.version not in _VERSIONS:
                version = f"HTTP/{message.version.major}.{message.version.minor}"
                exc = HttpProcessingError(code=505, message=f"{version} is not supported: send HTTP/1.1 or HTTP/1.0")
                self._messages[index] = (_ErrInfo(status=505, exc=exc, message=exc.message), EMPTY_PAYLOAD)
            elif not isinstance(message, _ErrInfo):
                continue
            self._refused = True
            while len(self._messages) > index + 1:
                self._messages.pop()
            return

    # -- the head timeout ------------------------------------------------------------------

    def _arm_header_timer(self) -> None:
        if self._header_timer is None and self._header_timeout > 0:
            self._header_timer = self._loop.call_later(self._header_timeout, self._header_timed_out)

    def _disarm_header_timer(self) -> None:
        if self._header_timer is not None:
            self._header_timer.cancel()
            self._header_timer = None

    def _header_timed_out(self) -> None:
        self._header_timer = None
        if not self._awaiting_head or self._refused or self.transport is None:
            return
        waiter = self._waiter
        if self._messages or waiter is None or waiter.done():
            # A request is being handled: the head that follows it is timed once that one is answered.
            self._arm_header_timer()
            return
        exc = HttpProcessingError(code=408, message=f"the request head took more than {self._header_timeout:g} s")
        self._messages.append((_ErrInfo(status=408, exc=exc, message=exc.message), EMPTY_PAYLOAD))
        self._refused = True
        waiter.set_result(None)

    # -- refusals --------------------------------------------------------------------------

    def handle_error(self, request: Any, status: int = 500, exc: BaseException | None = None,
                     message: str | None = None) -> web.StreamResponse:
        """The JSON reply to an error of the HTTP layer (or to an exception no middleware caught)."""
        if request.writer.output_size > 0:
            raise ConnectionError("the reply had begun: no error reply can follow it")
        if status >= 500 and not isinstance(exc, HttpProcessingError):
            # A bug of ours, not the client's: the traceback is wanted.
            self.log_exception("error handling a request from %s", request.remote, exc_info=exc)
            body = {"ex": "::genom::unkex", "message": "internal error (see the gateway log)"}
        else:
            status, text = self._refusal(status, exc)
            log.debug("refused a request from %s: %d %s", request.remote, status, text)
            body = {"ex": "::genomix::http", "message": text}
        response = web.Response(status=status, body=dumps(body), headers=_JSON)
        response.force_close()
        return response

    def _refusal(self, status: int, exc: BaseException | None) -> tuple[int, str]:
        if isinstance(exc, LineTooLong):
            limit = exc.args[1] if len(exc.args) > 1 else None
            if limit == self.max_field_size:
                return 431, f"a request header line is longer than {limit} bytes"
            return 414, (f"the request line (the URL with its query, input= included) is longer than "
                         f"{self.max_line_size} bytes, this gateway's limit")
        text = exc.message if isinstance(exc, HttpProcessingError) else str(exc or "")
        # aiohttp's messages quote the bytes received over several lines: one short line is enough.
        line = " ".join(str(text).split())
        if len(line) > 120:
            line = line[:117] + "..."
        if status in (408, 505):
            return status, line
        return status, f"malformed HTTP request: {line}" if line else "malformed HTTP request"

    def _make_error_handler(self, err_info: _ErrInfo) -> Any:
        async def refuse(request: web.BaseRequest) -> web.StreamResponse:
            response = self.handle_error(request, err_info.status, err_info.exc, err_info.message)
            await self._answer_and_linger(request, response)
            return response

        return refuse

    async def _answer_and_linger(self, request: web.BaseRequest, response: web.StreamResponse) -> None:
        """Send the refusal, then read and drop what the client still sends until it has read it.

        Closing while the client still sends makes the kernel reset the
        connection, and the client never reads the answer.  So the answer goes
        out with a half-close, and the connection closes when the client closes
        its side, or after :data:`LINGER` seconds.
        """
        try:
            await response.prepare(request)
            await response.write_eof()
        except ConnectionError:
            return
        transport = self.transport
        if transport is None or transport.is_closing() or self._peer_done is None:
            return
        if transport.can_write_eof():
            transport.write_eof()
        try:
            async with asyncio.timeout(LINGER):
                await asyncio.shield(self._peer_done)
        except TimeoutError:
            pass
