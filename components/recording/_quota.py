"""The bytes a host's recordings may write: so many per file, so many per record directory together.

A recording's client chooses how long it runs; the disk it fills is the host's.  Two bounds of
:class:`~aiogenomix.components.core.Budgets` keep it: ``recording_bytes`` (one file, its summary
included) and ``record_dir_bytes`` (the files of one ``--record-dir`` together).  A directory is
measured (its regular files, not following links) when a recording starts there and none is being
written; while recordings are written there, what they take is added as they take it.  Each chunk
is taken before it is written: the file ends, readable, before the chunk that would pass a bound,
with room kept for its summary.

The writer threads take bytes while the event loop starts recordings: everything here is thread-safe.
"""

from __future__ import annotations

import os
import stat
import threading

from ..core import Budgets, OverBudget

__all__ = ["RecordQuotas", "FileQuota", "directory_bytes"]


def directory_bytes(root: str) -> int:
    """The bytes of the regular files under *root*, its subdirectories included, never following a link.

    Blocking: it walks the directory.  Entries that vanish or cannot be read while it walks count nothing.
    """
    total = 0
    pending = [root]
    while pending:
        try:
            with os.scandir(pending.pop()) as entries:
                for entry in entries:
                    try:
                        info = entry.stat(follow_symlinks=False)
                    except OSError:
                        continue
                    if stat.S_ISDIR(info.st_mode):
                        pending.append(entry.path)
                    elif stat.S_ISREG(info.st_mode):
                        total += info.st_size
        except OSError:
            continue
    return total


class RecordQuotas:
    """What the recordings of one host may still write into each record directory.

    Args:
        budgets: The host's budgets (``recording_bytes``, ``record_dir_bytes``).
    """

    def __init__(self, budgets: Budgets) -> None:
        self.budgets = budgets
        self._lock = threading.Lock()
        #: Bytes held in each directory: measured, plus what its recordings took since.
        self._used: dict[str, int] = {}
        #: Recordings being written in each directory.
        self._writers: dict[str, int] = {}

    def open(self, root: str | None, name: str, least: int) -> FileQuota:
        """The quota of a new recording *name* in the directory *root* (None: a host that allows any path).

        Blocking: the directory is measured when no recording is being written there.

        Args:
            root: The allowed directory the file will be in.
            name: The file, as the client named it (for refusals).
            least: The bytes it needs to be worth starting (its first records and one chunk).

        Raises:
            OverBudget: when the file's bound is below *least*, or the directory has less than *least* left.
        """
        budgets = self.budgets
        if budgets.recording_bytes < least:
            raise budgets.over("recording_bytes", f"a recording ({name})", least)
        if root is None:
            return FileQuota(self, None, name)
        measured = directory_bytes(root) if not self._writers.get(root) else None
        with self._lock:
            if not self._writers.get(root) and measured is not None:
                self._used[root] = measured
            held = self._used.get(root, 0)
            if held + least > budgets.record_dir_bytes:
                raise OverBudget(f"a recording ({name}) in its directory", least, budgets.record_dir_bytes,
                                 budgets.flag("record_dir_bytes"), held=held)
            self._writers[root] = self._writers.get(root, 0) + 1
        return FileQuota(self, root, name)

    def used(self, root: str) -> int:
        """The bytes held in *root* as counted now (0 for a directory no recording started in)."""
        with self._lock:
            return self._used.get(root, 0)

    def _take(self, root: str, amount: int, what: str) -> None:
        with self._lock:
            held = self._used.get(root, 0)
            if held + amount > self.budgets.record_dir_bytes:
                raise OverBudget(what, amount, self.budgets.record_dir_bytes, self.budgets.flag("record_dir_bytes"),
                                 held=held)
            self._used[root] = held + amount

    def _close(self, root: str, surplus: int) -> None:
        with self._lock:
            self._used[root] = max(0, self._used.get(root, 0) - surplus)
            self._writers[root] -= 1


class FileQuota:
    """The bytes one recording may still write: its file's bound and its directory's (made by :class:`RecordQuotas`).

    The file takes what it writes before writing it (:meth:`take`), and says what it kept when it
    ends (:meth:`close`): what it took beyond that goes back to the directory.
    """

    def __init__(self, quotas: RecordQuotas, root: str | None, name: str) -> None:
        self._quotas, self._root, self.name = quotas, root, name
        #: Bytes taken so far.
        self.taken = 0
        self._closed = False

    def take(self, amount: int) -> None:
        """Take *amount* more bytes for the file.

        Raises:
            OverBudget: naming ``--max-recording-bytes`` or ``--max-record-dir-bytes`` (nothing is taken).
        """
        budgets = self._quotas.budgets
        what = f"the recording {self.name}, with its next chunk and its summary,"
        if self.taken + amount > budgets.recording_bytes:
            raise budgets.over("recording_bytes", what, self.taken + amount)
        if self._root is not None:
            self._quotas._take(self._root, amount, what)
        self.taken += amount

    def close(self, kept: int) -> None:
        """The file ended holding *kept* bytes: the rest of what it took goes back (idempotent)."""
        if self._closed:
            return
        self._closed = True
        if self._root is not None:
            self._quotas._close(self._root, max(0, self.taken - kept))
