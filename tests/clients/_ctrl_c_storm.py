"""A storm of Ctrl-Cs on a blocking wait while another thread keeps setting the awaited event.

Run as a program by ``test_ctrl_c.py``: prints ``ok`` and exits 0 when the setting thread went on for
3 s, prints ``stuck`` and exits 1 when it could not set the event for 2 s (a Ctrl-C left the event's
lock held).  With ``plain``, the wait is the event's own ``wait``, as the client's was.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from types import FrameType

from aiogenomix.clients._ctrl_c import wait_until

awaited = threading.Event()
waiting = threading.Event()
sets = 0


def keep_setting() -> None:
    global sets
    while True:
        awaited.set()
        sets += 1
        awaited.clear()


def interrupt_each_wait() -> None:
    while True:
        waiting.wait()
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.0005)             # pacing, not waiting: a Ctrl-C each half millisecond of a wait


def watch() -> None:
    last, since, began = -1, time.monotonic(), time.monotonic()
    while True:
        time.sleep(0.05)               # the watchdog's period: it measures progress, it awaits nothing
        if sets != last:
            last, since = sets, time.monotonic()
        elif time.monotonic() - since > 2:
            print("stuck", flush=True)
            os._exit(1)
        if time.monotonic() - began > 3:
            print("ok", flush=True)
            os._exit(0)


def wait(timeout: float | None) -> bool:
    waiting.set()                      # the storm hits only while the wait is on
    try:
        return awaited.wait(timeout)
    finally:
        waiting.clear()


armed = False


def interrupt(signum: int, frame: FrameType | None) -> None:
    """Python's default handler while a wait runs; outside one, a late Ctrl-C would end the program itself."""
    if armed:
        raise KeyboardInterrupt


def main() -> None:
    global armed
    plain = sys.argv[1:] == ["plain"]
    signal.signal(signal.SIGINT, interrupt)
    for target in (keep_setting, interrupt_each_wait, watch):
        threading.Thread(target=target, daemon=True).start()
    while True:
        try:
            armed = True
            wait(0.001) if plain else wait_until(wait, 0.001)
        except KeyboardInterrupt:
            pass
        finally:
            armed = False


if __name__ == "__main__":
    main()
