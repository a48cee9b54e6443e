"""The aiogenomix gateway: a genomix-compatible HTTP/JSON server hosting components in-process.

Run it with ``aiogenomix-gateway`` (or ``python -m aiogenomix.gateway``), or
build it in code with :func:`create_app` and :class:`GatewayConfig`.
"""

from ._app import create_app
from ._config import GatewayConfig
from ._errors import BadQuery, GatewayError, LoadForbidden, NoSuchSession
from ._replies import SERVER_VERSION
from ._routes_admin import GENOMIX_PROTOCOL_VERSION
from ._run import run, serve, serve_in_thread

__version__ = SERVER_VERSION

__all__ = [
    "create_app", "GatewayConfig", "run", "serve", "serve_in_thread", "GatewayError", "NoSuchSession", "BadQuery",
    "LoadForbidden", "GENOMIX_PROTOCOL_VERSION", "__version__",
]
