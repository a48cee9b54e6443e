"""Components in other processes and on other hosts, through Zenoh.

A component host process (``aiogenomix-component``, :mod:`._host_main`) runs components on the
ordinary runtime and offers each on Zenoh (:class:`ComponentExporter`); a gateway started with
``--zenoh`` finds them (:class:`ZenohDirectory`) and serves each through a proxy
(:class:`RemoteComponent`) that the routes treat as any loaded instance.  The key space and the
messages are in :mod:`._wire`; the decision is docs/decisions/0017.

Importing this package imports Zenoh: the gateway does it only when asked for remote components.
"""

from ._directory import ZenohDirectory
from ._exporter import ComponentExporter, PortEncoder
from ._mirror import MirroredOutPort, MirroredWindow
from ._proxy import REMOTE_IO, RemoteComponent, RemoteRequest, RemoteTimeouts
from ._session import ZenohEndpoints, open_session

__all__ = [
    "ZenohDirectory", "ZenohEndpoints", "open_session", "ComponentExporter", "PortEncoder", "RemoteComponent",
    "RemoteRequest", "RemoteTimeouts", "REMOTE_IO", "MirroredOutPort", "MirroredWindow",
]
