"""Arrays held as immutable chunks, each encoded to JSON once: what a port read joins instead of copying.

An audio port publishes a window of chunks many times a second, and readers
read the whole window.  Copying the window into one array and encoding it to
JSON on every read costs the gateway far more than moving the bytes.  Here
each chunk is a read-only array that keeps its own JSON text once made, and a
:class:`ChunkedArray` stands for the concatenation of chunks without making
it: the gateway writes the chunks' bytes (binary) or their JSON texts one
after the other.  Nothing a reader holds can change, so a reply written over
many loop turns carries exactly the chunks of the publication it read.

Port data that can answer in this form is :class:`Chunked`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt
import orjson

__all__ = ["Chunk", "ChunkedArray", "Chunked"]

_NUMPY = orjson.OPT_SERIALIZE_NUMPY


class Chunk:
    """One read-only, contiguous 1-D array and its JSON text.

    The text is made on first use and kept (the array never changes): a capture
    that nobody reads as JSON never pays for it, and one that is read pays once
    per chunk however many readers there are.

    Args:
        array: The samples; it must be read-only (a port's published chunk).

    Raises:
        ValueError: for a writable, non-contiguous or multi-dimensional array.
    """

    __slots__ = ("array", "size", "_json", "_bytes")

    def __init__(self, array: npt.NDArray[Any]) -> None:
        if array.ndim != 1 or array.flags.writeable or not array.flags.c_contiguous:
            raise ValueError("a chunk is a read-only contiguous 1-D array")
        self.array = array
        #: The number of elements (an attribute: a read sums those of every chunk of a window).
        self.size = int(array.shape[0])
        self._json: bytes | None = None
        self._bytes: memoryview | None = None

    @property
    def json(self) -> bytes:
        """The elements as orjson writes them inside an array: ``1,-2,3`` (no brackets)."""
        if self._json is None:
            # Encoding the chunk alone gives the same digits as encoding it inside a longer
            # array: orjson writes each element on its own, separated by commas.
            self._json = orjson.dumps(self.array, option=_NUMPY)[1:-1]
        return self._json

    @property
    def bytes(self) -> memoryview:
        """The elements' memory, as bytes (a view, made once)."""
        if self._bytes is None:
            self._bytes = memoryview(self.array).cast("B")
        return self._bytes

    def __len__(self) -> int:
        return self.size


class ChunkedArray:
    """A 1-D array held as consecutive chunks, never joined unless asked (:meth:`numpy`).

    Args:
        chunks: The chunks, in order (all of one dtype).
        dtype: Their dtype (needed when there are none).
    """

    __slots__ = ("chunks", "dtype", "size")

    def __init__(self, chunks: Sequence[Chunk], dtype: npt.DTypeLike) -> None:
        self.chunks = tuple(chunks)
        self.dtype = np.dtype(dtype)
        #: The number of elements.
        self.size = sum([chunk.size for chunk in self.chunks])

    @property
    def nbytes(self) -> int:
        """Bytes of the elements."""
        return self.size * self.dtype.itemsize

    def json_pieces(self) -> list[bytes]:
        """The JSON array, in pieces to be written in order (``[``, chunks and commas, ``]``)."""
        pieces = [b"["]
        for chunk in self.chunks:
            if chunk.size:
                if len(pieces) > 1:
                    pieces.append(b",")
                pieces.append(chunk.json)
        pieces.append(b"]")
        return pieces

    def buffers(self) -> list[memoryview]:
        """The raw bytes of the chunks, in order, without copying them."""
        return [chunk.bytes for chunk in self.chunks if chunk.size]

    def numpy(self) -> npt.NDArray[Any]:
        """The elements joined into one new array."""
        if not self.chunks:
            return np.zeros(0, self.dtype)
        return np.concatenate([chunk.array for chunk in self.chunks])

    def __len__(self) -> int:
        return self.size

    def __repr__(self) -> str:
        return f"<ChunkedArray {self.dtype} x {self.size} in {len(self.chunks)} chunks>"


@runtime_checkable
class Chunked(Protocol):
    """Port data whose large arrays are immutable chunks, readable without copying them.

    The gateway reads such data with :meth:`chunked` and writes the chunks as
    they are (binary) or their JSON texts (genomix JSON), byte for byte what
    encoding the copied arrays would give.
    """

    def chunked(self, since: int | None = None) -> tuple[Any, int]:
        """The port struct with its sample arrays as :class:`ChunkedArray`, and the items lost.

        Args:
            since: None for the whole port; else only the items after this index
                (as :meth:`Incremental.since`).
        """
