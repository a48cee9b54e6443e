"""Small reply helpers: JSON and text bodies with byte-exact Content-Length."""

from __future__ import annotations

from typing import Any

import orjson
from aiohttp import web

__all__ = ["json_reply", "text_reply", "dumps"]

_OPTIONS = orjson.OPT_SERIALIZE_NUMPY


def dumps(obj: Any) -> bytes:
    """Compact JSON bytes (numpy arrays serialised without a Python loop)."""
    return orjson.dumps(obj, option=_OPTIONS)


def json_reply(obj: Any, status: int = 200) -> web.Response:
    """An ``application/json`` reply."""
    return web.Response(status=status, body=dumps(obj), content_type="application/json")


def text_reply(text: str, status: int = 200) -> web.Response:
    """A ``text/plain`` UTF-8 reply (Content-Length counts bytes, not characters)."""
    return web.Response(status=status, body=text.encode(), content_type="text/plain", charset="utf-8")
