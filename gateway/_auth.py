"""The gateway's token (``--token``): carried by every request, in a header or in the console's cookie.

Programs send ``Authorization: Bearer <token>``; the live view's viewers, which
cannot set a header on a WebSocket, put it in the URL (``?token=``, ``_door``).  A browser page cannot add
that header to the ``EventSource`` streams it opens, so the console trades the
token once for a cookie: ``GET /console/login`` with the header answers with
``Set-Cookie`` holding a random credential of this gateway run (never the
token itself), ``HttpOnly`` (no script reads it) and ``SameSite=Strict`` (no
other site's page sends it).  The console page itself holds nothing secret
and is served to anyone, so that it can ask for the token; so is
``/console/auth``, which says whether a request carries credentials.
"""

from __future__ import annotations

import hmac
import secrets
from collections.abc import Mapping

from aiohttp import web

from ._replies import SERVER_HEADER, json_reply

__all__ = ["TokenCheck", "COOKIE", "LOGIN_PATH", "AUTH_PATH", "OPEN_PATHS", "unauthorized_body"]

#: The cookie the console gets in exchange for the token.
COOKIE = "aiogenomix_console"
LOGIN_PATH = "/console/login"
#: Says whether a request carries credentials (``{"authorized": bool}``), so the console can ask first.
AUTH_PATH = "/console/auth"
#: Served without credentials: the console page, its scripts and style, and the two requests it makes
#: about the token (the login checks the token itself); the OpenAPI description, and Swagger UI's page and
#: files, which read it before anyone can say the token (every operation it describes needs the token).
OPEN_PATHS = frozenset({"/console", "/console/plots.js", "/console/uPlot.iife.min.js", "/console/uPlot.min.css",
                        AUTH_PATH, LOGIN_PATH,
                        "/openapi.json", "/docs", "/docs/swagger-ui-bundle.js", "/docs/swagger-ui.css"})


class TokenCheck:
    """Checks the token of requests and hands the console its cookie.

    Args:
        token: The gateway's ``--token``.
    """

    def __init__(self, token: str) -> None:
        self._expected = f"Bearer {token}".encode()
        # A fresh credential per run: a cookie never outlives the gateway that issued it.
        self._cookie = secrets.token_urlsafe(32).encode()

    def authorizes(self, authorization: str) -> bool:
        """Whether the value of an ``Authorization`` header carries the token."""
        # Header bytes that are not UTF-8 arrive as surrogate escapes: compare the bytes as sent.
        given = authorization.encode("utf-8", "surrogateescape")
        return hmac.compare_digest(given, self._expected)

    def matches(self, token: str) -> bool:
        """Whether *token* (given bare, as in the live view's URL) is the gateway's token."""
        return hmac.compare_digest(b"Bearer " + token.encode("utf-8", "surrogateescape"), self._expected)

    def admits(self, headers: Mapping[str, str]) -> bool:
        """Whether a request with *headers* (by lower-case name) carries the token or the console's cookie."""
        if self.authorizes(headers.get("authorization", "")):
            return True
        given = _cookie(headers.get("cookie", ""), COOKIE).encode("utf-8", "surrogateescape")
        return bool(given) and hmac.compare_digest(given, self._cookie)

    def login(self, request: web.Request) -> web.Response:
        """``/console/login``: the cookie for a request with the token in its header, else 401."""
        if not self.authorizes(request.headers.get("Authorization", "")):
            return json_reply(unauthorized_body(), status=401)
        response = web.Response(status=204, headers=SERVER_HEADER)
        response.set_cookie(COOKIE, self._cookie.decode(), httponly=True, samesite="Strict", path="/")
        return response


def unauthorized_body() -> dict[str, str]:
    """The error body of a request without the token."""
    return {"ex": "::genomix::unauthorized", "message": "this gateway needs Authorization: Bearer <token>"}


def _cookie(header: str, name: str) -> str:
    """The value of cookie *name* in a ``Cookie`` header (empty when absent)."""
    for pair in header.split(";"):
        key, _, value = pair.strip().partition("=")
        if key == name:
            return value.strip('"')
    return ""
