"""Shutting the gateway down: stop the components, then answer and end everything still open.

The order is what clients notice.  Components stop first, so every running
request ends (``::genom::interrupted``, ``by: "kill"``) while its ``wait`` and
its session's listeners are still there to hear it.  Then the endless replies
end: a ``wait`` whose request still runs (a host the gateway does not own, or
a component that did not stop in time) answers 503, watch streams end, and
every session's listeners get ``quit``.  Each step is bounded, so the process
exits within two seconds whatever clients hold open.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable

from aiohttp import web

from ..components.core.runtime import RequestStatus
from ._keys import HOST, SESSIONS, SHUTDOWN
from ._replies import json_reply

__all__ = ["STOP_COMPONENTS_WITHIN", "HANDLER_GRACE", "shut_down", "shutting_down_reply"]

log = logging.getLogger(__name__)

#: Seconds the components have to stop (interrupt activities, close hardware) before the gateway exits anyway.
STOP_COMPONENTS_WITHIN = 1.0
#: Seconds a request handler still running after the shutdown step may take before aiohttp cancels it.
#: Every endless reply ends in that step; this bounds the rest (aiohttp's default is 60 s, twice).
HANDLER_GRACE = 0.25


def shut_down(owns_host: bool) -> Callable[[web.Application], Awaitable[None]]:
    """The application's shutdown step (an ``on_shutdown`` handler).

    Args:
        owns_host: Whether the gateway stops the components (it leaves a host it
            was given to its owner).
    """

    async def step(app: web.Application) -> None:
        if owns_host:
            await _stop_components(app)
        app[SHUTDOWN].set()
        app[SESSIONS].stop_all()

    return step


async def _stop_components(app: web.Application) -> None:
    host = app[HOST]
    loaded = ", ".join(host.instances) or "none loaded"
    try:
        async with asyncio.timeout(STOP_COMPONENTS_WITHIN):
            await host.close()
    except TimeoutError:
        # Exiting beats hanging: the user asked the process to end.
        log.error("the components (%s) did not stop within %.1f s; shutting down anyway", loaded,
                  STOP_COMPONENTS_WITHIN)


def shutting_down_reply(request: RequestStatus) -> web.Response:
    """The reply to a ``wait`` on a request that had not ended when the gateway shut down."""
    return json_reply({"ex": "::genomix::shutting_down",
                       "message": f"the gateway is shutting down; request {request.id} had not ended"}, status=503)
