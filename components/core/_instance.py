"""What a host serves of a loaded instance, wherever it runs: the seam between the gateway and the components.

A component of this process (:class:`~aiogenomix.components.core.Component`) and the proxy of
one that runs in another process (``aiogenomix.remote``) both satisfy :class:`LoadedInstance`;
the gateway's routes use nothing else, so they never ask which one they hold.
"""

from __future__ import annotations

from typing import Any, Literal, Protocol, TypedDict

from ._ports import InPortRuntime, OutPortRuntime
from ._requests import RequestStatus

__all__ = ["LoadedInstance", "Placement"]


class Placement(TypedDict, total=False):
    """Where an instance runs, as ``/`` and a load's reply say it.

    ``runs`` is ``"here"`` for a component of this process; an instance of a component host has
    ``runs: "remote"`` and the rest.

    Attributes:
        runs: ``"here"`` or ``"remote"``.
        component: The component's name (``demo``).
        version: The component's version.
        host: The id of the component host that runs it (``aiogenomix-component --host-id``).
        instance: Its instance name on that host (it may be loaded here under another name).
        endpoints: The Zenoh endpoints the host says it listens on or connects to.
        zid: The host's Zenoh session id (one per run of the host process).
        protocol: The remote protocol version the host speaks.
    """

    runs: Literal["here", "remote"]
    component: str
    version: str
    host: str
    instance: str
    endpoints: list[str]
    zid: str
    protocol: int


class LoadedInstance(Protocol):
    """A loaded instance as a host serves it: its description, requests and ports.

    Requests are :class:`RequestStatus` objects: their status object, whether they run, their
    ``ended`` event.  Everything that can be refused raises the runtime's errors
    (``NoSuchService``, ``InputError``, ``NoSuchRequest``, ``RemoteUnreachable``...).
    """

    @property
    def instance(self) -> str:
        """The instance name here (``/module/<instance>/...``)."""

    @property
    def genom_name(self) -> str:
        """The component's name (the scope of its exception ids)."""

    def description(self) -> dict[str, Any]:
        """The ``/module/M/info`` description (the same object while it holds: not to be changed in place)."""

    def placement(self) -> Placement:
        """Where the instance runs."""

    def port(self, name: str) -> OutPortRuntime[Any] | InPortRuntime[Any]:
        """The port *name* (raises ``NoSuchPort``)."""

    async def send(self, name: str, raw_input: object = None, *, session: str | None = None,
                   oneway: bool = False) -> RequestStatus:
        """Start a request of service *name* with the JSON-decoded *raw_input*."""

    async def request(self, request_id: str) -> RequestStatus:
        """The request *request_id* (raises ``NoSuchRequest``)."""

    async def abort(self, request_id: str) -> RequestStatus:
        """Interrupt the request *request_id*; return it, ended."""

    async def clean(self, request_id: str) -> None:
        """Forget the ended request *request_id* (raises ``RequestRunning`` for one that runs)."""

    async def session_ended(self, session: str) -> None:
        """The gateway's session *session* ended (stopped, expired): its requests that run may end with it."""

    async def start(self) -> None:
        """Start serving (the host calls it once, when it loads the instance)."""

    async def stop(self) -> None:
        """Stop serving: every request that runs ends (the host calls it when it unloads the instance)."""
