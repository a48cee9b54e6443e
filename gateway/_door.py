"""The door: one decision, from a request's method, path, query and headers, on whether the gateway answers it.

Every entry point asks the door, and only the door: the guard in front of the
routes, and the connection that answers plain port reads itself (which
answers only what the door admits and leaves everything else to the routes,
so a refusal always comes from one place).  The checks run in this order:

1. the head's names: two ``Host`` or two ``Origin`` fields are a malformed
   request (400), since each reader of a head could take another of them;
2. browsers (``_access``): the host a request names (the authority of an
   absolute-form target, ``GET http://name/...``, else its ``Host``), and its
   ``Origin`` or cross-site marks; a refused page learns nothing more, not
   even whether a token is needed (403); a page of an allowed origin asking
   first (``OPTIONS``, a CORS preflight) is told what it may send;
3. the token (``_auth``), when the gateway has one (401): in a header or the
   console's cookie, or in the live view's URL (``?token=``: a viewer cannot
   set a header on a WebSocket);
4. the query's parameters (``_parameters``): a name the endpoint does not take,
   or one of its names twice, is refused before anything runs (400).

The decision is a pure function of its arguments (and of the configuration
the door was built with): no I/O, no request object, so that any reader of
requests can ask it.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any

from ._access import AccessPolicy, browser_refusal
from ._auth import OPEN_PATHS, TokenCheck, unauthorized_body
from ._parameters import parameter_refusal

__all__ = ["Door", "Admission", "Preflight", "Refusal", "ADMITTED", "repeated_fields"]


def repeated_fields(headers: Any) -> tuple[str, ...]:
    """The lower-case names of the fields the door must see once that *headers* (a multidict) carries twice.

    aiohttp's parser refuses a second ``Host`` itself; a second ``Origin`` is the door's to refuse.
    """
    return ("origin",) if "Origin" in headers and len(headers.getall("Origin")) > 1 else ()


@dataclass(frozen=True, slots=True)
class Admission:
    """The request is answered.

    Attributes:
        origin: The other-site origin (allowed by ``--allow-origin``) whose page made
            the request: its reply carries the CORS headers. None for programs.
    """

    origin: str | None


@dataclass(frozen=True, slots=True)
class Preflight:
    """A browser asks (``OPTIONS``) whether a page of the allowed *origin* may send its request."""

    origin: str


@dataclass(frozen=True, slots=True)
class Refusal:
    """The request is refused with *status* and the genomix error *body*.

    Attributes:
        status: 400, 401 or 403.
        body: ``{"ex", "message"[, "detail"]}``.
        origin: As for :class:`Admission` (a page allowed to use the gateway may read its refusals).
    """

    status: int
    body: dict[str, Any]
    origin: str | None = None


#: The admission of a program's request (the usual one: made once).
ADMITTED = Admission(None)


class Door:
    """Decides whether the gateway answers a request.

    Args:
        policy: The host names and web origins browsers may use.
        token: The token check, or None when the gateway has no token.
    """

    def __init__(self, policy: AccessPolicy, token: TokenCheck | None) -> None:
        self.policy = policy
        self.token = token

    def decide(self, method: str, path: str, names: Collection[str], headers: Mapping[str, str],
               scheme: str = "http", url_token: str | None = None, *, authority: str | None = None,
               repeated: Collection[str] = ()) -> Admission | Preflight | Refusal:
        """Decide on a request.

        Args:
            method: Its method (the routes answer the methods they do not take).
            path: Its path, percent-decoded.
            names: The names of its query parameters, decoded, in order, repeats included (a list,
                or a dictionary's keys when none repeats).
            headers: Its header fields, looked up by lower-case name.
            scheme: How it reached the gateway (for telling the gateway's own pages apart).
            url_token: The token as the live view's URL carries it (``?token=``, decoded), for the
                viewers that cannot send a header; None elsewhere.
            authority: The authority of its target when sent in absolute form
                (``GET http://name:port/path``): the host it names, whatever ``Host`` says.
            repeated: The lower-case names of the header fields it carries more than once
                (only ``host`` and ``origin`` matter here).
        """
        if repeated:
            for name in ("Host", "Origin"):
                if name.lower() in repeated:
                    return Refusal(400, {"ex": "::genomix::http", "message": f"malformed HTTP request: the {name} "
                                                                             "header field is given more than once"})
        body, origin = browser_refusal(self.policy, path, headers, scheme, authority)
        if body is not None:
            return Refusal(403, body)
        if origin is not None and method == "OPTIONS" and "access-control-request-method" in headers:
            return Preflight(origin)  # a browser's question, never with credentials: before the token
        if (self.token is not None and path not in OPEN_PATHS and not self.token.admits(headers)
                and (url_token is None or not self.token.matches(url_token))):
            return Refusal(401, unauthorized_body(), origin)
        if names:  # (most requests carry no query: nothing to refuse there)
            body = parameter_refusal(path, names, method)
            if body is not None:
                return Refusal(400, body, origin)
        return ADMITTED if origin is None else Admission(origin)
