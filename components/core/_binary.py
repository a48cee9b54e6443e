"""The binary form of port data: a JSON header plus the raw little-endian bytes of its arrays.

The gateway answers binary reads in it and component hosts send port data to gateways in it.

Layout (all little-endian)::

    b"AGXB"                 magic
    u32                     header length in bytes
    header                  compact JSON (see below)
    payload                 the arrays' bytes, one after the other, each starting at a multiple of 8

The header is ``{"port": NAME, "data": DATA, "arrays": [...], ...extra}`` where
DATA is the port data as in JSON except that every numeric array is replaced
by ``{"$array": i}``, and ``arrays[i]`` is ``{"dtype": "<i4", "shape": [n],
"offset": o}`` (offset from the start of the payload).  A client rebuilds each
array with one ``numpy.frombuffer`` call, without copying or parsing numbers.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import orjson

from ._chunked import ChunkedArray

__all__ = ["BINARY_MAGIC", "BINARY_CONTENT_TYPE", "encode_binary"]

BINARY_MAGIC = b"AGXB"
#: The media type of the binary form (``Accept`` it, or ask with ``format=binary``).
BINARY_CONTENT_TYPE = "application/x-aiogenomix-binary"
_ALIGN = 8


def _extract(value: Any, arrays: list[np.ndarray | ChunkedArray]) -> Any:
    if isinstance(value, (np.ndarray, ChunkedArray)):
        arrays.append(value)
        return {"$array": len(arrays) - 1}
    if isinstance(value, dict):
        return {key: _extract(item, arrays) for key, item in value.items()}
    if isinstance(value, list):
        return [_extract(item, arrays) for item in value]
    return value


def encode_binary(port: str, data: Any, **extra: Any) -> list[bytes | memoryview]:
    """Encode JSON-ready port *data* (numpy arrays left as arrays) into binary parts.

    A :class:`~aiogenomix.components.core.ChunkedArray` is one array of the layout,
    its chunks written one after the other (not joined).

    Returns:
        The parts of the body, to be written in order (the arrays are not copied: write
        them all before the next await if the arrays may change).
    """
    arrays: list[np.ndarray | ChunkedArray] = []
    skeleton = _extract(data, arrays)
    described = []
    payload: list[bytes | memoryview] = []
    offset = 0
    for array in arrays:
        if isinstance(array, ChunkedArray) and array.dtype != array.dtype.newbyteorder("<"):
            array = array.numpy()  # a big-endian chunk: converted below, as any array
        padding = -offset % _ALIGN
        if padding:
            payload.append(b"\0" * padding)
            offset += padding
        if isinstance(array, ChunkedArray):
            # Its chunks, one after the other: the layout of the joined array, without joining it.
            described.append({"dtype": array.dtype.str, "shape": [array.size], "offset": offset})
            payload += array.buffers()
            offset += array.nbytes
            continue
        wanted = array.dtype.newbyteorder("<")
        # Native int32 on this (little-endian) machine is already right: no copy then.
        little = np.ascontiguousarray(array if array.dtype == wanted else array.astype(wanted))
        described.append({"dtype": little.dtype.str, "shape": list(little.shape), "offset": offset})
        payload.append(memoryview(little).cast("B"))
        offset += little.nbytes
    header = orjson.dumps({"port": port, "data": skeleton, "arrays": described, **extra})
    # The small parts go out as one write; the arrays follow without being copied.
    return [BINARY_MAGIC + struct.pack("<I", len(header)) + header, *payload]
