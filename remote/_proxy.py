"""The proxy of an instance that runs in another process: what the gateway's routes serve as a loaded instance.

It satisfies :class:`~aiogenomix.components.core.runtime.LoadedInstance` as a component of the gateway
does.  Its description, requests and ports are the remote instance's: ``send``, ``abort``, ``clean``
and unknown request ids are queries to the host process (bounded in time); request events and port
data arrive as publications and keep a local copy current, from which ``status``, ``wait``, the
listen stream, ``read`` and ``watch`` are answered as for a local instance.  A port whose host was
not heard from within the stale bound is not served as current: its read answers
``::genom::remote_io``.  When the host process goes away, :meth:`RemoteInstance.lost` ends the
pending queries and requests at once with ``::genom::remote_io`` and unloads the proxy (the listen
stream says ``unload``).  Unloading the proxy lets go of the instance as a gateway that vanished
would, at once: the motions this proxy sent stop there (``interrupted``, by ``kill``, as a local
unload says), what they left going stops too, and its other requests go on, for whoever asks.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import datetime
import logging
import secrets
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import orjson
import zenoh

from ..components.core.runtime import (
    REMOTE_IO, ComponentError, NoSuchPort, NoSuchRequest, Placement, RemoteUnreachable, RequestRunning,
    RequestStatus, parse_request_id,
)
from ._mirror import MirroredOutPort
from ._settings import RemoteTimeouts
from ._session import GONE, Answer, Unanswered, ask, ask_all, on_zenoh_thread
from ._wire import (
    PROTOCOL, OfferKey, cleaned_key, decode_message, events_key, info_key, port_key, request_key, snapshot_key,
)

if TYPE_CHECKING:
    from ..components.core import ComponentHost, InPortRuntime, OutPortRuntime

__all__ = [
    "RemoteInstance", "RemoteRequest", "RemoteTimeouts", "RemoteLink", "REMOTE_IO", "describe_remote", "heard_text",
    "utc_text",
]

log = logging.getLogger(__name__)

#: Seconds a clean answered by the gateway waits for a query to carry it before it is published.
CLEAN_DELAY = 0.05


@dataclasses.dataclass(frozen=True)
class RemoteLink:
    """What the proxies of one process share: the session, this process's id, the bounds, the heartbeats.

    Attributes:
        session: The Zenoh session.
        gateway: This process's Zenoh session id: its requests' events come to it alone.
        timeouts: The bounds.
        silence: Seconds since the host of a Zenoh session id was last heard from.
    """

    session: zenoh.Session
    gateway: str
    timeouts: RemoteTimeouts
    silence: Callable[[str], float]


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
    sent: float = 0.0
    #: The service this gateway sent it to, and the input it sent ("" and None: another gateway's request).
    called: str = ""
    given: Any = None

    def command(self) -> tuple[str, Any]:
        """The service called and its input, as this gateway sent them ("" and None when it did not)."""
        return self.called, self.given

    def take(self, status: dict[str, Any]) -> bool:
        """Take a status object from the host; return whether it ended the request now (never undone)."""
        if not self.running or status.get("status") not in ("done", "error"):
            return False
        self.status = status["status"]
        self.output = status.get("output")
        self.exception = status.get("exception")
        self.ended.set()
        return True


class RemoteInstance:
    """An instance of another process, as this process serves it.

    Args:
        host: This process's host (it announces the requests' changes and unloads the proxy).
        link: The session and bounds shared by the proxies.
        offer: The offer this proxy was made from: which host run, which instance.
        name: The instance name here (the remote name, unless loaded with ``-i``).
        description: The remote ``/info``.
        facts: What the host says of itself (endpoints, versions), when asked.
    """

    def __init__(self, host: ComponentHost, link: RemoteLink, offer: OfferKey, name: str,
                 description: dict[str, Any], facts: Callable[[], dict[str, Any]]) -> None:
        self.host = host
        self.link = link
        self.session = link.session
        self.timeouts = link.timeouts
        self.offer = offer
        self.instance = name
        self.remote_instance = offer.instance
        self._facts = facts
        # The remote description, under the name it has here.
        self._description = {**description, "name": name}
        # Exceptions ids and state ports carry the remote component's name, as on its own host.
        self.genom_name: str = description.get("component", offer.instance)
        self.version: str = description.get("version", "")
        self._loop = asyncio.get_running_loop()
        self._remote: dict[int, RemoteRequest] = {}
        # The serial of the copy last cleaned under each number: late news of it is not news.
        self._cleaned: dict[int, int] = {}
        # Cleans answered here that the host has not been told yet, and the timer that tells it.
        self._cleans_due: list[str] = []
        self._clean_timer: asyncio.TimerHandle | None = None
        # What a mirrored window holds counts against this process's audio budget, as a local port would.
        self._mirrors = {port["name"]: MirroredOutPort(port, self, host.ledgers.audio)
                         for port in description.get("ports", []) if port.get("dir") == "out"}
        self._in_ports = {port["name"] for port in description.get("ports", []) if port.get("dir") == "in"}
        self._subscribers: list[Any] = []
        self._background: set[asyncio.Task[Any]] = set()
        # The queries waiting for an answer: ended at once when the host is known to be gone.
        self._pending: set[asyncio.Future[Answer]] = set()
        self._started = False
        self._gone = False
        # This proxy among the proxies of this gateway (one instance may be loaded under two names): the
        # host lets go of what this one sent when it is unloaded, and of nothing else.
        self._via = secrets.token_hex(4)
        self._sent = False
        #: When a port message or an answer last came (set on Zenoh's thread too): news of the host.
        self._last_message = time.monotonic()
        #: When the host was last heard from, kept when it was found gone (see heard_at).
        self._heard_when_lost: float | None = None

    # -- what the routes use ------------------------------------------------------------------

    def description(self) -> dict[str, Any]:
        """The remote instance's ``/info``, under its name here."""
        return self._description

    def placement(self) -> Placement:
        """Where the instance runs: its host, the host's endpoints and protocol, the component."""
        facts = self._facts()
        return {"runs": "remote", "component": self.genom_name, "version": self.version, "host": self.offer.host,
                "instance": self.remote_instance, "endpoints": list(facts.get("endpoints") or []),
                "zid": self.offer.zid, "protocol": PROTOCOL}

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

    def check_heard(self) -> None:
        """Refuse to serve the host's data as current when it was not heard from within the stale bound.

        Raises:
            RemoteUnreachable: naming the host and how long it has been silent.
        """
        if self._gone:
            raise RemoteUnreachable(f"{self.instance} is gone: its host {self.offer.host} no longer answers")
        silence = min(self.link.silence(self.offer.zid), time.monotonic() - self._last_message)
        if silence > self.timeouts.stale:
            raise RemoteUnreachable(
                f"{self.instance} runs on {self.offer.host}, not heard from for {silence:.1f} s (more than the "
                f"{self.timeouts.stale:g} s bound): the network is cut or the host froze; its last data is not "
                f"served as current")

    async def send(self, name: str, raw_input: object = None, *, session: str | None = None,
                   oneway: bool = False) -> RemoteRequest:
        """Send the request to the remote instance; return its copy (its status as the host replied)."""
        self.check_heard()
        self._sent = True
        sent = self.host.clock.wall()
        status = await self._ask("send", {"service": name, "input": raw_input, "session": session,
                                          "oneway": oneway, "via": self._via}, self.timeouts.send, f"send {name}")
        number = parse_request_id(self.remote_instance, status["id"])
        if oneway:
            # Nobody tracks a oneway request: the host forgets it when it ends.
            request = RemoteRequest(number, self.instance, session, True, status["serial"], sent=sent, called=name,
                                    given=raw_input)
            request.take(status)
            return request
        request, new = self._track(number, status["serial"], session)
        request.sent, request.called, request.given = sent, name, raw_input
        # Each change is announced once, by whichever of the reply and the host's event comes first.
        if request.take(status) or (new and request.running):
            self.host.announce_request(request)
        return request

    async def request(self, request_id: str) -> RemoteRequest:
        """The copy of request *request_id*; asked from the host when this gateway has none."""
        number = parse_request_id(self.instance, request_id)
        known = self._remote.get(number)
        if known is not None:
            return known
        self._refuse_if_gone()
        status = await self._ask("status", {"id": str(number)}, self.timeouts.control, "status")
        request, _ = self._track(number, status["serial"], None)
        request.take(status)
        return request

    async def abort(self, request_id: str) -> RemoteRequest:
        """Abort the request on the host; return its copy, ended."""
        number = parse_request_id(self.instance, request_id)
        self._refuse_if_gone()
        status = await self._ask("abort", {"id": str(number)}, self.timeouts.control, "abort")
        request, _ = self._track(number, status["serial"], None)
        if request.take(status):
            self.host.announce_request(request)
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
        number = parse_request_id(self.instance, request_id)
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
            await self._ask("clean", {"id": str(number)}, self.timeouts.control, "clean")
        self._remote.pop(number, None)

    async def _ask(self, operation: str, payload: dict[str, Any], timeout: float, what: str) -> Any:
        """Ask the request *operation* of the host, telling it the cleans it has not been told yet."""
        payload["gateway"] = self.link.gateway
        if self._cleans_due:
            payload["cleaned"], self._cleans_due = self._cleans_due, []
            self._cancel_clean_timer()
        try:
            result = await ask(self.session, request_key(self.offer.zid, self.remote_instance, operation), payload,
                               timeout, what=f"{what} of {self.instance} on {self.offer.host}", pending=self._pending)
        except Unanswered:
            raise Unanswered(f"{what} of {self.instance}: its host {self.offer.host} went away, or withdrew "
                             f"{self.remote_instance}, before answering ({self.last_heard()})") from None
        self._last_message = time.monotonic()  # an answer is news from the host
        return result

    def heard_at(self) -> float:
        """When the host was last heard from (a heartbeat, an answer, a port message): seconds since the epoch.

        Kept as it was when the host was found gone (its heartbeats are forgotten then).
        """
        if self._heard_when_lost is not None:
            return self._heard_when_lost
        silence = min(self.link.silence(self.offer.zid), time.monotonic() - self._last_message)
        return time.time() - silence

    def last_heard(self) -> str:
        """When the host was last heard from, said for a message."""
        return heard_text(self.heard_at())

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

        A copy of an older serial is replaced (its request was cleaned and the number reused);
        for an older serial than the copy's, the answer is a copy nobody keeps.
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
            raise RemoteUnreachable(f"{self.instance} is gone: its host {self.offer.host} no longer answers")

    async def session_ended(self, session: str) -> None:
        """Tell the host that this gateway's session *session* ended (nothing to tell when this proxy sent nothing)."""
        if not (self._started and self._sent) or self._gone:
            return
        try:
            await self._ask("session_ended", {"session": session}, self.timeouts.control, "session end")
        except (ComponentError, zenoh.ZError) as exc:
            log.warning("%s: the end of session %r did not reach its host %s (%s): its requests of that session go "
                        "on there", self.instance, session, self.offer.host, exc)

    # -- lifetime -------------------------------------------------------------------------------

    async def start(self) -> None:
        """Follow the instance's events and ports, then take each port's data as it is now."""
        if self._started:
            return
        self._started = True
        zid, instance, gateway = self.offer.zid, self.remote_instance, self.link.gateway
        self._cleans = self.session.declare_publisher(cleaned_key(zid, instance, gateway), express=True,
                                                      congestion_control=zenoh.CongestionControl.BLOCK,
                                                      reliability=zenoh.Reliability.RELIABLE)
        self._subscribers.append(self._cleans)
        # Both on Zenoh's receiving thread (indirect=False), not each on a thread of its own (the
        # default): the loop then takes events and port messages in the order the host sent them, so
        # a request's end never overtakes its last publication (a read after it would see older data).
        # The callbacks only hand the payload to the loop: they never hold that thread up.
        self._subscribers.append(self.session.declare_subscriber(
            events_key(zid, instance, gateway), on_zenoh_thread(self._on_event)))
        self._subscribers.append(self.session.declare_subscriber(
            port_key(zid, instance, "*"), on_zenoh_thread(self._on_port)))
        await asyncio.gather(*(self._fetch(name) for name in self._mirrors))

    async def _fetch(self, name: str) -> None:
        """Take the whole data of port *name* from the host (at start, and after a message went missing)."""
        key = snapshot_key(self.offer.zid, self.remote_instance, name)
        for body in await ask_all(self.session, key, timeout=self.timeouts.control):
            with contextlib.suppress(ValueError):
                header, whole, delta = decode_message(body)
                mirror = self._mirrors[name]
                # Publications that came while this was asked are newer: a base never goes back in time.
                if header.get("kind") != "base" or mirror.version == 0 or header["index"] >= mirror.index:
                    mirror.apply(header, whole, delta)

    def _on_event(self, sample: zenoh.Sample) -> None:
        body = sample.payload.to_bytes()
        self._loop.call_soon_threadsafe(self._take_event, body)

    def _take_event(self, body: bytes) -> None:
        event = orjson.loads(body)
        status = event["status"]
        try:
            number = parse_request_id(self.remote_instance, status["id"])
        except NoSuchRequest:
            return
        # Events travel after the replies: the news may be of a request this gateway already cleaned.
        if self._is_stale(number, status["serial"]):
            return
        request, new = self._track(number, status["serial"], event.get("session"))
        if new and status["status"] == "sent":
            # A request this gateway has not seen yet (its send reply may come after this event),
            # or a new request under a number cleaned elsewhere.
            self.host.announce_request(request)
        if request.take(status):
            self.host.announce_request(request)

    def _on_port(self, sample: zenoh.Sample) -> None:
        self._last_message = time.monotonic()
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

    def _end_all(self, why: str) -> None:
        """End every pending query and every request not ended yet, once, with ``::genom::remote_io``."""
        self._gone = True
        for answer in list(self._pending):
            if not answer.done():
                answer.set_result(GONE)
        for request in list(self._remote.values()):
            if request.take({"status": "error", "exception": {"ex": REMOTE_IO, "detail": {"what": why}}}):
                self.host.announce_request(request)

    def lost(self, why: str) -> None:
        """The host process is gone: end the pending queries and requests with ``::genom::remote_io``, then unload."""
        if self._gone:
            return
        self._heard_when_lost = self.heard_at()
        self._end_all(why)
        self.host.unload_soon(self.instance)

    async def stop(self) -> None:
        """Let go of the instance (it keeps running in its process) and stop following it.

        The motions this proxy sent stop there first, and their copies end as the host ended them
        (``interrupted``, by ``kill``); its other requests go on there, their copies here end with
        ``::genom::remote_io`` saying so.
        """
        if not self._started:
            return
        self._cancel_clean_timer()
        self._publish_cleans()  # the host keeps running: leave it nothing this gateway cleaned
        self._started = False
        if not self._gone:
            self._end_all(await self._let_go())
        for mirror in self._mirrors.values():
            mirror.release()
        for subscriber in self._subscribers:
            with contextlib.suppress(zenoh.ZError):
                subscriber.undeclare()
        for task in list(self._background):
            task.cancel()
        await asyncio.gather(*self._background, return_exceptions=True)


    async def _let_go(self) -> str:
        """Ask the host to stop this proxy's motions (it answers their ends); return why the others end here."""
        host, place = self.offer.host, f"{self.remote_instance}@{self.offer.host}"
        going_on = (f"{self.instance} was unloaded from this gateway; the request goes on on {host} (load {place} "
                    f"to follow it)")
        if not self._sent:
            return going_on
        try:
            self.check_heard()
            released = await self._ask("release", {"via": self._via}, self.timeouts.control, "release")
        except (ComponentError, zenoh.ZError) as exc:
            log.warning("%s was unloaded without reaching its host %s (%s): its motions there stop when the host "
                        "finds this gateway gone", self.instance, host, exc)
            return (f"{self.instance} was unloaded from this gateway without reaching {host} ({exc}): the request "
                    f"may go on there")
        for status in (released or {}).get("ended", []):
            with contextlib.suppress(NoSuchRequest, KeyError, TypeError):
                request = self._remote.get(parse_request_id(self.remote_instance, status["id"]))
                if request is not None and request.serial == status["serial"] and request.take(status):
                    self.host.announce_request(request)
        return going_on


def utc_text(at: float) -> str:
    """The time *at* (seconds since the epoch) in ISO 8601, UTC, to the millisecond: ``2026-11-27T23:08:05.126Z``."""
    return datetime.datetime.fromtimestamp(at, datetime.UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def heard_text(at: float) -> str:
    """``last heard 0.52 s ago, at 2026-11-27T23:08:05.126Z``: when a host was last heard from (*at*: epoch s)."""
    return f"last heard {max(0.0, time.time() - at):.2f} s ago, at {utc_text(at)}"


async def describe_remote(session: zenoh.Session, offer: OfferKey, timeout: float) -> dict[str, Any]:
    """The ``/info`` of the instance *offer* offers."""
    result: dict[str, Any] = await ask(session, info_key(offer.zid, offer.instance), None, timeout=timeout,
                                       what=f"the description of {offer.name}")
    return result
