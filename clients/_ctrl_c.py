"""Blocking waits that a Ctrl-C ends cleanly, never inside one of threading's locks.

Python raises ``KeyboardInterrupt`` wherever the main thread is when SIGINT comes, threading's own
code included: between a lock's acquisition and the ``with`` block that would release it, the lock
stays held for ever.  When that lock is a client event's (a request's end, a reply's future), the
thread that sets it (the client's event loop) blocks for ever in ``set()``, and the whole client with
it: the shell hung after a Ctrl-C on a busy machine.  So while a blocking call waits in the main
thread, SIGINT only takes note, and the wait, in steps of :data:`STEP` seconds, raises
``KeyboardInterrupt`` between steps, where no lock is held.
"""

from __future__ import annotations

import concurrent.futures
import signal
import threading
import time
from collections.abc import Callable
from types import FrameType
from typing import TypeVar

__all__ = ["wait_until", "result_of", "STEP"]

T = TypeVar("T")

#: Seconds of each step of a wait: a Ctrl-C takes effect within this.
STEP = 0.05


def wait_until(wait: Callable[[float | None], bool], timeout: float | None = None) -> bool:
    """``wait(timeout)`` (an event's ``wait``), a Ctrl-C raised between its steps; whether it came true.

    Outside the main thread, or when SIGINT is not Python's to handle (ignored, or the system's
    default), this is ``wait(timeout)`` itself.

    Raises:
        KeyboardInterrupt: when a Ctrl-C came during the wait (with Python's default handler; another
            handler the program installed is called instead, once the step has ended).
    """
    if threading.current_thread() is not threading.main_thread():
        return wait(timeout)
    previous = signal.getsignal(signal.SIGINT)
    if not callable(previous):
        return wait(timeout)
    caught: list[FrameType | None] = []

    def note(signum: int, frame: FrameType | None) -> None:
        caught.append(frame)

    signal.signal(signal.SIGINT, note)
    try:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            step = STEP if deadline is None else min(STEP, max(0.0, deadline - time.monotonic()))
            ended = wait(step)
            if caught:  # even when the wait ended in the same step: the Ctrl-C came first
                signal.signal(signal.SIGINT, previous)
                previous(signal.SIGINT, caught[0])  # Python's default raises KeyboardInterrupt here
                caught.clear()
                signal.signal(signal.SIGINT, note)
            if ended:
                return True
            if deadline is not None and time.monotonic() >= deadline:
                return False
    finally:
        signal.signal(signal.SIGINT, previous)


def result_of(future: concurrent.futures.Future[T], timeout: float | None = None) -> T:
    """``future.result(timeout)``, a Ctrl-C raised between the steps of its wait (see :func:`wait_until`).

    Raises:
        TimeoutError: when *timeout* passes first.
        KeyboardInterrupt: when a Ctrl-C came during the wait.
    """
    def ended(step: float | None) -> bool:
        return bool(concurrent.futures.wait((future,), step).done)

    if not wait_until(ended, timeout):
        raise TimeoutError
    return future.result()
