"""The events of a component host as data: what its requests, instances and sessions did, and when.

A host (``host.events``) hands each event, as an object, to whoever subscribed: the gateway's
sessions (which frame them as server-sent events, in genomix's form or the standard one), a
recorder (which keeps what was commanded when beside the ports), a live view.  The events are
made once and never framed here: each delivery writes them in its own form, at its edge.

* :class:`RequestEvent`: a request was sent or ended (its id, service, input, status, output or
  exception, and when it was sent): what a session's listeners hear as ``request``.
* :class:`InstanceLoaded` and :class:`InstanceUnloaded`: an instance came or went (every session
  hears of an unload, as ``unload``).
* :class:`ComponentsOffered`: a component host offered an instance on Zenoh (every session hears
  it, as ``offered``).
* :class:`SessionEnded`: a gateway's session ended (its listeners heard ``quit``).

A subscriber is called in the event loop, as the event happens, and must not block: it keeps
the event or hands it on.  One that raises is logged and the others are called all the same.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ClassVar, Literal

from ._log_limits import ThrottledLog

if TYPE_CHECKING:
    from ._requests import RequestStatus

__all__ = ["Event", "RequestEvent", "InstanceLoaded", "InstanceUnloaded", "ComponentsOffered", "SessionEnded",
           "HostEvents", "Subscription", "status_object"]

log = logging.getLogger(__name__)
#: A subscriber that fails fails at every event: one traceback, then rate-limited lines.
_failures = ThrottledLog(log)

#: Who hears an event: the listeners of its own session, those of every session, or no session's
#: (a recording, a live view: whoever subscribed to the host's events).
Audience = Literal["its session", "every session", "no session"]


def status_object(request_id: str, status: str, output: dict[str, Any] | None,
                  exception: dict[str, Any] | None) -> dict[str, Any]:
    """A request's JSON status object: ``{"id", "status"}``, and ``output`` once done, ``exception`` once failed."""
    body: dict[str, Any] = {"id": request_id, "status": status}
    if status == "done":
        body["output"] = output or {}
    elif status == "error":
        body["exception"] = exception
    return body


class Event:
    """Something that happened on a host, at a time.

    Attributes:
        time: When, in POSIX seconds of the host's clock (the rig's time: recordings stamp their
            data with it too).
    """

    __slots__ = ("time",)

    #: Its name on the wire (the ``event:`` of a server-sent event).
    name: ClassVar[str] = "event"
    #: Who hears it.
    audience: ClassVar[Audience] = "no session"

    def __init__(self, time: float) -> None:
        self.time = time

    @property
    def session(self) -> str | None:
        """The session it belongs to (None: none in particular)."""
        return None

    def data(self) -> Any:
        """What a listener is told (the ``data:`` of its server-sent event), JSON-ready; None: nothing."""
        return None

    def record(self) -> dict[str, Any]:
        """Everything it says, JSON-ready, its name and time included: what a recording keeps."""
        return {"event": self.name, "time": self.time, "data": self.data()}

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.record()!r}>"


class RequestEvent(Event):
    """A request was sent (it runs on), or it ended: its status as it was then.

    The request itself may have changed since (a ``sent`` event of a request that is done now):
    the event keeps the status, output and exception it had.

    Args:
        request: The request.
        time: When its status became this one.
    """

    __slots__ = ("request", "status", "output", "exception")
    name = "request"
    audience = "its session"

    def __init__(self, request: RequestStatus, time: float) -> None:
        super().__init__(time)
        self.request = request
        self.status = request.status
        self.output = request.output
        self.exception = request.exception

    @property
    def session(self) -> str | None:
        """The session that sent the request (None: it was sent in none)."""
        return self.request.session

    @property
    def id(self) -> str:
        """The request's id, ``"<instance>::<n>"``."""
        return self.request.id

    @property
    def ended(self) -> bool:
        """Whether this is the request's end (``done`` or ``error``)."""
        return self.status != "sent"

    def data(self) -> dict[str, Any]:
        """The request's status object as it was then (what genomix clients read in a ``request`` event)."""
        return status_object(self.request.id, self.status, self.output, self.exception)

    def record(self) -> dict[str, Any]:
        """What was commanded and how it went: id, instance, service, input, session, status, times."""
        request = self.request
        service, given = request.command()
        return {"event": self.name, "time": self.time, "id": request.id, "instance": request.instance,
                "service": service, "input": given, "session": request.session, "sent": request.sent or None,
                **{k: v for k, v in self.data().items() if k != "id"}}


class InstanceLoaded(Event):
    """An instance was loaded (started, and listed by its host).

    Args:
        instance: Its name.
        component: The component it is an instance of.
        time: When.
    """

    __slots__ = ("instance", "component")
    name = "load"

    def __init__(self, instance: str, component: str, time: float) -> None:
        super().__init__(time)
        self.instance, self.component = instance, component

    def data(self) -> dict[str, str]:
        """The instance and its component."""
        return {"instance": self.instance, "component": self.component}


class InstanceUnloaded(Event):
    """An instance was unloaded (by a client, by its own ``kill``, or with the host of another process).

    Args:
        instance: Its name.
        time: When.
    """

    __slots__ = ("instance",)
    name = "unload"
    audience = "every session"

    def __init__(self, instance: str, time: float) -> None:
        super().__init__(time)
        self.instance = instance

    def data(self) -> str:
        """The instance's name."""
        return self.instance


class ComponentsOffered(Event):
    """A component host offered an instance on Zenoh.

    Args:
        offer: ``{"name": instance, "host": host id, "loaded": the name it was loaded again under, or None}``.
        time: When.
    """

    __slots__ = ("offer",)
    name = "offered"
    audience = "every session"

    def __init__(self, offer: dict[str, Any], time: float) -> None:
        super().__init__(time)
        self.offer = offer

    def data(self) -> dict[str, Any]:
        """The offer."""
        return self.offer


class SessionEnded(Event):
    """A gateway's session ended: its client stopped it, or it expired unlistened.

    Its listeners heard ``quit`` (whose data, in the standard form, is the session's name).

    Args:
        session: The session.
        time: When.
    """

    __slots__ = ("_session",)
    name = "quit"

    def __init__(self, session: str, time: float) -> None:
        super().__init__(time)
        self._session = session

    @property
    def session(self) -> str:
        """The session that ended."""
        return self._session

    def data(self) -> str:
        """The session's name."""
        return self._session


#: A subscriber: called with each event it subscribed to.
Subscriber = Callable[[Event], None]


class Subscription:
    """A subscriber of a host's events, until :meth:`close` (or the end of a ``with``)."""

    __slots__ = ("events", "subscriber", "scope")

    def __init__(self, events: HostEvents, subscriber: Subscriber, scope: str | None | bool) -> None:
        self.events, self.subscriber, self.scope = events, subscriber, scope

    def close(self) -> None:
        """Stop calling the subscriber (idempotent)."""
        self.events._remove(self)

    def __enter__(self) -> Subscription:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class HostEvents:
    """The events of one host, handed as objects to their subscribers (``host.events``).

    Args:
        wall: The host clock's POSIX time (events are stamped with it).
    """

    def __init__(self, wall: Callable[[], float]) -> None:
        self.wall = wall
        self._every: list[Subscription] = []
        self._in_sessions: list[Subscription] = []
        self._by_session: dict[str, list[Subscription]] = {}

    def subscribe(self, subscriber: Subscriber, session: str | None = None, *,
                  sessions_only: bool = False) -> Subscription:
        """Call *subscriber* with each event of the host from now on, or of one session.

        Args:
            subscriber: Called with each event; it must not block.
            session: Only the events of this session: its requests' and its end, and those every
                session hears (unloads, offers).  None: every event.
            sessions_only: With no *session*: every event but those of requests sent in no session
                (what a gateway's sessions are told).

        Returns:
            The subscription: ``close()`` it to stop.
        """
        scope: str | None | bool = session if session is not None else (True if sessions_only else None)
        subscription = Subscription(self, subscriber, scope)
        if session is not None:
            self._by_session.setdefault(session, []).append(subscription)
        elif sessions_only:
            self._in_sessions.append(subscription)
        else:
            self._every.append(subscription)
        return subscription

    def _remove(self, subscription: Subscription) -> None:
        scope = subscription.scope
        if isinstance(scope, str):
            subscribers = self._by_session.get(scope, [])
            if subscription in subscribers:
                subscribers.remove(subscription)
            if not subscribers:
                self._by_session.pop(scope, None)
        else:
            subscribers = self._in_sessions if scope is True else self._every
            if subscription in subscribers:
                subscribers.remove(subscription)

    def wanted(self, session: str | None) -> bool:
        """Whether any subscriber wants the events of a request sent in *session* (None: in none)."""
        if self._every:
            return True
        return session is not None and (bool(self._in_sessions) or session in self._by_session)

    def request_changed(self, request: RequestStatus) -> None:
        """Publish the status *request* has now (sent, or ended), if anyone wants it."""
        if self.wanted(request.session):
            self.publish(RequestEvent(request, self.wall()))

    def publish(self, event: Event) -> None:
        """Hand *event* to every subscriber that wants it."""
        session = event.session
        in_session = session is not None or event.audience == "every session"
        targets = [*self._every, *self._in_sessions] if in_session else list(self._every)
        if event.audience == "every session":
            for subscribers in self._by_session.values():
                targets.extend(subscribers)
        elif session is not None:
            targets.extend(self._by_session.get(session, ()))
        for subscription in targets:
            try:
                subscription.subscriber(event)
            except Exception as exc:  # noqa: BLE001  # one subscriber's fault: the others hear the event
                _failures.error("a subscriber of the host's events failed on %s: %s", event.name,
                                f"{type(exc).__name__}: {exc}", exc=exc)
