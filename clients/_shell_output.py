"""The shell's standard output: a cell's own writes at once, other threads' above the prompt.

prompt_toolkit's ``patch_stdout`` hands every write to a thread of its own, which writes it above the
prompt when a prompt is up, and straight out otherwise. A cell's output (``%tb``'s traceback, a
``print``) then races the next prompt: on a busy machine that thread found no prompt up, wrote, and
the prompt drawn meanwhile was left above the text, with nothing below it until a key was pressed.
What the main thread writes while no prompt is up is the cell's, and belongs before the next prompt:
it goes straight to the terminal, in order. Everything else (the ends of ``ack=True`` requests,
callbacks that print, a prompt's own thread) goes through the proxy, above the prompt.
"""

from __future__ import annotations

import threading
from typing import Any, TextIO

from prompt_toolkit.application.current import get_app_or_none
from prompt_toolkit.patch_stdout import StdoutProxy

__all__ = ["CellOutput"]


class CellOutput:
    """A text stream that writes the cell's output directly and everything else through *proxy*.

    Args:
        direct: The terminal's stream (the ``sys.stdout`` or ``sys.stderr`` that was).
        proxy: prompt_toolkit's proxy, which writes above a prompt that is up.

    Any other attribute (``encoding``, ``isatty``, ``fileno``) is the terminal stream's.
    """

    def __init__(self, direct: TextIO, proxy: StdoutProxy) -> None:
        self.direct = direct
        self.proxy = proxy

    def _from_the_cell(self) -> bool:
        """Whether the caller is the running cell: the main thread, with no prompt up."""
        return threading.current_thread() is threading.main_thread() and get_app_or_none() is None

    def write(self, text: str) -> int:
        if self._from_the_cell():
            self.proxy.flush()  # a partial line another thread began goes first, as it was written first
            written = self.direct.write(text)
            self.direct.flush()
            return written
        return self.proxy.write(text)

    def flush(self) -> None:
        if self._from_the_cell():
            self.direct.flush()
        else:
            self.proxy.flush()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.direct, name)
