"""Requests and the tracker that owns them: ids, status, the asyncio task of an activity.

A request id is ``"<instance>::<n>"`` where ``n`` is the smallest number not
held by an uncleaned request, so ids are reused after ``clean`` as in genomix.
Every status change is reported to the tracker's listener (the gateway routes
it to the request's session as a ``request`` event).
"""

from __future__ import annotations

import asyncio
import contextvars
import dataclasses
import heapq
from collections import OrderedDict
from collections.abc import Callable
from typing import Any, Literal

from ._events import status_object
from ._exceptions import NoSuchRequest, RequestRunning
from ._services import ServiceSpec

__all__ = ["Request", "RequestStatus", "RequestTracker", "Status", "parse_request_id", "SENDER_SCOPE"]

#: Which requests the sender of the request being made may name (None: every one).  A component host
#: serving several gateways sets it while it makes one gateway's request: ``abort_activity`` of another
#: gateway's request then ends ``::genom::no_such_activity``, as for a number that names no request.
SENDER_SCOPE: contextvars.ContextVar[Callable[[Request], bool] | None] = contextvars.ContextVar(
    "aiogenomix_sender_scope", default=None)

Status = Literal["sent", "done", "error"]

#: The most digits the ``n`` of a request id can have (no component runs 10**18 requests).
_MAX_ID_DIGITS = 18


def parse_request_id(instance: str, request_id: str) -> int:
    """The ``n`` of a request id of *instance*: ``demo::3``, ``::demo::3`` or ``3`` give 3.

    Raises:
        NoSuchRequest: for another instance's id or a malformed id.
    """
    text = request_id.strip()
    prefix, sep, number = text.rpartition("::")
    shown = repr(request_id) if len(request_id) <= 60 else repr(request_id[:57]) + "..."
    if sep and prefix.lstrip(":") != instance:
        raise NoSuchRequest(f"request {shown} does not belong to {instance}")
    # isdigit() alone takes "²" (int() does not); no id has more digits than a request count can.
    if not (number.isascii() and number.isdigit()) or len(number) > _MAX_ID_DIGITS:
        raise NoSuchRequest(f"malformed request id {shown} (expected {instance}::<n> or <n>)")
    return int(number)


class RequestStatus:
    """What a request shows on the wire and to its session: its id, whether it runs, its status object.

    Shared by :class:`Request` and the gateway's copy of a request that runs in
    another process, so that both answer ``status``, ``wait`` and ``request`` events alike.
    Subclasses hold every attribute declared here.
    """

    number: int
    instance: str
    status: str
    output: dict[str, Any] | None
    exception: dict[str, Any] | None
    #: The session its events go to (None: nobody's).
    session: str | None
    #: Whether nobody wants its result (no events; forgotten when it ends).
    oneway: bool
    #: Its incarnation: two requests that held the same number one after the other differ by it.
    serial: int
    #: Set when it ends.
    ended: asyncio.Event
    #: When it was sent, in POSIX seconds of its host's clock (0: not known).
    sent: float

    @property
    def id(self) -> str:
        """The wire id, ``"<instance>::<n>"``."""
        return f"{self.instance}::{self.number}"

    @property
    def running(self) -> bool:
        """Whether the request has not ended yet."""
        return self.status == "sent"

    def status_object(self) -> dict[str, Any]:
        """The JSON status object (also the data of the ``request`` event)."""
        return status_object(self.id, self.status, self.output, self.exception)

    def command(self) -> tuple[str, Any]:
        """The service called and its input, JSON-ready (``""`` and None where this copy does not know them)."""
        return "", None


@dataclasses.dataclass(eq=False)
class Request(RequestStatus):
    """One call of a service.

    Attributes:
        number: The ``n`` of the id.
        instance: The component instance name.
        service: The service called.
        session: The session its events go to (or None).
        oneway: Whether nobody wants its result (cleaned as soon as it ends).
        status: ``sent``, then ``done`` or ``error``.
        output: The outputs once ``done``.
        exception: ``{"ex": ..., "detail": ...}`` once ``error``.
        serial: How many requests the tracker made before this one: it tells apart two requests
            that held the same number one after the other (a copy kept in another process needs it).
        sent: When it was sent, in POSIX seconds of its host's clock.
    """

    number: int
    instance: str
    service: ServiceSpec
    inputs: dict[str, Any]
    session: str | None = None
    oneway: bool = False
    status: Status = "sent"
    output: dict[str, Any] | None = None
    exception: dict[str, Any] | None = None
    task: asyncio.Task[None] | None = None
    interrupted_by: str | None = None
    ended: asyncio.Event = dataclasses.field(default_factory=asyncio.Event)
    serial: int = 0
    sent: float = 0.0

    def command(self) -> tuple[str, Any]:
        """The service called and its input, JSON-ready (encoded as a client would send it)."""
        return self.service.name, self.service.encode_inputs(self.inputs)


class RequestTracker:
    """Allocates request ids and keeps requests until they are cleaned.

    Args:
        instance: The component instance name (prefix of the ids).
        listener: Called with each request whose status changed.
        keep_ended: How many ended, uncleaned requests to keep; the oldest are
            dropped past that, so clients that never clean cannot exhaust memory
            (genomix 1.6 cleans untracked replies for the same reason).
        wall: The POSIX time of the host's clock, which stamps when each request is sent (none: 0).
    """

    def __init__(self, instance: str, listener: Callable[[Request], None], keep_ended: int = 1000,
                 wall: Callable[[], float] | None = None) -> None:
        self.instance = instance
        self.listener = listener
        self.wall = wall
        self.keep_ended = keep_ended
        self._requests: dict[int, Request] = {}
        self._running: dict[int, Request] = {}
        self._ended: OrderedDict[int, None] = OrderedDict()
        # Every number below _next that is not in use is in _free (a min-heap), so
        # the smallest free number is found without scanning the requests.
        self._next = 0
        self._free: list[int] = []
        self._made = 0

    def create(self, service: ServiceSpec, inputs: dict[str, Any], session: str | None, oneway: bool) -> Request:
        """Register a new request with the smallest free number."""
        if self._free:
            number = heapq.heappop(self._free)
        else:
            number, self._next = self._next, self._next + 1
        request = Request(number, self.instance, service, inputs, session, oneway, serial=self._made,
                          sent=self.wall() if self.wall is not None else 0.0)
        self._made += 1
        self._requests[number] = request
        self._running[number] = request
        return request

    def _forget(self, number: int) -> None:
        if self._requests.pop(number, None) is not None:
            heapq.heappush(self._free, number)

    def parse_id(self, request_id: str) -> int:
        """Accept ``demo::3``, ``::demo::3`` or ``3``; return 3.

        Raises:
            NoSuchRequest: for another instance's id or a malformed id.
        """
        return parse_request_id(self.instance, request_id)

    def get(self, request_id: str | int) -> Request:
        """The request of that id.

        Raises:
            NoSuchRequest: when there is none.
        """
        number = request_id if isinstance(request_id, int) else self.parse_id(request_id)
        try:
            return self._requests[number]
        except KeyError:
            raise NoSuchRequest(f"no request {self.instance}::{number}") from None

    def running(self) -> list[Request]:
        """The requests that have not ended, oldest first."""
        return list(self._running.values())

    def announce(self, request: Request) -> None:
        """Report the request's current status to the listener."""
        if not request.oneway:
            self.listener(request)

    def finish(self, request: Request, status: Status, output: dict[str, Any] | None = None,
               exception: dict[str, Any] | None = None) -> None:
        """Record the end of a request and report it."""
        if not request.running:
            return
        request.status, request.output, request.exception = status, output, exception
        request.ended.set()
        del self._running[request.number]
        if request.oneway:
            self._forget(request.number)
            return
        self._ended[request.number] = None
        while len(self._ended) > self.keep_ended:
            number, _ = self._ended.popitem(last=False)
            self._forget(number)
        self.announce(request)

    def clean(self, request_id: str) -> None:
        """Forget an ended request, freeing its number.

        Raises:
            NoSuchRequest: when there is no such request.
            RequestRunning: when it has not ended.
        """
        request = self.get(request_id)
        if request.running:
            raise RequestRunning(f"request {request.id} is still running: abort it or wait for it to end")
        self._ended.pop(request.number, None)
        self._forget(request.number)
