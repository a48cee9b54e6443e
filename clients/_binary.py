"""Decoding the binary form of port data (``format=binary``; layout in docs/protocol.md).

The reply is ``b"AGXB"``, a little-endian u32 header length, a JSON header, and
the raw bytes of every numeric array; each array is rebuilt with one
``numpy.frombuffer`` (no copy, no number parsing).
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import orjson

from ._errors import ProtocolError

__all__ = ["BINARY_TYPE", "decode_binary"]

#: The media type of the binary form.
BINARY_TYPE = "application/x-aiogenomix-binary"
_MAGIC = b"AGXB"


def decode_binary(body: bytes) -> tuple[str, Any, dict[str, Any]]:
    """Split a binary port reply into ``(port name, data, extra members such as "lost")``.

    Raises:
        ProtocolError: when the body is not in the binary form.
    """
    if body[:4] != _MAGIC or len(body) < 8:
        raise ProtocolError(f"not a binary port reply: {body[:16]!r}")
    (length,) = struct.unpack_from("<I", body, 4)
    try:
        header = orjson.loads(body[8:8 + length])
        payload = memoryview(body)[8 + length:]
        arrays = [np.frombuffer(payload, a["dtype"], int(np.prod(a["shape"], dtype=np.int64)),
                                a["offset"]).reshape(a["shape"]) for a in header["arrays"]]
    except (orjson.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise ProtocolError(f"malformed binary port reply: {exc}") from None

    def rebuild(value: Any) -> Any:
        if isinstance(value, dict):
            if len(value) == 1 and "$array" in value:
                return arrays[value["$array"]]
            return {key: rebuild(item) for key, item in value.items()}
        if isinstance(value, list):
            return [rebuild(item) for item in value]
        return value

    extra = {k: v for k, v in header.items() if k not in ("port", "data", "arrays")}
    return header["port"], rebuild(header["data"]), extra
