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
from ._connection import drained_of
from ._gather import Buffer, direct_socket, write_draining

__all__ = ["json_pieces", "PiecesPayload", "body_of", "JOINED_UP_TO"]

#: Bodies up to this size are joined and go out in one write with the HTTP head:
#: copying a few kilobytes costs less than a gathered write's second system call.
JOINED_UP_TO = 1 << 16

_OPTIONS = orjson.OPT_SERIALIZE_NUMPY
# orjson never writes a raw NUL byte (it escapes control characters in strings),
# so a NUL in its output can only be a mark left by _mark.
_MARK = b"\x00"
_FRAGMENT = orjson.Fragment(_MARK)


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


def body_of(pieces: Sequence[Buffer], content_type: str) -> bytes | PiecesPayload:
    """The reply body of *pieces*: one joined ``bytes`` when small, else the pieces as they are."""
    if sum(len(piece) for piece in pieces) <= JOINED_UP_TO:
        return b"".join(pieces)
    return PiecesPayload(pieces, content_type)


class PiecesPayload(payload.Payload):
    """A reply body of immutable pieces, written in order and never joined.

    Plain port reads are answered ahead of the routes with their head and pieces in
    one gathered write (``_fast_reads``); this payload is the routes' form of the same
    body.  Its first piece goes through aiohttp's writer, with the HTTP head the writer
    holds until then; when the connection then has nothing queued, the other pieces
    go straight to the socket in one gathered write, and what the socket does not
    take goes to the transport as the client takes it (:func:`._gather.write_draining`):
    nothing is copied on the way but by the kernel (and, on Python 3.11, by the
    transport for the little it queues at a time).  Otherwise they go through
    aiohttp's writer, after what it holds, which waits for the client likewise.  The
    routes never compress these replies nor frame them in chunks (a ``Content-Length``
    is set): the pieces are the bytes of the body.

    Args:
        pieces: The body's pieces, in order: bytes, or byte-format memoryviews of
            data that never changes (a reply may still be written when the port
            has moved on).
        content_type: The body's media type.
    """

    def __init__(self, pieces: Sequence[Buffer], content_type: str) -> None:
        kept = tuple(piece for piece in pieces if len(piece))
        super().__init__(kept, content_type=content_type)
        self._pieces = kept
        self._nbytes = sum(len(piece) for piece in kept)
        self._size = self._nbytes

    @property
    def size(self) -> int:
        """The body's length in bytes."""
        return self._nbytes

    @property
    def pieces(self) -> tuple[Buffer, ...]:
        """The body's pieces, in order (none of them empty)."""
        return self._pieces

    async def write(self, writer: AbstractStreamWriter) -> None:
        """Write every piece without waiting for the socket in between (aiohttp drains at the end)."""
        pieces = self._pieces
        if not pieces:
            return
        # aiohttp's StreamWriter takes drain=; the abstract writer it is typed as does not say so.
        await writer.write(pieces[0], drain=False)  # type: ignore[call-arg]  # with the head
        rest = pieces[1:]
        transport = getattr(writer, "transport", None)
        fd = direct_socket(transport) if rest and not getattr(writer, "chunked", True) else None
        if fd is None or transport is None:
            # The transport has bytes queued (the head and first piece, or a reply before this
            # one) or is not a plain socket: everything goes through aiohttp's writer, which
            # waits for the client past the transport's high-water mark.
            for piece in rest:
                await writer.write(piece)
            return
        # The rest goes out as the client takes it (aiohttp waits for the last bytes at the
        # end of the reply, as for any body): the transport never holds a copy of it all.
        size = self._nbytes - len(pieces[0])
        await write_draining(transport, rest, drained_of(getattr(writer, "protocol", None)), size)
        _account(writer, size)

    def decode(self, encoding: str = "utf-8", errors: str = "strict") -> str:
        """The body as text (for logs and tests)."""
        return b"".join(self._pieces).decode(encoding, errors)


def _account(writer: AbstractStreamWriter, sent: int) -> None:
    """Tell aiohttp's writer about body bytes written beside it (what it counts of a body it writes)."""
    if sent <= 0:
        return
    writer.output_size += sent
    if writer.length is not None:
        writer.length -= sent
    notify = getattr(writer, "on_body_write", None)
    if notify is not None:
        notify(sent, writer.output_size)
