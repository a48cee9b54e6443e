"""Small reply helpers: JSON and text bodies with byte-exact Content-Length."""

from __future__ import annotations

import importlib.metadata
import time
from email.utils import formatdate
from typing import Any

import orjson
from aiohttp import web

__all__ = ["json_reply", "text_reply", "dumps", "http_date", "SERVER_VERSION", "SERVER_HEADER", "JSON_HEADERS"]

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
    return web.Response(status=status, body=dumps(obj), headers=JSON_HEADERS)


def text_reply(text: str, status: int = 200) -> web.Response:
    """A ``text/plain`` UTF-8 reply (Content-Length counts bytes, not characters)."""
    return web.Response(status=status, body=text.encode(), headers=_TEXT)


_date: tuple[int, str] = (0, "")


def http_date() -> str:
    """The ``Date`` of a reply written now (RFC 9110's IMF-fixdate), made once a second."""
    global _date
    now = int(time.time())
    if _date[0] != now:
        _date = (now, formatdate(now, usegmt=True))
    return _date[1]
