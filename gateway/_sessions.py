"""Sessions: named contexts whose events reach their listeners over server-sent events.

A session keeps its events as objects (the host's :class:`~aiogenomix.components.core.Event`:
its requests' changes, the unloads and offers every session hears); each listener writes
them in its own form (``_sse``: genomix's, or the standard one with ids), framed once per
form and shared.  Each listener has its own bounded buffer, so a slow or stalled reader never
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

from ..components.core import NAME_FORBIDDEN, Event, SessionEnded, forbidden_in_name
from ._errors import BadQuery, NoSuchSession, TooManySessions
from ._sse import GENOMIX_FORM, EventForm

__all__ = ["Listener", "Logged", "Session", "SessionStore", "check_session_name", "MAX_NAME_LENGTH",
           "NAME_FORBIDDEN", "WRITE_SLICE"]

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


class Logged:
    """An event as a session keeps it: its number in the session, and its frames once made.

    A form frames the event the first time a listener of that form takes it; the frame is kept
    here, so that every listener of the form shares it (a listener holds references, never copies).

    Attributes:
        number: Its number in the session (the standard form's ``id``).
        event: The event.
    """

    __slots__ = ("number", "event", "_frames")

    def __init__(self, number: int, event: Event) -> None:
        self.number, self.event = number, event
        self._frames: dict[EventForm, bytes] | None = None

    def framed(self, form: EventForm) -> bytes:
        """The event's bytes in *form*, made once."""
        frames = self._frames
        if frames is None:
            frames = self._frames = {}
        frame = frames.get(form)
        if frame is None:
            frame = frames[form] = form.frame(self.number, self.event)
        return frame


class Listener:
    """One open listen stream: a bounded buffer of its session's events, written in its form.

    The buffer holds the session's own :class:`Logged` events, framed as they are taken and the
    frames shared: a storm of listens replaying the session's latest events costs a pointer per
    event each, not the events again.

    Args:
        limit: How many undelivered events it may hold before it is dropped.
        alive: Whether its connection is still open (a vanished client is only
            noticed at the next write otherwise, and its events would be lost).
        form: How the stream writes events (genomix's form by default).
    """

    def __init__(self, limit: int, alive: Callable[[], bool] = lambda: True, form: EventForm = GENOMIX_FORM) -> None:
        self.limit = limit
        self.alive = alive
        self.form = form
        self.events: deque[Logged] = deque()
        self.ready = asyncio.Event()
        self.overflowed = False
        self.closed = False

    def offer(self, logged: Logged) -> None:
        """Queue one event of its session (never blocks)."""
        if self.closed:
            return
        if len(self.events) >= self.limit:
            self.overflowed = True
        else:
            self.events.append(logged)
        self.ready.set()

    def quit(self, ended: SessionEnded) -> None:
        """Queue ``quit`` (the session ended), then end the stream."""
        self.events.append(Logged(0, ended))
        self.close()

    def close(self) -> None:
        """End the stream after the events already queued."""
        self.closed = True
        self.ready.set()

    @property
    def ended(self) -> bool:
        """Whether the stream is over: closed or overflowed, and nothing is left to write."""
        return (self.closed or self.overflowed) and not self.events

    def take(self, most: int = WRITE_SLICE) -> bytes:
        """The next events framed, joined into one write of at most *most* bytes (or one event, if larger).

        A replay of the session's latest events goes out in such slices, each written when the
        connection has taken the one before: a listen that dies in the middle held one slice.
        """
        events, form = self.events, self.form
        taken = [events.popleft().framed(form)] if events else []
        size = len(taken[0]) if taken else 0
        while events:
            frame = events[0].framed(form)
            if size + len(frame) > most:
                break
            size += len(frame)
            taken.append(frame)
            events.popleft()
        if not events:
            self.ready.clear()
        return taken[0] if len(taken) == 1 else b"".join(taken)


class Session:
    """A named session: its latest events and its listeners.

    Args:
        name: The session name.
        backlog: How many of its latest events it keeps (for listeners that attach or come back).
        listener_limit: The buffer size of each listener.
    """

    def __init__(self, name: str, backlog: int = 1000, listener_limit: int = 10000) -> None:
        self.name = name
        self.listeners: set[Listener] = set()
        #: The latest events (the oldest go first).
        self.recent: deque[Logged] = deque(maxlen=backlog)
        #: The number of the session's last event (a standard stream's event ids).
        self.events = 0
        #: The number of the last event offered to a listener: those after it wait for one.
        self.offered = 0
        self.listener_limit = listener_limit
        #: When a client last used the session (its store's clock), for the expiry of unlistened sessions.
        self.used = 0.0

    def deliver(self, event: Event) -> None:
        """Hand *event* to every live listener, and keep it among the latest (see :meth:`attach`)."""
        self.prune()
        self.events += 1
        logged = Logged(self.events, event)
        self.recent.append(logged)
        if self.listeners:
            self.offered = self.events
        for listener in self.listeners:
            listener.offer(logged)

    def attach(self, alive: Callable[[], bool] = lambda: True, form: EventForm = GENOMIX_FORM,
               last_id: str | None = None) -> Listener:
        """Open a listener (in genomix's form, or another).

        It first receives the events kept after *last_id* (a standard stream's ``Last-Event-ID``,
        when it names one of this session's events), else those no listener was offered.
        """
        listener = Listener(self.listener_limit, alive, form)
        after = self._resumed_after(last_id)
        for logged in self.recent:
            if logged.number > after:
                listener.offer(logged)
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

    def stop(self, ended: SessionEnded) -> None:
        """Send ``quit`` to every listener and end their streams."""
        for listener in self.listeners:
            listener.quit(ended)
        self.listeners.clear()
        self.recent.clear()


class SessionStore:
    """Every session of the gateway, and the routing of the host's events to them (:meth:`route`).

    Args:
        backlog: How many of its latest events each session keeps.
        listener_limit: The buffer size of each listener.
        idle_timeout: Seconds after which a session with no listener, unused by
            any client, is forgotten.
        max_sessions: How many sessions may exist at once.
        clock: Seconds, monotonic (a parameter so that tests need not wait).
        wall: POSIX seconds, which stamp a session's end.
    """

    def __init__(self, backlog: int = 1000, listener_limit: int = 10000, idle_timeout: float = 600.0,
                 max_sessions: int = 256, clock: Callable[[], float] = time.monotonic,
                 wall: Callable[[], float] = time.time) -> None:
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
        self.wall = wall
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

    def attach(self, session: Session, alive: Callable[[], bool] = lambda: True, form: EventForm = GENOMIX_FORM,
               last_id: str | None = None) -> Listener:
        """Open a listener of *session* (see :meth:`Session.attach`); a session listened to never expires."""
        listener = session.attach(alive, form, last_id)
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
        self.get(name).stop(SessionEnded(name, self.wall()))
        self._forget(name)

    def route(self, event: Event) -> None:
        """Deliver a host's event to the sessions that hear it: its own (if it has not expired), or every one.

        Subscribe it to the host's events (``host.events.subscribe(store.route, sessions_only=True)``).
        """
        if event.audience == "every session":
            self.broadcast(event)
        elif event.audience == "its session" and event.session is not None:
            session = self._live(event.session)
            if session is not None:
                session.deliver(event)

    def broadcast(self, event: Event) -> None:
        """Deliver *event* to every session."""
        self.expire()
        for session in self._sessions.values():
            session.deliver(event)

    def stop_all(self) -> None:
        """Stop every session (gateway shutdown)."""
        for name, session in self._sessions.items():
            session.stop(SessionEnded(name, self.wall()))
        self._sessions.clear()
        self._idle.clear()
