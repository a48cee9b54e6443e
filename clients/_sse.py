"""A sans-I/O parser of server-sent events: bytes in, events and comments out.

It follows the WHATWG event-stream rules that matter to genomix streams: lines
end with LF, CRLF or CR (a CRLF split across two chunks is one line end), a
blank line dispatches the event, ``data:`` lines are joined with LF, a single
space after the colon is dropped, and lines starting with ``:`` are comments
(the gateway's ``: ping``).  It never touches a socket, so it is tested with
byte strings cut at every position.
"""

from __future__ import annotations

import dataclasses

__all__ = ["Comment", "SSEParser", "ServerSentEvent"]


@dataclasses.dataclass(frozen=True)
class ServerSentEvent:
    """One dispatched event.

    Attributes:
        event: The event name (``message`` when the stream gave none).
        data: The data lines joined with LF ("" when there were none).
        id: The last event id seen on the stream, if any.
    """

    event: str = "message"
    data: str = ""
    id: str | None = None


@dataclasses.dataclass(frozen=True)
class Comment:
    """A comment line (``: ping``), reported so a reader can notice a live but idle stream."""

    text: str


class SSEParser:
    """Incremental event-stream parser.

    Feed it chunks as they arrive; each call returns what those bytes completed.
    """

    def __init__(self) -> None:
        self._buffer = b""
        self._skip_lf = False  # the previous chunk ended with CR: a leading LF belongs to it
        self._event = ""
        self._data: list[str] = []
        self._has_fields = False
        self._last_id: str | None = None

    def feed(self, chunk: bytes) -> list[ServerSentEvent | Comment]:
        """Parse *chunk*; return the events and comments it completed, in stream order."""
        if self._skip_lf and chunk.startswith(b"\n"):
            chunk = chunk[1:]
        self._skip_lf = False
        out: list[ServerSentEvent | Comment] = []
        data = self._buffer + chunk
        start = 0
        size = len(data)
        while start < size:
            cr = data.find(b"\r", start)
            lf = data.find(b"\n", start)
            if cr < 0 and lf < 0:
                break
            if lf < 0 or (0 <= cr < lf):
                end, nxt = cr, cr + 1
                if nxt < size and data[nxt:nxt + 1] == b"\n":
                    nxt += 1
                elif nxt == size:
                    self._skip_lf = True
            else:
                end, nxt = lf, lf + 1
            self._line(data[start:end].decode("utf-8", errors="replace"), out)
            start = nxt
        self._buffer = data[start:]
        return out

    def _line(self, line: str, out: list[ServerSentEvent | Comment]) -> None:
        if not line:
            if self._has_fields:
                out.append(ServerSentEvent(self._event or "message", "\n".join(self._data), self._last_id))
            self._event, self._data, self._has_fields = "", [], False
            return
        if line.startswith(":"):
            out.append(Comment(line[1:].lstrip(" ")))
            return
        name, colon, value = line.partition(":")
        if colon and value.startswith(" "):
            value = value[1:]
        if name == "event":
            self._event = value
        elif name == "data":
            self._data.append(value)
        elif name == "id":
            if "\0" not in value:
                self._last_id = value
        else:
            return  # retry and unknown fields carry nothing a genomix client uses
        self._has_fields = True
