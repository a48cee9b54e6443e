"""Reply bodies made of pieces written in order: genomix JSON around pre-encoded chunks, and their payload.

A port read of the audio window is a small struct around two large arrays that
are already encoded, chunk by chunk (:class:`~aiogenomix.components.core.ChunkedArray`).
:func:`json_pieces` encodes the struct with orjson, as every other reply,
leaving a mark where each chunked array goes, and splices in the chunks' JSON
texts: the bytes are those that encoding the joined arrays would give, without
encoding a single sample again.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import orjson
from aiohttp import payload
from aiohttp.abc import AbstractStreamWriter

from ..components.core import ChunkedArray

__all__ = ["json_pieces", "PiecesPayload"]

_OPTIONS = orjson.OPT_SERIALIZE_NUMPY
# orjson never writes a raw NUL byte (it escapes control characters in strings),
# so a NUL in its output can only be a mark left by _mark.
_MARK = b"\x00"
_FRAGMENT = orjson.Fragment(_MARK)

Buffer = bytes | memoryview


def json_pieces(obj: Any) -> list[bytes]:
    """Compact JSON of *obj* (numpy arrays as arrays, :class:`ChunkedArray` as their chunks' texts), in pieces.

    Joined, the pieces are byte for byte what ``orjson.dumps`` gives for the same data with
    every chunked array joined into one numpy array.
    """
    found: list[ChunkedArray] = []

    def _mark(value: Any) -> Any:
        if isinstance(value, ChunkedArray):
            found.append(value)
            return _FRAGMENT
        raise TypeError(f"Type is not JSON serializable: {type(value).__name__}")

    text = orjson.dumps(obj, option=_OPTIONS, default=_mark)
    if not found:
        return [text]
    literals = text.split(_MARK)
    pieces = [literals[0]]
    for array, literal in zip(found, literals[1:], strict=True):
        pieces += array.json_pieces()
        pieces.append(literal)
    return pieces


class PiecesPayload(payload.Payload):
    """A reply body in two immutable parts: a small head, written with the HTTP head, and the rest.

    aiohttp joins the HTTP head with the first write of the body (one send for a small
    reply).  For a body of megabytes that join would copy the whole body once more, so the
    body is split: its first piece (a few hundred bytes) goes with the HTTP head, and the
    rest, already one buffer, goes to the socket as it is.

    Args:
        head: The first bytes of the body.
        rest: The remaining bytes (empty for a small body).
        content_type: The body's media type.
    """

    def __init__(self, head: bytes, rest: bytes, content_type: str) -> None:
        super().__init__(head, content_type=content_type)
        self._head, self._rest = head, rest
        self._size = len(head) + len(rest)

    @classmethod
    def of(cls, pieces: Sequence[Buffer], content_type: str) -> PiecesPayload:
        """The payload of *pieces*: the first as the head, the others joined (one copy, none may change after)."""
        head = bytes(pieces[0])
        return cls(head, b"".join(pieces[1:]), content_type)

    async def write(self, writer: AbstractStreamWriter) -> None:
        """Write both parts without waiting for the socket in between (aiohttp drains at the end)."""
        # aiohttp's StreamWriter takes drain=; the abstract writer it is typed as does not say so.
        await writer.write(self._head, drain=False)  # type: ignore[call-arg]
        if self._rest:
            await writer.write(self._rest, drain=False)  # type: ignore[call-arg]

    def decode(self, encoding: str = "utf-8", errors: str = "strict") -> str:
        """The body as text (for logs and tests)."""
        return (self._head + self._rest).decode(encoding, errors)
