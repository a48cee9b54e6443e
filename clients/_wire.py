"""The wire contract as the client reads it: typed shapes of docs/protocol.md and their checks."""

from __future__ import annotations

import dataclasses
import enum
import math
import re
from collections.abc import Mapping
from typing import Any, Literal, NotRequired, TypedDict, cast
from urllib.parse import urlsplit

from ._errors import ProtocolError

__all__ = [
    "DEFAULT_ADDRESS",
    "GatewayClock",
    "ExceptionInfo",
    "ExceptionObject",
    "ModuleInfo",
    "ParameterInfo",
    "PortInfo",
    "ServiceInfo",
    "Status",
    "StatusObject",
    "TaskInfo",
    "TypeInfo",
    "base_url",
    "check_info",
    "clock_of",
    "parse_status",
    "request_number",
]

#: Where :func:`connect` goes when given no address (python-genomix and MATLAB do the same).
DEFAULT_ADDRESS = "localhost:8080"


class Status(str, enum.Enum):
    """The status of a request; compares equal to the wire strings (``h.status == "done"``)."""

    sent = "sent"
    done = "done"
    error = "error"

    def __str__(self) -> str:
        return self.value


class TypeInfo(TypedDict):
    """An IDL type description (``kind`` decides which other members exist)."""

    name: str
    kind: str
    values: NotRequired[list[str]]
    members: NotRequired[list[MemberInfo]]
    element: NotRequired[TypeInfo]
    bound: NotRequired[int | None]
    length: NotRequired[int]


class GridInfo(TypedDict):
    """What the index of a sequence stands for: ``start + index * step`` in ``unit``."""

    start: float
    step: float
    unit: str


class MemberInfo(TypedDict):
    """A struct member, or an exception detail member."""

    name: str
    type: TypeInfo
    doc: NotRequired[str]
    unit: NotRequired[str]
    grid: NotRequired[GridInfo]


class ParameterInfo(TypedDict):
    """A service parameter."""

    name: str
    dir: Literal["in", "out", "inout"]
    type: TypeInfo
    doc: str
    unit: NotRequired[str]
    default: NotRequired[Any]


class ServiceInfo(TypedDict):
    """A service of a module."""

    name: str
    kind: Literal["function", "activity", "attribute"]
    doc: str
    task: str | None
    parameters: list[ParameterInfo]
    interrupts: list[str]
    throws: list[str]


class PortInfo(TypedDict):
    """A port of a module."""

    name: str
    dir: Literal["in", "out"]
    kind: Literal["simple", "multiple"]
    type: TypeInfo
    doc: str


class ExceptionInfo(TypedDict):
    """A declared exception."""

    name: str
    doc: str
    detail: list[MemberInfo]


class TaskInfo(TypedDict):
    """An execution task."""

    name: str
    period: float | None
    doc: str


class ModuleInfo(TypedDict):
    """The reply of ``/module/M/info``."""

    name: str
    component: str
    version: str
    doc: str
    revision: int
    services: list[ServiceInfo]
    ports: list[PortInfo]
    exceptions: list[ExceptionInfo]
    tasks: list[TaskInfo]


class ExceptionObject(TypedDict):
    """``{"ex": id, "detail": {...}}``."""

    ex: str
    detail: NotRequired[dict[str, Any]]


class StatusObject(TypedDict):
    """The reply of send/status/wait/abort and the data of a ``request`` event."""

    id: str
    status: Literal["sent", "done", "error"]
    output: NotRequired[dict[str, Any]]
    exception: NotRequired[ExceptionObject]


def parse_status(data: Any) -> StatusObject:
    """Check a status object.

    Raises:
        ProtocolError: when it lacks an id or a known status, or an ended one lacks its payload.
    """
    if not isinstance(data, Mapping) or not isinstance(data.get("id"), str):
        raise ProtocolError(f"expected a request status object with an id, got {data!r:.200}")
    status = data.get("status")
    if status not in ("sent", "done", "error"):
        raise ProtocolError(f"unknown request status {status!r} in {data!r:.200}")
    if status == "error" and not isinstance(data.get("exception"), Mapping):
        raise ProtocolError(f"an error status without its exception: {data!r:.200}")
    if status == "done" and not isinstance(data.get("output", {}), Mapping):
        raise ProtocolError(f"a done status whose output is not an object: {data!r:.200}")
    return cast(StatusObject, data)  # checked above


def check_info(data: Any) -> ModuleInfo:
    """Check the top level of an ``/info`` reply (the client is lenient below that).

    Raises:
        ProtocolError: when the description is not an object with services and ports.
    """
    if not isinstance(data, Mapping) or not isinstance(data.get("services"), list):
        raise ProtocolError(f"/info did not describe a module: {data!r:.200}")
    info = dict(data)
    info.setdefault("ports", [])
    info.setdefault("exceptions", [])
    info.setdefault("tasks", [])
    info.setdefault("doc", "")
    info.setdefault("component", info.get("name", ""))
    return cast(ModuleInfo, info)  # its top level checked above


def base_url(address: str | None) -> str:
    """Turn ``host:port``, ``host``, ``:port`` or ``http://host:port/`` into ``http://host:port``.

    Raises:
        ValueError: for an address that names no host.
    """
    text = (address or DEFAULT_ADDRESS).strip()
    if not re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*://", text):
        text = "http://" + text
    parts = urlsplit(text)
    if parts.scheme not in ("http", "https"):
        raise ValueError(f"genomix gateways speak http, not {parts.scheme!r}")
    host = parts.hostname or "localhost"
    port = parts.port or (8080 if parts.scheme == "http" else 443)
    shown = f"[{host}]" if ":" in host else host
    return f"{parts.scheme}://{shown}:{port}{parts.path.rstrip('/')}"


def request_number(request_id: str) -> str:
    """The ``n`` of ``demo::n`` (the gateway accepts both forms; the short one is path-safe)."""
    return request_id.rpartition("::")[2]


@dataclasses.dataclass(frozen=True)
class GatewayClock:
    """The gateway's clock as its ``/`` told it: the time its rig stamps the ports' data with.

    Attributes:
        wall: POSIX seconds on that clock when the reply was made.
        scale: Its runtime seconds per real second; ``math.inf`` for a clock that moves with a
            simulation, not with real time (``ManualClock``, ``VirtualClock``).
        kind: ``RealClock``, ``ScaledClock``, ``ManualClock`` or ``VirtualClock``.
    """

    wall: float
    scale: float
    kind: str


def clock_of(index: Any) -> GatewayClock | None:
    """The clock a gateway's ``/`` describes (None from a gateway that describes none, such as genomixd)."""
    clock = index.get("clock") if isinstance(index, Mapping) else None
    if not isinstance(clock, Mapping) or not isinstance(clock.get("wall"), int | float):
        return None
    scale = clock.get("scale")
    return GatewayClock(float(clock["wall"]), float(scale) if isinstance(scale, int | float) else math.inf,
                        str(clock.get("kind", "")))
