"""Log lines a client can cause, rate-limited: a client must not be able to fill the disk or hide real faults.

Each kind of line (its message template, and for a fault the place it comes from) may be written
:data:`BURST` times a :data:`PERIOD`; beyond that the lines are counted, and the next one written says
how many were left out.  A traceback is written once per place it comes from (exception type, file
and line), always, however many lines of its template came before: a fault never seen is never left
out.  The next ones of that place are one line.  So a loop of bad requests costs the log a few lines
a minute, however fast it runs, and hides no other fault.
"""

from __future__ import annotations

import logging
import time
import traceback
from collections.abc import Callable

__all__ = ["ThrottledLog", "BURST", "PERIOD"]

#: Lines of one kind written in a row before the limit applies.
BURST = 5
#: Seconds over which :data:`BURST` lines of one kind are allowed.
PERIOD = 60.0


class _Kind:
    __slots__ = ("tokens", "last", "left_out")

    def __init__(self, now: float) -> None:
        self.tokens, self.last, self.left_out = float(BURST), now, 0


class ThrottledLog:
    """A logger's lines, each kind at most ``burst`` times a ``period`` (a token bucket per template and place).

    Args:
        logger: Where the lines go.
        burst: Lines of one kind written in a row.
        period: Seconds in which ``burst`` lines of one kind are allowed again.
        clock: Monotonic seconds (for tests).
    """

    def __init__(self, logger: logging.Logger, *, burst: int = BURST, period: float = PERIOD,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.logger, self.burst, self.period, self._clock = logger, burst, period, clock
        self._kinds: dict[tuple[str, tuple[str, str, int] | None], _Kind] = {}
        self._traced: set[tuple[str, str, int]] = set()

    def _allowed(self, key: tuple[str, tuple[str, str, int] | None], *, new: bool = False) -> tuple[bool, int]:
        """Whether a line of kind *key* may be written now, and how many were left out before it."""
        now = self._clock()
        kind = self._kinds.get(key)
        if kind is None:
            kind = self._kinds[key] = _Kind(now)
        kind.tokens = min(float(self.burst), kind.tokens + (now - kind.last) * self.burst / self.period)
        kind.last = now
        if kind.tokens < 1.0 and not new:
            kind.left_out += 1
            return False, 0
        kind.tokens = max(0.0, kind.tokens - 1.0)
        left_out, kind.left_out = kind.left_out, 0
        return True, left_out

    def log(self, level: int, msg: str, *args: object, exc: BaseException | None = None, stacklevel: int = 1) -> bool:
        """Write one line (``msg % args``) unless its kind passed its limit; return whether it was written.

        With *exc*, the first line from each place *exc* comes from carries its traceback and is
        always written; the next ones name the exception in one line, limited per template and place.
        """
        if not self.logger.isEnabledFor(level):
            return False
        place = None if exc is None else _place(exc)
        new = place is not None and place not in self._traced
        allowed, left_out = self._allowed((msg, place), new=new)
        if not allowed:
            return False
        if left_out:
            msg += f" ({left_out} more like this left out of the log)"
        exc_info: BaseException | None = None
        if new:
            assert place is not None
            self._traced.add(place)
            exc_info = exc
        # The record names the caller's line, not this module's.
        self.logger.log(level, msg, *args, exc_info=exc_info, stacklevel=stacklevel + 1)
        return True

    def info(self, msg: str, *args: object) -> bool:
        """An INFO line (see :meth:`log`)."""
        return self.log(logging.INFO, msg, *args, stacklevel=2)

    def warning(self, msg: str, *args: object) -> bool:
        """A WARNING line (see :meth:`log`)."""
        return self.log(logging.WARNING, msg, *args, stacklevel=2)

    def error(self, msg: str, *args: object, exc: BaseException | None = None) -> bool:
        """An ERROR line (see :meth:`log`)."""
        return self.log(logging.ERROR, msg, *args, exc=exc, stacklevel=2)


def _place(exc: BaseException) -> tuple[str, str, int]:
    """Where *exc* was raised: its type, and the file and line of its innermost frame."""
    frames = traceback.extract_tb(exc.__traceback__)
    last = frames[-1] if frames else None
    return type(exc).__qualname__, last.filename if last else "", (last.lineno or 0) if last else 0
