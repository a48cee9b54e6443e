"""Server-sent events on ``/session/listen``: event framing, and a close-delimited stream response.

genomix's own clients (Tcl, MATLAB, python-genomix) read the listen socket with
hand-written HTTP code, so the stream is sent the way genomixd sends it: no
``Transfer-Encoding: chunked`` and no ``Content-Length`` — the body simply runs
until the connection closes — and each event is flushed as soon as it exists.
"""

from __future__ import annotations

from aiohttp import web

from ._replies import SERVER_HEADER

__all__ = ["format_event", "EventStream", "PING"]

#: An SSE comment, sent on idle streams so that a vanished client is noticed.
PING = b": ping\n\n"


def format_event(event: str, data: bytes | None = None) -> bytes:
    """Frame one event: ``event: NAME``, an optional one-line ``data:``, a blank line.

    Args:
        event: The event name (``request``, ``unload``, ``quit``).
        data: Compact JSON, on one line (JSON never needs a raw newline).
    """
    if "\n" in event or (data is not None and b"\n" in data):
        raise ValueError("SSE event names and data must be single lines")
    if data is None:
        return b"event: " + event.encode() + b"\n\n"
    return b"event: " + event.encode() + b"\ndata: " + data + b"\n\n"


class EventStream(web.StreamResponse):
    """A ``text/event-stream`` response delimited by closing the connection.

    aiohttp switches an HTTP/1.1 response with no length to chunked transfer
    coding; turning its length check off (as its own WebSocket response does)
    keeps the body raw, and forcing the connection to close at the end tells
    the client where the body ends.
    """

    _length_check = False

    def __init__(self) -> None:
        super().__init__(status=200, headers={
            "Content-Type": "text/event-stream",
            "Cache-Control": "no-cache",
            "X-Accel-Buffering": "no",
            **SERVER_HEADER,
        })
        self.force_close()
