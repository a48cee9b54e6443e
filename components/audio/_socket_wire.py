"""The dedicated-socket wire format of 2014 (seed section 5.4, Table 6.3), sans I/O.

A client sends the ASCII line ``Read Port - Index <k>`` (LF or CRLF), *k* being
the index of the last chunk it holds.  The server answers with little-endian
int32 values::

    [n] [left: n * FPC] [right: n * FPC] [last index]

and the merged capture + KEMAR component appends ``[n positions as float32
degrees]``, the head position at the end of each chunk.  So 10 chunks of 2205
frames take ``4 * (10 * (2 * 2205 + 1) + 2) = 176448`` bytes.

A request that does not parse is answered with one ASCII line starting with
``ERROR`` (readable with ``nc``; a binary client sees the impossible count
``b"ERRO"``) and the connection is closed.
"""

from __future__ import annotations

import re

import numpy as np

from ._errors import RequestError
from ._line_server import ERROR_PREFIX, MAX_REQUEST_LINE, encode_error, split_lines
from ._window import WindowRead, WindowState

__all__ = [
    "REQUEST_PREFIX", "MAX_REQUEST_LINE", "ERROR_PREFIX", "RequestParser", "parse_request", "encode_request",
    "encode_reply", "encode_state_reply", "encode_error", "reply_size",
]

REQUEST_PREFIX = "Read Port - Index "

# Lenient about spacing and letter case, strict about the number: a negative or
# fractional index has no meaning and is refused rather than guessed at.
_REQUEST = re.compile(rb"\s*read\s+port\s*-\s*index\s+(\d{1,19})\s*", re.IGNORECASE)


def parse_request(line: bytes) -> int:
    """Return the index *k* of one request line (without its line ending).

    Raises:
        RequestError: when the line is not ``Read Port - Index <k>``.
    """
    match = _REQUEST.fullmatch(line)
    if match is None:
        shown = line[:60].decode("ascii", "replace")
        raise RequestError(f"expected 'Read Port - Index <k>' with k >= 0, got {shown!r}")
    return int(match.group(1))


def encode_request(index: int) -> bytes:
    """The request line asking for the chunks after *index*."""
    if index < 0:
        raise ValueError(f"a chunk index is >= 0, not {index}")
    return f"{REQUEST_PREFIX}{index}\n".encode("ascii")


class RequestParser:
    """Splits the bytes a client sends into request indices.

    Feed it whatever arrives; it returns the complete requests so far and keeps
    a partial line for the next call.
    """

    def __init__(self) -> None:
        self._pending = bytearray()

    def feed(self, data: bytes) -> list[int]:
        """Add received bytes and return the indices of the complete requests.

        Raises:
            RequestError: at the first malformed line, or a line longer than
                :data:`MAX_REQUEST_LINE` (the stream cannot be trusted after it).
        """
        return [parse_request(line) for line in split_lines(self._pending, data)]


def reply_size(count: int, frames_per_chunk: int, *, with_positions: bool = False) -> int:
    """The size in bytes of a reply carrying *count* chunks."""
    return 4 * (2 + 2 * count * frames_per_chunk + (count if with_positions else 0))


def encode_reply(chunks: WindowRead, *, with_positions: bool = False) -> bytearray:
    """The reply carrying *chunks* (from :meth:`ChunkWindow.since`), in one buffer of its own.

    Nothing else refers to the buffer, so a transport may hold it as long as the
    client takes to drain it.

    Raises:
        ValueError: when positions are asked for but the chunks carry none.
    """
    count, fpc = chunks.left.shape
    if with_positions and chunks.positions is None:
        raise ValueError("the reply needs positions but the window keeps none")
    reply = bytearray(reply_size(count, fpc, with_positions=with_positions))
    words = np.frombuffer(reply, dtype="<i4")
    samples = count * fpc
    words[0] = count
    words[1:1 + samples] = chunks.left.reshape(-1)
    words[1 + samples:1 + 2 * samples] = chunks.right.reshape(-1)
    words[1 + 2 * samples] = chunks.last_index
    if with_positions:
        words[2 + 2 * samples:].view("<f4")[:] = chunks.positions
    return reply


def encode_state_reply(state: WindowState, index: int, *, with_positions: bool = False,
                       limit: int | None = None) -> bytearray:
    """The reply carrying the chunks of *state* after *index*, copied once from the chunks into a buffer of its own.

    The same bytes as :func:`encode_reply` of ``state.since(index, limit=limit)``, without the
    window's arrays in between.

    Args:
        state: The window at one publication.
        index: The last chunk the client holds.
        with_positions: Append the head positions.
        limit: At most this many chunks (the newest).

    Raises:
        ValueError: when positions are asked for but the window keeps none.
    """
    if with_positions and state.positions is None:
        raise ValueError("the reply needs positions but the window keeps none")
    left, right, _ = state.chunks_since(index, limit)
    count, fpc = len(left), len(state.left[0])
    reply = bytearray(reply_size(count, fpc, with_positions=with_positions))
    words = np.frombuffer(reply, dtype="<i4")
    words[0] = count
    samples = count * fpc
    for channel, start in ((left, 1), (right, 1 + samples)):
        for number, chunk in enumerate(channel):
            words[start + number * fpc:start + (number + 1) * fpc] = chunk.array
    words[1 + 2 * samples] = state.last_index
    if with_positions:
        positions = state.positions_since(index, limit)
        assert positions is not None
        words[2 + 2 * samples:].view("<f4")[:] = positions
    return reply
