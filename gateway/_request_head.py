"""Request heads as the gateway's connections read them: where one ends, what it says, what is refused at once.

Every connection reads each request's head before aiohttp does (``_connection``):
to answer plain port reads itself, and to know where each request ends so that
its own replies never overtake aiohttp's.  Both readers must agree on every
boundary, so this one is the stricter: a head is accepted only in the plain
form that aiohttp's parser accepts too (CRLF line ends, a known method, a
printable ASCII target, ``name: value`` fields with token names and visible
values, a body only by ``Content-Length``), and anything else is refused here
with its status, before aiohttp sees a byte of it:

* 400 for a malformed request line or field line, a method this gateway does
  not know, a field that may appear once given twice (:data:`SINGLETONS`:
  ``Host``, ``Content-Type``, ``User-Agent``...; RFC 9110 and 9112), or a
  ``Content-Length`` that is not a number,
* 411 for a body in chunked transfer coding (send a ``Content-Length``),
* 414 for a request line longer than the gateway's ``max_url_bytes``,
* 431 for a field line longer than :data:`MAX_FIELD_LINE` bytes, or more than
  :data:`MAX_FIELDS` fields,
* 505 for an HTTP version other than 1.0 and 1.1 (HTTP/0.9 above all).

Pure functions on bytes: no sockets, no event loop.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["RequestHead", "HeadRefusal", "MAX_FIELD_LINE", "MAX_FIELDS", "SINGLETONS", "head_end", "parse_head",
           "check_partial"]

#: The longest field (header) line, in bytes (aiohttp's own default).
MAX_FIELD_LINE = 8190
#: The most fields a request may carry (below aiohttp's own limit, so that the refusal is this one's).
MAX_FIELDS = 100
#: Methods passed on to the routes (which answer 405 for those they do not take).  aiohttp's parser
#: knows more (WebDAV's, CONNECT), none of which this gateway serves.
METHODS = frozenset({"GET", "HEAD", "POST", "PUT", "DELETE", "OPTIONS", "PATCH"})

#: The fields a request may carry once at most (RFC 9110's singletons): aiohttp's parser refuses a repeated
#: one too, so a head with one is refused here, where the refusal is the gateway's documented one.
SINGLETONS = frozenset({"content-length", "content-location", "content-range", "content-type", "etag", "host",
                        "max-forwards", "server", "transfer-encoding", "user-agent"})

_METHOD_NAMES = {method.encode(): method for method in METHODS}
_VERSIONS = {b" HTTP/1.1": "1.1", b" HTTP/1.0": "1.0"}
_TARGET = re.compile(rb"/[\x21-\x7e]*|https?://[\x21-\x7e]+")
_TOKEN = rb"[!#$%&'*+\-.^_`|~0-9A-Za-z]+"
# method SP request-target SP HTTP-version: origin form or absolute form, printable ASCII.
_REQUEST_LINE = re.compile(rb"(" + _TOKEN + rb") (/[\x21-\x7e]*|https?://[\x21-\x7e]+) HTTP/(\d)\.(\d)")
# A request line without a version: HTTP/0.9.
_SIMPLE_REQUEST = re.compile(rb"[A-Z]+ /[\x21-\x7e]*")
# Field lines, each ending in CRLF: a token name, a colon, visible characters, spaces and tabs.
_FIELD_LINES = re.compile(rb"(?:" + _TOKEN + rb":[\t\x20-\x7e\x80-\xff]*\r\n)*")
_CONTENT_LENGTH = re.compile(rb"^content-length:[ \t]*([0-9]{1,15})[ \t]*\r$", re.IGNORECASE | re.MULTILINE)
_UPGRADE_LINE = re.compile(rb"^upgrade:[^\r]*\r\n", re.IGNORECASE | re.MULTILINE)
_SINGLETON_LINE = re.compile(rb"^(" + rb"|".join(name.encode() for name in sorted(SINGLETONS)) + rb"):",
                             re.IGNORECASE | re.MULTILINE)
# The fields that say what follows a head: a body, or another protocol.
_FRAMING = re.compile(rb"^(?:content-length|transfer-encoding|upgrade):", re.IGNORECASE | re.MULTILINE)


class HeadRefusal(Exception):
    """A request head refused before aiohttp reads it.

    Attributes:
        status: The HTTP status of the refusal (400, 411, 414, 431 or 505).
        message: A readable sentence for the JSON error body.
    """

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status, self.message = status, message


@dataclass(slots=True)
class RequestHead:
    """One request head, checked.

    Attributes:
        method: The method (upper case, one of :data:`METHODS`).
        target: The request target as sent (path and query, still percent-encoded).
        version: ``"1.1"`` or ``"1.0"``.
        fields: The field lines as sent, each ending in CRLF.
        raw: The bytes to pass on to aiohttp: the head as sent, minus any ``Upgrade``
            field (this gateway never switches protocols, and aiohttp would stop
            reading the connection as HTTP after one).
        body_length: The ``Content-Length`` (0 without one).
    """

    method: str
    target: str
    version: str
    fields: bytes
    raw: bytes
    body_length: int

    def headers(self) -> tuple[dict[str, str], set[str]]:
        """The fields by lower-case name, and the names given more than once.

        A repeated name keeps its first value, as aiohttp's ``get`` does.
        """
        found: dict[str, str] = {}
        repeated: set[str] = set()
        for line in self.fields.split(b"\r\n")[:-1]:
            name, _, value = line.partition(b":")
            key = name.decode("ascii").lower()
            if key in found:
                repeated.add(key)
            else:
                found[key] = value.strip(b" \t").decode("latin-1")
        return found, repeated

    def keeps_alive(self, headers: dict[str, str]) -> bool:
        """Whether the connection stays open after the reply: HTTP/1.1 whose *headers* do not say ``close``."""
        if self.version != "1.1":
            return False
        return "close" not in (token.strip().lower() for token in headers.get("connection", "").split(","))


def head_end(buffer: bytes, start: int = 0) -> int:
    """The offset just past the head that starts at *start* in *buffer* (its blank line), or -1 when incomplete."""
    end = buffer.find(b"\r\n\r\n", start)
    return end + 4 if end >= 0 else -1


def parse_head(buffer: bytes, start: int, end: int) -> RequestHead:
    """Check and read the head ``buffer[start:end]`` (*end* from :func:`head_end`).

    Raises:
        HeadRefusal: for anything but the plain form described in the module.
    """
    line_end = buffer.find(b"\r\n", start, end)
    line = buffer[start:line_end]
    # The usual line first, without a regular expression's groups: METHOD SP target SP HTTP/1.x.
    space = line.find(b" ")
    name = _METHOD_NAMES.get(line[:space])
    version = _VERSIONS.get(line[-9:])
    if name is None or version is None or not _TARGET.fullmatch(line, space + 1, len(line) - 9):
        raise _refusal_of_line(line)
    target = line[space + 1:-9].decode("ascii")
    fields = buffer[line_end + 2:end - 2]
    if _FIELD_LINES.fullmatch(fields) is None:
        raise _malformed_field(fields)
    body_length = 0
    raw = buffer[start:end]
    # A field line is 4 bytes at least ("a:" CRLF): only a long block can hold too many.
    if len(fields) > 4 * MAX_FIELDS and fields.count(b"\r\n") > MAX_FIELDS:
        raise HeadRefusal(431, f"a request may carry at most {MAX_FIELDS} header fields")
    if len(fields) > MAX_FIELD_LINE and max(map(len, fields.split(b"\r\n"))) > MAX_FIELD_LINE:
        raise HeadRefusal(431, f"a request header line is longer than {MAX_FIELD_LINE} bytes")
    singletons = _SINGLETON_LINE.findall(fields)
    if len(singletons) > 1:
        _refuse_repeated(singletons)
    if _FRAMING.search(fields):  # rare: a body, or an upgrade
        lowered = fields.lower()
        if b"\ntransfer-encoding:" in b"\n" + lowered:
            raise HeadRefusal(411, "a request body must come with a Content-Length (chunked bodies are not taken)")
        if b"\ncontent-length:" in b"\n" + lowered:
            body_length = _content_length(fields)
        if _UPGRADE_LINE.search(fields):
            raw = buffer[start:line_end + 2] + _UPGRADE_LINE.sub(b"", fields) + b"\r\n"
    return RequestHead(name, target, version, fields, raw, body_length)


def check_partial(buffer: bytes, start: int, max_url_bytes: int) -> None:
    """Refuse an incomplete head in ``buffer[start:]`` that already passes a limit.

    Raises:
        HeadRefusal: 414 for a request line past *max_url_bytes*, 431 for a field
            line past :data:`MAX_FIELD_LINE` or too many fields.
    """
    line_end = buffer.find(b"\r\n", start)
    if line_end < 0:
        if len(buffer) - start > max_url_bytes:
            raise _too_long(max_url_bytes)
        return
    if line_end - start > max_url_bytes:
        raise _too_long(max_url_bytes)
    last = buffer.rfind(b"\r\n", line_end)
    if len(buffer) - last - 2 > MAX_FIELD_LINE:
        raise HeadRefusal(431, f"a request header line is longer than {MAX_FIELD_LINE} bytes")
    if buffer.count(b"\r\n", line_end) > MAX_FIELDS + 1:
        raise HeadRefusal(431, f"a request may carry at most {MAX_FIELDS} header fields")


def _too_long(max_url_bytes: int) -> HeadRefusal:
    return HeadRefusal(414, f"the request line (the URL with its query, input= included) is longer than "
                            f"{max_url_bytes} bytes, this gateway's limit")


def _refuse_repeated(singletons: list[bytes]) -> None:
    """Refuse a head in which one of the *singletons* found (field names as sent) is given twice."""
    seen: set[bytes] = set()
    for name in singletons:
        lowered = name.lower()
        if lowered in seen:
            raise HeadRefusal(400, f"malformed HTTP request: the {name.decode()} header field is given more "
                                   "than once")
        seen.add(lowered)


def _content_length(fields: bytes) -> int:
    found = _CONTENT_LENGTH.findall(fields)
    declared = sum(1 for line in fields.lower().split(b"\r\n") if line.startswith(b"content-length:"))
    if len(found) != 1 or declared != 1:
        raise HeadRefusal(400, "malformed HTTP request: one Content-Length, a number of bytes, is expected")
    return int(found[0])


def _refusal_of_line(line: bytes) -> HeadRefusal:
    """Why a request line that is not the usual one is refused."""
    match = _REQUEST_LINE.fullmatch(line)
    if match is None:
        if _SIMPLE_REQUEST.fullmatch(line):
            # "GET /path" alone: an HTTP/0.9 request, whose reply would have no status line or headers.
            return HeadRefusal(505, "HTTP/0.9 is not supported: send HTTP/1.1 or HTTP/1.0")
        return HeadRefusal(400, f"malformed HTTP request: bad request line {_shown(line)}")
    method, _, major, minor = match.groups()
    if (major, minor) not in ((b"1", b"1"), (b"1", b"0")):
        return HeadRefusal(505, f"HTTP/{major.decode()}.{minor.decode()} is not supported: send HTTP/1.1 or HTTP/1.0")
    return HeadRefusal(400, f"malformed HTTP request: unknown method {_shown(method)}")


def _malformed_field(fields: bytes) -> HeadRefusal:
    for line in fields.split(b"\r\n")[:-1]:
        if _FIELD_LINES.fullmatch(line + b"\r\n") is None:
            if len(line) > MAX_FIELD_LINE:
                return HeadRefusal(431, f"a request header line is longer than {MAX_FIELD_LINE} bytes")
            return HeadRefusal(400, f"malformed HTTP request: bad header line {_shown(line)}")
    return HeadRefusal(400, "malformed HTTP request: bad header lines")


def _shown(raw: bytes) -> str:
    """Part of a request fit for a one-line message: ASCII, short."""
    text = ascii(raw)[2:-1]
    return repr(text if len(text) <= 60 else text[:57] + "...")
