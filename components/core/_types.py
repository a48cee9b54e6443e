"""IDL-like data types and their genom3 JSON mapping (decode, encode, describe).

Type hints are the single source of truth of a component's interface: a
parameter annotated ``Annotated[Double, "Goto position in m"]`` is described in
``/info`` as a ``double``, decoded from JSON with genom3's leniency and encoded
back as genom3 does (enums by full name, booleans as 0/1, NaN as ``null``).
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import math
import types
import typing
from collections.abc import Callable, Mapping
from typing import Annotated, Any, ClassVar, TypeVar, dataclass_transform

import numpy as np

from ._chunked import ChunkedArray
from ._exceptions import InputError
from ._kinds import PortKind, carried_by

__all__ = [
    "IdlType", "Scalar", "StringType", "EnumType", "StructType", "SequenceType", "ArrayType",
    "OptionalType", "DescribedType", "idl_type", "idl_struct", "idl_enum", "sequence", "array", "optional", "string",
    "Bound", "Length", "Unit", "Grid", "notes_of", "Boolean", "Octet", "Char", "Short", "UShort", "Long", "ULong",
    "LongLong", "ULongLong", "Float", "Double", "String",
]


class IdlType:
    """One IDL type: how it is described, decoded from JSON and encoded to JSON."""

    #: The IDL spelling, e.g. ``double``, ``::demo::state``, ``sequence<long>``.
    name: str
    #: The description kind: a scalar name, or enum/struct/sequence/array/optional.
    kind: str

    def describe(self) -> dict[str, Any]:
        """Return the ``/info`` description of this type."""
        return {"name": self.name, "kind": self.kind}

    @property
    def carries(self) -> PortKind | None:
        """What data of this type is (audio, a head's state...), when its declaration says: its port kind."""
        return None

    def decode(self, value: Any, path: str) -> Any:
        """Convert a JSON value into the Python value of this type.

        Raises:
            InputError: naming *path* when the value does not fit.
        """
        raise NotImplementedError

    def encode(self, value: Any) -> Any:
        """Convert a Python value of this type into JSON-ready data."""
        return value

    def zero(self) -> Any:
        """The value a genom3 IDS member of this type starts with."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<IDL {self.name}>"


class DescribedType(IdlType):
    """The type of a port known only by its ``/info`` description (another process's port, a recorded one).

    Its data comes JSON-ready already: it is passed on as it is.

    Args:
        described: The ``type`` object of the port's description.
        kind: Where the description comes from (``mirrored``, ``recorded``): what ``kind`` says.
    """

    def __init__(self, described: dict[str, Any], kind: str) -> None:
        self.described = described
        self.name = str(described.get("name", ""))
        self.kind = kind

    def describe(self) -> dict[str, Any]:
        """The description it was made from."""
        return self.described

    @functools.cached_property
    def carries(self) -> PortKind | None:
        """The kind its description carries (None: none, or one this process does not know)."""
        return carried_by(self.described)

    def zero(self) -> Any:
        """Nothing until the first publication."""
        return None


#: Index objects of unbounded sequences name indices below this (a bounded one: below its bound),
#: so that ``{"99999999": 0}`` cannot make the gateway build a list of a hundred million items.
MAX_SPARSE_INDEX = 65536


def _kind_of(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int) and value.bit_length() > 64:
        # Never print it: a thousand digits help nobody (and str() refuses past 4300).
        return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value!r}" if len(value) < 40 else "a string"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _short(key: Any) -> str:
    """A key or name from the input, quoted and cut short, printable whatever it holds."""
    text = repr(key)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_surrogate(char: str) -> bool:
    return "\ud800" <= char <= "\udfff"


class Scalar(IdlType):
    """A numeric, boolean or char IDL scalar."""

    _INT_RANGES: ClassVar[dict[str, tuple[int, int]]] = {
        "octet": (0, 2**8 - 1),
        "short": (-(2**15), 2**15 - 1),
        "unsigned short": (0, 2**16 - 1),
        "long": (-(2**31), 2**31 - 1),
        "unsigned long": (0, 2**32 - 1),
        "long long": (-(2**63), 2**63 - 1),
        "unsigned long long": (0, 2**64 - 1),
    }
    _NUMPY: ClassVar[dict[str, str]] = {
        "octet": "u1", "short": "<i2", "unsigned short": "<u2", "long": "<i4",
        "unsigned long": "<u4", "long long": "<i8", "unsigned long long": "<u8",
        "float": "<f4", "double": "<f8", "boolean": "u1",
    }

    def __init__(self, name: str) -> None:
        self.name = self.kind = name
        self.range = self._INT_RANGES.get(name)

    @property
    def numpy_dtype(self) -> np.dtype[Any]:
        """The little-endian numpy dtype used for arrays of this scalar."""
        return np.dtype(self._NUMPY[self.name])

    def decode(self, value: Any, path: str) -> Any:
        if self.name in ("double", "float"):
            if value is None:
                return math.nan
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InputError(path, f"expected a number ({self.name}), got {_kind_of(value)}")
            try:
                return float(value)
            except OverflowError:
                raise InputError(path, f"{_kind_of(value)} is too large for a {self.name}") from None
        if self.name == "boolean":
            if isinstance(value, bool):
                return value
            if isinstance(value, int) and value in (0, 1):
                return bool(value)
            raise InputError(path, f"expected a boolean (0, 1, true or false), got {_kind_of(value)}")
        if self.name == "char":
            if isinstance(value, str) and len(value) == 1 and not _is_surrogate(value):
                return value
            raise InputError(path, f"expected a one-character string, got {_kind_of(value)}")
        # Integers: genom3 scans them with strtoll, so a fraction is an error.  We
        # accept integral floats (MATLAB sends every number as a double).
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(path, f"expected an integer ({self.name}), got {_kind_of(value)}")
        if isinstance(value, float):
            if not value.is_integer():
                raise InputError(path, f"expected an integer ({self.name}), got {value!r}")
            value = int(value)
        assert self.range is not None  # every other scalar is an integer type, and has a range
        low, high = self.range
        if not low <= value <= high:
            raise InputError(path, f"{_kind_of(value)} is out of range for {self.name} [{low}, {high}]")
        return value

    def encode(self, value: Any) -> Any:
        if self.name in ("double", "float"):
            value = float(value)
            return value if math.isfinite(value) else None
        if self.name == "boolean":
            return 1 if value else 0
        return value

    def zero(self) -> Any:
        if self.name in ("double", "float"):
            return 0.0
        if self.name == "boolean":
            return False
        if self.name == "char":
            return "\0"
        return 0


class StringType(IdlType):
    """``string`` or the bounded ``string<N>``."""

    kind = "string"

    def __init__(self, bound: int | None = None) -> None:
        self.bound = bound
        self.name = "string" if bound is None else f"string<{bound}>"

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "kind": "string", "bound": self.bound}

    def decode(self, value: Any, path: str) -> Any:
        if not isinstance(value, str):
            raise InputError(path, f"expected a string, got {_kind_of(value)}")
        try:
            size = len(value.encode())
        except UnicodeEncodeError:
            # A lone UTF-16 surrogate (JSON "\\ud800") is no character: it could be neither
            # sent to a component as UTF-8 nor written back in a reply.
            raise InputError(path, "the string holds a lone surrogate (\\ud800-\\udfff), which is not a character"
                             ) from None
        if self.bound is not None and size > self.bound:
            raise InputError(path, f"string longer than its bound of {self.bound} bytes")
        return value

    def zero(self) -> Any:
        return ""


class EnumType(IdlType):
    """An IDL enum backed by a Python :class:`enum.Enum`."""

    kind = "enum"

    def __init__(self, py_enum: type[enum.Enum], name: str) -> None:
        self.py_enum = py_enum
        self.name = name
        scope = name.rsplit("::", 1)[0]
        # IDL enumerators live in the enum's enclosing scope: ::demo::SLOW.
        self.full_names = {member: f"{scope}::{member.name}" for member in py_enum}
        self._by_name: dict[str, enum.Enum] = {}
        for member, full in self.full_names.items():
            self._by_name[full] = member
            self._by_name[member.name] = member

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "kind": "enum", "values": list(self.full_names.values())}

    def decode(self, value: Any, path: str) -> Any:
        if isinstance(value, self.py_enum):
            return value
        if isinstance(value, str) and value in self._by_name:
            return self._by_name[value]
        allowed = ", ".join(self.full_names.values())
        raise InputError(path, f"expected one of {allowed} (or the short names), got {_kind_of(value)}")

    def encode(self, value: Any) -> Any:
        return self.full_names.get(value, "<invalid>")

    def zero(self) -> Any:
        return next(iter(self.py_enum))


class StructType(IdlType):
    """An IDL struct backed by a dataclass; members keep declaration order."""

    kind = "struct"

    def __init__(self, cls: type, name: str, carries: PortKind | None = None) -> None:
        self.cls = cls
        self.name = name
        self._carries = carries

    @functools.cached_property
    def members(self) -> list[tuple[str, IdlType]]:
        """The ``(name, type)`` pairs of the members (resolved on first use: hints may name later classes)."""
        hints = typing.get_type_hints(self.cls, include_extras=True)
        return [(f.name, idl_type(hints[f.name])) for f in dataclasses.fields(self.cls)]

    @functools.cached_property
    def member_types(self) -> dict[str, IdlType]:
        """The member types by name."""
        return dict(self.members)

    @functools.cached_property
    def member_notes(self) -> dict[str, dict[str, Any]]:
        """What the declaration says of each member besides its type: ``doc``, ``unit`` and ``grid``, when given.

        ``Annotated[Double, Unit("deg"), "Head azimuth"]`` notes ``{"unit": "deg", "doc": "Head azimuth"}``.
        """
        hints = typing.get_type_hints(self.cls, include_extras=True)
        return {name: notes_of(hint) for name, hint in hints.items()}

    def _shape(self) -> dict[str, Any]:
        notes = self.member_notes
        return {
            "name": self.name,
            "kind": "struct",
            "members": [{"name": n, "type": t.describe(), **notes.get(n, {})} for n, t in self.members],
        }

    @functools.cached_property
    def carries(self) -> PortKind | None:
        """The kind the declaration says its data is, checked against its members (None: none said).

        Raises:
            TypeError: when the kind names a member the struct does not have, or one of another shape or unit.
        """
        return None if self._carries is None else self._carries.bind(self._shape())

    def describe(self) -> dict[str, Any]:
        described = self._shape()
        if self.carries is not None:
            described["carries"] = self.carries.describe()
        return described

    def decode(self, value: Any, path: str) -> Any:
        if isinstance(value, self.cls):
            return value
        if not isinstance(value, Mapping):
            raise InputError(path, f"expected an object ({self.name}), got {_kind_of(value)}")
        types_by_name = self.member_types
        unknown = [key for key in value if key not in types_by_name]
        if unknown:
            key = unknown[0]
            shown = key if isinstance(key, str) and key.isprintable() and len(key) <= 60 else _short(key)
            raise InputError(
                f"{path}.{shown}" if path else shown,
                f"unknown member {_short(key)} of {self.name} (members: {', '.join(types_by_name)})",
            )
        # Missing members keep their initial value, as genom3 does.
        result = self.zero()
        for key, item in value.items():
            setattr(result, key, types_by_name[key].decode(item, f"{path}.{key}" if path else key))
        return result

    def encode(self, value: Any) -> Any:
        if isinstance(value, Mapping):
            return {n: t.encode(value[n]) for n, t in self.members if n in value}
        return {n: t.encode(getattr(value, n)) for n, t in self.members}

    def zero(self) -> Any:
        kwargs = {}
        for f in dataclasses.fields(self.cls):
            if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                kwargs[f.name] = self.member_types[f.name].zero()
        return self.cls(**kwargs)


class SequenceType(IdlType):
    """``sequence<T>`` or ``sequence<T,N>``; optionally carried as a numpy array."""

    kind = "sequence"

    def __init__(self, element: IdlType, bound: int | None = None, numpy: bool = False) -> None:
        self.element = element
        self.bound = bound
        self.numpy = numpy and isinstance(element, Scalar) and element.name != "char"
        #: The dtype of the numpy arrays that carry this sequence (None: carried as a list).
        self.dtype = element.numpy_dtype if self.numpy and isinstance(element, Scalar) else None
        self.name = f"sequence<{element.name}>" if bound is None else f"sequence<{element.name},{bound}>"

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "kind": "sequence", "bound": self.bound, "element": self.element.describe()}

    def _items(self, value: Any, path: str) -> list[Any]:
        if isinstance(value, np.ndarray):
            return list(value.tolist())
        if isinstance(value, list):
            return value
        if isinstance(value, Mapping):
            # genom3 accepts sparse index objects such as {"0": 1, "3": 2}.
            items: list[Any] = []
            limit = MAX_SPARSE_INDEX if self.bound is None else self.bound
            for key, item in value.items():
                # isdigit() alone takes "²" and "٣"; the length test keeps int() from 4300-digit keys.
                if not (isinstance(key, str) and key.isascii() and key.isdigit()):
                    raise InputError(path, f"expected an array or an index object, got key {_short(key)}")
                if len(key) > len(str(limit)) or int(key) >= limit:
                    raise InputError(path, f"index {_short(key)} is beyond the {'bound' if self.bound else 'limit'} "
                                           f"of {limit} elements")
                index = int(key)
                if index >= len(items):
                    items.extend([None] * (index + 1 - len(items)))
                items[index] = item
            return [self.element.zero() if item is None else item for item in items]
        raise InputError(path, f"expected an array ({self.name}), got {_kind_of(value)}")

    def decode(self, value: Any, path: str) -> Any:
        if self.numpy and isinstance(value, np.ndarray):
            items_count = len(value)
            if self.bound is not None and items_count > self.bound:
                raise InputError(path, f"{items_count} elements exceed the bound of {self.bound}")
            return value.astype(self.dtype, copy=False)
        items = self._items(value, path)
        if self.bound is not None and len(items) > self.bound:
            raise InputError(path, f"{len(items)} elements exceed the bound of {self.bound}")
        decoded = [self.element.decode(item, f"{path}[{i}]") for i, item in enumerate(items)]
        if self.numpy:
            return np.asarray(decoded, dtype=self.dtype)
        return decoded

    def encode(self, value: Any) -> Any:
        if isinstance(value, ChunkedArray):
            return value  # written chunk by chunk by the gateway, never copied here
        if isinstance(value, np.ndarray):
            # orjson serialises contiguous native arrays directly, with no Python loop.
            array_value = np.ascontiguousarray(value)
            if array_value.dtype.byteorder == ">":
                array_value = array_value.astype(array_value.dtype.newbyteorder("="))
            return array_value
        return [self.element.encode(item) for item in value]

    def zero(self) -> Any:
        if self.numpy:
            return np.zeros(0, dtype=self.dtype)
        return []


class ArrayType(SequenceType):
    """A fixed-length IDL array ``T[N]``."""

    kind = "array"

    def __init__(self, element: IdlType, length: int, numpy: bool = False) -> None:
        super().__init__(element, length, numpy)
        self.length = length
        self.name = f"{element.name}[{length}]"

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "kind": "array", "length": self.length, "element": self.element.describe()}

    def decode(self, value: Any, path: str) -> Any:
        items = super().decode(value, path)
        missing = self.length - len(items)
        if missing > 0:
            # A short array leaves the remaining elements at their initial value.
            tail = self.zero()[len(items):]
            items = np.concatenate([items, tail]) if self.numpy else list(items) + list(tail)
        return items

    def zero(self) -> Any:
        if self.numpy:
            return np.zeros(self.length, dtype=self.dtype)
        return [self.element.zero() for _ in range(self.length)]


class OptionalType(IdlType):
    """``optional<T>``: ``null`` when absent."""

    kind = "optional"

    def __init__(self, element: IdlType) -> None:
        self.element = element
        self.name = f"optional<{element.name}>"

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "kind": "optional", "element": self.element.describe()}

    def decode(self, value: Any, path: str) -> Any:
        return None if value is None else self.element.decode(value, path)

    def encode(self, value: Any) -> Any:
        return None if value is None else self.element.encode(value)

    def zero(self) -> Any:
        return None


Boolean = Annotated[bool, Scalar("boolean")]
Octet = Annotated[int, Scalar("octet")]
Char = Annotated[str, Scalar("char")]
Short = Annotated[int, Scalar("short")]
UShort = Annotated[int, Scalar("unsigned short")]
Long = Annotated[int, Scalar("long")]
ULong = Annotated[int, Scalar("unsigned long")]
LongLong = Annotated[int, Scalar("long long")]
ULongLong = Annotated[int, Scalar("unsigned long long")]
Float = Annotated[float, Scalar("float")]
Double = Annotated[float, Scalar("double")]
String = Annotated[str, StringType()]

_PLAIN: dict[Any, IdlType] = {
    float: Scalar("double"),
    int: Scalar("long"),
    bool: Scalar("boolean"),
    str: StringType(),
}


@dataclasses.dataclass(frozen=True)
class Bound:
    """Annotation metadata: the bound of a ``string<N>`` or a ``sequence<T,N>``.

    ``Annotated[str, Bound(64)]`` is ``string<64>``; ``Annotated[list[Double], Bound(16)]``
    is ``sequence<double,16>``; ``Annotated[NDArray[np.float64], Bound(16)]`` is the same
    sequence carried as a numpy array.  Type checkers read the first argument (``str``,
    ``list[float]``), the runtime reads both.
    """

    size: int

    def apply(self, base: IdlType) -> IdlType:
        """The bounded version of *base*.

        Raises:
            TypeError: when *base* is neither a string nor a sequence.
        """
        if isinstance(base, StringType):
            return StringType(self.size)
        if isinstance(base, SequenceType) and not isinstance(base, ArrayType):
            return SequenceType(base.element, self.size, base.numpy)
        raise TypeError(f"Bound({self.size}) applies to strings and sequences, not to {base.name}")


@dataclasses.dataclass(frozen=True)
class Length:
    """Annotation metadata: the fixed length of an IDL array ``T[N]``.

    ``Annotated[list[Double], Length(3)]`` is ``double[3]``;
    ``Annotated[NDArray[np.int32], Length(3)]`` is ``long[3]`` carried as a numpy array.
    """

    size: int

    def apply(self, base: IdlType) -> IdlType:
        """The fixed-length array of the elements of the sequence *base*.

        Raises:
            TypeError: when *base* is not an unbounded sequence.
        """
        if isinstance(base, SequenceType) and not isinstance(base, ArrayType) and base.bound is None:
            return ArrayType(base.element, self.size, base.numpy)
        raise TypeError(f"Length({self.size}) applies to list[...] and NDArray[...], not to {base.name}")


@dataclasses.dataclass(frozen=True)
class Unit:
    """Annotation metadata: the unit of a number, or of each number of a sequence.

    ``position: Annotated[Double, Unit("deg"), "Head azimuth"]`` says the member is in degrees:
    ``/info`` gives it as the member's (or the parameter's) ``unit``, the OpenAPI document as
    ``x-unit``, and the console labels its axes with it.  Symbols are plain ASCII, as MATLAB and
    Tcl users type them: ``deg``, ``deg/s``, ``rad``, ``m``, ``m/s``, ``s``, ``Hz``, ``dBFS``.
    """

    symbol: str

    def __post_init__(self) -> None:
        if not self.symbol or not self.symbol.isascii() or not self.symbol.isprintable():
            raise TypeError(f"Unit({self.symbol!r}): a unit is a non-empty printable ASCII symbol (deg, m/s)")


@dataclasses.dataclass(frozen=True)
class Grid:
    """Annotation metadata: what the index of a sequence stands for, ``start + index * step`` in *unit*.

    ``Annotated[NDArray[np.float64], Grid(0, 1, "deg")]`` is a value for each azimuth 0°, 1°, … (a
    log-likelihood per direction): ``/info`` gives it as the member's ``grid``,
    ``{"start": 0, "step": 1, "unit": "deg"}``, and the console draws such a sequence of angles as a ring.
    """

    start: float
    step: float
    unit: str

    def __post_init__(self) -> None:
        Unit(self.unit)
        if not (math.isfinite(self.start) and math.isfinite(self.step) and self.step != 0):
            raise TypeError(f"{self!r}: start and step are finite numbers, and step is not 0")

    def describe(self) -> dict[str, Any]:
        """The ``/info`` form: ``{"start", "step", "unit"}``."""
        return {"start": self.start, "step": self.step, "unit": self.unit}


def notes_of(hint: Any) -> dict[str, Any]:
    """What the annotation metadata of a member or parameter says besides its type, as ``/info`` gives it.

    ``{"doc": ..., "unit": ..., "grid": {...}}``, each only when declared: the first string is the doc,
    a :class:`Unit` the unit, a :class:`Grid` the grid.

    Raises:
        TypeError: when a member declares two units or two grids.
    """
    if typing.get_origin(hint) is not Annotated:
        return {}
    metadata = hint.__metadata__
    notes: dict[str, Any] = {}
    doc = next((m for m in metadata if isinstance(m, str)), "")
    if doc:
        notes["doc"] = doc
    units = {m.symbol for m in metadata if isinstance(m, Unit)}
    grids = [m for m in metadata if isinstance(m, Grid)]
    if len(units) > 1 or len(grids) > 1:
        raise TypeError(f"{hint!r} declares more than one unit or grid")
    if units:
        notes["unit"] = units.pop()
    if grids:
        notes["grid"] = grids[0].describe()
    return notes


def string(bound: int) -> Any:
    """The annotation of a bounded ``string<bound>``, built at run time.

    Prefer ``Annotated[str, Bound(bound)]`` in declarations: a type checker
    understands it, and not a call.
    """
    return Annotated[str, StringType(bound)]


def sequence(element: Any, bound: int | None = None, *, numpy: bool = False) -> Any:
    """The annotation of ``sequence<element[,bound]>`` (numpy arrays when *numpy*), built at run time.

    Prefer ``list[T]``, ``Annotated[list[T], Bound(n)]`` or ``NDArray[...]`` in
    declarations: a type checker understands them, and not a call.
    """
    return Annotated[np.ndarray if numpy else list, SequenceType(idl_type(element), bound, numpy)]


def array(element: Any, length: int, *, numpy: bool = False) -> Any:
    """The annotation of the fixed-length array ``element[length]``, built at run time.

    Prefer ``Annotated[list[T], Length(n)]`` in declarations.
    """
    return Annotated[np.ndarray if numpy else list, ArrayType(idl_type(element), length, numpy)]


def optional(element: Any) -> Any:
    """The annotation of ``optional<element>``, built at run time (prefer ``T | None``)."""
    return Annotated[Any, OptionalType(idl_type(element))]


_Class = TypeVar("_Class", bound=type)


@dataclass_transform()
def idl_struct(name: str, *, carries: PortKind | None = None) -> Callable[[_Class], _Class]:
    """Class decorator: declare a class as the IDL struct *name* (``"demo::state"``).

    The class becomes a dataclass (unless it is one already): members are its
    annotated attributes, in order, with their defaults.  Type checkers see the
    generated ``__init__`` too.

    Args:
        name: The IDL name.
        carries: What the data is (:class:`~aiogenomix.components.core.AudioStream`,
            :class:`~aiogenomix.components.core.HeadState`...) and which members hold it: the
            recordings, the live view and the localiser read any port of this type by it.

    Raises:
        TypeError: when *carries* names a member the struct does not have, or one of another shape or
            unit (checked here, or when the struct is first described if its hints name later classes).
    """

    def decorate(cls: _Class) -> _Class:
        struct: Any = cls if dataclasses.is_dataclass(cls) else dataclasses.dataclass(cls)
        declared = struct.__idl_type__ = StructType(struct, _scoped(name), carries)
        if carries is not None:
            try:
                declared.carries  # noqa: B018 (checked now, where the author declares it)
            except NameError:
                pass  # a hint names a class not defined yet: checked when the struct is first described
        return typing.cast(_Class, struct)

    return decorate


_Enum = TypeVar("_Enum", bound=type[enum.Enum])


def idl_enum(name: str) -> Callable[[_Enum], _Enum]:
    """Class decorator: declare an :class:`enum.Enum` as the IDL enum *name*."""

    def decorate(cls: _Enum) -> _Enum:
        cls.__idl_type__ = EnumType(cls, _scoped(name))  # type: ignore[attr-defined]
        return cls

    return decorate


def _scoped(name: str) -> str:
    return name if name.startswith("::") else f"::{name}"


def idl_type(annotation: Any) -> IdlType:
    """Return the :class:`IdlType` an annotation stands for.

    Raises:
        TypeError: for annotations with no IDL meaning (a programmer error).
    """
    if isinstance(annotation, IdlType):
        return annotation
    if typing.get_origin(annotation) is Annotated:
        metadata = annotation.__metadata__
        # Nested Annotated flatten into one: the innermost IDL type comes first, the last one wins.
        base = next((meta for meta in reversed(metadata) if isinstance(meta, IdlType)), None)
        if base is None:
            base = idl_type(annotation.__origin__)
        for meta in metadata:
            if isinstance(meta, (Bound, Length)):
                base = meta.apply(base)
        return base
    explicit = getattr(annotation, "__idl_type__", None)
    if isinstance(explicit, IdlType):
        return explicit
    expanded = _expand_type_alias(annotation)
    if expanded is not None:
        return idl_type(expanded)
    if annotation in _PLAIN:
        return _PLAIN[annotation]
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(args) == 1:
            return OptionalType(idl_type(args[0]))
    if origin is list:
        (element,) = typing.get_args(annotation)
        return SequenceType(idl_type(element))
    if origin is np.ndarray:
        return _numpy_sequence(annotation)
    raise TypeError(f"{annotation!r} has no IDL type: use Double, Long, String, an @idl_struct, ...")


def _expand_type_alias(annotation: Any) -> Any:
    """What a ``type X[T] = ...`` alias (PEP 695) stands for, or None for anything else.

    numpy 2.5 and later declares ``NDArray`` so: ``NDArray[np.int32]`` then has the
    alias for origin, not ``np.ndarray``.
    """
    alias = typing.get_origin(annotation) or annotation
    value = getattr(alias, "__value__", None)
    if value is None or not hasattr(alias, "__type_params__"):
        return None
    args = typing.get_args(annotation)
    return value[args] if args else value


#: The IDL scalar of each numpy element type (``NDArray[np.float64]`` is ``sequence<double>``).
_NUMPY_SCALARS: dict[type, str] = {
    np.float64: "double", np.float32: "float", np.uint8: "octet", np.int16: "short", np.uint16: "unsigned short",
    np.int32: "long", np.uint32: "unsigned long", np.int64: "long long", np.uint64: "unsigned long long",
    np.bool_: "boolean",
}


def _numpy_sequence(annotation: Any) -> SequenceType:
    """The sequence an ``NDArray[np.<scalar>]`` annotation stands for, carried as numpy arrays."""
    args = typing.get_args(annotation)
    dtype_args = typing.get_args(args[1]) if len(args) == 2 else ()
    scalar = _NUMPY_SCALARS.get(dtype_args[0]) if dtype_args else None
    if scalar is None:
        known = ", ".join(f"np.{t.__name__}" for t in _NUMPY_SCALARS)
        raise TypeError(f"{annotation!r} has no IDL type: use NDArray[T] with T one of {known}")
    return SequenceType(Scalar(scalar), numpy=True)
