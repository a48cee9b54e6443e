"""``/docs``: the gateway's OpenAPI description in Swagger UI, served by the gateway itself.

Swagger UI's script and style come from the ``swagger-ui-py`` package, a
dependency (no CDN: the gateway often runs where there is no internet).  Only
its two files are served, read once; the page around them is ours.
"""

from __future__ import annotations

import functools
import importlib.util
import pathlib

from aiohttp import web

from ._access import inline_hashes
from ._replies import SERVER_HEADER

__all__ = ["routes", "DOCS_PATH", "ASSETS"]

routes = web.RouteTableDef()

DOCS_PATH = "/docs"
#: The files of Swagger UI the page loads, and their types.
ASSETS = {"swagger-ui-bundle.js": "application/javascript; charset=utf-8", "swagger-ui.css": "text/css; charset=utf-8"}

_PAGE = (pathlib.Path(__file__).parent / "docs.html").read_bytes()


def _policy(page: bytes) -> str:
    # Swagger UI's own script and style come from here; it sets style attributes (which a hash
    # cannot allow) and shows inline images; its requests go to this gateway only.
    return (f"default-src 'none'; script-src 'self' {inline_hashes(page, 'script')}; "
            "style-src 'self' 'unsafe-inline'; connect-src 'self'; img-src 'self' data:; base-uri 'none'; "
            "form-action 'none'; frame-ancestors 'none'")


_HEADERS = {"Content-Type": "text/html; charset=utf-8", "Content-Security-Policy": _policy(_PAGE), **SERVER_HEADER}


@functools.cache
def _asset(name: str) -> bytes:
    """A file of Swagger UI, read once (the package is found without importing it)."""
    spec = importlib.util.find_spec("swagger_ui")
    if spec is None or not spec.submodule_search_locations:
        raise web.HTTPNotFound(reason="Swagger UI is not installed (the swagger-ui-py package)")
    return (pathlib.Path(spec.submodule_search_locations[0]) / "static" / name).read_bytes()


@routes.get(DOCS_PATH)
async def docs(request: web.Request) -> web.Response:
    """Swagger UI on ``/openapi.json``."""
    return web.Response(body=_PAGE, headers=_HEADERS)


@routes.get(DOCS_PATH + "/{asset}")
async def asset(request: web.Request) -> web.Response:
    """One of Swagger UI's files."""
    name = request.match_info["asset"]
    if name not in ASSETS:
        raise web.HTTPNotFound()
    return web.Response(body=_asset(name), headers={"Content-Type": ASSETS[name],
                                                     "Cache-Control": "max-age=86400", **SERVER_HEADER})
