"""Components in other processes and on other hosts, through Zenoh: the remote layer.

A component host process (``aiogenomix-component``, :mod:`._host_main`) runs components on the
ordinary runtime and offers each on Zenoh (:class:`HostNode`, :class:`ComponentExporter`); a gateway
started with ``--zenoh-connect`` (or ``--zenoh-listen``, ``--zenoh-config``) finds them
(:class:`ZenohDirectory`) and serves each through a proxy (:class:`RemoteInstance`) that satisfies
the same seam as a component of its own (``LoadedInstance``).  The key space and the messages are
in :mod:`._wire`; the decisions are docs/decisions/0017 and 0028.

This layer imports the component runtime, never the HTTP gateway: a robot running its components
carries no web server.  Importing it imports Zenoh: the gateway does it only when asked for remote
components.
"""

from ._directory import ZenohDirectory
from ._exporter import ComponentExporter, PortEncoder
from ._host_node import HostNode
from ._mirror import MirroredOutPort, MirroredWindow
from ._offers import OfferBook
from ._proxy import REMOTE_IO, RemoteInstance, RemoteLink, RemoteRequest, RemoteTimeouts
from ._session import ZenohSessionError, ZenohSettings, open_session
from ._wire import PROTOCOL

__all__ = [
    "ZenohDirectory", "ZenohSettings", "ZenohSessionError", "open_session", "HostNode", "ComponentExporter",
    "PortEncoder", "RemoteInstance", "RemoteLink", "RemoteRequest", "RemoteTimeouts", "REMOTE_IO",
    "MirroredOutPort", "MirroredWindow", "OfferBook", "PROTOCOL",
]
