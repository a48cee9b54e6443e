"""The aiogenomix Python client: genomix sessions with functions generated from each module's ``/info``.

Blocking, for scripts, the REPL and Jupyter::

    from aiogenomix.clients import connect

    with connect("localhost:8080") as g:
        demo = g.load("demo")
        demo.GotoPosition(0.5)                 # blocks until the robot is there
        r = demo.GotoPosition(1, ack=True)     # returns at once: r.status is "sent"
        r.wait(); r.status                     # "done"
        demo.Mobile().position                 # 1.0

asyncio, with the same functions awaited::

    async with aconnect("localhost:8080") as g:
        demo = await g.load("demo")
        await demo.GotoPosition(0.5)

See docs/client.md for the exception tree and the differences from python-genomix.
"""

from ._async_client import AsyncClient, AsyncModule, aconnect
from ._errors import (
    ClientClosed,
    Forbidden,
    GenoMError,
    GenomixError,
    HostUnreachable,
    Interrupted,
    InvalidInput,
    ModuleUnloaded,
    NotFound,
    ProtocolError,
    RemoteError,
    RequestTimeout,
    TooManyActivities,
    TransportError,
    remote_exception_class,
)
from ._request import AsyncRequest
from ._service import USE_CLIENT_DEFAULT
from ._streams import PortEvent, SessionEvent
from ._sync_client import Client, Module, Request, connect
from ._types import Record
from ._wire import DEFAULT_ADDRESS, GatewayClock, Status
from .audio_socket import (
    DEFAULT_PORT,
    AsyncAudioSocketClient,
    AudioBlock,
    AudioSocketClient,
    AudioSocketError,
)
from .frame_socket import AsyncFrameSocketClient, FrameBlock, FrameSocketClient

__all__ = [
    # Connecting
    "connect", "aconnect", "Client", "AsyncClient", "DEFAULT_ADDRESS",
    # Modules and requests
    "Module", "AsyncModule", "Request", "AsyncRequest", "Status", "Record", "USE_CLIENT_DEFAULT",
    # Event streams of ports and sessions (AsyncClient.watch, AsyncClient.session_events), the rig's clock
    "PortEvent", "SessionEvent", "GatewayClock",
    # Errors
    "GenomixError", "GenoMError", "RemoteError", "Interrupted", "InvalidInput", "NotFound", "Forbidden",
    "TooManyActivities", "HostUnreachable", "TransportError", "RequestTimeout", "ProtocolError", "ModuleUnloaded",
    "ClientClosed", "remote_exception_class",
    # The dedicated audio socket (clients/audio_socket.py)
    "AudioSocketClient", "AsyncAudioSocketClient", "AudioBlock", "AudioSocketError", "DEFAULT_PORT",
    # The frame-indexed socket of 2015 (bass; clients/frame_socket.py)
    "FrameSocketClient", "AsyncFrameSocketClient", "FrameBlock",
]

# Public names say they live here, not in the private module that defines them (as httpx does).
for _name in __all__:
    _obj = globals()[_name]
    if getattr(_obj, "__module__", "").startswith(__name__ + "._"):
        _obj.__module__ = __name__
del _name, _obj
