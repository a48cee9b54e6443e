"""The proxy of a component that runs in another process: a ``Component`` the routes serve unchanged.

Its description, requests and ports are the remote instance's: ``send``, ``abort``, ``clean`` and
unknown request ids are queries to the host process (bounded in time); request events and port data
arrive as publications and keep a local copy current, from which ``status``, ``wait``, the listen
stream, ``read`` and ``watch`` are answered as for a local instance.  When the host process goes
away, :meth:`RemoteComponent.lost` ends the pending requests once with ``::genom::remote_io`` and
unloads the proxy (the listen stream says ``unload``).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
from typing import TYPE_CHECKING, Any

import orjson
import zenoh

from ...components.core import Component, ComponentHost
from ...components.core.runtime import NoSuchPort, NoSuchRequest, RequestRunning, RequestStatus
from .._errors import RemoteUnreachable
from ._mirror import MirroredOutPort
from ._session import ask, ask_all, on_zenoh_thread
from ._wire import decode_message, events_key, info_key, port_key, request_key, snapshot_key

if TYPE_CHECKING:
    from ...components.core import InPortRuntime, OutPortRuntime

__all__ = ["RemoteComponent", "RemoteRequest", "RemoteTimeouts", "REMOTE_IO"]

log = logging.getLogger(__name__)

#: The exception that ends the requests of a component whose process is gone.
REMOTE_IO = "::genom::remote_io"
#: Seconds a clean answered by the gateway waits for a query to carry it before it is published.
CLEAN_DELAY = 0.05


@dataclasses.dataclass
class RemoteTimeouts:
    """How long the gateway waits for a component host before answering ``::genom::remote_io``.

    Attributes:
        control: Seconds for a description, status, abort or clean.
        send: Seconds for a send (a function may take up to the host's function grace to end).
    """

    control: float = 5.0
    send: float = 10.0


@dataclasses.dataclass(eq=False)
class RemoteRequest(RequestStatus):
    """The gateway's copy of a request of a remote instance (the fields the routes and sessions use)."""

    number: int
    instance: str
    session: str | None = None
    oneway: bool = False
    serial: int = -1
    status: str = "sent"
    output: dict[str, Any] | None = None
    exception: dict[str, Any] | None = None
    ended: asyncio.Event = dataclasses.field(default_factory=asyncio.Event)

    def take(self, status: dict[str, Any]) -> bool:
        """Take a status object from the host; return whether it ended the request now (never undone)."""
        if not self.running or status.get("status") not in ("done", "error"):
            return False
        self.status = status["status"]
        self.output = status.get("output")
        self.exception = status.get("exception")
        self.ended.set()
        return True


class RemoteComponent(Component, name="remote"):
    """A component instance of another process, as this host serves it.

    Args:
        host: This process's host.
        instance: The remote instance name.
        session: The Zenoh session.
        description: The remote ``/info``.
        timeouts: The query bounds.
    """

    def __init__(self, host: ComponentHost, instance: str, session: zenoh.Session, description: dict[str, Any],
                 timeouts: RemoteTimeouts | None = None) -> None:
        super().__init__(host, instance, [])
        self.session = session
        self.timeouts = timeouts or RemoteTimeouts()
        self._description = description
        # Exceptions ids and state ports carry the remote component's name, as on its own host.
        self.genom_name = description.get("component", instance)  # type: ignore[misc]
        self.version = description.get("version", "")  # type: ignore[misc]
        self._loop = asyncio.get_running_loop()
        self._remote: dict[int, RemoteRequest] = {}
        # The serial of the copy last cleaned under each number: late news of it is not news.
        self._cleaned: dict[int, int] = {}
        # Cleans answered here that the host has not been told yet, and the timer that tells it.
        self._cleans_due: list[str] = []
        self._clean_timer: asyncio.TimerHandle | None = None
        self._mirrors = {port["name"]: MirroredOutPort(port, self)
                         for port in description.get("ports", []) if port.get("dir") == "out"}
        self._in_ports = {port["name"] for port in description.get("ports", []) if port.get("dir") == "in"}
        self._subscribers: list[Any] = []
        self._background: set[asyncio.Task[Any]] = set()
        self._gone = False

    # -- what the routes use ------------------------------------------------------------------

    def description(self) -> dict[str, Any]:
        """The remote instance's ``/info``."""
        return self._description

    def port(self, name: str) -> OutPortRuntime[Any] | InPortRuntime[Any]:
        """The mirrored out port *name*.

        Raises:
            NoSuchPort: for a port the remote instance does not have, or an in port (whose data
                is the out port it reads: read that one).
        """
        mirror = self._mirrors.get(name)
        if mirror is not None:
            return mirror
        if name in self._in_ports:
            raise NoSuchPort(f"{name} is an in port of {self.instance}, which runs in another process: "
                             f"read the out port it is connected to")
        raise NoSuchPort(f"{self.instance} has no port {name!r} (ports: {', '.join(self._mirrors)})")

    async def send(self, name: str, raw_input: Any = None, *, session: str | None = None,
                   oneway: bool = False) -> Any:
        """Send the request to the remote instance; return its copy (its status as the host replied)."""
        self._refuse_if_gone()
        status = await self._ask("send", {"service": name, "input": raw_input, "session": session,
                                          "oneway": oneway}, self.timeouts.send)
        number = self.requests.parse_id(status["id"])
        if oneway:
            # Nobody tracks a oneway request: the host forgets it when it ends.
            request = RemoteRequest(number, self.instance, session, True, status["serial"])
            request.take(status)
            return request
        request, new = self._track(number, status["serial"], session)
        # Each change is announced once, by whichever of the reply and the host's event comes first.
        if request.take(status) or (new and request.running):
            self.host.announce_request(request)  # type: ignore[arg-type]
        return request

    async def request(self, request_id: str) -> Any:
        """The copy of request *request_id*; asked from the host when this gateway has none."""
        number = self.requests.parse_id(request_id)
        known = self._remote.get(number)
        if known is not None:
            return known
        self._refuse_if_gone()
        status = await self._ask("status", {"id": str(number)}, self.timeouts.control)
        request, _ = self._track(number, status["serial"], None)
        request.take(status)
        return request

    async def abort(self, request_id: str) -> Any:
        """Abort the request on the host; return its copy, ended."""
        number = self.requests.parse_id(request_id)
        self._refuse_if_gone()
        status = await self._ask("abort", {"id": str(number)}, self.timeouts.control)
        request, _ = self._track(number, status["serial"], None)
        if request.take(status):
            self.host.announce_request(request)  # type: ignore[arg-type]
        return request

    async def clean(self, request_id: str) -> None:
        """Clean the request on the host, then forget the copy.

        A request this gateway saw end cannot be refused: the clean is answered at once and told
        to the host with this gateway's next query (a blocking call is then one message each
        way, not two), or published after CLEAN_DELAY when no query comes; either way the host
        takes it before any later query of this gateway, as if it had been asked.

        Raises:
            RequestRunning: for a request that has not ended.
        """
        number = self.requests.parse_id(request_id)
        self._refuse_if_gone()
        known = self._remote.get(number)
        if known is not None and known.running:
            raise RequestRunning(f"request {known.id} is still running: abort it or wait for it to end")
        if known is not None:
            self._cleaned[number] = known.serial
            self._cleans_due.append(str(number))
            if self._clean_timer is None:
                self._clean_timer = self._loop.call_later(CLEAN_DELAY, self._publish_cleans)
        else:
            await self._ask("clean", {"id": str(number)}, self.timeouts.control)
        self._remote.pop(number, None)

    async def _ask(self, operation: str, payload: dict[str, Any], timeout: float) -> Any:
        """Ask the request *operation* of the host, telling it the cleans it has not been told yet."""
        if self._cleans_due:
            payload["cleaned"], self._cleans_due = self._cleans_due, []
            self._cancel_clean_timer()
        return await ask(self.session, request_key(self.instance, operation), payload, timeout=timeout)

    def _publish_cleans(self) -> None:
        """Publish the cleans no query carried (the publication travels before any later query)."""
        self._clean_timer = None
        if self._cleans_due and self._started:
            due, self._cleans_due = self._cleans_due, []
            with contextlib.suppress(zenoh.ZError):
                self._cleans.put(orjson.dumps({"ids": due}))

    def _cancel_clean_timer(self) -> None:
        if self._clean_timer is not None:
            self._clean_timer.cancel()
            self._clean_timer = None

    def _track(self, number: int, serial: int, session: str | None) -> tuple[RemoteRequest, bool]:
        """The copy of request *number* whose serial is *serial*, and whether it was made now.

        A copy of an older serial is replaced (its request was cleaned elsewhere and the number
        reused); for an older serial than the copy's, the answer is a copy nobody keeps.
        """
        request = self._remote.get(number)
        if request is not None and request.serial == serial:
            return request, False
        if request is not None and request.serial > serial:
            return RemoteRequest(number, self.instance, session, serial=serial), True
        request = self._remote[number] = RemoteRequest(number, self.instance, session, serial=serial)
        return request, True

    def _is_stale(self, number: int, serial: int) -> bool:
        """Whether news of request *number* with *serial* is about a request already cleaned or replaced."""
        known = self._remote.get(number)
        if known is not None:
            return serial < known.serial
        return serial <= self._cleaned.get(number, -1)

    def _refuse_if_gone(self) -> None:
        if self._gone:
            raise RemoteUnreachable(f"{self.instance} is gone: its process no longer answers")

    # -- lifetime -------------------------------------------------------------------------------

    async def start(self) -> None:
        """Follow the instance's events and ports, then take each port's data as it is now."""
        if self._started:
            return
        self._started = True
        self._cleans = self.session.declare_publisher(request_key(self.instance, "clean"), express=True,
                                                      congestion_control=zenoh.CongestionControl.BLOCK,
                                                      reliability=zenoh.Reliability.RELIABLE)
        self._subscribers.append(self._cleans)
        # Both on Zenoh's receiving thread (indirect=False), not each on a thread of its own (the
        # default): the loop then takes events and port messages in the order the host sent them, so
        # a request's end never overtakes its last publication (a read after it would see older data).
        # The callbacks only hand the payload to the loop: they never hold that thread up.
        self._subscribers.append(self.session.declare_subscriber(
            events_key(self.instance), on_zenoh_thread(self._on_event)))
        self._subscribers.append(self.session.declare_subscriber(
            port_key(self.instance, "*"), on_zenoh_thread(self._on_port)))
        await asyncio.gather(*(self._fetch(name) for name in self._mirrors))

    async def _fetch(self, name: str) -> None:
        """Take the whole data of port *name* from the host (at start, and after a message went missing)."""
        for body in await ask_all(self.session, snapshot_key(self.instance, name), timeout=self.timeouts.control):
            with contextlib.suppress(ValueError):
                header, whole, delta = decode_message(body)
                mirror = self._mirrors[name]
                # Publications that came while this was asked are newer: a base never goes back in time.
                if header.get("kind") != "base" or mirror.version == 0 or header["index"] >= mirror.read().index:
                    mirror.apply(header, whole, delta)

    def _on_event(self, sample: zenoh.Sample) -> None:
        body = sample.payload.to_bytes()
        self._loop.call_soon_threadsafe(self._take_event, body)

    def _take_event(self, body: bytes) -> None:
        event = orjson.loads(body)
        status = event["status"]
        try:
            number = self.requests.parse_id(status["id"])
        except NoSuchRequest:
            return
        # Events travel after the replies: the news may be of a request this gateway already cleaned.
        if self._is_stale(number, status["serial"]):
            return
        request, new = self._track(number, status["serial"], event.get("session"))
        if new and status["status"] == "sent":
            # A request this gateway has not seen yet (its send reply may come after this event),
            # or a new request under a number cleaned elsewhere.
            self.host.announce_request(request)  # type: ignore[arg-type]
        if request.take(status):
            self.host.announce_request(request)  # type: ignore[arg-type]

    def _on_port(self, sample: zenoh.Sample) -> None:
        name = str(sample.key_expr).rsplit("/", 1)[-1]
        body = sample.payload.to_bytes()
        self._loop.call_soon_threadsafe(self._take_port, name, body)

    def _take_port(self, name: str, body: bytes) -> None:
        mirror = self._mirrors.get(name)
        if mirror is None or self._gone:
            return
        header, whole, delta = decode_message(body)
        if not mirror.apply(header, whole, delta):
            task = self._loop.create_task(self._fetch(name), name=f"refetch {self.instance}/{name}")
            self._background.add(task)
            task.add_done_callback(self._background.discard)

    def lost(self, why: str) -> None:
        """The host process is gone: end every pending request once with ``::genom::remote_io``, then unload."""
        if self._gone:
            return
        self._gone = True
        for request in list(self._remote.values()):
            if request.take({"status": "error", "exception": {"ex": REMOTE_IO, "detail": {"what": why}}}):
                self.host.announce_request(request)  # type: ignore[arg-type]
        self.host.unload_soon(self.instance)

    async def stop(self) -> None:
        """Stop following the instance (it keeps running in its process); pending copies end with remote_io."""
        if not self._started:
            return
        self._cancel_clean_timer()
        self._publish_cleans()  # the host keeps running: leave it nothing this gateway cleaned
        self._started = False
        if not self._gone:
            self._gone = True
            for request in list(self._remote.values()):
                if request.take({"status": "error", "exception": {
                        "ex": REMOTE_IO, "detail": {"what": f"{self.instance} was unloaded from this gateway"}}}):
                    self.host.announce_request(request)  # type: ignore[arg-type]
        for subscriber in self._subscribers:
            with contextlib.suppress(zenoh.ZError):
                subscriber.undeclare()
        for task in list(self._background):
            task.cancel()
        await asyncio.gather(*self._background, return_exceptions=True)


async def describe_remote(session: zenoh.Session, instance: str, timeout: float) -> dict[str, Any]:
    """The ``/info`` of the remote instance *instance*."""
    result: dict[str, Any] = await ask(session, info_key(instance), None, timeout=timeout)
    return result
