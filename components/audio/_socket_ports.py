"""Which component of a host holds which dedicated-socket port, so that a refused socket says whom to ask.

The audio components of a host (``capture``, ``kemarcapture``, ``bass``) all serve their
dedicated socket on the gateway's ``--audio-socket-port``: one at a time.  When a second
asks for the port, the refusal names the component holding it and its ``CloseSocket``;
only a port held by another program needs another ``--audio-socket-port``.
"""

from __future__ import annotations

import contextlib
import errno
from collections.abc import Iterator

__all__ = ["SocketPorts"]


class SocketPorts:
    """The dedicated-socket ports the components of one host hold (one per host: ``host.shared``)."""

    def __init__(self) -> None:
        self._holders: dict[int, str] = {}

    @contextlib.contextmanager
    def held(self, port: int, holder: str) -> Iterator[None]:
        """Record that the instance *holder* serves on *port* while the context is open."""
        self._holders[port] = holder
        try:
            yield
        finally:
            if self._holders.get(port) == holder:
                del self._holders[port]

    def holder(self, port: int) -> str | None:
        """The instance serving on *port*, if one of this host's does."""
        return self._holders.get(port)

    def why_refused(self, port: int, exc: OSError) -> str:
        """Why *port* could not be listened on (*exc*), and what to do about it."""
        holder = self.holder(port)
        if holder is not None:
            return (f"port {port} is held by {holder}'s dedicated socket: call {holder}'s CloseSocket first "
                    f"(the dedicated sockets share --audio-socket-port, one component at a time)")
        if exc.errno == errno.EADDRINUSE:
            return (f"port {port} is used by another program: restart the gateway with --audio-socket-port "
                    f"to choose another ({exc.strerror or exc})")
        return f"{exc.strerror or exc}; the gateway's --audio-socket-port chooses another port"
