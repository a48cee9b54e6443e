"""Gathered writes: many buffers straight to a connection's socket with one ``writev``, never joined.

A port read of the audio window is a few hundred immutable buffers (the
chunks' JSON texts or their samples).  Joining them into one body costs a copy
into freshly mapped memory on every new publication, and writing them one by
one costs a system call each (and a wake-up of the reader each).  asyncio's
socket transport has no gathered write before Python 3.12, and aiohttp does
not use the one of 3.12 and 3.13 before their fixed releases.  So, when the
transport has nothing queued, the buffers go to its socket with ``writev``:
the kernel takes what its send buffer holds (on loopback, usually all of it)
in one call, in order; whatever it does not take is handed back to the
transport, which sends it as it sends everything else.

Writing beside the transport is safe only when the transport holds no bytes
of its own (they would go out after ours) and when it writes the socket as it
is (not through TLS): :func:`direct_socket` checks both.

What the socket does not take is not handed to the transport all at once
(:func:`write_draining`): asyncio's transport of Python 3.11 copies every byte
it is given into a buffer of its own, so a client that asked for the 59 MiB
window in JSON (150 MB of text) and never read made the gateway hold a copy of
it, each such client its own.  The transport is given bytes up to its
high-water mark (64 KiB) at a time, and the rest as the client takes them: a
client that never reads holds references to the reply's shared pieces, not a
copy.
"""

from __future__ import annotations

import asyncio
import bisect
import itertools
import os
from collections.abc import Awaitable, Callable, Sequence

__all__ = ["Buffer", "direct_socket", "write_gathered", "unsent", "write_draining", "unlinked"]

#: A piece of a reply: bytes, or a byte-format (``"B"``) memoryview of immutable data.
Buffer = bytes | memoryview

# writev takes at most this many buffers per call (1024 on Linux).
_IOV_MAX = os.sysconf("SC_IOV_MAX") if hasattr(os, "sysconf") else 16


def direct_socket(transport: asyncio.BaseTransport | None) -> int | None:
    """The file descriptor to write *transport*'s next bytes to, or None when only the transport may write.

    Args:
        transport: The connection's transport.

    Returns:
        The socket's descriptor when the transport is open, has no bytes queued and
        is not TLS; else None.
    """
    if (not hasattr(os, "writev") or not isinstance(transport, asyncio.WriteTransport) or transport.is_closing()
            or transport.get_write_buffer_size() or transport.get_extra_info("sslcontext") is not None):
        return None
    sock = transport.get_extra_info("socket")
    return None if sock is None else sock.fileno()


def write_gathered(fd: int, buffers: Sequence[Buffer]) -> int:
    """Write *buffers* in order to the non-blocking socket *fd*, as far as it takes them now.

    Args:
        fd: A non-blocking stream socket (from :func:`direct_socket`).
        buffers: The pieces, each of ``len()`` bytes.

    Returns:
        How many bytes went out (0 when the socket takes nothing now or fails: the
        transport then writes everything, and reports a failure its own way).
    """
    if len(buffers) <= _IOV_MAX:  # the usual case: one call, no sizes to add up
        try:
            return os.writev(fd, buffers)
        except OSError:  # full (EAGAIN), or a reset: the transport's next write sees the same
            return 0
    written = 0
    for start in range(0, len(buffers), _IOV_MAX):
        batch = buffers[start:start + _IOV_MAX]
        count = write_gathered(fd, batch)
        written += count
        if count < sum(len(piece) for piece in batch):
            return written
    return written


def unsent(buffers: Sequence[Buffer], written: int) -> list[Buffer]:
    """The part of *buffers* after their first *written* bytes (a cut piece as a view, not a copy)."""
    if not written:
        return list(buffers)
    # The pieces' ends found in C: a window's reply is a few hundred pieces, and a loop over
    # them in Python cost a read of the 4000 ms window 25 µs on the benchmark's machine.
    ends = list(itertools.accumulate(map(len, buffers)))
    index = bisect.bisect_right(ends, written)
    if index == len(buffers):
        return []
    rest = list(buffers[index:])
    cut = written - (ends[index - 1] if index else 0)
    if cut:
        rest[0] = memoryview(rest[0])[cut:]
    return rest


async def write_draining(transport: asyncio.WriteTransport, pieces: Sequence[Buffer],
                         drained: Callable[[], Awaitable[None]], size: int | None = None) -> None:
    """Write *pieces* in order to *transport*'s connection as fast as its client takes them, never copying them all.

    While the transport holds nothing, the pieces go straight to the socket
    (:func:`write_gathered`); the transport is handed the next ones until it holds more
    than its high-water mark (by one piece at most), where its protocol is asked to
    wait, and the rest waits for *drained*.

    Args:
        transport: The connection's transport (nothing else writes to it meanwhile).
        pieces: The bytes to write, in order (immutable: they are written as the client reads).
        drained: Waits until the transport holds little again (the protocol's flow control:
            aiohttp's ``drain``); it may raise to give up (a client that takes nothing).
        size: The pieces' total length when the caller knows it: a reply the socket takes
            whole at once (the usual case on a fast link) is then done without looking at
            its pieces again.

    Raises:
        ConnectionResetError: The connection closed before the last piece went out.
    """
    high = transport.get_write_buffer_limits()[1]
    rest = list(pieces)
    while rest:
        if transport.is_closing():  # the reader went away: what aiohttp's writer raises then
            raise ConnectionResetError("the connection closed while the reply was written")
        fd = direct_socket(transport)
        if fd is not None:
            written = write_gathered(fd, rest)
            if written == size:
                return
            rest = unsent(rest, written)
        size = None  # the first write only: the rest is smaller
        given = 0
        # A write may find the connection reset (the transport closes then): the next ones would
        # each be dropped with a warning of asyncio's.
        while given < len(rest) and transport.get_write_buffer_size() <= high and not transport.is_closing():
            transport.write(rest[given])
            given += 1
        del rest[:given]
        if rest:
            try:
                await drained()
            except ConnectionError as exc:
                raise unlinked(exc) from None


def unlinked(exc: ConnectionError) -> ConnectionResetError:
    """A fresh error for *exc*, a lost connection met while waiting for it to drain; *exc* let go of its frames.

    The waiter that *exc* ended keeps it, and its traceback keeps the frames it went through with
    their locals (the reply being written: a whole publication of the audio window): a cycle that
    only a full collection frees, which a gateway holding a million long-lived objects seldom runs.
    """
    exc.__traceback__ = None
    return ConnectionResetError(f"the connection closed while a reply was written ({exc})")
