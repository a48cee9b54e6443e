"""ROS 2 message types and their CDR encoding, sans I/O: one declaration gives the definition, encoder and decoder.

A recording is read by tools that know ROS 2 (rosbag2, Foxglove, Lichtblick, ``rosbags``,
``mcap-ros2-support``): each channel's schema is the message definition in the ``ros2msg``
encoding (the ``.msg`` text of the type followed by those of the types it uses), and each
message is CDR (little endian, XCDR1 alignment as ROS 2's default middleware writes it).
Here a :class:`MessageType` is declared once as its fields; it writes its definition, encodes
a mapping of field values and decodes bytes back into one.  Arrays of numbers are written and
read with numpy in one copy (an audio chunk, a camera frame), never element by element.
"""

from __future__ import annotations

import dataclasses
import struct
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["Field", "MessageType", "CdrError", "ENCAPSULATION"]

#: The encapsulation header of little-endian plain CDR (what ROS 2 writes).
ENCAPSULATION = b"\x00\x01\x00\x00"

#: The primitive types of ROS 2 messages: their numpy dtype (little endian).
_PRIMITIVES: dict[str, str] = {
    "bool": "u1", "byte": "u1", "char": "u1", "uint8": "u1", "int8": "i1",
    "int16": "<i2", "uint16": "<u2", "int32": "<i4", "uint32": "<u4", "int64": "<i8", "uint64": "<u8",
    "float32": "<f4", "float64": "<f8",
}
_STRUCT = {name: struct.Struct("<" + code) for name, code in {
    "bool": "B", "byte": "B", "char": "B", "uint8": "B", "int8": "b", "int16": "h", "uint16": "H",
    "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float32": "f", "float64": "d"}.items()}
#: A line between the definitions of a message and of the types it uses (rosbag2's convention).
_SEPARATOR = "=" * 80


class CdrError(ValueError):
    """Bytes that are not a CDR message of the expected type (truncated, bad encapsulation)."""


@dataclasses.dataclass(frozen=True)
class Field:
    """One field of a message.

    Attributes:
        name: Its name.
        type: A primitive (``float64``...), ``string``, or a :class:`MessageType`.
        array: None for one value, ``-1`` for a sequence (``float64[]``), N for a fixed array (``float64[36]``).
        comment: What it holds, written after it in the definition.
    """

    name: str
    type: str | MessageType
    array: int | None = None
    comment: str = ""

    @property
    def spelling(self) -> str:
        """How the definition writes the field's type (``geometry_msgs/Pose``, ``float64[36]``)."""
        base = self.type.short_name if isinstance(self.type, MessageType) else self.type
        if self.array is None:
            return base
        return f"{base}[]" if self.array < 0 else f"{base}[{self.array}]"


@dataclasses.dataclass(frozen=True)
class MessageType:
    """A ROS 2 message type declared by its fields.

    Args:
        name: Its full name, as schemas are named: ``sensor_msgs/msg/JointState``.
        fields: Its fields, in order.
        comment: Lines written above the fields in its definition.
    """

    name: str
    fields: tuple[Field, ...]
    comment: str = ""

    def __post_init__(self) -> None:
        for f in self.fields:
            if isinstance(f.type, str) and f.type != "string" and f.type not in _PRIMITIVES:
                raise ValueError(f"{self.name}.{f.name}: unknown type {f.type!r}")

    @property
    def short_name(self) -> str:
        """The name fields of other messages use for it: ``sensor_msgs/JointState``."""
        package, _, rest = self.name.partition("/msg/")
        return f"{package}/{rest}"

    # -- the definition ---------------------------------------------------------------------

    def _own_text(self) -> str:
        lines = [f"# {line}" if line else "#" for line in self.comment.splitlines()]
        for f in self.fields:
            lines.append(f"{f.spelling} {f.name}" + (f"  # {f.comment}" if f.comment else ""))
        return "\n".join(lines) + "\n"

    def _dependencies(self) -> list[MessageType]:
        found: dict[str, MessageType] = {}

        def visit(kind: MessageType) -> None:
            for f in kind.fields:
                if isinstance(f.type, MessageType) and f.type.name not in found:
                    found[f.type.name] = f.type
                    visit(f.type)

        visit(self)
        return list(found.values())

    def definition(self) -> str:
        """The ``ros2msg`` schema text: this type's fields, then each type it uses after a separator line."""
        parts = [self._own_text()]
        for dependency in self._dependencies():
            parts.append(f"{_SEPARATOR}\nMSG: {dependency.short_name}\n{dependency._own_text()}")
        return "".join(parts)

    # -- encoding ----------------------------------------------------------------------------

    def encode(self, value: Mapping[str, Any]) -> bytes:
        """The CDR message (encapsulation header first) of *value*, a mapping of field names to values.

        Missing fields are written as zeros and empty sequences.  Numeric arrays may be numpy
        arrays, sequences of numbers, or bytes-like objects (``uint8[]``).

        Raises:
            CdrError: for a fixed array of the wrong length.
        """
        out = bytearray(ENCAPSULATION)
        _write_struct(out, self, value)
        return bytes(out)

    def decode(self, data: bytes | memoryview) -> dict[str, Any]:
        """The field values of the CDR message *data*: numbers, strings, numpy arrays, nested dicts.

        Raises:
            CdrError: for data that is not little-endian CDR or ends before the message does.
        """
        view = memoryview(data)
        if len(view) < 4 or bytes(view[:2]) != ENCAPSULATION[:2]:
            raise CdrError(f"not a little-endian CDR message of {self.name}")
        reader = _Reader(view[4:])
        try:
            return reader.struct(self)
        except (struct.error, IndexError, ValueError) as exc:
            raise CdrError(f"a truncated or malformed {self.name}: {exc}") from exc


def _align(out: bytearray, size: int) -> None:
    # Offsets count from the end of the encapsulation header.
    pad = -(len(out) - 4) % min(size, 8)
    if pad:
        out += b"\x00" * pad


def _write_struct(out: bytearray, kind: MessageType, value: Mapping[str, Any]) -> None:
    for f in kind.fields:
        _write_field(out, f, value.get(f.name))


def _write_field(out: bytearray, f: Field, item: Any) -> None:
    if f.array is None:
        _write_one(out, f.type, item)
        return
    if isinstance(f.type, str) and f.type in _PRIMITIVES:
        dtype = np.dtype(_PRIMITIVES[f.type])
        if item is None:
            array = np.zeros(max(f.array, 0), dtype)
        elif isinstance(item, (bytes, bytearray, memoryview)):
            array = np.frombuffer(item, dtype)
        else:
            array = np.asarray(item, dtype=dtype)
        array = array.reshape(-1)
        if f.array >= 0 and array.size != f.array:
            raise CdrError(f"{f.name} is an array of {f.array}, not {array.size}")
        if f.array < 0:
            _align(out, 4)
            out += _STRUCT["uint32"].pack(array.size)
        if array.size:
            _align(out, dtype.itemsize)
            out += array.tobytes()
        return
    items = list(item) if item is not None else []
    if f.array >= 0:
        items += [None] * (f.array - len(items))
        if len(items) != f.array:
            raise CdrError(f"{f.name} is an array of {f.array}, not {len(items)}")
    else:
        _align(out, 4)
        out += _STRUCT["uint32"].pack(len(items))
    for element in items:
        _write_one(out, f.type, element)


def _write_one(out: bytearray, kind: str | MessageType, item: Any) -> None:
    if isinstance(kind, MessageType):
        _write_struct(out, kind, item if item is not None else {})
    elif kind == "string":
        text = ("" if item is None else str(item)).encode()
        _align(out, 4)
        out += _STRUCT["uint32"].pack(len(text) + 1)
        out += text + b"\x00"
    else:
        packer = _STRUCT[kind]
        _align(out, packer.size)
        out += packer.pack(0 if item is None else item)


class _Reader:
    """Reads CDR fields from a buffer (after the encapsulation header), aligning as it goes."""

    def __init__(self, data: memoryview) -> None:
        self.data = data
        self.at = 0

    def _align(self, size: int) -> None:
        self.at += -self.at % min(size, 8)

    def _take(self, count: int) -> memoryview:
        if self.at + count > len(self.data):
            raise ValueError(f"needs {count} bytes at offset {self.at}, has {len(self.data) - self.at}")
        piece = self.data[self.at:self.at + count]
        self.at += count
        return piece

    def struct(self, kind: MessageType) -> dict[str, Any]:
        return {f.name: self.field(f) for f in kind.fields}

    def field(self, f: Field) -> Any:
        if f.array is None:
            return self.one(f.type)
        count = f.array
        if count < 0:
            self._align(4)
            count = _STRUCT["uint32"].unpack(self._take(4))[0]
        if isinstance(f.type, str) and f.type in _PRIMITIVES:
            dtype = np.dtype(_PRIMITIVES[f.type])
            if count:
                self._align(dtype.itemsize)
            return np.frombuffer(self._take(count * dtype.itemsize), dtype).copy()
        return [self.one(f.type) for _ in range(count)]

    def one(self, kind: str | MessageType) -> Any:
        if isinstance(kind, MessageType):
            return self.struct(kind)
        if kind == "string":
            self._align(4)
            length = _STRUCT["uint32"].unpack(self._take(4))[0]
            return bytes(self._take(length)).rstrip(b"\x00").decode()
        unpacker = _STRUCT[kind]
        self._align(unpacker.size)
        value = unpacker.unpack(self._take(unpacker.size))[0]
        return bool(value) if kind == "bool" else value
