"""The session's listen stream: read server-sent events off aiohttp's StreamReader, reconnect when it drops."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Any

import aiohttp
import orjson

from ._errors import GenomixError, ProtocolError, RemoteError, TransportError
from ._http import HttpGateway
from ._sse import Comment, ServerSentEvent, SSEParser
from ._tracker import RequestTracker
from ._wire import parse_status

__all__ = ["ListenStream"]

#: Backoff between reconnection attempts: first at once, then doubling up to the cap.
_FIRST_RETRY, _RETRY_CAP = 0.05, 2.0


class ListenStream:
    """Keeps ``/session/listen`` open and feeds its events to the tracker.

    A stream that ends without ``quit`` (a dropped connection, a gateway that
    disconnected a slow listener) is reopened at once, then with a growing
    delay; the tracker re-reads what may have been lost.

    Args:
        gateway: The gateway (its session name is the one listened to).
        tracker: Receives ``request`` events, pings and attachments.
        on_unload: Called with the instance name of an ``unload`` event.
        on_quit: Called when the session was stopped (the stream then ends for good).
        report: Called with an asyncio exception-handler context for errors nobody awaits.
        reconnect_timeout: After this many seconds without a stream, pending requests
            fail with :class:`TransportError` (reconnection goes on).
        idle_timeout: Seconds without any byte (the gateway pings idle streams) before
            the connection is taken for dead.
    """

    def __init__(self, gateway: HttpGateway, tracker: RequestTracker, *, on_unload: Callable[[str], None],
                 on_quit: Callable[[], None], report: Callable[[dict[str, Any]], None],
                 reconnect_timeout: float = 30.0, idle_timeout: float = 60.0) -> None:
        self._gateway = gateway
        self._tracker = tracker
        self._on_unload = on_unload
        self._on_quit = on_quit
        self._report = report
        self.reconnect_timeout = reconnect_timeout
        self.idle_timeout = idle_timeout
        self._task: asyncio.Task[None] | None = None
        self._reply: aiohttp.ClientResponse | None = None
        self._stopping = False
        self._quit = False
        #: How many times the stream was attached (1 after connection).
        self.attachments = 0
        self.attached = asyncio.Event()
        self._attach_changed = asyncio.Condition()

    async def start(self, timeout: float | None) -> None:
        """Open the stream and return once the gateway attached it.

        Raises:
            TransportError, RemoteError: when the first attempt fails (nothing retries it).
        """
        first: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._task = asyncio.get_running_loop().create_task(self._run(first), name="aiogenomix listen")
        try:
            async with asyncio.timeout(timeout):
                await first
        except TimeoutError:
            await self.stop(0)
            raise TransportError(f"{self._gateway.base} did not open the event stream within {timeout} s") from None
        except BaseException:
            await self.stop(0)
            raise

    async def stop(self, timeout: float | None = 5.0) -> None:
        """Stop reading (after ``/session/stop``, the stream ends by itself with ``quit``)."""
        self._stopping = True
        task, self._task = self._task, None
        if task is None:
            return
        try:
            async with asyncio.timeout(timeout):
                await asyncio.shield(task)
        except TimeoutError:
            pass
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task

    async def _wait_attachments(self, count: int) -> None:
        """Wait until the stream was attached *count* times in all (a hook for tests)."""
        async with self._attach_changed:
            await self._attach_changed.wait_for(lambda: self.attachments >= count)

    def _drop(self) -> None:
        """Abort the current connection, as a network failure would (a hook for tests)."""
        reply = self._reply
        if reply is not None and reply.connection is not None and reply.connection.transport is not None:
            reply.connection.transport.abort()

    async def _run(self, first: asyncio.Future[None]) -> None:
        loop = asyncio.get_running_loop()
        delay, down_since, failed_pending = 0.0, loop.time(), False
        while not (self._stopping or self._quit):
            attachments = self.attachments
            try:
                await self._listen_once(first)
            except (TransportError, aiohttp.ClientError, OSError, TimeoutError) as exc:
                if not first.done():
                    first.set_exception(exc if isinstance(exc, GenomixError) else TransportError(
                        f"cannot listen to the events of {self._gateway.base}: {exc}"))
                    return
            except RemoteError as exc:
                # The gateway refused to listen (a token, most likely): retrying cannot help.
                if not first.done():
                    first.set_exception(exc)
                else:
                    self._tracker.fail_pending(exc)
                    self._report({"message": "the gateway refused the event stream", "exception": exc})
                return
            self.attached.clear()
            if self._stopping or self._quit:
                return
            if self.attachments > attachments:
                # A working stream dropped: retry at once, then back off.
                delay, down_since, failed_pending = 0.0, loop.time(), False
            if not failed_pending and loop.time() - down_since > self.reconnect_timeout:
                failed_pending = True
                self._tracker.fail_pending(TransportError(
                    f"lost the event stream of {self._gateway.base} for over {self.reconnect_timeout} s"))
            if delay:
                await asyncio.sleep(delay)
            delay = min(max(delay * 2, _FIRST_RETRY), _RETRY_CAP)

    async def _listen_once(self, first: asyncio.Future[None]) -> None:
        http = self._gateway.http
        timeout = aiohttp.ClientTimeout(total=None, sock_connect=10.0, sock_read=self.idle_timeout)
        params = {"s": self._gateway.session_name}
        async with http.get(self._gateway.base + "/session/listen", params=params, timeout=timeout) as reply:
            if reply.status != 200:
                raise self._gateway.error_for(reply.status, await reply.read(), "/session/listen")
            self._reply = reply
            try:
                self.attachments += 1
                self._tracker.on_attached()
                self.attached.set()
                async with self._attach_changed:
                    self._attach_changed.notify_all()
                if not first.done():
                    first.set_result(None)
                parser = SSEParser()
                while True:
                    chunk = await reply.content.readany()
                    if not chunk:
                        return  # close-delimited body: EOF is the end, whether clean or not
                    for item in parser.feed(chunk):
                        self._dispatch(item)
                    if self._quit:
                        return
            finally:
                self._reply = None

    def _dispatch(self, item: ServerSentEvent | Comment) -> None:
        if isinstance(item, Comment):
            self._tracker.on_ping()
            return
        try:
            if item.event == "request":
                self._tracker.on_request_event(parse_status(orjson.loads(item.data)))
            elif item.event == "unload":
                name = orjson.loads(item.data)
                if not isinstance(name, str):
                    raise ProtocolError(f"unload event without an instance name: {item.data!r}")
                self._tracker.on_unload(name)
                self._on_unload(name)
            elif item.event == "quit":
                self._quit = True
                self._on_quit()
        except (orjson.JSONDecodeError, ProtocolError) as exc:
            # One malformed event must not end the stream; say so where asyncio reports errors.
            self._report({"message": f"malformed {item.event} event: {item.data!r:.200}", "exception": exc})
