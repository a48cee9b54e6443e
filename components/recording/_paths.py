"""Where recordings may be written and read: under the directories the operator allowed, and nowhere else.

A recording's path comes from a client, so it must not become a way to write (or read)
the gateway's disk.  Paths are refused unless they lie in a directory the operator
named (``--record-dir DIR``; none by default).  The file is reached from that directory
one component at a time, each opened relative to the one before and never through a
symbolic link (``O_NOFOLLOW``), and a new recording is created only if nothing is there
yet (``O_EXCL``): swapping a directory for a link while the file is opened cannot lead
outside, and no existing file is ever overwritten.  A recording holds microphones and cameras:
it is created readable by its owner only (``0600``) unless the operator chose another mode
(``--record-mode``).  A path holding a character no client's name may hold (a control character,
a line separator, a bidirectional control) is refused.  Blocking: call these off the event loop.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from collections.abc import Callable, Iterator, Sequence
from typing import BinaryIO, NamedTuple

from ..core import forbidden_in_name
from ._errors import PathRefused, RecordingError
from ._quota import FileQuota, RecordQuotas

__all__ = ["create_recording", "open_recording", "replay_roots", "NewRecording", "SUFFIX"]

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


def _refuse_forbidden_characters(path: str) -> None:
    """Refuse a path with a character no client's name may hold (a NUL would even end it early for the system).

    Raises:
        PathRefused: naming the character.
    """
    forbidden = forbidden_in_name(path)
    if forbidden is not None:
        raise PathRefused(f"{ascii(path)} holds {forbidden}: a recording's path has no control character, line "
                          "separator or bidirectional control")


class NewRecording(NamedTuple):
    """A recording file just created (by :func:`create_recording`).

    Attributes:
        stream: The file, open for writing, unbuffered.
        path: Its full path on this host (for the host's own log; a client is told :attr:`name`).
        root: The allowed directory it was created in (None: a host that allows any path).
        name: The file as a client knows it: its path within :attr:`root` (``session/take1.mcap``).
        quota: What it may take (None: whatever the disk takes).
    """

    stream: BinaryIO
    path: str
    root: str | None
    name: str
    quota: FileQuota | None = None


def _refusal(path: str, roots: Sequence[str] | None) -> PathRefused:
    if roots is not None and not roots:
        return PathRefused("recordings are disabled on this host (its operator can allow a directory with "
                           "--record-dir DIR)")
    return PathRefused(f"{path!r} is not in a directory this host allows for recordings (--record-dir)")


def create_recording(path: str, roots: Sequence[str] | None, mode: int = 0o600, *,
                     quotas: RecordQuotas | None = None, least: int = 0) -> NewRecording:
    """Create the recording file *path* (unbuffered, for writing) in one of *roots*.

    Args:
        path: The path a client gave: relative (to the allowed directory) or absolute; it must end in ``.mcap``.
        roots: The directories the operator allowed; None: anywhere (a host built in code).
        mode: Its permissions, whatever the process's umask (``0600``: its owner's only); read and write
            bits only (the others are dropped; ``HostSettings`` refuses them in an operator's ``--record-mode``).
        quotas: The host's quotas of bytes: the file's quota is opened before the file is made.
        least: The bytes the quota must have room for (refused before the file is made).

    Raises:
        PathRefused: when recordings are disabled, the path leads outside every allowed directory,
            through a symbolic link, or holds a control character, line separator or bidirectional control.
        RecordingError: when the file exists already, a directory on its way is missing, or it cannot be created.
        OverBudget: when *quotas* have no room for *least* bytes (no file is made).
    """
    _refuse_forbidden_characters(path)
    mode &= 0o666
    if not path.endswith(SUFFIX) or os.path.basename(path) == SUFFIX:
        raise RecordingError(f"a recording's name ends in {SUFFIX}: {path!r} does not")
    base: str | None = None
    components: list[str] = []
    if roots is None:
        name, full = os.path.normpath(path), os.path.abspath(path)
    else:
        places = list(_parts(path, roots))
        if not places:
            raise _refusal(path, roots)
        base, components = places[0]
        name, full = "/".join(components), os.path.join(base, *components)
    quota = quotas.open(base, name, least) if quotas is not None else None
    try:
        if base is None:
            stream = _create(lambda flags: os.open(path, flags, mode), path)
        else:
            with _directory(base, components) as parent:
                stream = _create(lambda flags: os.open(components[-1], flags | _NOFOLLOW, mode, dir_fd=parent),
                                 path)
    except BaseException as exc:
        if quota is not None:
            quota.close(0)
        if isinstance(exc, OSError):
            raise _why(exc, path, "create") from exc
        raise
    # The mode asked for, not what the umask left of it (an operator's 640 under a umask of 077).  Where the
    # file system refuses (no permissions on FAT), the file keeps what the umask left: never more than asked.
    with contextlib.suppress(OSError):
        os.fchmod(stream.fileno(), mode)
    return NewRecording(stream, full, base, name, quota)


def _create(opener: Callable[[int], int], shown: str) -> BinaryIO:
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | _CLOEXEC
    try:
        fd = opener(flags)
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
            control character, line separator or bidirectional control.
        RecordingError: when it is missing or not a regular file.
    """
    _refuse_forbidden_characters(path)
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
