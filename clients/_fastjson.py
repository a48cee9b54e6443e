"""Decoding large numeric arrays of a JSON port reply without building Python lists.

A genomix JSON read of a 4 s audio window is 3.4 MB of digits; ``orjson.loads``
turns it into 700 000 Python ints, which numpy then converts again.  For the
numeric sequence members of the port's top-level struct, this module cuts the
array texts out of the reply and parses them with numpy's C text parser, then
parses the small remainder as JSON.  Anything unexpected (a member name inside
a string, nested arrays, ``null``, a number out of range) makes it fall back to
the plain parse, so the result never differs from ``orjson.loads``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import orjson

__all__ = ["loads_with_arrays"]

#: Below this many bytes the plain parse is as fast: not worth cutting.
_MIN_SIZE = 1 << 16
_PLACEHOLDER = b"0"


def _parse_array(text: bytes, dtype: np.dtype[Any]) -> np.ndarray | None:
    if not text.strip():
        return np.zeros(0, dtype)
    if any(mark in text for mark in (b"[", b"{", b'"', b"n")):
        return None  # nested data, strings or null: leave it to the JSON parser
    try:
        if dtype.kind in "iu" and dtype.itemsize < 8:
            wide = np.fromstring(text, dtype=np.int64, sep=",")  # noqa: NPY201 - text mode is supported
            info = np.iinfo(dtype)
            if wide.size and (wide.min() < info.min or wide.max() > info.max):
                return None
            return wide.astype(dtype)
        return np.fromstring(text, dtype=dtype, sep=",")  # noqa: NPY201
    except ValueError:
        return None


def loads_with_arrays(body: bytes, port: str, arrays: dict[str, np.dtype[Any]]) -> Any:
    """Parse ``{"PORT": {...}}`` with the members named in *arrays* decoded straight into numpy.

    Args:
        body: The JSON reply.
        port: The port name (the reply's only top-level key).
        arrays: Numeric sequence members of the port's struct, with their dtypes.

    Returns:
        The parsed reply; the listed members are numpy arrays when the fast
        path applied, lists otherwise.
    """
    if len(body) < _MIN_SIZE or not arrays:
        return orjson.loads(body)
    found: dict[str, np.ndarray] = {}
    pieces: list[bytes] = []
    position = 0
    for name, dtype in arrays.items():
        key = b'"' + name.encode() + b'":['
        start = body.find(key, position)
        if start < 0:
            continue
        opening = start + len(key) - 1
        closing = body.find(b"]", opening)
        parsed = _parse_array(body[opening + 1:closing], dtype) if closing > 0 else None
        if parsed is None:
            continue
        found[name] = parsed
        pieces += [body[position:opening], _PLACEHOLDER]
        position = closing + 1
    if not found:
        return orjson.loads(body)
    pieces.append(body[position:])
    reply = orjson.loads(b"".join(pieces))
    data = reply.get(port) if isinstance(reply, dict) else None
    if not isinstance(data, dict) or any(data.get(name) != 0 for name in found):
        return orjson.loads(body)  # a key matched somewhere else: the safe way
    data.update(found)
    return reply
