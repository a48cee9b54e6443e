"""The aiogenomix gateway: a genomix-compatible HTTP/JSON server hosting components in-process.

Run it with ``aiogenomix-gateway`` (or ``python -m aiogenomix.gateway``), or
build it in code with :func:`create_app` and :class:`GatewayConfig`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._config import GatewayConfig

if TYPE_CHECKING:
    from ._app import create_app
    from ._errors import BadQuery, GatewayError, LoadForbidden, NoSuchSession
    from ._routes_admin import GENOMIX_PROTOCOL_VERSION
    from ._run import ListenError, run, serve, serve_in_thread

    __version__: str

__all__ = [
    "create_app", "GatewayConfig", "run", "serve", "serve_in_thread", "GatewayError", "NoSuchSession", "BadQuery",
    "LoadForbidden", "ListenError", "GENOMIX_PROTOCOL_VERSION", "__version__",
]

# The command line imports this package before its own first line runs: importing
# aiohttp and the components here would leave the first half-second of every start
# to Python's defaults (a traceback on Ctrl-C, a silent death on SIGTERM) instead of
# the gateway's stop (see __main__).  Names are imported on first use instead.
_LAZY = {
    "create_app": ("_app", "create_app"),
    "BadQuery": ("_errors", "BadQuery"),
    "GatewayError": ("_errors", "GatewayError"),
    "LoadForbidden": ("_errors", "LoadForbidden"),
    "NoSuchSession": ("_errors", "NoSuchSession"),
    "GENOMIX_PROTOCOL_VERSION": ("_routes_admin", "GENOMIX_PROTOCOL_VERSION"),
    "ListenError": ("_run", "ListenError"),
    "run": ("_run", "run"),
    "serve": ("_run", "serve"),
    "serve_in_thread": ("_run", "serve_in_thread"),
    "__version__": ("_replies", "SERVER_VERSION"),
}


def __getattr__(name: str) -> Any:
    try:
        module, attribute = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f".{module}", __name__), attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
