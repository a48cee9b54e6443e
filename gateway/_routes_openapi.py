"""``/openapi.json``: the OpenAPI 3.1 description of this gateway and of the modules loaded now."""

from __future__ import annotations

from aiohttp import web

from ._keys import DOOR, HOST
from ._openapi import openapi_document
from ._replies import SERVER_VERSION, json_reply

__all__ = ["routes"]

routes = web.RouteTableDef()


@routes.get("/openapi.json")
async def openapi(request: web.Request) -> web.Response:
    """The endpoints, and one path per service of every loaded module (it changes with ``load``/``unload``)."""
    infos = {name: component.description() for name, component in request.app[HOST].instances.items()}
    return json_reply(openapi_document(infos, f"{request.scheme}://{request.host}", SERVER_VERSION,
                                       token=request.app[DOOR].token is not None))
