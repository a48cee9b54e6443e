"""The query parameters each endpoint takes: a request that names any other is refused before anything runs.

genomix puts everything in the query string, and a parameter the gateway does
not read would otherwise be ignored: ``send/GotoPosition?posRef=0.7`` (the
flattened form an OpenAPI generator builds) or ``?inptu=...`` (a typo) would
send the service with its default input, and the robot would move to where
nobody asked.  So every endpoint lists what it takes, and a request naming
another parameter, or one of them twice, is answered 400
``::genomix::bad_parameter`` naming the parameters the endpoint takes.

Two names are taken everywhere: ``s`` (genomix: every request may name its
session) and ``_``, the cache-buster that jQuery's ``cache: false`` and some
HTTP libraries append to GET URLs (it asks for nothing, so it cannot be
mistaken for an input; docs/decisions/0023).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

__all__ = ["ENDPOINT_PARAMETERS", "POST_PARAMETERS", "REPEATABLE", "LIVE_VIEW", "endpoint_of", "parameter_refusal"]

_EVERYWHERE = frozenset({"s", "_"})
#: The live view's WebSocket (on a port of its own, ``--foxglove``), as the door knows it whatever the path
#: a viewer connects to: it takes the token, for viewers that cannot send a header.
LIVE_VIEW = "/foxglove"

#: The parameters of each endpoint, besides ``s`` and ``_`` (keys: see :func:`endpoint_of`).
ENDPOINT_PARAMETERS: dict[str, frozenset[str]] = {
    "/": frozenset(),
    "/version": frozenset(),
    "/console": frozenset(),
    "/console/auth": frozenset(),
    "/console/login": frozenset(),
    "/console/plots.js": frozenset(),
    "/console/uPlot.iife.min.js": frozenset(),
    "/console/uPlot.min.css": frozenset(),
    "/favicon.ico": frozenset(),
    "/openapi.json": frozenset(),
    "/docs": frozenset(),
    "/docs/swagger-ui-bundle.js": frozenset(),
    "/docs/swagger-ui.css": frozenset(),
    "/session/start": frozenset(),
    "/session/stop": frozenset(),
    "/session/listen": frozenset(),
    "/load": frozenset({"argv"}),
    "/unload": frozenset(),
    "/usage": frozenset(),
    "/module/info": frozenset(),
    "/module/send": frozenset({"input", "oneway"}),
    "/module/status": frozenset(),
    "/module/wait": frozenset({"timeout"}),
    "/module/abort": frozenset(),
    "/module/clean": frozenset(),
    "/module/read": frozenset({"name", "format", "since"}),
    "/module/watch": frozenset({"name", "since"}),
}
#: What the door checks: the HTTP endpoints, and the live view.
_TAKES = {**ENDPOINT_PARAMETERS, LIVE_VIEW: frozenset({"token"})}
#: The parameters of the endpoints that take a ``POST`` (its body is the input: no ``input`` in the query).
POST_PARAMETERS: dict[str, frozenset[str]] = {"/module/send": frozenset({"oneway"})}
#: Parameters that may be given more than once (``argv=-i&argv=demo2``).
REPEATABLE = frozenset({"argv"})

_NAMED = frozenset({"load", "unload", "usage"})
#: How many offending names a refusal lists (the query is the client's: it may hold thousands).
_SHOWN = 8


def endpoint_of(path: str) -> str | None:
    """The endpoint a (decoded) *path* asks for: ``/module/send`` for ``/module/demo/send/GotoPosition``.

    None for a path that is no endpoint (the routes answer it 404).  :data:`LIVE_VIEW` is the live view.
    """
    parts = path.split("/", 4)
    if len(parts) < 2:
        return None
    first = parts[1]
    if first == "module":
        key = f"/module/{parts[3]}" if len(parts) >= 4 else None
    elif first in _NAMED:
        key = f"/{first}" if len(parts) >= 3 else None
    else:
        key = path
    return key if key in _TAKES else None


def parameter_refusal(path: str, names: Iterable[str], method: str = "GET") -> dict[str, Any] | None:
    """The error body refusing the query parameters *names* on *path*, or None when they are all taken.

    Requests with other methods than GET (and HEAD) are checked where the endpoint takes
    them (``POST`` on ``send``); elsewhere the routes answer 405.
    """
    key = endpoint_of(path)
    if key is None:
        return None
    if method in ("GET", "HEAD"):
        takes = _TAKES[key]
    elif key in POST_PARAMETERS and method == "POST":
        takes = POST_PARAMETERS[key]
    else:
        return None
    seen: set[str] = set()
    unknown: list[str] = []
    repeated: list[str] = []
    for name in names:
        if name in seen:
            if name not in REPEATABLE and name not in repeated:
                repeated.append(name)
            continue
        seen.add(name)
        if name not in takes and name not in _EVERYWHERE:
            unknown.append(name)
    if not unknown and not repeated:
        return None
    listed = sorted(takes | {"s"})
    what = key.rsplit("/", 1)[1] or "/"
    unknown, repeated = unknown[:_SHOWN], repeated[:_SHOWN]
    if unknown:
        message = (f"{what} takes the parameters {', '.join(listed)}: {_names(unknown)} "
                   f"{'is' if len(unknown) == 1 else 'are'} not among them")
        if key == "/module/send" and method == "POST":
            message += " (a POST's input is its JSON body)"
        elif key == "/module/send":
            message += ' (a service\'s input goes in input=, as JSON: input={"posRef":0.7})'
    else:
        message = f"{_names(repeated)} may be given once only"
    detail = {"unknown": [_cut(name) for name in unknown], "repeated": repeated, "takes": listed}
    return {"ex": "::genomix::bad_parameter", "detail": detail, "message": message}


def _cut(name: str) -> str:
    return name if len(name) <= 40 else name[:37] + "..."


def _names(names: list[str]) -> str:
    return ", ".join(ascii(_cut(name)) for name in names)
