"""Components in other processes and on other hosts, through Zenoh: the remote layer.

A component host process (``aiogenomix-component``, :mod:`._host_main`) runs components on the
ordinary runtime and offers each on Zenoh (:class:`HostNode`, :class:`ComponentExporter`); a gateway
started with ``--zenoh-connect`` (or ``--zenoh-listen``, ``--zenoh-config``) finds them
(:class:`ZenohDirectory`) and serves each through a proxy (:class:`RemoteInstance`) that satisfies
the same seam as a component of its own (``LoadedInstance``).  The key space and the messages are
in :mod:`._wire`; the decisions are docs/decisions/0017 and 0028.

This layer imports the component runtime, never the HTTP gateway: a robot running its components
carries no web server.  Its settings groups (:class:`ZenohSettings`, :class:`RemoteTimeouts`) are
plain data that a gateway's configuration holds; every other name imports Zenoh, on first use: the
gateway does it only when asked for remote components.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._settings import RemoteTimeouts, ZenohSettings

if TYPE_CHECKING:
    from ._directory import ZenohDirectory
    from ._exporter import ComponentExporter, PortEncoder
    from ._host_node import HostNode
    from ._mirror import MirroredOutPort, MirroredWindow
    from ._offers import OfferBook
    from ._proxy import REMOTE_IO, RemoteInstance, RemoteLink, RemoteRequest
    from ._session import ZenohSessionError, open_session
    from ._wire import PROTOCOL

#: The names that import Zenoh, and their modules.
_WITH_ZENOH = {
    "ZenohDirectory": "._directory", "ComponentExporter": "._exporter", "PortEncoder": "._exporter",
    "HostNode": "._host_node", "MirroredOutPort": "._mirror", "MirroredWindow": "._mirror", "OfferBook": "._offers",
    "REMOTE_IO": "._proxy", "RemoteInstance": "._proxy", "RemoteLink": "._proxy", "RemoteRequest": "._proxy",
    "ZenohSessionError": "._session", "open_session": "._session", "PROTOCOL": "._wire",
}


def __getattr__(name: str) -> Any:
    module = _WITH_ZENOH.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(module, __name__), name)


__all__ = [
    "ZenohDirectory", "ZenohSettings", "ZenohSessionError", "open_session", "HostNode", "ComponentExporter",
    "PortEncoder", "RemoteInstance", "RemoteLink", "RemoteRequest", "RemoteTimeouts", "REMOTE_IO",
    "MirroredOutPort", "MirroredWindow", "OfferBook", "PROTOCOL",
]
