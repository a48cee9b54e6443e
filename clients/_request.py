"""Request handles: the status, outputs and end of one service call, reported exactly once."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Awaitable, Callable, Generator
from typing import TYPE_CHECKING, Any

from ._errors import GenomixError, RequestTimeout, remote_error
from ._types import Record
from ._wire import Status, StatusObject

if TYPE_CHECKING:
    from ._service import ServiceSpec

__all__ = ["AsyncRequest"]


class AsyncRequest:
    """A request sent by an :class:`~aiogenomix.clients.AsyncClient` (``ack=True`` returns one).

    ``await request`` gives the result (or raises), like :meth:`result`.

    Attributes:
        id: The request id, ``"<instance>::<n>"``.
        module: The module instance.
        service: The service name.
    """

    def __init__(self, request_id: str, module: str, spec: ServiceSpec, *,
                 abort: Callable[[AsyncRequest, float | None], Awaitable[None]], epoch: int) -> None:
        self.id = request_id
        self.module = module
        self.service = spec.name
        self._spec = spec
        self._abort = abort
        self._status = Status.sent
        self._output: Record | None = None
        self._error: GenomixError | None = None
        self._ended = asyncio.get_running_loop().create_future()
        #: Set at the end too, for threads that wait without the event loop (the sync facade).
        self.ended_event = threading.Event()
        #: The synchronous handle wrapping this one, once the sync facade made it.
        self.facade: Any = None
        self._end_callbacks: list[Callable[[AsyncRequest], None]] = []
        #: The stream epoch its send began in (see RequestTracker).
        self.epoch = epoch
        #: Whether its final ``request`` event was read from the stream (then it may be cleaned).
        self.final_event_seen = False

    def __repr__(self) -> str:
        return f"<request {self.id} {self.service} {self._status.value}>"

    @property
    def status(self) -> Status:
        """``Status.sent`` while running, then ``Status.done`` or ``Status.error``."""
        return self._status

    @property
    def done(self) -> bool:
        """Whether the request has ended (done or error)."""
        return self._status is not Status.sent

    @property
    def output(self) -> Record | None:
        """All outputs by name once done (None before, or after an error)."""
        return self._output

    @property
    def exception(self) -> GenomixError | None:
        """The error it ended with, if it ended in error."""
        return self._error

    def add_done_callback(self, callback: Callable[[AsyncRequest], None]) -> None:
        """Call *callback* (on the client's event loop) once the request ends; at once if it has."""
        if self.done:
            callback(self)
        else:
            self._end_callbacks.append(callback)

    async def wait(self, timeout: float | None = None) -> bool:
        """Wait until the request ends or *timeout* seconds pass; return whether it ended."""
        if not self._ended.done():
            # asyncio.timeout rather than wait_for, which on 3.11 can lose a cancellation racing the end.
            try:
                async with asyncio.timeout(timeout):
                    await asyncio.shield(self._ended)
            except TimeoutError:
                return False
        return True

    async def result(self, timeout: float | None = None) -> Any:
        """Wait for the end and return the outputs the way the blocking call does.

        Raises:
            RemoteError: the exception the request ended with (a generated class, or Interrupted).
            RequestTimeout: when *timeout* expires first; the request keeps running.
        """
        if not await self.wait(timeout):
            raise RequestTimeout(
                f"{self.service} ({self.id}) did not end within {timeout} s; it still runs: "
                "wait for it again or abort() it", request=self)
        if self._error is not None:
            raise self._error
        return self._spec.result(self._output or Record())

    async def abort(self, timeout: float | None = None) -> None:
        """Interrupt the request (it then ends with Interrupted, ``by="abort"``); no-op once ended."""
        if not self.done:
            await self._abort(self, timeout)

    def __await__(self) -> Generator[Any, None, Any]:
        return self.result().__await__()

    # -- fed by the tracker -------------------------------------------------------------------

    def apply(self, status: StatusObject) -> bool:
        """Take a status object; return True when it ended the request (only the first end counts)."""
        if self.done or status["status"] == "sent":
            return False
        if status["status"] == "done":
            self._output = self._spec.decode_outputs(status.get("output") or {})
            self._finish(Status.done)
        else:
            self._error = remote_error(status["exception"], request_id=self.id, module=self.module,
                                       service=self.service)
            self._finish(Status.error)
        return True

    def fail(self, error: GenomixError) -> bool:
        """End the request locally (the client lost track of it); return True if it was pending."""
        if self.done:
            return False
        self._error = error
        self._finish(Status.error)
        return True

    def _finish(self, status: Status) -> None:
        self._status = status
        self._ended.set_result(None)
        self.ended_event.set()
        callbacks, self._end_callbacks = self._end_callbacks, []
        for callback in callbacks:
            callback(self)
