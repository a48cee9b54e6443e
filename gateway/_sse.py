"""Server-sent events: event framing, and the two forms of an event stream response.

genomix's own clients (Tcl, MATLAB, python-genomix) read the listen socket with
hand-written HTTP code, so by default a stream is sent the way genomixd sends
it: no ``Transfer-Encoding: chunked`` and no ``Content-Length`` (the body runs
until the connection closes), each event flushed as soon as it exists, and
``quit`` a bare ``event: quit`` line.

Standard clients say what they are: a WHATWG ``EventSource`` (every browser)
always sends ``Accept: text/event-stream``, and so do aiohttp-sse-client,
httpx-sse and sseclient-py when told to.  They get the standard form
(docs/decisions/0023): chunked framing, which their HTTP libraries hand over
chunk by chunk (a close-delimited body is read in blocks, so a line-buffered
client saw each event only when the next one's bytes came); an ``id:`` on every
event; and ``data:`` on ``quit`` and ``unload`` too, since an EventSource
never dispatches an event without data.  The ``id`` of the last event of a
stream (``quit``, ``unload``) is :data:`FINAL_ID`: a client that reconnects
with it as ``Last-Event-ID`` is answered 204, which stops an EventSource for
good, so a stopped session is never started again by a reconnect.

A session's events are objects (``aiogenomix.components.core.Event``): each form
(:data:`GENOMIX_FORM`, :data:`STANDARD_FORM`) frames them here, at the edge.
"""

from __future__ import annotations

import orjson
from aiohttp import web

from ..components.core import Event, SessionEnded
from ._access import allow_origin, other_origin
from ._replies import SERVER_HEADER

__all__ = ["format_event", "event_id", "EventStream", "event_stream", "wants_standard", "PING", "FINAL_ID",
           "EventForm", "GENOMIX_FORM", "STANDARD_FORM"]

#: An SSE comment, sent on idle streams so that a vanished client is noticed.
PING = b": ping\n\n"
#: The id of the event that ends a stream (``quit``, ``unload``): a reconnect carrying it gets 204.
FINAL_ID = "end"
_STANDARD = "text/event-stream"
_HEADERS = {"Content-Type": "text/event-stream", "Cache-Control": "no-cache", "X-Accel-Buffering": "no",
            **SERVER_HEADER}


def format_event(event: str, data: bytes | None = None) -> bytes:
    """Frame one event: ``event: NAME``, an optional one-line ``data:``, a blank line.

    Args:
        event: The event name (``request``, ``unload``, ``quit``, ``port``).
        data: Compact JSON, on one line (JSON never needs a raw newline).
    """
    if "\n" in event or (data is not None and b"\n" in data):
        raise ValueError("SSE event names and data must be single lines")
    if data is None:
        return b"event: " + event.encode() + b"\n\n"
    return b"event: " + event.encode() + b"\ndata: " + data + b"\n\n"


def event_id(identifier: int | str) -> bytes:
    """The ``id:`` line that goes before an event of the standard form."""
    return b"id: %s\n" % str(identifier).encode()


class EventForm:
    """How a listen stream writes a session's events: genomix's form, or (*standard*) the one with ids.

    Args:
        standard: Whether each event carries its ``id:`` (and ``quit`` its data).
    """

    def __init__(self, standard: bool) -> None:
        self.standard = standard

    def frame(self, number: int, event: Event) -> bytes:
        """The bytes of *event*, the session's event *number*, in this form."""
        if isinstance(event, SessionEnded):
            # genomix's quit is a bare event line; the standard one has data (an EventSource drops an
            # event without) and the final id, which a reconnect carrying it gets 204 for.
            if not self.standard:
                return format_event("quit")
            return event_id(FINAL_ID) + format_event("quit", orjson.dumps(event.data()))
        framed = format_event(event.name, orjson.dumps(event.data(), option=orjson.OPT_SERIALIZE_NUMPY))
        return event_id(number) + framed if self.standard else framed

    def __repr__(self) -> str:
        return f"<EventForm {'standard' if self.standard else 'genomix'}>"


#: genomix's form: what its Tcl, MATLAB and Python clients read.
GENOMIX_FORM = EventForm(standard=False)
#: The standard form, with ids: what an EventSource reads.
STANDARD_FORM = EventForm(standard=True)


def wants_standard(request: web.BaseRequest) -> bool:
    """Whether the client asked for the standard form (``Accept: text/event-stream``)."""
    return _STANDARD in request.headers.get("Accept", "")


class EventStream(web.StreamResponse):
    """A ``text/event-stream`` response in the standard form: chunked on HTTP/1.1, with ids.

    The connection closes after it: a stream that ends is a stream its client
    reconnects to, on a new connection.
    """

    standard = True

    def __init__(self) -> None:
        super().__init__(status=200, headers=_HEADERS)
        self.force_close()


class GenomixEventStream(EventStream):
    """A ``text/event-stream`` response in genomix's form: delimited by closing the connection.

    aiohttp switches an HTTP/1.1 response with no length to chunked transfer
    coding; turning its length check off (as its own WebSocket response does)
    keeps the body raw, and closing the connection tells the client where it ends.
    """

    standard = False
    # Private to aiohttp (pinned by the range ./run test checks at both ends, docs/decisions/0037): aiohttp
    # has no public way to send an HTTP/1.1 body of unknown length unchunked; such a switch would replace it.
    _length_check = False


def event_stream(request: web.BaseRequest) -> EventStream:
    """The stream response in the form *request* asked for, readable by the page of another origin that made it.

    (The door let the request in: an other origin it comes from is an allowed one.)
    """
    stream = EventStream() if wants_standard(request) else GenomixEventStream()
    origin = other_origin(request.headers, request.scheme)
    if origin is not None:
        allow_origin(stream, origin)
    return stream
