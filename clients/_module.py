"""Module proxies: one object per loaded instance whose attributes are generated service and port functions."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ._errors import remote_exception_class, short_name
from ._service import PortSpec, ServiceSpec
from ._wire import ModuleInfo

__all__ = ["GENERATED_MODULE", "ModuleDescription", "ModuleProxy", "build_members", "dress"]

#: Where generated functions and classes say they come from (shown by help()).
GENERATED_MODULE = "aiogenomix.clients.remote"


class ModuleDescription:
    """The specs of every service, port and declared exception of one ``/info`` reply."""

    def __init__(self, info: ModuleInfo) -> None:
        self.info = info
        self.instance = info["name"]
        self.component = info.get("component", self.instance)
        self.services = {s["name"]: ServiceSpec(s, info) for s in info["services"]}
        self.ports = {p["name"]: PortSpec(p, info) for p in info.get("ports", [])}
        self.exceptions = {
            short_name(e["name"]): remote_exception_class(e["name"], e.get("doc"), e.get("detail", []))
            for e in info.get("exceptions", [])
        }
        # Thrown ids that /info does not list among its exceptions still get their class.
        for spec in self.services.values():
            for ex in spec.info.get("throws", []):
                self.exceptions.setdefault(short_name(ex), remote_exception_class(ex))

    def doc(self) -> str:
        """The docstring of the module proxy: component doc, services, ports, exceptions."""
        info = self.info
        lines = [(info.get("doc") or "").strip() or f"The {self.component} component.", "",
                 f"Instance {self.instance} of component {self.component} {info.get('version', '')}".rstrip() + ".",
                 "", "Services:"]
        lines += [f"    {s.pyname}{_short_signature(s)}: {s.kind}. {_first_line(s.info.get('doc'))}"
                  for s in self.services.values()]
        if self.ports:
            lines += ["", "Ports:"]
            lines += [f"    {p.pyname}(): {p.info.get('dir', 'out')} port. {_first_line(p.info.get('doc'))}"
                      for p in self.ports.values()]
        if self.exceptions:
            lines += ["", "Exceptions:"]
            lines += [f"    {name}: {_first_line(cls.__doc__)}" for name, cls in self.exceptions.items()]
        return "\n".join(lines)


def _first_line(text: str | None) -> str:
    return (text or "").strip().split("\n", 1)[0]


def _short_signature(spec: ServiceSpec) -> str:
    return "(" + ", ".join(p.pyname for p in spec.inputs) + ")"


def dress(func: Callable[..., Any], *, name: str, qualname: str, signature: Any, doc: str) -> Callable[..., Any]:
    """Give a generated function its name, signature, annotations and docstring."""
    func.__name__ = name
    func.__qualname__ = qualname
    func.__module__ = GENERATED_MODULE
    func.__doc__ = doc
    vars(func)["__signature__"] = signature
    annotations = {n: p.annotation for n, p in signature.parameters.items()}
    annotations["return"] = signature.return_annotation
    func.__annotations__ = annotations
    return func


class ModuleProxy:
    """Base of module objects: services, ports and exceptions as attributes, listed by ``dir()``.

    Private names are never looked up as remote members, so IPython's probes
    (``_repr_html_``, ``_ipython_canary_method_should_not_exist_``) fail fast.
    """

    def __init__(self, description: ModuleDescription, members: dict[str, Any]) -> None:
        self._description = description
        self._members = members
        self.__name__ = description.instance

    @classmethod
    def create(cls, description: ModuleDescription, members: dict[str, Any]) -> Any:
        """An instance of a subclass made for this module, holding its members.

        Members live on a class of their own (functions as static methods) so that
        ``help(demo)`` shows the component's doc and every service with its signature.
        """
        namespace: dict[str, Any] = {
            name: staticmethod(value) if callable(value) and not isinstance(value, type) else value
            for name, value in members.items()
        }
        namespace.update(__doc__=description.doc(), __module__=GENERATED_MODULE, __qualname__=description.instance)
        return type(description.instance, (cls,), namespace)(description, members)

    @property
    def __info__(self) -> ModuleInfo:
        """The ``/info`` description this object was built from."""
        return self._description.info

    def __dir__(self) -> list[str]:
        return list(self._members)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        description = self.__dict__.get("_description")
        known = ", ".join(self.__dict__.get("_members", {})) or "none"
        instance = description.instance if description is not None else "?"
        raise AttributeError(f"module {instance} has no service, port or exception {name!r} (it has: {known})")

    def __repr__(self) -> str:
        d = self._description
        return (f"<genomix module {d.instance} ({d.component}): {len(d.services)} services, "
                f"{len(d.ports)} ports>")


def build_members(description: ModuleDescription, service_function: Callable[[ServiceSpec], Callable[..., Any]],
                  port_function: Callable[[PortSpec], Callable[..., Any]]) -> dict[str, Any]:
    """Every public member of a module: services first, then ports, then exception classes.

    A name taken by an earlier kind is not overwritten (services win).
    """
    members: dict[str, Any] = {}
    for spec in description.services.values():
        members[spec.pyname] = service_function(spec)
    for port in description.ports.values():
        members.setdefault(port.pyname, port_function(port))
    for name, cls in description.exceptions.items():
        members.setdefault(name, cls)
    return members

