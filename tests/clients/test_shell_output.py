"""The shell's output: what a cell prints is on the terminal before the next prompt; other threads' goes above it.

prompt_toolkit's proxy wrote a cell's ``%tb`` traceback from a thread of its own, after the next prompt
was drawn on a busy machine, and left that prompt above the traceback (a flake of the shell's pty test,
and what a user saw). The cell's writes now reach the terminal stream before ``write`` returns.
"""

from __future__ import annotations

import io
import threading
from typing import Any, cast

import pytest

pytest.importorskip("prompt_toolkit")

from aiogenomix.clients._shell_output import CellOutput  # noqa: E402


class Proxy:
    """What the shell's proxy was handed, in order (prompt_toolkit's writes it above the prompt)."""

    def __init__(self) -> None:
        self.written: list[str] = []
        self.flushes = 0

    def write(self, text: str) -> int:
        self.written.append(text)
        return len(text)

    def flush(self) -> None:
        self.flushes += 1


def test_a_cells_output_is_on_the_terminal_when_its_write_returns() -> None:
    terminal, proxy = io.StringIO(), Proxy()
    out = CellOutput(terminal, cast(Any, proxy))  # the proxy's two methods, recorded
    print("Traceback (most recent call last):", file=out)
    assert terminal.getvalue() == "Traceback (most recent call last):\n"
    assert proxy.written == []


def test_another_threads_output_goes_above_the_prompt() -> None:
    terminal, proxy = io.StringIO(), Proxy()
    out = CellOutput(terminal, cast(Any, proxy))
    callback = threading.Thread(target=lambda: print("[demo::0 GotoPosition done]", file=out))
    callback.start()
    callback.join()
    assert terminal.getvalue() == ""
    assert "".join(proxy.written) == "[demo::0 GotoPosition done]\n"


def test_it_answers_for_the_terminal_stream() -> None:
    terminal = io.StringIO()
    out = CellOutput(terminal, cast(Any, Proxy()))
    assert (out.isatty(), out.encoding) == (terminal.isatty(), terminal.encoding)
