"""Where recordings may be written and read: under the directories the operator allowed, and nowhere else.

A recording's path comes from a client, so it must not become a way to write (or read)
the gateway's disk.  Paths are refused unless they lie in a directory the operator
named (``--record-dir DIR``; none by default).  The file is reached from that directory
one component at a time, each opened relative to the one before and never through a
symbolic link (``O_NOFOLLOW``), and a new recording is created only if nothing is there
yet (``O_EXCL``): swapping a directory for a link while the file is opened cannot lead
outside, and no existing file is ever overwritten.  Blocking: call these off the event loop.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from collections.abc import Iterator, Sequence
from typing import BinaryIO

from ._errors import PathRefused, RecordingError

__all__ = ["create_recording", "open_recording", "replay_roots", "SUFFIX"]

#: The suffix every recording has.
SUFFIX = ".mcap"
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_DIRECTORY = getattr(os, "O_DIRECTORY", 0)


def _parts(path: str, roots: Sequence[str]) -> Iterator[tuple[str, list[str]]]:
    """The allowed directories *path* may lie in, each with the path's components below it.

    A relative path is taken relative to each directory in turn; an absolute one only where it
    lies under a directory (compared after resolving the directory, not the path: the walk
    below never follows a link).
    """
    for root in roots:
        base = os.path.realpath(root)
        target = path if os.path.isabs(path) else os.path.join(base, path)
        normal = os.path.normpath(target)
        if os.path.commonpath([normal, base]) != base or normal == base:
            continue
        yield base, os.path.relpath(normal, base).split(os.sep)


@contextlib.contextmanager
def _directory(base: str, components: list[str]) -> Iterator[int]:
    """The directory holding the file *components* names below *base*, opened without following links."""
    fd = os.open(base, os.O_RDONLY | _DIRECTORY | _CLOEXEC)
    try:
        for name in components[:-1]:
            child = os.open(name, os.O_RDONLY | _DIRECTORY | _NOFOLLOW | _CLOEXEC, dir_fd=fd)
            os.close(fd)
            fd = child
        yield fd
    finally:
        os.close(fd)


def replay_roots(record_dirs: Sequence[str] | None, audio_files: Sequence[str] | None) -> tuple[str, ...] | None:
    """Where a recording may be read from to be replayed: the operator's ``--record-dir``, then ``--audio-files``.

    Returns:
        The directories, or None (anywhere) when either is unrestricted (a host built in code).
    """
    if record_dirs is None or audio_files is None:
        return None
    return (*record_dirs, *audio_files)


def _refuse_control_characters(path: str) -> None:
    """Refuse a path with a control character (a NUL would end it early for the system: never a file's name).

    Raises:
        PathRefused: naming the character.
    """
    bad = next((c for c in path if ord(c) < 32 or ord(c) == 127), None)
    if bad is not None:
        raise PathRefused(f"{path!r} holds a control character ({bad!r}): a recording's path has none")


def _refusal(path: str, roots: Sequence[str] | None) -> PathRefused:
    if roots is not None and not roots:
        return PathRefused("recordings are disabled on this host (its operator can allow a directory with "
                           "--record-dir DIR)")
    return PathRefused(f"{path!r} is not in a directory this host allows for recordings (--record-dir)")


def create_recording(path: str, roots: Sequence[str] | None) -> tuple[BinaryIO, str]:
    """Create the recording file *path* (unbuffered, for writing) in one of *roots*; return it and its full path.

    Args:
        path: The path a client gave: relative (to the allowed directory) or absolute; it must end in ``.mcap``.
        roots: The directories the operator allowed; None: anywhere (a host built in code).

    Raises:
        PathRefused: when recordings are disabled, the path leads outside every allowed directory,
            through a symbolic link, or holds a control character.
        RecordingError: when the file exists already, a directory on its way is missing, or it cannot be created.
    """
    _refuse_control_characters(path)
    if not path.endswith(SUFFIX) or os.path.basename(path) == SUFFIX:
        raise RecordingError(f"a recording's name ends in {SUFFIX}: {path!r} does not")
    if roots is None:
        return _create(lambda flags: os.open(path, flags, 0o644), path), os.path.abspath(path)
    places = list(_parts(path, roots))
    if not places:
        raise _refusal(path, roots)
    base, components = places[0]
    try:
        with _directory(base, components) as parent:
            stream = _create(lambda flags: os.open(components[-1], flags | _NOFOLLOW, 0o644, dir_fd=parent), path)
    except OSError as exc:
        raise _why(exc, path, "create") from exc
    return stream, os.path.join(base, *components)


def _create(opener: object, shown: str) -> BinaryIO:
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | _CLOEXEC
    try:
        fd = opener(flags)  # type: ignore[operator]
    except OSError as exc:
        raise _why(exc, shown, "create") from exc
    return os.fdopen(fd, "wb", buffering=0)


def _why(exc: OSError, path: str, doing: str) -> RecordingError:
    if isinstance(exc, RecordingError):
        return exc
    if exc.errno == errno.EEXIST:
        return RecordingError(f"{path!r} exists already: a recording never overwrites a file (choose another name)")
    if exc.errno in (errno.ELOOP, errno.ENOTDIR):
        return PathRefused(f"{path!r} leads through a symbolic link or a file: recordings are reached only "
                           "through directories")
    if exc.errno == errno.ENOENT:
        what = "a directory on its way does not exist" if doing == "create" else "there is no such recording"
        return RecordingError(f"cannot {doing} {path!r}: {what}")
    return RecordingError(f"cannot {doing} {path!r}: {exc.strerror or exc}")


def open_recording(path: str, roots: Sequence[str] | None) -> tuple[BinaryIO, str]:
    """Open the recording *path* for reading from one of *roots*; return it (buffered, seekable) and its full path.

    Raises:
        PathRefused: when reading recordings is disabled, or the path leads outside every allowed
            directory, through a symbolic link (never saying whether the path exists there), or holds a
            control character.
        RecordingError: when it is missing or not a regular file.
    """
    _refuse_control_characters(path)
    if roots is None:
        places = [(os.path.dirname(os.path.abspath(path)), [os.path.basename(path)])]
    else:
        places = list(_parts(path, roots))
        if not places:
            raise _refusal(path, roots)
    last: OSError | None = None
    for base, components in places:
        try:
            with _directory(base, components) as parent:
                # O_NONBLOCK: a FIFO opens at once instead of waiting for a writer; it is refused below.
                fd = os.open(components[-1], os.O_RDONLY | os.O_NONBLOCK | _NOFOLLOW | _CLOEXEC, dir_fd=parent)
        except OSError as exc:
            last = exc
            continue
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise RecordingError(f"{path!r} is not a regular file")
            os.set_blocking(fd, True)
        except BaseException:
            os.close(fd)
            raise
        return os.fdopen(fd, "rb"), os.path.join(base, *components)
    assert last is not None
    raise _why(last, path, "open")
