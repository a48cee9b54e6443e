"""IDL types on the client side: encode Python values to genom JSON, decode replies, name annotations.

Encoding is strict where genom is (an integer type gets a JSON integer, never
``1.0``; booleans go as ``0``/``1``; enums as full names, short names
accepted), and lenient where Python users expect it (numpy scalars and arrays,
tuples, integral floats for integer types, ``enum.Enum`` members for enums).
Decoding turns numeric sequences into numpy arrays and structs into
:class:`Record` dicts that also allow ``rec.position``.
"""

from __future__ import annotations

import enum
import math
import numbers
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from ._wire import TypeInfo

__all__ = ["INTEGER_RANGES", "NUMPY_DTYPES", "Record", "annotation_source", "decode", "encode", "zero"]

#: Inclusive ranges of the IDL integer kinds.
INTEGER_RANGES: dict[str, tuple[int, int]] = {
    "octet": (0, 2**8 - 1),
    "short": (-(2**15), 2**15 - 1),
    "unsigned short": (0, 2**16 - 1),
    "long": (-(2**31), 2**31 - 1),
    "unsigned long": (0, 2**32 - 1),
    "long long": (-(2**63), 2**63 - 1),
    "unsigned long long": (0, 2**64 - 1),
}

#: The numpy dtype of a decoded sequence of each numeric kind.
NUMPY_DTYPES: dict[str, Any] = {
    "octet": np.uint8, "short": np.int16, "unsigned short": np.uint16, "long": np.int32,
    "unsigned long": np.uint32, "long long": np.int64, "unsigned long long": np.uint64,
    "float": np.float32, "double": np.float64, "boolean": np.bool_,
}

_FLOATS = ("float", "double")


class Record(dict[str, Any]):
    """A decoded struct: a dict in member order whose members also read as attributes.

    ``state["position"]`` and ``state.position`` are the same; members named like
    dict methods (``items``, ``keys``...) are reached with ``[]`` only.
    """

    __slots__ = ()

    def __getattr__(self, name: str) -> Any:
        if not name.startswith("_"):
            try:
                return self[name]
            except KeyError:
                pass
        raise AttributeError(f"no member {name!r} (members: {', '.join(self) or 'none'})")

    def __dir__(self) -> list[str]:
        return sorted(set(super().__dir__()) | {k for k in self if k.isidentifier()})


def _where(path: str) -> str:
    return f"{path}: " if path else ""


def _enum_name(value: Any) -> Any:
    return value.name if isinstance(value, enum.Enum) else value


def encode(value: Any, t: TypeInfo, path: str = "") -> Any:
    """Encode *value* as the JSON data of type *t*.

    Args:
        value: A Python value (numpy scalars and arrays accepted).
        t: The type description from ``/info``.
        path: Where the value sits, for error messages (``posRef``, ``state.speed``).

    Raises:
        TypeError: for a value of the wrong kind.
        ValueError: for a value out of range or not among the enum's values.
    """
    kind = t["kind"]
    if kind in INTEGER_RANGES:
        return _encode_integer(value, kind, path)
    if kind in _FLOATS:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            raise TypeError(f"{_where(path)}expected a number ({kind}), got {value!r}")
        number = float(value)
        # NaN travels as null (docs/protocol.md); ±inf as the Infinity literal genom accepts.
        return None if math.isnan(number) else number
    if kind == "boolean":
        if isinstance(value, (bool, np.bool_)) or (isinstance(value, numbers.Integral) and value in (0, 1)):
            return 1 if value else 0
        raise TypeError(f"{_where(path)}expected a boolean, got {value!r}")
    if kind == "char":
        if isinstance(value, str) and len(value) == 1:
            return value
        raise TypeError(f"{_where(path)}expected one character, got {value!r}")
    if kind == "string":
        if not isinstance(value, str):
            raise TypeError(f"{_where(path)}expected a string, got {value!r}")
        return value
    if kind == "enum":
        return _encode_enum(value, t, path)
    if kind == "struct":
        return _encode_struct(value, t, path)
    if kind in ("sequence", "array"):
        return _encode_sequence(value, t, path)
    if kind == "optional":
        return None if value is None else encode(value, t["element"], path)
    # A kind this client does not know yet: trust the caller and the gateway's checks.
    return value


def _encode_integer(value: Any, kind: str, path: str) -> int:
    if isinstance(value, (bool, np.bool_, numbers.Integral)):
        number = int(value)
    elif isinstance(value, numbers.Real) and float(value).is_integer():
        # 2.0 is meant as 2; never send 2.0 where genom wants an integer.  (Every Real has __int__:
        # typeshed's numbers.Real does not say so.)
        number = int(value)  # type: ignore[call-overload]
    else:
        raise TypeError(f"{_where(path)}expected an integer ({kind}), got {value!r}")
    low, high = INTEGER_RANGES[kind]
    if not low <= number <= high:
        raise ValueError(f"{_where(path)}{number} is out of range for {kind} ({low}..{high})")
    return number


def _encode_enum(value: Any, t: TypeInfo, path: str) -> str:
    values = t.get("values", [])
    name = _enum_name(value)
    if isinstance(name, str):
        if name in values:
            return name
        for full in values:
            if full.rpartition("::")[2] == name:
                return full
    shown = ", ".join(v.rpartition("::")[2] for v in values)
    raise ValueError(f"{_where(path)}{value!r} is not a value of {t['name']} ({shown})")


def _encode_struct(value: Any, t: TypeInfo, path: str) -> dict[str, Any]:
    members = {m["name"]: m["type"] for m in t.get("members", [])}
    if not isinstance(value, Mapping):
        # Objects with matching attributes (dataclasses, namedtuples) are accepted too.
        if not any(hasattr(value, name) for name in members):
            raise TypeError(f"{_where(path)}expected a mapping of {t['name']} members, got {value!r}")
        value = {name: getattr(value, name) for name in members if hasattr(value, name)}
    unknown = [k for k in value if k not in members]
    if unknown:
        raise ValueError(f"{_where(path)}{t['name']} has no member {unknown[0]!r} (members: {', '.join(members)})")
    prefix = f"{path}." if path else ""
    return {name: encode(value[name], members[name], prefix + name) for name in members if name in value}


def _encode_sequence(value: Any, t: TypeInfo, path: str) -> Any:
    element = t["element"]
    if isinstance(value, Mapping):
        # genom's index object {"0": v, "3": w} sets chosen elements only.
        return {str(k): encode(v, element, f"{path}[{k}]") for k, v in value.items()}
    if isinstance(value, (str, bytes)) or not isinstance(value, (Iterable, np.ndarray)):
        raise TypeError(f"{_where(path)}expected a sequence ({t['name']}), got {value!r:.80}")
    if isinstance(value, np.ndarray) and value.ndim == 1 and element["kind"] in NUMPY_DTYPES:
        items = _encode_numeric_array(value, element["kind"], path)
    else:
        items = [encode(v, element, f"{path}[{i}]") for i, v in enumerate(value)]
    limit = t.get("length") if t["kind"] == "array" else t.get("bound")
    if limit is not None and len(items) > limit:
        raise ValueError(f"{_where(path)}{len(items)} elements do not fit in {t['name']} (at most {limit})")
    return items


def _encode_numeric_array(array: np.ndarray, kind: str, path: str) -> list[Any]:
    # One vectorised conversion instead of a Python call per element (audio buffers are long).
    if kind in INTEGER_RANGES:
        if array.dtype.kind == "f":
            if not np.all(np.isfinite(array)) or not np.all(array == np.round(array)):
                raise TypeError(f"{_where(path)}expected integers ({kind}), got non-integral values")
        elif array.dtype.kind not in "iub":
            raise TypeError(f"{_where(path)}expected integers ({kind}), got an array of {array.dtype}")
        low, high = INTEGER_RANGES[kind]
        if array.size and (array.min() < low or array.max() > high):
            raise ValueError(f"{_where(path)}values out of range for {kind} ({low}..{high})")
        return [int(v) for v in array.tolist()]
    if kind == "boolean":
        return [1 if v else 0 for v in array.tolist()]
    if array.dtype.kind not in "iufb":
        raise TypeError(f"{_where(path)}expected numbers ({kind}), got an array of {array.dtype}")
    return [None if math.isnan(v) else v for v in array.astype(np.float64).tolist()]


def decode(data: Any, t: TypeInfo) -> Any:
    """Decode the JSON data of type *t*: numpy arrays for numeric sequences, Records for structs."""
    kind = t["kind"]
    if kind in _FLOATS:
        return math.nan if data is None else float(data)
    if kind == "boolean":
        return bool(data)
    if kind == "struct" and isinstance(data, Mapping):
        members = {m["name"]: m["type"] for m in t.get("members", [])}
        return Record((k, decode(v, members[k]) if k in members else v) for k, v in data.items())
    if kind in ("sequence", "array") and isinstance(data, list):
        element = t["element"]
        if _numeric_leaf(element) is not None:
            array = _to_array(data, t)
            if array is not None:
                return array
        return [decode(v, element) for v in data]
    if kind == "optional":
        return None if data is None else decode(data, t["element"])
    return data


def _numeric_leaf(t: TypeInfo) -> str | None:
    """The numeric kind at the bottom of nested sequences/arrays of *t*, if there is one."""
    while t["kind"] in ("sequence", "array"):
        t = t["element"]
    return t["kind"] if t["kind"] in NUMPY_DTYPES else None


def _to_array(data: list[Any], t: TypeInfo) -> np.ndarray | None:
    leaf = _numeric_leaf(t)
    assert leaf is not None
    try:
        # numpy turns null (NaN on the wire) into nan for float dtypes by itself.
        return np.array(data, dtype=NUMPY_DTYPES[leaf])
    except (ValueError, TypeError):
        return None  # ragged nested sequences stay lists of arrays


def zero(t: TypeInfo) -> Any:
    """The value genom gives a parameter that was not sent (the zero of its type), decoded."""
    kind = t["kind"]
    if kind in INTEGER_RANGES:
        return 0
    if kind in _FLOATS:
        return 0.0
    if kind == "boolean":
        return False
    if kind in ("char", "string"):
        return ""
    if kind == "enum":
        return (t.get("values") or [""])[0]
    if kind == "struct":
        return Record((m["name"], zero(m["type"])) for m in t.get("members", []))
    if kind == "array":
        return decode([encode(zero(t["element"]), t["element"])] * int(t.get("length", 0)), t)
    if kind == "sequence":
        return decode([], t)
    return None


def annotation_source(t: TypeInfo, direction: str) -> str:
    """The annotation of type *t*, as source text evaluable with ``typing``, ``numpy`` and ``Record``.

    Args:
        t: The type description.
        direction: ``in`` for what a call accepts, ``out`` for what it returns.
    """
    kind = t["kind"]
    if kind in INTEGER_RANGES:
        return "int"
    if kind in _FLOATS:
        return "float"
    if kind == "boolean":
        return "bool"
    if kind in ("char", "string"):
        return "str"
    if kind == "enum":
        values = list(t.get("values", []))
        if direction == "in":
            values += [v.rpartition("::")[2] for v in values]
        return f"Literal[{', '.join(repr(v) for v in values)}]" if values else "str"
    if kind == "struct":
        return "Mapping[str, Any]" if direction == "in" else "Record"
    if kind in ("sequence", "array"):
        element = t["element"]
        if _numeric_leaf(t) is not None:
            inner = annotation_source(element, direction)
            return "numpy.ndarray" if direction == "out" else f"numpy.ndarray | Sequence[{inner}]"
        return f"{'Sequence' if direction == 'in' else 'list'}[{annotation_source(element, direction)}]"
    if kind == "optional":
        return f"{annotation_source(t['element'], direction)} | None"
    return "Any"
