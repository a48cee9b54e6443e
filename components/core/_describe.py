"""The ``/module/M/info`` description of a component (schema in docs/protocol.md)."""

from __future__ import annotations

import inspect
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ._component import Component

__all__ = ["describe"]

PROTOCOL_REVISION = 1


def describe(component: Component) -> dict[str, Any]:
    """Describe services, parameters, exceptions, ports and tasks in declaration order."""
    cls = type(component)
    name = cls.genom_name
    overrides = cls.service_defaults(component.host)
    services = []
    for spec in cls.services().values():
        described = spec.describe(overrides.get(spec.name))
        described["throws"] = [exc.ex_id(name) for exc in spec.throws]
        services.append(described)
    exceptions = []
    for exc in cls.declared_exceptions():
        members = [{"name": n, "type": t.describe()} for n, t in exc.detail_members()]
        exceptions.append({"name": exc.ex_id(name), "doc": inspect.getdoc(exc) or "", "detail": members})
    return {
        "name": component.instance,
        "component": name,
        "version": cls.version,
        "doc": (inspect.getdoc(cls) or "").split("\n\n", 1)[0].replace("\n", " "),
        "revision": PROTOCOL_REVISION,
        "services": services,
        "ports": [port.describe() for port in cls.ports().values()],
        "exceptions": exceptions,
        "tasks": [task.describe() for task in cls.tasks().values()],
    }
