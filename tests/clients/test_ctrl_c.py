"""A Ctrl-C during a blocking call never leaves the client stuck.

Python raises KeyboardInterrupt wherever the main thread is, threading's locks included; one raised
after a client event's lock was taken and before it was released left that lock held, and the
client's event loop blocked for ever on it (the shell hung after Ctrl-C on a busy machine). A storm
of Ctrl-Cs on a wait shows it: with the event's own wait the thread that sets it gets stuck within
seconds; with the client's wait it never does.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

STORM = Path(__file__).with_name("_ctrl_c_storm.py")


def test_a_storm_of_ctrl_c_on_a_blocking_wait_leaves_the_event_settable() -> None:
    ran = subprocess.run([sys.executable, str(STORM)], capture_output=True, text=True, timeout=60)
    assert (ran.returncode, ran.stdout.strip()) == (0, "ok"), ran.stderr[-2000:]
