"""Sessions: named contexts whose request events reach their listeners over server-sent events.

Each listener has its own bounded buffer, so a slow or stalled reader never
delays the others: when its buffer overflows, its stream is closed (the client
reconnects and re-reads the status of its pending requests).  A session keeps its
latest events (a bounded number): a listener that attaches gets those nobody has
been offered yet, so a client that listens just after sending loses nothing, and
a standard stream opened again with ``Last-Event-ID`` gets every one after that
id, including those offered to its previous connection while it was dying
unnoticed.

Any client may name a session, so what sessions hold is bounded: a session
nobody listens to is forgotten after an idle time (its requests run on and keep
their status; only its undelivered events go), and there is a cap on their
number.  Names are checked: at most 128 characters, none of them a character no
client's name may hold (the core's ``NAME_FORBIDDEN``: control characters, line
separators, bidirectional controls).
"""

from __future__ import annotations

import asyncio
import itertools
import time
from collections import OrderedDict, deque
from collections.abc import Callable

import orjson

from ..components.core import NAME_FORBIDDEN, forbidden_in_name
from ..components.core.runtime import RequestStatus
from ._errors import BadQuery, NoSuchSession, TooManySessions
from ._sse import FINAL_ID, event_id, format_event

__all__ = ["Listener", "Event", "Session", "SessionStore", "check_session_name", "MAX_NAME_LENGTH", "NAME_FORBIDDEN",
           "WRITE_SLICE"]

_JSON_OPTIONS = orjson.OPT_SERIALIZE_NUMPY

#: The longest session name, in characters.
MAX_NAME_LENGTH = 128
#: The most bytes of events a listen stream writes at once (a replay of many events goes out in slices).
WRITE_SLICE = 16 * 1024


def check_session_name(name: str) -> str:
    """Return *name* if it can name a session.

    Raises:
        BadQuery: for a character no client's name may hold (``NAME_FORBIDDEN``: control characters,
            line separators, bidirectional controls), or more than 128 characters.
    """
    forbidden = forbidden_in_name(name)
    if forbidden is not None:
        raise BadQuery(f"session name {_shown(name)} holds {forbidden}: control characters, line separators and "
                       "bidirectional controls are refused")
    if len(name) > MAX_NAME_LENGTH:
        raise BadQuery(f"session name {_shown(name)} is longer than {MAX_NAME_LENGTH} characters")
    return name


def _shown(name: str) -> str:
    text = ascii(name)
    return text if len(text) <= 60 else text[:57] + "..."


class Listener:
    """One open listen stream: a bounded buffer of framed events.

    The frames are the session's own (made once per event, in both forms): a listener holds
    references, never copies, so that a storm of listens replaying the session's latest events
    costs a pointer per event each, not the events again.

    Args:
        limit: How many undelivered events it may hold before it is dropped.
        alive: Whether its connection is still open (a vanished client is only
            noticed at the next write otherwise, and its events would be lost).
        standard: Whether the stream is in the standard form (an ``id`` on each event,
            data on ``quit``: see ``_sse``), else genomix's.
    """

    def __init__(self, limit: int, alive: Callable[[], bool] = lambda: True, standard: bool = False) -> None:
        self.limit = limit
        self.alive = alive
        self.standard = standard
        self.frames: deque[bytes] = deque()
        self.ready = asyncio.Event()
        self.overflowed = False
        self.closed = False

    def offer(self, event: Event) -> None:
        """Queue one event of its session, in the listener's form (never blocks)."""
        if self.closed:
            return
        if len(self.frames) >= self.limit:
            self.overflowed = True
        else:
            self.frames.append(event.standard if self.standard else event.frame)
        self.ready.set()

    def quit(self, session: str) -> None:
        """Queue ``quit`` (*session* stopped), then end the stream."""
        if self.standard:
            self.frames.append(event_id(FINAL_ID) + format_event("quit", orjson.dumps(session)))
        else:
            self.frames.append(format_event("quit"))
        self.close()

    def close(self) -> None:
        """End the stream after the frames already queued."""
        self.closed = True
        self.ready.set()

    @property
    def ended(self) -> bool:
        """Whether the stream is over: closed or overflowed, and nothing is left to write."""
        return (self.closed or self.overflowed) and not self.frames

    def take(self, most: int = WRITE_SLICE) -> bytes:
        """The next frames, joined into one write of at most *most* bytes (or one frame, if larger).

        A replay of the session's latest events goes out in such slices, each written when the
        connection has taken the one before: a listen that dies in the middle held one slice.
        """
        frames = self.frames
        taken = [frames.popleft()] if frames else []
        size = len(taken[0]) if taken else 0
        while frames and size + len(frames[0]) <= most:
            size += len(frames[0])
            taken.append(frames.popleft())
        if not frames:
            self.ready.clear()
        return taken[0] if len(taken) == 1 else b"".join(taken)


class Event:
    """An event of a session, framed once in each form.

    Attributes:
        number: Its number in the session (the standard form's ``id``).
        frame: genomix's form.
        standard: The standard form (``id:`` line first).
    """

    __slots__ = ("number", "frame", "standard")

    def __init__(self, frame: bytes, number: int) -> None:
        self.number, self.frame = number, frame
        self.standard = event_id(number) + frame


class Session:
    """A named session and its listeners.

    Args:
        name: The session name.
        backlog: How many of its latest events it keeps (for listeners that attach or come back).
        listener_limit: The buffer size of each listener.
    """

    def __init__(self, name: str, backlog: int = 1000, listener_limit: int = 10000) -> None:
        self.name = name
        self.listeners: set[Listener] = set()
        #: The latest events (the oldest go first).
        self.recent: deque[Event] = deque(maxlen=backlog)
        #: The number of the session's last event (a standard stream's event ids).
        self.events = 0
        #: The number of the last event offered to a listener: those after it wait for one.
        self.offered = 0
        self.listener_limit = listener_limit
        #: When a client last used the session (its store's clock), for the expiry of unlistened sessions.
        self.used = 0.0

    def deliver(self, frame: bytes) -> None:
        """Send a framed event to every live listener, and keep it among the latest (see :meth:`attach`)."""
        self.prune()
        self.events += 1
        event = Event(frame, self.events)
        self.recent.append(event)
        if self.listeners:
            self.offered = self.events
        for listener in self.listeners:
            listener.offer(event)

    def attach(self, alive: Callable[[], bool] = lambda: True, standard: bool = False,
               last_id: str | None = None) -> Listener:
        """Open a listener (in the standard form or genomix's).

        It first receives the events kept after *last_id* (a standard stream's ``Last-Event-ID``,
        when it names one of this session's events), else those no listener was offered.
        """
        listener = Listener(self.listener_limit, alive, standard)
        after = self._resumed_after(last_id)
        for event in self.recent:
            if event.number > after:
                listener.offer(event)
        self.offered = self.events
        self.listeners.add(listener)
        return listener

    def _resumed_after(self, last_id: str | None) -> int:
        """The number of the last event the attaching client had: *last_id*'s, or the last one offered."""
        # A header any client writes: only plain decimal digits name an event (not "²", nor 5,000 digits).
        if last_id is not None and len(last_id) <= 20 and last_id.isascii() and last_id.isdigit() \
                and int(last_id) <= self.events:
            return int(last_id)
        return self.offered

    def detach(self, listener: Listener) -> None:
        """Forget a listener whose stream ended."""
        self.listeners.discard(listener)

    def prune(self) -> bool:
        """Close and forget the listeners whose connection has gone; return whether there were any."""
        gone = [listener for listener in self.listeners if not listener.alive()]
        for listener in gone:
            listener.close()
            self.listeners.discard(listener)
        return bool(gone)

    def stop(self) -> None:
        """Send ``quit`` to every listener and end their streams."""
        for listener in self.listeners:
            listener.quit(self.name)
        self.listeners.clear()
        self.recent.clear()


class SessionStore:
    """Every session of the gateway, and the routing of request events to them.

    Args:
        backlog: How many of its latest events each session keeps.
        listener_limit: The buffer size of each listener.
        idle_timeout: Seconds after which a session with no listener, unused by
            any client, is forgotten.
        max_sessions: How many sessions may exist at once.
        clock: Seconds, monotonic (a parameter so that tests need not wait).
    """

    def __init__(self, backlog: int = 1000, listener_limit: int = 10000, idle_timeout: float = 600.0,
                 max_sessions: int = 256, clock: Callable[[], float] = time.monotonic) -> None:
        self._sessions: dict[str, Session] = {}
        # The sessions nobody listens to, least recently used first: expiry looks at the front only,
        # so that starting a session costs the same with 15,000 of them as with one.
        self._idle: OrderedDict[str, Session] = OrderedDict()
        self._numbers = itertools.count(1)
        self._backlog = backlog
        self._listener_limit = listener_limit
        self.idle_timeout = idle_timeout
        self.max_sessions = max_sessions
        self.clock = clock
        self._end_listeners: list[Callable[[str], None]] = []

    def __len__(self) -> int:
        self.expire()
        return len(self._sessions)

    def start(self, name: str = "") -> Session:
        """Start a session (an empty name picks a unique one); an existing name is reused.

        Raises:
            BadQuery: for a name that cannot name a session.
            TooManySessions: when a new session would pass the cap.
        """
        if not name:
            self.expire()
            name = next(f"s{n}" for n in self._numbers if f"s{n}" not in self._sessions)
        return self.get_or_create(name)

    def get(self, name: str) -> Session:
        """The session *name*.

        Raises:
            BadQuery: for a name that cannot name a session.
            NoSuchSession: when there is none (or it expired).
        """
        session = self._live(check_session_name(name))
        if session is None:
            raise NoSuchSession(f"no session {_shown(name)}")
        return session

    def get_or_create(self, name: str) -> Session:
        """The session *name*, created if needed (genomix clients may listen before starting).

        Raises:
            BadQuery: for a name that cannot name a session.
            TooManySessions: when a new session would pass the cap.
        """
        session = self._live(name)
        if session is None:
            check_session_name(name)
            self.expire()
            if len(self._sessions) >= self.max_sessions:
                raise TooManySessions(
                    f"{len(self._sessions)} sessions exist, the most this gateway keeps: stop one "
                    f"(/session/stop), or wait: a session nobody listens to ends after {self.idle_timeout:g} s unused"
                )
            session = self._sessions[name] = Session(name, self._backlog, self._listener_limit)
        self._used(session)
        return session

    def _used(self, session: Session) -> None:
        """A client used *session* now: its idle time starts again."""
        session.used = self.clock()
        if not session.listeners:
            self._idle[session.name] = session
            self._idle.move_to_end(session.name)

    def expire(self) -> None:
        """Forget the sessions that nobody listens to and no client used for ``idle_timeout`` seconds."""
        deadline = self.clock() - self.idle_timeout
        while self._idle:
            name, session = next(iter(self._idle.items()))
            if session.used > deadline:
                return
            self._forget(name)

    def add_end_listener(self, listener: Callable[[str], None]) -> None:
        """Call *listener* with the name of each session that ends: stopped, or expired (not at shutdown)."""
        self._end_listeners.append(listener)

    async def expire_on_time(self) -> None:
        """Expire sessions as their idle time passes, not only when a client next comes (runs until cancelled).

        What ends with a session (a recording of it) must not wait for a client that may never come:
        the sessions are looked at every tenth of the idle time, at most every 5 s.
        """
        period = min(max(self.idle_timeout / 10, 0.01), 5.0)
        while True:
            await asyncio.sleep(period)
            self.expire()

    def _forget(self, name: str) -> None:
        del self._sessions[name]
        self._idle.pop(name, None)
        for listener in self._end_listeners:
            listener(name)

    def _live(self, name: str) -> Session | None:
        session = self._sessions.get(name)
        if session is not None and name in self._idle and self.clock() - session.used >= self.idle_timeout:
            self._forget(name)
            return None
        return session

    def attach(self, session: Session, alive: Callable[[], bool] = lambda: True, standard: bool = False,
               last_id: str | None = None) -> Listener:
        """Open a listener of *session* (see :meth:`Session.attach`); a session listened to never expires."""
        listener = session.attach(alive, standard, last_id)
        self._idle.pop(session.name, None)
        return listener

    def detach(self, session: Session, listener: Listener) -> None:
        """Forget a listener whose stream ended; the session's idle time starts when its last one goes."""
        session.detach(listener)
        if self._sessions.get(session.name) is session:
            self._used(session)

    def stop(self, name: str) -> None:
        """Stop and forget the session *name*.

        Raises:
            NoSuchSession: when there is none.
        """
        self.get(name).stop()
        self._forget(name)

    def route_request(self, request: RequestStatus) -> None:
        """Deliver a ``request`` event to the request's session, if it has one (and it has not expired)."""
        if request.session is None:
            return
        session = self._live(request.session)
        if session is not None:
            session.deliver(format_event("request", orjson.dumps(request.status_object(), option=_JSON_OPTIONS)))

    def broadcast(self, frame: bytes) -> None:
        """Deliver a framed event to every session."""
        self.expire()
        for session in self._sessions.values():
            session.deliver(frame)

    def stop_all(self) -> None:
        """Stop every session (gateway shutdown)."""
        for session in self._sessions.values():
            session.stop()
        self._sessions.clear()
        self._idle.clear()
