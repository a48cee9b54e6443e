"""The gateway's token (``--token``): checked on every request, from a header or from the console's cookie.

Programs send ``Authorization: Bearer <token>``.  A browser page cannot add
that header to the ``EventSource`` streams it opens, so the console trades the
token once for a cookie: ``GET /console/login`` with the header answers with
``Set-Cookie`` holding a random credential of this gateway run (never the
token itself), ``HttpOnly`` (no script reads it) and ``SameSite=Strict`` (no
other site's page sends it).  The console page itself holds nothing secret
and is served to anyone, so that it can ask for the token.
"""

from __future__ import annotations

import hmac
import secrets
from collections.abc import Awaitable, Callable

from aiohttp import web

from ._replies import SERVER_HEADER, json_reply

__all__ = ["TokenCheck", "COOKIE", "LOGIN_PATH", "AUTH_PATH", "login_without_token", "auth_without_token"]

#: The cookie the console gets in exchange for the token.
COOKIE = "aiogenomix_console"
LOGIN_PATH = "/console/login"
#: Says whether a request carries credentials (``{"authorized": bool}``), so the console can ask first.
AUTH_PATH = "/console/auth"
#: Served without credentials: the console page asks for the token itself.
_OPEN_PATHS = frozenset({"/console"})

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


class TokenCheck:
    """Checks the token of every request and hands the console its cookie.

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

    def _has_header(self, request: web.BaseRequest) -> bool:
        return self.authorizes(request.headers.get("Authorization", ""))

    def _has_cookie(self, request: web.BaseRequest) -> bool:
        given = request.cookies.get(COOKIE, "").encode("utf-8", "surrogateescape")
        return bool(given) and hmac.compare_digest(given, self._cookie)

    def screen(self, request: web.BaseRequest) -> web.Response | None:
        """The reply that stops *request* here (401, or the console's login and auth answers); None lets it on."""
        path = request.path
        if path in _OPEN_PATHS:
            return None
        if path == AUTH_PATH:
            return json_reply({"authorized": self._has_header(request) or self._has_cookie(request)})
        if path == LOGIN_PATH:
            if not self._has_header(request):
                return _unauthorized()
            return self._login()
        if not (self._has_header(request) or self._has_cookie(request)):
            return _unauthorized()
        return None

    @web.middleware
    async def middleware(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        """Refuse (401) a request without the token, the console page aside (the gateway's own is ``_guard``)."""
        reply = self.screen(request)
        if reply is not None:
            return reply
        return await handler(request)

    def _login(self) -> web.Response:
        response = web.Response(status=204, headers=SERVER_HEADER)
        response.set_cookie(COOKIE, self._cookie.decode(), httponly=True, samesite="Strict", path="/")
        return response


def _unauthorized() -> web.Response:
    return json_reply({"ex": "::genomix::unauthorized",
                       "message": "this gateway needs Authorization: Bearer <token>"}, status=401)


async def login_without_token(request: web.Request) -> web.Response:
    """``/console/login`` on a gateway without a token: nothing to exchange."""
    return web.Response(status=204, headers=SERVER_HEADER)


async def auth_without_token(request: web.Request) -> web.Response:
    """``/console/auth`` on a gateway without a token: every request is authorized."""
    return json_reply({"authorized": True})
