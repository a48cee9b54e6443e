"""Stop signals of the gateway process: SIGINT and SIGTERM stop it from its first line to its last.

Before the event loop runs (imports, argument parsing) a stop signal raises
:class:`StopSignal`, as SIGINT raises ``KeyboardInterrupt`` in any Python
program; SIGTERM would otherwise kill the process without a word.  Once the
loop runs, the loop's own handlers take over and the gateway stops in order
(see ``_run``).
"""

from __future__ import annotations

import signal
from types import FrameType

__all__ = ["STOP_SIGNALS", "StopSignal", "raise_on_stop_signals", "ignore_stop_signals", "signal_name"]

#: The signals that stop the gateway: Ctrl-C, and what ``kill``, systemd and ``docker stop`` send.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def signal_name(signum: int) -> str:
    """``SIGINT`` for 2 (the name users know from ``kill -l``)."""
    return signal.Signals(signum).name


class StopSignal(KeyboardInterrupt):
    """A stop signal arrived before the gateway's event loop ran.

    A subclass of ``KeyboardInterrupt`` so that it crosses library code (and an
    event loop that is starting) the way Ctrl-C always does.

    Attributes:
        signum: The signal number.
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signal_name(signum))
        self.signum = signum


def _raise_stop(signum: int, frame: FrameType | None) -> None:
    raise StopSignal(signum)


def raise_on_stop_signals() -> None:
    """Make SIGINT and SIGTERM raise :class:`StopSignal` in the main thread (until an event loop takes them)."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, _raise_stop)


def ignore_stop_signals() -> None:
    """Ignore SIGINT and SIGTERM: the gateway has stopped and the interpreter is only exiting."""
    for signum in STOP_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)
