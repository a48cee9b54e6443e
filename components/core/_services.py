"""Service declarations: the ``@function``, ``@activity`` and ``@attribute`` decorators.

A decorated method keeps working as a plain method; the decorator attaches a
:class:`ServiceSpec` read from its signature and type hints: parameter names,
IDL types, defaults and docs (``Annotated[Double, "doc"]``), outputs (the
return annotation), interrupts, declared exceptions and a validate hook.
The options are keyword-only and typed; a misspelled one, or one of the wrong
shape, is refused in the class body.  :func:`redeclare` declares, in a merged
component, a new implementation of a service of one of its parts.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import inspect
import typing
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Annotated, Any, Literal, Protocol, TypeVar, overload

from ._exceptions import GenomException, InputError
from ._types import IdlType, idl_type, notes_of

if TYPE_CHECKING:
    from ._tasks import Task

__all__ = [
    "function", "activity", "attribute", "redeclare", "Out", "ParamSpec", "ServiceSpec", "NO_DEFAULT",
    "ServiceDecorator", "check_validate_hook", "check_redeclaration",
]

_F = TypeVar("_F", bound=Callable[..., Any])

ServiceKind = Literal["function", "activity", "attribute"]


class _NoDefault:
    def __repr__(self) -> str:
        return "NO_DEFAULT"


#: Marks a parameter without a default value.
NO_DEFAULT: Any = _NoDefault()


@dataclasses.dataclass(frozen=True)
class Out:
    """Names (and documents) the single output of a service: ``-> Annotated[T, Out("name", "doc")]``."""

    name: str
    doc: str = ""


@dataclasses.dataclass(frozen=True)
class ParamSpec:
    """One parameter of a service.

    Attributes:
        name: The parameter name on the wire.
        direction: ``in``, ``out`` or ``inout``.
        type: Its IDL type.
        doc: Its documentation.
        default: Its default (a Python value), or :data:`NO_DEFAULT`.
        unit: Its unit (``Annotated[Double, Unit("deg")]``), or "" when it has none.
    """

    name: str
    direction: Literal["in", "out", "inout"]
    type: IdlType
    doc: str = ""
    default: Any = NO_DEFAULT
    unit: str = ""

    def describe(self, default: Any = NO_DEFAULT) -> dict[str, Any]:
        """The ``/info`` description of this parameter (*default* replaces the declared one)."""
        described: dict[str, Any] = {"name": self.name, "dir": self.direction, "type": self.type.describe(),
                                     "doc": self.doc}
        if self.unit:
            described["unit"] = self.unit
        if default is NO_DEFAULT:
            default = self.default
        if default is not NO_DEFAULT:
            described["default"] = self.type.encode(default)
        return described


@dataclasses.dataclass(frozen=True)
class ServiceSpec:
    """Everything the runtime knows about one service."""

    name: str
    kind: ServiceKind
    func: Callable[..., Any]
    inputs: tuple[ParamSpec, ...]
    outputs: tuple[ParamSpec, ...]
    doc: str = ""
    interrupts: tuple[str, ...] = ()
    throws: tuple[type[GenomException], ...] = ()
    validate: Callable[..., Any] | None = None
    task: str | None = None
    #: Whether the activity moves hardware: its host stops it when the client that started it vanishes.
    motion: bool = False
    #: Where the activity's progress is published: ``"Port.member"`` of an out port of its component.
    progress: str | None = None
    #: How the return value maps to outputs: "none", "single" or "fields".
    output_style: str = "none"
    #: Whether the method is a coroutine function (plain ones run inline).
    is_async: bool = False

    @functools.cached_property
    def _inputs_by_name(self) -> dict[str, ParamSpec]:
        # Made once per service rather than on every request (cached_property writes past frozen).
        return {p.name: p for p in self.inputs}

    @property
    def parameters(self) -> list[ParamSpec]:
        """Inputs then outputs, with an output that is also an input listed once as ``inout``."""
        inputs = {p.name for p in self.inputs}
        return list(self.inputs) + [p for p in self.outputs if p.name not in inputs]

    def decode_inputs(self, raw: Any, defaults: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Decode the JSON ``input`` of a request into keyword arguments.

        Missing inputs take their default — from *defaults* (set by the host)
        first, then the declared one, then their type's zero value, as genom3
        leaves IDS members untouched; unknown names are refused.

        Raises:
            InputError: naming the offending parameter.
        """
        if raw is None:
            raw = {}
        if not isinstance(raw, Mapping):
            if len(self.inputs) == 1:
                # A bare value for a one-parameter service, as Tcl users type it.
                raw = {self.inputs[0].name: raw}
            else:
                raise InputError("input", "expected a JSON object of the service's parameters")
        known = self._inputs_by_name
        for key in raw:
            if key not in known:
                names = ", ".join(known) or "none"
                raise InputError(str(key), f"unknown parameter of {self.name} (parameters: {names})")
        decoded = {}
        for param in self.inputs:
            if param.name in raw:
                decoded[param.name] = param.type.decode(raw[param.name], param.name)
            elif defaults and param.name in defaults:
                decoded[param.name] = defaults[param.name]
            elif param.default is not NO_DEFAULT:
                decoded[param.name] = param.default
            else:
                decoded[param.name] = param.type.zero()
        return decoded

    def encode_inputs(self, inputs: Mapping[str, Any]) -> dict[str, Any]:
        """Decoded inputs (keyword arguments of the service) as the JSON ``input`` a client would send."""
        return {p.name: p.type.encode(inputs[p.name]) for p in self.inputs if p.name in inputs}

    def encode_outputs(self, result: Any) -> dict[str, Any]:
        """Turn a service's return value into the ``output`` object of its request."""
        if self.output_style == "none":
            return {}
        if self.output_style == "single":
            (param,) = self.outputs
            return {param.name: param.type.encode(result)}
        if isinstance(result, Mapping):
            return {p.name: p.type.encode(result[p.name]) for p in self.outputs}
        return {p.name: p.type.encode(getattr(result, p.name)) for p in self.outputs}

    def describe(self, defaults: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The ``/info`` description of this service, with host-dependent *defaults* applied.

        ``throws`` is left to the caller: exception ids need the component name.
        """
        outputs = {p.name for p in self.outputs}
        params = []
        for p in self.parameters:
            described = p.describe((defaults or {}).get(p.name, NO_DEFAULT) if p.direction == "in" else NO_DEFAULT)
            if p.direction == "in" and p.name in outputs:
                described["dir"] = "inout"
            params.append(described)
        described = {"name": self.name, "kind": self.kind, "doc": self.doc, "task": self.task,
                     "parameters": params, "interrupts": list(self.interrupts)}
        if self.progress:
            described["progress"] = self.progress
        return described


def _doc_and_unit(hint: Any) -> tuple[str, str]:
    notes = notes_of(hint)
    return notes.get("doc", ""), notes.get("unit", "")


def _split_doc(func: Callable[..., Any]) -> str:
    doc = inspect.getdoc(func) or ""
    return doc.split("\n\n", 1)[0].replace("\n", " ").strip()


def _outputs_of(annotation: Any) -> tuple[tuple[ParamSpec, ...], str]:
    if annotation in (None, type(None), inspect.Signature.empty):
        return (), "none"
    if typing.get_origin(annotation) is Annotated:
        out = next((m for m in annotation.__metadata__ if isinstance(m, Out)), None)
        if out is not None:
            unit = _doc_and_unit(annotation)[1]
            return (ParamSpec(out.name, "out", idl_type(annotation), out.doc, unit=unit),), "single"
    base = typing.get_args(annotation)[0] if typing.get_origin(annotation) is Annotated else annotation
    if dataclasses.is_dataclass(base) and not hasattr(base, "__idl_type__"):
        hints = typing.get_type_hints(base, include_extras=True)
        params = []
        for field in dataclasses.fields(base):
            hint = hints[field.name]
            doc, unit = _doc_and_unit(hint)
            params.append(ParamSpec(field.name, "out", idl_type(hint), doc, unit=unit))
        return tuple(params), "fields"
    raise TypeError(
        f"return annotation {annotation!r}: use None, Annotated[T, Out('name')] or a dataclass of outputs"
    )


@dataclasses.dataclass(frozen=True)
class _Declaration:
    """What a service decorator attaches to a method: the kind, the options, where the signature is read."""

    kind: ServiceKind
    options: Mapping[str, Any]
    #: The method whose parameters and return annotation declare the service: the
    #: decorated one, or for a redeclaration the original one.
    signature_of: Callable[..., Any]


def _build_spec(func: Callable[..., Any], declaration: _Declaration) -> ServiceSpec:
    kind, options, source = declaration.kind, declaration.options, declaration.signature_of
    hints = typing.get_type_hints(source, include_extras=True)
    inputs = []
    for name, param in list(inspect.signature(source).parameters.items())[1:]:
        if param.kind in (param.VAR_POSITIONAL, param.VAR_KEYWORD):
            raise TypeError("*args and **kwargs have no IDL meaning")
        if name not in hints:
            raise TypeError(f"parameter {name!r} needs a type annotation")
        hint = hints[name]
        doc, unit = _doc_and_unit(hint)
        default = NO_DEFAULT if param.default is param.empty else param.default
        try:
            param_type = idl_type(hint)
        except TypeError as exc:
            raise TypeError(f"parameter {name!r}: {exc}") from None
        inputs.append(ParamSpec(name, "in", param_type, doc, default, unit))
    outputs, style = _outputs_of(hints.get("return", inspect.Signature.empty))
    task = options.get("task")
    return ServiceSpec(
        name=options.get("name") or source.__name__,
        kind=kind,
        func=func,
        inputs=tuple(inputs),
        outputs=outputs,
        doc=options.get("doc") or _split_doc(source),
        interrupts=tuple(options.get("interrupts", ())),
        throws=tuple(options.get("throws", ())),
        validate=options.get("validate"),
        task=getattr(task, "name", task),
        motion=bool(options.get("motion", False)),
        progress=options.get("progress"),
        output_style=style,
        is_async=inspect.iscoroutinefunction(func),
    )


#: The options every service decorator takes.
_OPTIONS = ("name", "doc", "interrupts", "throws", "validate", "task", "motion", "progress")


def _check_options(owner: str, kind: ServiceKind, options: Mapping[str, Any]) -> None:
    """Refuse what a decorator would otherwise ignore or misread: unknown options, wrong shapes.

    Raises:
        TypeError: naming the method (``Component.Service``) and the option.
    """
    for key in options:
        if key not in _OPTIONS:
            close = difflib.get_close_matches(key, _OPTIONS, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise TypeError(f"{owner}: @{kind} has no option {key!r}{hint}; its options are {', '.join(_OPTIONS)}")
    for key in ("interrupts", "throws"):
        value = options.get(key, ())
        # A bare string would be read as a sequence of one-letter names.
        if isinstance(value, str) or not isinstance(value, Sequence):
            raise TypeError(f"{owner}: @{kind} option {key!r} must be a tuple, not {value!r}")
    for name in options.get("interrupts", ()):
        if not isinstance(name, str):
            raise TypeError(f"{owner}: @{kind} option 'interrupts' names services by string, not {name!r}")
    for exc in options.get("throws", ()):
        if not (isinstance(exc, type) and issubclass(exc, GenomException)):
            raise TypeError(f"{owner}: @{kind} option 'throws' takes GenomException classes, not {exc!r}")
    validate = options.get("validate")
    if validate is not None and not callable(validate):
        raise TypeError(f"{owner}: @{kind} option 'validate' must be callable, not {validate!r}")
    motion = options.get("motion", False)
    if not isinstance(motion, bool):
        raise TypeError(f"{owner}: @{kind} option 'motion' is True or False, not {motion!r}")
    if motion and kind != "activity":
        # A function or attribute ends within the function grace: there is no motion left to stop.
        raise TypeError(f"{owner}: only an @activity can be a motion (motion=True), not an @{kind}")
    progress = options.get("progress")
    if progress is not None and not (isinstance(progress, str) and all(p.isidentifier() for p in progress.split("."))):
        raise TypeError(f"{owner}: @{kind} option 'progress' names an out port and a member, \"Port.member\", "
                        f"not {progress!r}")
    if progress is not None and kind != "activity":
        # A function or attribute ends within the function grace: there is no progress to follow.
        raise TypeError(f"{owner}: only an @activity has a progress to follow, not an @{kind}")


class ServiceDecorator(Protocol):
    """The type of :func:`function`, :func:`activity` and :func:`attribute`: bare, or with keyword-only options."""

    @overload
    def __call__(self, func: _F, /) -> _F: ...
    @overload
    def __call__(
        self,
        /,
        *,
        name: str | None = None,
        doc: str | None = None,
        interrupts: Sequence[str] = (),
        throws: Sequence[type[GenomException]] = (),
        validate: Callable[..., Any] | None = None,
        task: Task | str | None = None,
        motion: bool = False,
        progress: str | None = None,
    ) -> Callable[[_F], _F]: ...


_OPTIONS_DOC = """
    Keyword Args:
        name: The service name (default: the method name).
        doc: Its documentation (default: the docstring's first paragraph).
        interrupts: Names of the services a request of this one interrupts.
        throws: The GenomException classes it may raise.
        validate: ``validate(self, **inputs)``, sync or async, raising a GenomException
            to refuse a request before it starts (the request then ends in ``error``).
            Its parameters must be the service's inputs: checked when the class is created.
        task: The Task an activity runs in (descriptive; use ``await self.<task>.tick()``).
        motion: The activity moves hardware (a head, a base): a component host stops it when the
            gateway that started it vanishes (its process died, or its link stayed cut past Zenoh's
            lease), as a dead-man switch would.  Other activities (a capture, a recording) go on.
        progress: Where the activity's progress can be followed while it runs: ``"Port.member"`` (or
            ``"Port"``) of an out port of the component, such as ``"currentState.position"`` for a head's
            moves (``/info`` says it; the console shows it beside the running request).  Checked when the
            class is created.

    Raises:
        TypeError: for an unknown option (``interupts``) or an option of the wrong shape.
"""


_KEYWORD = inspect.Parameter.KEYWORD_ONLY
_DECORATOR_SIGNATURE = inspect.Signature([
    inspect.Parameter("func", inspect.Parameter.POSITIONAL_ONLY, default=None, annotation="Callable[..., Any] | None"),
    inspect.Parameter("name", _KEYWORD, default=None, annotation="str | None"),
    inspect.Parameter("doc", _KEYWORD, default=None, annotation="str | None"),
    inspect.Parameter("interrupts", _KEYWORD, default=(), annotation="Sequence[str]"),
    inspect.Parameter("throws", _KEYWORD, default=(), annotation="Sequence[type[GenomException]]"),
    inspect.Parameter("validate", _KEYWORD, default=None, annotation="Callable[..., Any] | None"),
    inspect.Parameter("task", _KEYWORD, default=None, annotation="Task | str | None"),
    inspect.Parameter("motion", _KEYWORD, default=False, annotation="bool"),
    inspect.Parameter("progress", _KEYWORD, default=None, annotation="str | None"),
], return_annotation="Any")


def _declare(f: Callable[..., Any], declaration: _Declaration) -> None:
    """Mark *f* as the method of a service (what :func:`service_spec` reads back)."""
    vars(f)["__genom_service__"] = declaration


def _decorator(kind: ServiceKind) -> ServiceDecorator:
    def decorator(func: Callable[..., Any] | None = None, /, **options: Any) -> Any:
        def attach(f: Callable[..., Any]) -> Callable[..., Any]:
            # Checked now, in the class body: a misspelled option would otherwise be ignored.
            _check_options(getattr(f, "__qualname__", repr(f)), kind, options)
            # The spec is built lazily: type hints may name classes defined after the method.
            _declare(f, _Declaration(kind, options, f))
            return f

        return attach(func) if func is not None else attach

    decorator.__name__ = decorator.__qualname__ = kind
    # help() shows the options the type checker knows; the body takes **options to refuse a
    # misspelled one with a suggestion rather than Python's bare "unexpected keyword argument".
    vars(decorator)["__signature__"] = _DECORATOR_SIGNATURE
    decorator.__doc__ = f"""Declare a method as a genom3 *{kind}* service.

    Usable bare (``@{kind}``) or with options (``@{kind}(interrupts=("Stop",))``).
    {_OPTIONS_DOC}"""
    return decorator


function = _decorator("function")
activity = _decorator("activity")
attribute = _decorator("attribute")


def redeclare(
    service: _F,
    /,
    *,
    name: str | None = None,
    doc: str | None = None,
    interrupts: Sequence[str] | None = None,
    throws: Sequence[type[GenomException]] | None = None,
    validate: Callable[..., Any] | None = None,
    task: Task | str | None = None,
    motion: bool | None = None,
    progress: str | None = None,
) -> Callable[[Callable[..., Any]], _F]:
    """Declare a new implementation of a service declared by a base class (a merged component's).

    The new method is the same service — its kind, parameters, outputs, docs and
    options — except for the options given here.  It is called with the inputs
    as keyword arguments, so ``async def Move(self, **inputs)`` fits, and it
    may call the original (``await Base.Move(self, **inputs)``)::

        class KemarCapture(Capture, Kemar, name="kemarcapture"):
            @redeclare(Kemar.MoveAbsolutePosition, doc="Turn the head, publish the chunk indexes")
            async def MoveAbsolutePosition(self, **inputs: Any) -> Any:
                ...
                return await Kemar.MoveAbsolutePosition(self, **inputs)

    Type checkers see the decorated method with the original's signature.

    Args:
        service: The original method, decorated with ``@function``, ``@activity`` or ``@attribute``.
        name: The service name (default: the original's).
        doc: Its documentation (default: the original's).
        interrupts: The services it interrupts (default: the original's).
        throws: The GenomException classes it may raise (default: the original's).
        validate: Its validate hook (default: the original's).
        task: The Task it runs in (default: the original's).
        motion: Whether it moves hardware (default: the original's).
        progress: Where its progress is published (default: the original's).

    Raises:
        TypeError: when *service* declares no service, for an option of the wrong
            shape, or (when the class is created) when the new method does not take
            the service's inputs.
    """
    original = getattr(service, "__genom_service__", None)
    if not isinstance(original, _Declaration):
        raise TypeError(f"redeclare: {getattr(service, '__qualname__', service)!r} declares no service "
                        "(decorate it with @function, @activity or @attribute)")
    given = {"name": name, "doc": doc, "interrupts": interrupts, "throws": throws, "validate": validate,
             "task": task, "motion": motion, "progress": progress}
    changes = {key: value for key, value in given.items() if value is not None}

    def attach(f: Callable[..., Any]) -> _F:
        options = {**original.options, **changes}
        _check_options(getattr(f, "__qualname__", repr(f)), original.kind, options)
        _declare(f, _Declaration(original.kind, options, original.signature_of))
        return f  # type: ignore[return-value]  # it takes the original's inputs: checked by the class

    return attach


def _check_takes_inputs(func: Callable[..., Any], spec: ServiceSpec, where: str, call_name: str) -> None:
    """Check that ``func(component, **inputs)`` fits the service's inputs.

    Raises:
        TypeError: beginning with *where*, naming the parameter that does not match.
    """
    try:
        params = list(inspect.signature(func).parameters.values())
    except (TypeError, ValueError):
        return  # no introspectable signature (a builtin): the call itself will tell
    inputs = [p.name for p in spec.inputs]
    call = f"{call_name}(self{''.join(', ' + n for n in inputs)})"
    positional = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    if not params or (params[0].kind not in positional and params[0].kind is not inspect.Parameter.VAR_POSITIONAL):
        raise TypeError(f"{where} must take the component first: it is called as {call}")
    rest = params[1:] if params[0].kind is not inspect.Parameter.VAR_POSITIONAL else params
    takes_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in rest)
    by_keyword = {p.name: p for p in rest if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                                         inspect.Parameter.KEYWORD_ONLY)}
    for param in rest:
        if param.kind is inspect.Parameter.POSITIONAL_ONLY and param.default is param.empty:
            raise TypeError(f"{where} has the positional-only parameter {param.name!r}: it is called as {call}")
        if param.name in by_keyword and param.name not in inputs and param.default is param.empty:
            listed = ", ".join(inputs) or "none"
            raise TypeError(f"{where} takes the parameter {param.name!r}, which is not an input of "
                            f"{spec.name} (inputs: {listed})")
    for name in inputs:
        if name not in by_keyword and not takes_any:
            raise TypeError(f"{where} does not take the input {name!r} of {spec.name}: it is called as {call}")


def check_validate_hook(spec: ServiceSpec, owner: str) -> None:
    """Check that ``spec.validate(component, **inputs)`` fits the service's inputs.

    Args:
        spec: The service, with a validate hook.
        owner: How to name the component in the message.

    Raises:
        TypeError: naming the component, the service and the parameter that does not match.
    """
    hook = spec.validate
    assert hook is not None
    _check_takes_inputs(hook, spec, f"{owner}, service {spec.name}: validate hook {getattr(hook, '__name__', hook)!r}",
                        "validate")


def check_redeclaration(spec: ServiceSpec, owner: str) -> None:
    """Check that a method declared with :func:`redeclare` takes the inputs of the service it redeclares.

    Raises:
        TypeError: naming the component, the service and the parameter that does not match.
    """
    declaration = getattr(spec.func, "__genom_service__", None)
    assert isinstance(declaration, _Declaration)  # a redeclared service's method is declared
    if spec.func is not declaration.signature_of:
        _check_takes_inputs(spec.func, spec, f"{owner}, service {spec.name}: the redeclared method "
                                             f"{getattr(spec.func, '__qualname__', spec.func)!r}", spec.name)


def service_spec(func: Callable[..., Any]) -> ServiceSpec | None:
    """The ServiceSpec of a decorated method (None for an ordinary method).

    Raises:
        TypeError: for a declaration with no IDL meaning (an unannotated parameter, a type or a
            return annotation of no IDL type); the class that holds the method adds its name.
    """
    declaration = getattr(func, "__genom_service__", None)
    if not isinstance(declaration, _Declaration):
        return None
    return _build_spec(func, declaration)
