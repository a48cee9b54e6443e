"""File sources of a capture (``file:<path.wav>``, ``sim:<scene.json>``): confined, bounded, opened off the loop.

A device string comes from any client of the gateway, so a path in it must not
become a way to read the gateway's disk: paths are refused unless they lie in
a directory the operator named (``--audio-files DIR``; none by default), a
refusal says nothing about whether the path exists, and what is opened must be
a regular file of bounded size (``/dev/zero`` or a FIFO would otherwise fill
the memory or block a thread forever).  The functions here block on the disk:
call them with :func:`asyncio.to_thread`.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Sequence
from typing import BinaryIO

from ._errors import AudioError, SceneError

__all__ = ["PathRefused", "confined_path", "open_regular_file", "read_regular_file", "MAX_SCENE_BYTES"]

#: The largest scene description read.
MAX_SCENE_BYTES = 1 << 20


class PathRefused(AudioError, PermissionError):
    """A file path outside the directories the operator allowed (or files disabled altogether)."""


def confined_path(path: str, roots: Sequence[str] | None) -> str:
    """The real path of *path* when it lies in one of *roots* (symbolic links resolved).

    Args:
        path: The path a client gave.
        roots: The directories the operator allowed; None means no confinement
            (a host built in code, whose author is the operator).

    Raises:
        PathRefused: when files are disabled or the path leads outside every root; the
            message never says whether the path exists.
    """
    if roots is None:
        return path
    if not roots:
        raise PathRefused("file and scene paths are disabled on this gateway "
                          "(its operator can allow a directory with --audio-files DIR)")
    real = os.path.realpath(path)
    for root in roots:
        allowed = os.path.realpath(root)
        if os.path.commonpath([real, allowed]) == allowed:
            return real
    raise PathRefused(f"{path!r} is not in a directory this gateway allows for audio files (--audio-files)")


def open_regular_file(path: str, shown: str) -> BinaryIO:
    """Open *path* for reading if it is a regular file (blocking: call it off the event loop).

    Args:
        path: What to open.
        shown: How to name it in messages (the path as the client gave it).

    Raises:
        SceneError: when it does not exist, cannot be read or is not a regular file.
    """
    try:
        # O_NONBLOCK: a FIFO opens at once instead of waiting for a writer; it is refused below.
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise SceneError(f"cannot open {shown!r}: {exc.strerror}") from exc
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise SceneError(f"{shown!r} is not a regular file")
        os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return os.fdopen(fd, "rb")


def read_regular_file(path: str, shown: str, limit: int = MAX_SCENE_BYTES) -> bytes:
    """The content of a regular file of at most *limit* bytes (blocking: call it off the event loop).

    Raises:
        SceneError: when it cannot be read, is not a regular file, or is larger than *limit*.
    """
    with open_regular_file(path, shown) as stream:
        data = stream.read(limit + 1)
    if len(data) > limit:
        raise SceneError(f"{shown!r} is larger than {limit} bytes")
    return data
