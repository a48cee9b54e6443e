"""From ``/info`` to Python: the signature, docstring, argument binding and output decoding of services and ports."""

from __future__ import annotations

import dataclasses
import functools
import inspect
import keyword
from collections.abc import Mapping, Sequence

# typing's Callable and Optional, not collections.abc's and `X | None`: inspect prints them without
# module prefixes, which keeps help() and Jupyter's signature tooltips readable.
from typing import Any, Callable, Literal, Optional  # noqa: UP035

import numpy

from ._errors import short_name
from ._types import NUMPY_DTYPES, Record, annotation_source, decode, encode
from ._wire import ExceptionInfo, ModuleInfo, ParameterInfo, PortInfo, ServiceInfo

__all__ = [
    "CONTROL_OPTIONS",
    "USE_CLIENT_DEFAULT",
    "CallOptions",
    "PortSpec",
    "ServiceSpec",
    "evaluate_annotation",
    "python_name",
]


class _UseClientDefault:
    """The ``timeout`` default: use the timeout given to :func:`connect` (None there: wait for ever)."""

    _instance: _UseClientDefault | None = None

    def __new__(cls) -> _UseClientDefault:
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "USE_CLIENT_DEFAULT"

    def __reduce__(self) -> str:
        return "USE_CLIENT_DEFAULT"


#: Sentinel default of ``timeout=``: the client's default timeout applies.
USE_CLIENT_DEFAULT: Any = _UseClientDefault()


class _Unset:
    """Default shown for a parameter without an ``/info`` default that follows one with a default."""

    def __repr__(self) -> str:
        return "<zero of its type>"


_UNSET: Any = _Unset()

#: The keyword-only options of every generated service function, and their docs.
CONTROL_OPTIONS: dict[str, tuple[str, Any, str]] = {
    "ack": ("bool", False, "Return a request handle as soon as the gateway acknowledged the request, "
                           "instead of waiting for its end (Tcl's ``&``, MATLAB's ``'-a'``)."),
    "callback": ("Optional[Callable[[Any], Any]]", None, "Called with the request handle once the request "
                                                       "has ended (done or error)."),
    "oneway": ("bool", False, "Send and forget: the gateway reports nothing, the call returns None."),
    "timeout": ("Optional[float]", USE_CLIENT_DEFAULT, "Seconds to wait for the end (None: no limit). "
                                                     "On expiry RequestTimeout is raised and the request "
                                                     "keeps running."),
}

_ANNOTATION_NAMESPACE: dict[str, Any] = {
    "Any": Any, "Literal": Literal, "Mapping": Mapping, "Sequence": Sequence, "Callable": Callable,
    "Optional": Optional,
    "numpy": numpy, "Record": Record,
}


def evaluate_annotation(source: str) -> Any:
    """Turn annotation source text from :func:`annotation_source` into the typing object."""
    return eval(source, dict(_ANNOTATION_NAMESPACE))


def python_name(name: str) -> str:
    """A usable Python identifier for an IDL name (``class`` -> ``class_``)."""
    if not name.isidentifier():
        name = "".join(c if c.isalnum() or c == "_" else "_" for c in name)
        if not name or name[0].isdigit():
            name = "_" + name
    return name + "_" if keyword.iskeyword(name) else name


@dataclasses.dataclass(frozen=True)
class CallOptions:
    """The control options of one call, once bound."""

    ack: bool = False
    callback: Callable[[Any], Any] | None = None
    oneway: bool = False
    timeout: Any = USE_CLIENT_DEFAULT


@dataclasses.dataclass(frozen=True)
class Parameter:
    """A parameter as the client uses it."""

    info: ParameterInfo
    pyname: str

    @property
    def name(self) -> str:
        return self.info["name"]


class ServiceSpec:
    """Everything the client derives from one service description.

    Args:
        info: The service description.
        module: The module description it belongs to (for exception docs and interrupters).
    """

    def __init__(self, info: ServiceInfo, module: ModuleInfo) -> None:
        self.info = info
        self.name = info["name"]
        self.pyname = python_name(self.name)
        self.kind = info["kind"]
        params = [Parameter(p, python_name(p["name"])) for p in info.get("parameters", [])]
        self.inputs = tuple(p for p in params if p.info["dir"] in ("in", "inout"))
        self.outputs = tuple(p for p in params if p.info["dir"] in ("out", "inout"))
        taken = {p.pyname for p in self.inputs}
        # An input named like an option keeps its name; the option gets a trailing underscore.
        self.options = {opt: opt if opt not in taken else opt + "_" for opt in CONTROL_OPTIONS}
        self.input_signature = inspect.Signature(self._input_parameters())
        self.return_source = self._return_source()
        self.signature = inspect.Signature(
            list(self.input_signature.parameters.values()) + self._option_parameters(),
            return_annotation=evaluate_annotation(self.return_source),
        )
        self.doc = self._docstring(module)

    # -- signature -------------------------------------------------------------------------

    def _input_parameters(self) -> list[inspect.Parameter]:
        out = []
        seen_default = False
        for p in self.inputs:
            if "default" in p.info:
                default = decode(p.info["default"], p.info["type"])
                seen_default = True
            else:
                default = _UNSET if seen_default else inspect.Parameter.empty
            out.append(inspect.Parameter(p.pyname, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=default,
                                         annotation=evaluate_annotation(self.input_source(p))))
        return out

    def input_source(self, p: Parameter) -> str:
        """Annotation source of an input parameter."""
        return annotation_source(p.info["type"], "in")

    def _option_parameters(self) -> list[inspect.Parameter]:
        return [inspect.Parameter(self.options[opt], inspect.Parameter.KEYWORD_ONLY, default=default,
                                  annotation=evaluate_annotation(source))
                for opt, (source, default, _) in CONTROL_OPTIONS.items()]

    def _return_source(self) -> str:
        if not self.outputs:
            return "None"
        if len(self.outputs) == 1:
            return annotation_source(self.outputs[0].info["type"], "out")
        return "Record"

    # -- docstring -------------------------------------------------------------------------

    def _docstring(self, module: ModuleInfo) -> str:
        lines = [(self.info.get("doc") or f"The {self.name} service.").strip(), ""]
        task = f", task {self.info['task']}" if self.info.get("task") else ""
        lines.append(f"{module.get('name', '?')} {self.kind} {self.name}{task}.")
        lines += ["", "Args:"]
        for p in self.inputs:
            t = p.info["type"]
            text = (p.info.get("doc") or "").strip().rstrip(".")
            text = f"{text}. " if text else ""
            default = f"Default: {p.info['default']!r}." if "default" in p.info else "Default: the zero of its type."
            unit = f", {p.info['unit']}" if p.info.get("unit") else ""
            lines.append(f"    {p.pyname} ({t['name']}{unit}): {text}{default}{_values_note(t)}")
        for opt, (_, _, doc) in CONTROL_OPTIONS.items():
            lines.append(f"    {self.options[opt]}: {doc}")
        lines += ["", "Returns:"]
        if not self.outputs:
            lines.append("    None: the service has no outputs (a request handle with ack=True).")
        elif len(self.outputs) == 1:
            p = self.outputs[0]
            lines.append(f"    {p.info['type']['name']}: {p.name}, {(p.info.get('doc') or '').strip()} "
                         "(a request handle with ack=True).")
        else:
            lines.append("    Record: the outputs by name (a request handle with ack=True):")
            for p in self.outputs:
                lines.append(f"        {p.name} ({p.info['type']['name']}): {(p.info.get('doc') or '').strip()}")
        lines += ["", "Raises:"]
        exceptions = {e["name"]: e for e in module.get("exceptions", [])}
        for ex in self.info.get("throws", []):
            declared: ExceptionInfo | dict[str, Any] = exceptions.get(ex, {})
            doc = (declared.get("doc") or "").strip()
            detail = ", ".join(f"{m['name']} ({m['type']['name']})" for m in declared.get("detail", []))
            detail = f" Detail: {detail}." if detail else ""
            lines.append(f"    {short_name(ex)}: {ex}. {doc}{detail}".rstrip())
        interrupters = [s["name"] for s in module.get("services", []) if self.name in s.get("interrupts", [])]
        by = ", ".join(interrupters + ["abort"])
        lines.append(f"    Interrupted: when interrupted; ``by`` names who ({by}).")
        lines.append("    InvalidInput: when the gateway refuses the input.")
        lines.append("    RequestTimeout: when the timeout expires first (the request keeps running).")
        interrupts = self.info.get("interrupts", [])
        if interrupts:
            lines += ["", "Interrupts:", f"    Starting it interrupts running {', '.join(interrupts)} requests."]
        return "\n".join(lines)

    # -- calls -------------------------------------------------------------------------------

    def bind(self, args: tuple[Any, ...], kwargs: dict[str, Any]) -> tuple[dict[str, Any], CallOptions]:
        """Bind a call's arguments: the encoded ``input`` object and the control options.

        Arguments may be positional, by keyword, or one dict keyed by parameter
        names. Parameters left out are not sent, so the component applies the
        ``/info`` default shown in the signature.

        Raises:
            TypeError: for arguments that do not fit the signature or the types.
            ValueError: for values out of range or not among an enum's values.
        """
        options = CallOptions(**{opt: kwargs.pop(name) for opt, name in self.options.items() if name in kwargs})
        if len(args) == 1 and not kwargs and isinstance(args[0], Mapping) and self._is_input_dict(args[0]):
            kwargs = {self._pyname(k): v for k, v in args[0].items()}
            args = ()
        try:
            bound = self.input_signature.bind(*args, **kwargs)
        except TypeError as exc:
            raise TypeError(f"{self.name}{self.input_signature}: {exc}") from None
        by_pyname = {p.pyname: p for p in self.inputs}
        encoded = {}
        for pyname, value in bound.arguments.items():
            if value is _UNSET:
                continue
            p = by_pyname[pyname]
            encoded[p.name] = encode(value, p.info["type"], p.name)
        return encoded, options

    def _is_input_dict(self, value: Mapping[Any, Any]) -> bool:
        names = {p.name for p in self.inputs} | {p.pyname for p in self.inputs}
        return all(isinstance(k, str) and k in names for k in value)

    def _pyname(self, name: str) -> str:
        for p in self.inputs:
            if name == p.name:
                return p.pyname
        return name

    def decode_outputs(self, output: Mapping[str, Any]) -> Record:
        """Decode an ``output`` object: every output by name, in declaration order."""
        return Record((p.name, decode(output[p.name], p.info["type"])) for p in self.outputs if p.name in output)

    def result(self, outputs: Record) -> Any:
        """What a blocking call returns: None, the single output, or the Record of several."""
        if not self.outputs:
            return None
        if len(self.outputs) == 1:
            return outputs.get(self.outputs[0].name)
        return outputs


def _values_note(t: Mapping[str, Any]) -> str:
    if t.get("kind") == "enum":
        return " One of " + ", ".join(v.rpartition("::")[2] for v in t.get("values", [])) + "."
    if t.get("kind") == "struct":
        return " Members: " + ", ".join(f"{m['name']} ({m['type']['name']}{', ' + m['unit'] if m.get('unit') else ''})"
                                        for m in t.get("members", [])) + "."
    return ""


class PortSpec:
    """Everything the client derives from one port description."""

    def __init__(self, info: PortInfo, module: ModuleInfo) -> None:
        self.info = info
        self.name = info["name"]
        self.pyname = python_name(self.name)
        self.multiple = info.get("kind") == "multiple"
        self.return_source = annotation_source(info["type"], "out")
        params = []
        if self.multiple:
            params.append(inspect.Parameter("name", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=str))
        params += [
            inspect.Parameter("since", inspect.Parameter.KEYWORD_ONLY, default=None, annotation=Optional[int]),
            inspect.Parameter("raw", inspect.Parameter.KEYWORD_ONLY, default=False, annotation=bool),
            inspect.Parameter("timeout", inspect.Parameter.KEYWORD_ONLY, default=USE_CLIENT_DEFAULT,
                              annotation=Optional[float]),
        ]
        self.signature = inspect.Signature(params, return_annotation=evaluate_annotation(self.return_source))
        t = info["type"]
        lines = [(info.get("doc") or f"The {self.name} port.").strip(), "",
                 f"Read the {info.get('dir', 'out')} port {module.get('name', '?')}/{self.name} "
                 f"({info.get('kind', 'simple')}, {t['name']}).{_values_note(t)}", "", "Args:"]
        if self.multiple:
            lines.append("    name: The element of this multiple port to read.")
        lines += [
            "    since: Only the chunks after this chunk index (ports of numbered chunks, such as the",
            "        audio window); the result is then ``(data, lost)``, lost counting the chunks the",
            "        port no longer held.",
            f"    raw: Return the reply as sent, ``{{\"{self.name}\": data}}`` (plain JSON, no numpy).",
            "    timeout: Seconds to wait for the reply (None: no limit).", "",
            "Returns:", f"    {t['name']}: the data (numeric sequences as numpy arrays, structs as Records).",
            "", "Raises:", "    NotFound: when the port (or element) does not exist.",
        ]
        self.doc = "\n".join(lines)

    @functools.cached_property
    def numeric_members(self) -> dict[str, numpy.dtype[Any]]:
        """The numeric sequence members of the port's struct, with their dtypes (parsed fast)."""
        t = self.info["type"]
        members = t.get("members", []) if t.get("kind") == "struct" else []
        return {m["name"]: numpy.dtype(NUMPY_DTYPES[m["type"]["element"]["kind"]]).newbyteorder("<")
                for m in members
                if m["type"]["kind"] in ("sequence", "array") and m["type"]["element"]["kind"] in NUMPY_DTYPES
                and m["type"]["element"]["kind"] != "boolean"}

    def decode(self, data: Any) -> Any:
        """Decode the unwrapped port data."""
        return decode(data, self.info["type"])
