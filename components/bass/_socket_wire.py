"""The frame-indexed dedicated-socket wire format of 2015 (``bass``), sans I/O.

A client sends text lines (LF-terminated; CRLF is accepted).  A line holding
``Read Port`` asks for frames: ``N <n>`` is the most frames it wants and
``nfr <i>`` the absolute index of the next frame it wants.  The public MATLAB
client (``dedicatedSocketRead.m``) sends exactly::

    Read Port - N 4410 - nfr 0

The reply is a 16-byte little-endian header, then the samples as int32 LE,
all the left ones, then all the right ones (two blocks, not interleaved)::

    int32 n         frames sent
    int32 lost      frames skipped because the port no longer held them
    int64 next      the next frame to read (sent as two int32 halves, low first)
    int32 left[n]
    int32 right[n]

A ``Close`` line ends the connection (``dedicatedSocketClose.m``).  A line
that is neither, or a ``Read Port`` line without both numbers, is answered
with one ``ERROR ...`` line and the connection is closed: the original server
ignored such lines and left its client waiting forever.
"""

from __future__ import annotations

import dataclasses
import re
import struct

import numpy as np

from ..audio import RequestError, split_lines
from ._history import AudioSnapshot, FrameRead

__all__ = ["FrameRequest", "CLOSE_REQUEST", "FrameRequestParser", "parse_frame_request", "encode_frame_request",
           "encode_frame_reply", "encode_snapshot_reply", "HEADER", "frame_reply_size"]

#: The reply header: frames sent, frames lost, next frame (int64 as two int32 halves, low first).
HEADER = struct.Struct("<iiq")
#: The largest count the int32 header fields carry (larger losses are reported as this).
_INT32_MAX = 2**31 - 1
#: The largest frame index (the reply's next frame is an int64).
_INT64_MAX = 2**63 - 1

_READ = re.compile(rb"read\s+port", re.IGNORECASE)
# Whole words: "N" must not match inside another word, "nfr" not inside "nfrx".
_N = re.compile(rb"(?<![A-Za-z])N\s*[:=]?\s*(\d{1,10})(?!\d)")
_NFR = re.compile(rb"(?<![A-Za-z])nfr\s*[:=]?\s*(\d{1,19})(?!\d)")
_CLOSE = re.compile(rb"\s*close\s*", re.IGNORECASE)


@dataclasses.dataclass(frozen=True)
class FrameRequest:
    """One ``Read Port`` request: at most *frames* frames from frame *next_frame* on."""

    frames: int
    next_frame: int


#: What :func:`parse_frame_request` returns for a ``Close`` line.
CLOSE_REQUEST = None


def parse_frame_request(line: bytes) -> FrameRequest | None:
    """Parse one request line (without its line ending); None for ``Close``.

    Raises:
        RequestError: when the line is neither a ``Read Port`` request with ``N``
            and ``nfr`` nor ``Close``.
    """
    if _CLOSE.fullmatch(line):
        return CLOSE_REQUEST
    shown = line[:80].decode("ascii", "replace")
    if not _READ.search(line):
        raise RequestError(f"expected 'Read Port - N <n> - nfr <i>' or 'Close', got {shown!r}")
    count, first = _N.search(line), _NFR.search(line)
    if count is None or first is None:
        raise RequestError(f"a Read Port request needs 'N <frames>' and 'nfr <next frame>' (>= 0), got {shown!r}")
    frames, next_frame = int(count.group(1)), int(first.group(1))
    if frames > _INT32_MAX:
        raise RequestError(f"N is at most {_INT32_MAX} frames, not {frames}")
    if next_frame > _INT64_MAX:
        # The reply's next frame is an int64: a frame past it does not exist.
        raise RequestError(f"nfr is at most {_INT64_MAX}, not {next_frame}")
    return FrameRequest(frames, next_frame)


def encode_frame_request(frames: int, next_frame: int) -> bytes:
    """The request line the MATLAB client sends for *frames* frames from *next_frame*."""
    if frames < 0 or next_frame < 0:
        raise ValueError(f"N and nfr are never negative, not {frames} and {next_frame}")
    return f"Read Port - N {frames} - nfr {next_frame}\n".encode("ascii")


class FrameRequestParser:
    """Splits the bytes a client sends into requests (``None`` for ``Close``)."""

    def __init__(self) -> None:
        self._pending = bytearray()

    def feed(self, data: bytes) -> list[FrameRequest | None]:
        """Add received bytes and return the complete requests so far.

        Raises:
            RequestError: at the first malformed line (the stream cannot be trusted after it).
        """
        return [parse_frame_request(line) for line in split_lines(self._pending, data)]


def frame_reply_size(frames: int) -> int:
    """The size in bytes of a reply carrying *frames* frames."""
    return HEADER.size + 8 * frames


def encode_snapshot_reply(snapshot: AudioSnapshot, next_frame: int, limit: int | None) -> bytearray:
    """The reply to a read of *snapshot* (as :meth:`AudioSnapshot.frames` places it), copied once from its chunks.

    The same bytes as :func:`encode_frame_reply` of ``snapshot.frames(next_frame, limit)``, in a
    buffer of its own.
    """
    first, lost, count = snapshot.placed(next_frame, limit)
    reply = bytearray(frame_reply_size(count))
    HEADER.pack_into(reply, 0, count, min(lost, _INT32_MAX), first + count)
    snapshot.copy_frames(first, np.frombuffer(reply, dtype="<i4", offset=HEADER.size).reshape(2, count))
    return reply


def encode_frame_reply(read: FrameRead) -> bytearray:
    """The reply carrying *read* (header, left block, right block), in a buffer of its own.

    Nothing else refers to the buffer, so the transport may hold it as long as
    the client takes to drain it.
    """
    reply = bytearray(frame_reply_size(read.count))
    HEADER.pack_into(reply, 0, read.count, min(read.lost, _INT32_MAX), read.next)
    samples = np.frombuffer(reply, dtype="<i4", offset=HEADER.size).reshape(2, read.count)
    samples[0], samples[1] = read.left, read.right
    return reply
