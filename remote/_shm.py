"""Zenoh's shared memory on one machine: used for the large messages only, and nothing left in /dev/shm.

Between two processes of one machine, Zenoh can pass a message through a pool of shared memory
instead of copying it through a socket.  Its default does so for every message of 3 KiB or more
from a pool of 16 MiB that each sending process creates at its first such message, and that every
process it sends to maps: with a component description of a few KiB, every host created its pool
at its first load, and the gateway and the router each grew by 16-20 MB per host.  It pays for
large messages at a high rate only (a camera's frames: the receiver spends about a third less CPU),
so aiogenomix asks Zenoh to use it from :data:`THRESHOLD` bytes, from a pool of :data:`POOL_SIZE`
bytes: a host that never sends such a message (``demo``, ``kemar``, an audio capture's chunks)
creates no pool.  A Zenoh configuration file that sets either keeps its own value, and
``transport: {shared_memory: {enabled: false}}`` turns it off (machines apart need none).

A process killed with SIGKILL leaves its pool's files in /dev/shm; Zenoh removes them when a session
that uses shared memory opens, but not one that does not.  :func:`remove_orphaned_segments` does,
at the start of every aiogenomix process that opens a Zenoh session.
"""

from __future__ import annotations

import fcntl
import logging
import os
import time
from pathlib import Path

__all__ = ["THRESHOLD", "POOL_SIZE", "SETTINGS", "remove_orphaned_segments"]

log = logging.getLogger(__name__)

#: Messages of at least this many bytes go through shared memory (an audio window's whole data, a frame).
THRESHOLD = 64 * 1024
#: The pool a process creates at its first such message, and every process it sends to maps.
POOL_SIZE = 4 * 1024 * 1024
#: The Zenoh settings, where the configuration file sets neither.
SETTINGS = {
    "transport/shared_memory/transport_optimization/message_size_threshold": str(THRESHOLD),
    "transport/shared_memory/transport_optimization/pool_size": str(POOL_SIZE),
}

#: Where Zenoh's POSIX shared memory lives.
SHM_FOLDER = Path("/dev/shm")
#: A segment is left alone for this long after its last change: its creator locks it just after making it.
_SETTLED = 10.0


def remove_orphaned_segments(folder: Path = SHM_FOLDER) -> list[str]:
    """Remove the Zenoh segments of *folder* that no process holds any more; return their names.

    A Zenoh process holds a lock on each segment it made or maps, for as long as it runs: a segment
    of ours that nobody locks, and that has not changed for ``_SETTLED`` seconds, is what a killed
    process left behind.  Another user's segments are not ours to judge.
    """
    try:
        names = sorted(entry.name for entry in os.scandir(folder) if entry.name.endswith(".zenoh"))
    except OSError:
        return []  # no such folder here (not Linux): nothing to clean
    removed = []
    for name in names:
        path = folder / name
        try:
            fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
        except OSError:
            continue  # gone meanwhile, or not ours to open
        try:
            status = os.fstat(fd)
            if status.st_uid != os.geteuid() or time.time() - status.st_mtime < _SETTLED:
                continue
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                continue  # a running process holds it
            path.unlink()
            removed.append(name)
        except OSError:
            continue
        finally:
            os.close(fd)
    if removed:
        log.info("removed %d Zenoh shared-memory segment(s) that killed processes left in %s: %s", len(removed),
                 folder, ", ".join(removed))
    return removed
