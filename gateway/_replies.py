"""Small reply helpers: JSON and text bodies with byte-exact Content-Length, written whole.

Every JSON or text reply of the gateway (a route's answer, an error, a
refusal) is a :class:`Reply`: aiohttp's ``Response``, which writes its head and
body in one piece when it is a plain one, with the bytes aiohttp would write but
without its header preparation (8 % of the Python bytecodes a routed
``/version`` runs, docs/decisions/0047).
"""

from __future__ import annotations

import importlib.metadata
import re
import time
from email.utils import formatdate
from http.cookies import SimpleCookie
from typing import Any

import orjson
from aiohttp import web
from aiohttp.abc import AbstractStreamWriter
from aiohttp.http import HttpVersion11

__all__ = ["json_reply", "text_reply", "dumps", "http_date", "Reply", "SERVER_VERSION", "SERVER_HEADER",
           "JSON_HEADERS"]

_OPTIONS = orjson.OPT_SERIALIZE_NUMPY

#: This gateway's own version.
SERVER_VERSION = importlib.metadata.version("aiogenomix")
#: The headers of every reply: the server's name, and no content sniffing (an error page is never
#: run as a script).  Every reply the gateway makes starts from these: set here rather than in a
#: middleware or a response signal, which would cost every request a call more.
SERVER_HEADER = {"Server": f"aiogenomix/{SERVER_VERSION}", "X-Content-Type-Options": "nosniff"}
#: The headers of a JSON reply.
JSON_HEADERS = {"Content-Type": "application/json", **SERVER_HEADER}
_TEXT = {"Content-Type": "text/plain; charset=utf-8", **SERVER_HEADER}


def dumps(obj: Any) -> bytes:
    """Compact JSON bytes (numpy arrays serialised without a Python loop)."""
    return orjson.dumps(obj, option=_OPTIONS)


def json_reply(obj: Any, status: int = 200) -> web.Response:
    """An ``application/json`` reply."""
    return Reply(status=status, body=dumps(obj), headers=JSON_HEADERS)


def text_reply(text: str, status: int = 200) -> web.Response:
    """A ``text/plain`` UTF-8 reply (Content-Length counts bytes, not characters)."""
    return Reply(status=status, body=text.encode(), headers=_TEXT)


_date: tuple[int, str] = (0, "")


def http_date() -> str:
    """The ``Date`` of a reply written now (RFC 9110's IMF-fixdate), made once a second."""
    global _date
    now = int(time.time())
    if _date[0] != now:
        _date = (now, formatdate(now, usegmt=True))
    return _date[1]


#: What aiohttp refuses in a header field (a field's end, other control characters but the tab).
_FORBIDDEN = re.compile(r"[\x00-\x08\x0a-\x1f\x7f]")
#: The statuses and methods whose replies have no body (aiohttp's own rules apply to them).
_EMPTY_STATUSES = frozenset({204, 304})
_EMPTY_METHODS = frozenset({"HEAD", "CONNECT"})


class Reply(web.Response):
    """A reply of given bytes (JSON, text), written with its head in one piece when it is a plain one.

    It is aiohttp's ``Response`` in every way but one: when aiohttp prepares it for a
    kept-alive HTTP/1.1 request other than ``HEAD``, with a status that has a body and
    nothing asked of it but its fields (no cookie, compression or chunked coding, no
    ``on_response_prepare`` handler of the application), its head is made as aiohttp
    makes it (the status line, the fields in their order, ``Content-Length``, ``Date``)
    and written with its body through the request's writer, without aiohttp's header
    preparation.  Anything else goes aiohttp's way.  ``tests/gateway/test_whole_replies.py``
    compares both ways byte for byte.
    """

    _written: int | None = None  # the bytes written whole (head and body), once written
    _unusual = False  # a cookie, compression or chunked coding was asked for: aiohttp's way

    async def prepare(self, request: web.BaseRequest) -> AbstractStreamWriter | None:  # noqa: D102
        if self._written is not None:
            return None
        body = self.body
        if not isinstance(body, bytes) or self._unusual or (head := self._head(request, len(body))) is None:
            return await super().prepare(request)
        data = head + body
        self._written = len(data)
        await request.writer.write(data)
        return None

    def _head(self, request: web.BaseRequest, length: int) -> bytes | None:
        """The reply's head as aiohttp writes it, or None when aiohttp is to prepare the reply itself."""
        status = self.status
        if (status < 200 or status in _EMPTY_STATUSES or request.method in _EMPTY_METHODS
                or request.version != HttpVersion11 or not request.keep_alive or self.keep_alive is False
                or self.chunked or self.compression):
            return None
        if isinstance(request, web.Request):
            try:
                apps = request.match_info.apps
            except (AssertionError, AttributeError):  # answered ahead of the router: no application's handler runs
                apps = ()
            for app in apps:
                if app.on_response_prepare:  # (a handler that may change the head: aiohttp's way)
                    return None
        headers = self.headers
        if "Content-Length" in headers or "Date" in headers or "Connection" in headers:
            return None
        fields = [f"{name}: {value}" for name, value in headers.items()]
        if _FORBIDDEN.search("".join(fields)) is not None:
            return None  # aiohttp refuses it: a field's end (or a control character) in a name or a value
        return (f"HTTP/1.1 {status} {self.reason}\r\n" + "\r\n".join(fields)
                + f"\r\nContent-Length: {length}\r\nDate: {http_date()}\r\n\r\n").encode()

    async def write_eof(self, data: bytes = b"") -> None:  # noqa: D102
        if self._written is None:
            await super().write_eof(data)

    @property
    def keep_alive(self) -> bool | None:  # noqa: D102
        return True if self._written is not None else super().keep_alive

    @property
    def prepared(self) -> bool:  # noqa: D102
        return self._written is not None or super().prepared

    @property
    def body_length(self) -> int:  # noqa: D102
        return self._written if self._written is not None else super().body_length

    @property
    def cookies(self) -> SimpleCookie:  # noqa: D102
        self._unusual = True
        return super().cookies

    def set_cookie(self, name: str, value: str, **kwargs: Any) -> None:  # noqa: D102
        self._unusual = True
        super().set_cookie(name, value, **kwargs)

    def del_cookie(self, name: str, **kwargs: Any) -> None:  # noqa: D102
        self._unusual = True
        super().del_cookie(name, **kwargs)
