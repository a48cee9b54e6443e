"""Typed keys of the gateway's application state."""

from __future__ import annotations

import asyncio

from aiohttp import web

from ..components.core import ComponentHost
from ._config import GatewayConfig
from ._sessions import Listener, SessionStore

__all__ = ["CONFIG", "HOST", "SESSIONS", "LISTENERS", "SHUTDOWN"]

CONFIG = web.AppKey("config", GatewayConfig)
HOST = web.AppKey("host", ComponentHost)
SESSIONS = web.AppKey("sessions", SessionStore)
LISTENERS = web.AppKey("listeners", set[Listener])
#: Set when the gateway shuts down, so that endless streams end.
SHUTDOWN = web.AppKey("shutdown", asyncio.Event)
