"""Sessions: named contexts whose request events reach their listeners over server-sent events.

Each listener has its own bounded buffer, so a slow or stalled reader never
delays the others: when its buffer overflows, its stream is closed (the client
reconnects and re-reads the status of its pending requests).  Events for a
session that has no listener yet are kept in a bounded backlog and delivered
when one attaches, so a client that listens just after sending loses nothing.
"""

from __future__ import annotations

import asyncio
import itertools
from collections import deque
from collections.abc import Callable

import orjson

from ..components.core import Request
from ._errors import NoSuchSession
from ._sse import format_event

__all__ = ["Listener", "Session", "SessionStore"]

_JSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY


class Listener:
    """One open listen stream: a bounded buffer of framed events.

    Args:
        limit: How many undelivered events it may hold before it is dropped.
        alive: Whether its connection is still open (a vanished client is only
            noticed at the next write otherwise, and its events would be lost).
    """

    def __init__(self, limit: int, alive: Callable[[], bool] = lambda: True) -> None:
        self.limit = limit
        self.alive = alive
        self.frames: deque[bytes] = deque()
        self.ready = asyncio.Event()
        self.overflowed = False
        self.closed = False

    def offer(self, frame: bytes) -> None:
        """Queue a framed event (never blocks)."""
        if self.closed:
            return
        if len(self.frames) >= self.limit:
            self.overflowed = True
        else:
            self.frames.append(frame)
        self.ready.set()

    def close(self) -> None:
        """End the stream after the frames already queued."""
        self.closed = True
        self.ready.set()

    def take(self) -> bytes:
        """Everything queued, joined into one write."""
        data = b"".join(self.frames)
        self.frames.clear()
        self.ready.clear()
        return data


class Session:
    """A named session and its listeners.

    Args:
        name: The session name.
        backlog: How many events to keep while no listener is attached.
        listener_limit: The buffer size of each listener.
    """

    def __init__(self, name: str, backlog: int = 1000, listener_limit: int = 10000) -> None:
        self.name = name
        self.listeners: set[Listener] = set()
        self.backlog: deque[bytes] = deque(maxlen=backlog)
        self.listener_limit = listener_limit

    def deliver(self, frame: bytes) -> None:
        """Send a framed event to every live listener (or keep it until one attaches)."""
        for listener in [listener for listener in self.listeners if not listener.alive()]:
            listener.close()
            self.listeners.discard(listener)
        if not self.listeners:
            self.backlog.append(frame)
        for listener in self.listeners:
            listener.offer(frame)

    def attach(self, alive: Callable[[], bool] = lambda: True) -> Listener:
        """Open a listener; it first receives the backlog."""
        listener = Listener(self.listener_limit, alive)
        while self.backlog:
            listener.offer(self.backlog.popleft())
        self.listeners.add(listener)
        return listener

    def detach(self, listener: Listener) -> None:
        """Forget a listener whose stream ended."""
        self.listeners.discard(listener)

    def stop(self) -> None:
        """Send ``quit`` to every listener and end their streams."""
        quit_frame = format_event("quit")
        for listener in self.listeners:
            listener.offer(quit_frame)
            listener.close()
        self.listeners.clear()
        self.backlog.clear()


class SessionStore:
    """Every session of the gateway, and the routing of request events to them."""

    def __init__(self, backlog: int = 1000, listener_limit: int = 10000) -> None:
        self._sessions: dict[str, Session] = {}
        self._numbers = itertools.count(1)
        self._backlog = backlog
        self._listener_limit = listener_limit

    def __len__(self) -> int:
        return len(self._sessions)

    def start(self, name: str = "") -> Session:
        """Start a session (an empty name picks a unique one); an existing name is reused."""
        if not name:
            name = next(f"s{n}" for n in self._numbers if f"s{n}" not in self._sessions)
        return self.get_or_create(name)

    def get(self, name: str) -> Session:
        """The session *name*.

        Raises:
            NoSuchSession: when there is none.
        """
        try:
            return self._sessions[name]
        except KeyError:
            raise NoSuchSession(f"no session {name!r}") from None

    def get_or_create(self, name: str) -> Session:
        """The session *name*, created if needed (genomix clients may listen before starting)."""
        session = self._sessions.get(name)
        if session is None:
            session = self._sessions[name] = Session(name, self._backlog, self._listener_limit)
        return session

    def stop(self, name: str) -> None:
        """Stop and forget the session *name*.

        Raises:
            NoSuchSession: when there is none.
        """
        self.get(name).stop()
        del self._sessions[name]

    def route_request(self, request: Request) -> None:
        """Deliver a ``request`` event to the request's session, if it has one."""
        if request.session is None:
            return
        session = self._sessions.get(request.session)
        if session is not None:
            session.deliver(format_event("request", orjson.dumps(request.status_object(), option=_JSON_OPTIONS)))

    def broadcast(self, frame: bytes) -> None:
        """Deliver a framed event to every session."""
        for session in self._sessions.values():
            session.deliver(frame)

    def stop_all(self) -> None:
        """Stop every session (gateway shutdown)."""
        for session in self._sessions.values():
            session.stop()
        self._sessions.clear()
