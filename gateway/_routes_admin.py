"""Routes about the gateway itself: ``/``, ``/version``, ``/load``, ``/unload``, ``/usage`` and the console."""

from __future__ import annotations

import functools
import math
import pathlib
import shlex
from typing import Any

import orjson
from aiohttp import web

from ..components.core import Clock
from ..components.core.runtime import NoSuchModule, names_hint
from ._access import console_policy
from ._auth import AUTH_PATH, LOGIN_PATH
from ._errors import BadQuery, LoadForbidden
from ._keys import CONFIG, DOOR, HOST, SESSIONS
from ._replies import SERVER_HEADER, SERVER_VERSION, json_reply, text_reply

__all__ = ["routes", "ANSWERED_AHEAD", "GENOMIX_PROTOCOL_VERSION", "FEATURES", "WHERE_HEADER", "CONSOLE_ASSETS"]

#: The header of a load's reply that says where the instance runs (JSON: ``runs``, ``host``, ``endpoints``...).
WHERE_HEADER = "Aiogenomix-Where"

#: The genomixd release whose protocol this gateway speaks (clients check it at connection).
GENOMIX_PROTOCOL_VERSION = "1.7.3"

#: Where the console's scripts and style are served: its plots, and the plotting library they draw with.
CONSOLE_ASSET_PATH = "/console/"
_HERE = pathlib.Path(__file__).parent
#: The console's files, by name: where each is in the package (gateway/vendor/uplot/README.md says where
#: uPlot comes from), and its type.
CONSOLE_ASSETS = {
    "plots.js": (_HERE / "console_plots.js", "application/javascript; charset=utf-8"),
    "uPlot.iife.min.js": (_HERE / "vendor" / "uplot" / "uPlot.iife.min.js", "application/javascript; charset=utf-8"),
    "uPlot.min.css": (_HERE / "vendor" / "uplot" / "uPlot.min.css", "text/css; charset=utf-8"),
}

#: What this gateway offers beyond genomix (clients use the fast paths only when listed).
FEATURES = ["wait", "binary", "since", "watch", "console"]

routes = web.RouteTableDef()


@routes.get("/")
async def index(request: web.Request) -> web.Response:
    """What runs here: versions, loaded modules, loadable components, sessions."""
    return index_reply(request.app)


def index_reply(app: web.Application) -> web.Response:
    """The reply to ``GET /`` of the gateway *app* (made from the application alone: see :data:`ANSWERED_AHEAD`)."""
    host = app[HOST]
    instances = host.instances
    index: dict[str, object] = {
        "server": f"aiogenomix {SERVER_VERSION}",
        "genomix": GENOMIX_PROTOCOL_VERSION,
        "loaded": {name: c.genom_name for name, c in instances.items()},
        # Where each loaded instance runs: here, or on which component host (its endpoints, its protocol).
        "where": {name: c.placement() for name, c in instances.items()},
        "available": _allowed(app),
        # Components that other processes offer on Zenoh (gateway --zenoh), loadable as the others.
        "offered": host.finder.offered() if host.finder is not None else [],
        "sessions": len(app[SESSIONS]),
        "simulated": app[CONFIG].simulated_parts(),
        # The rig's clock, which stamps the ports' data: a recorder elsewhere stamps data without time with it.
        "clock": clock_reading(host.clock),
        "features": FEATURES,
    }
    if host.finder is not None:
        # This gateway's Zenoh session and links, each host heard (what it offers), the hosts refused.
        index["zenoh"] = host.finder.view()
    return json_reply(index)


def clock_reading(clock: Clock) -> dict[str, Any]:
    """The clock as ``/`` tells it: ``{"wall", "scale", "kind"}``.

    Its POSIX time now, its runtime seconds per real second (null when it moves with a
    simulation, not with real time), and its kind.
    """
    scale = clock.scale
    return {"wall": clock.wall(), "scale": scale if math.isfinite(scale) else None, "kind": type(clock).__name__}


_CONSOLE = (_HERE / "console.html").read_bytes()
#: Only the console's own script and style may run in its page.
_CONSOLE_POLICY = console_policy(_CONSOLE)


@routes.get("/console")
async def console(request: web.Request) -> web.Response:
    """A browser console: modules, services with forms built from /info, ports, live events."""
    return web.Response(body=_CONSOLE, headers={"Content-Type": "text/html; charset=utf-8",
                                                "Content-Security-Policy": _CONSOLE_POLICY, **SERVER_HEADER})


@routes.get(CONSOLE_ASSET_PATH + "{asset}")
async def console_asset(request: web.Request) -> web.Response:
    """A script or style of the console: its plots, or the plotting library (uPlot, in the package: no CDN)."""
    name = request.match_info["asset"]
    if name not in CONSOLE_ASSETS:
        raise web.HTTPNotFound()
    # Fetched again with each page (some 60 kB from the gateway itself): never an older gateway's plots.
    return web.Response(body=_console_asset(name), headers={"Content-Type": CONSOLE_ASSETS[name][1],
                                                            "Cache-Control": "no-cache", **SERVER_HEADER})


@functools.cache
def _console_asset(name: str) -> bytes:
    return CONSOLE_ASSETS[name][0].read_bytes()


@routes.get(LOGIN_PATH)
async def console_login(request: web.Request) -> web.Response:
    """Trade the token (``Authorization`` header) for the console's cookie; 204 at once without a token."""
    token = request.app[DOOR].token
    return web.Response(status=204, headers=SERVER_HEADER) if token is None else token.login(request)


@routes.get(AUTH_PATH)
async def console_auth(request: web.Request) -> web.Response:
    """Whether this request carries the token or the console's cookie: ``{"authorized": bool}``."""
    token = request.app[DOOR].token
    return json_reply({"authorized": token is None or token.admits(request.headers)})


@routes.get("/favicon.ico")
async def favicon(request: web.Request) -> web.Response:
    """No icon, said without an error: browsers ask for it on every page."""
    return web.Response(status=204, headers=SERVER_HEADER)


@routes.get("/version")
async def version(request: web.Request) -> web.Response:
    """The genomix protocol version (the Server header names aiogenomix)."""
    return version_reply(request.app)


def version_reply(app: web.Application) -> web.Response:
    """The reply to ``GET /version`` (the same for every gateway of this release)."""
    return text_reply(GENOMIX_PROTOCOL_VERSION)


#: The routes whose plain GETs the server's request handler answers ahead of the router
#: (``_fast_answers``), by path: what a client asks when it connects and for the rig's clock,
#: answered from the application alone by the same function as the route's.
ANSWERED_AHEAD = {"/": index_reply, "/version": version_reply}


def _allowed(app: web.Application) -> list[str]:
    allow = app[CONFIG].server.components
    return [n for n in app[HOST].available() if allow is None or n in allow]


def _argv(request: web.Request) -> list[str]:
    values = request.query.getall("argv", [])
    if len(values) > 1:
        return values
    text = values[0].strip() if values else ""
    if not text:
        return []
    if text.startswith("["):
        try:
            parsed = orjson.loads(text)
        except orjson.JSONDecodeError as exc:
            raise BadQuery(f"argv: {exc}") from None
        if not (isinstance(parsed, list) and all(isinstance(a, str) for a in parsed)):
            raise BadQuery("argv: expected a JSON array of strings")
        return parsed
    try:
        return shlex.split(text)
    except ValueError as exc:
        raise BadQuery(f"argv: {exc}") from None


@routes.get("/load/{name:.+}", allow_head=False)
async def load(request: web.Request) -> web.Response:
    """Load a registered component (``argv`` may hold ``-i INSTANCE``). Reply: the instance name.

    With remote components, ``NAME@HOST`` loads the instance a given component host offers.  The
    ``Aiogenomix-Where`` header says where the instance runs (the placement ``/`` shows).
    """
    name = request.match_info["name"]
    if "/" in name or name.endswith(".so"):
        raise LoadForbidden(
            f"cannot load {name!r}: only registered components load, by name ({', '.join(_allowed(request.app))})"
        )
    allow = request.app[CONFIG].server.components
    if allow is not None and name.partition("@")[0] not in allow:
        raise NoSuchModule(f"no component {name!r} {names_hint(name, _allowed(request.app), 'available')}")
    component = await request.app[HOST].load(name, _argv(request))
    reply = text_reply(component.instance)
    reply.headers[WHERE_HEADER] = orjson.dumps(component.placement()).decode()
    return reply


@routes.get("/unload/{name}", allow_head=False)
async def unload(request: web.Request) -> web.Response:
    """Unload an instance; every session gets an ``unload`` event."""
    name = request.match_info["name"]
    await request.app[HOST].unload(name)
    return text_reply(name)


@routes.get("/usage/{name}")
async def usage(request: web.Request) -> web.Response:
    """The load options of a component, as ``[{"option": ..., "descr": ...}]``."""
    name = request.match_info["name"]
    if name not in _allowed(request.app):
        raise NoSuchModule(f"no component {name!r} {names_hint(name, _allowed(request.app), 'available')}")
    return json_reply(request.app[HOST].usage(name))
