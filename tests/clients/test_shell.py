"""``aiogenomix-shell`` through a pseudo-terminal (issue 13): complete, call, see the result and the events."""

from __future__ import annotations

import os
import re
import sys
from collections.abc import Iterator
from typing import Any

import pytest

from aiogenomix.gateway import GatewayConfig, serve_in_thread

pexpect = pytest.importorskip("pexpect")
pytest.importorskip("IPython")
#: The prompt as IPython colours it: "In [", escapes, the number, escapes, "]".
PROMPT = r"In \[\S{0,40}%d\S{0,40}\]"


def shown(text: str) -> str:
    """A pattern of *text* as the terminal shows it: redrawn in pieces, with escapes between any two characters."""
    return r"(?:\x1b\[[0-9;?]*[A-Za-z])*".join(re.escape(c) for c in text)


@pytest.fixture
def shell(tmp_path: Any) -> Iterator[Any]:
    config = GatewayConfig(port=0, time_scale=20.0, audio_socket_port=0, preload=["demo"])
    with serve_in_thread(config) as url:
        # A private IPython directory (no history or profile of the user's); no cursor-position queries.
        # PAGER=cat: help (Service?) prints in place, whatever the test process's terminal size.
        env = dict(os.environ, IPYTHONDIR=str(tmp_path), TERM="xterm", PROMPT_TOOLKIT_NO_CPR="1", PAGER="cat")
        child = pexpect.spawn(sys.executable, ["-m", "aiogenomix.clients.shell", url.removeprefix("http://")],
                              env=env, encoding="utf-8", timeout=30, dimensions=(40, 160))
        log = open(tmp_path / "terminal.log", "w")  # what the terminal showed, for a failure's diagnosis
        child.logfile_read = log
        try:
            child.expect(r"Modules: demo")
            child.expect(PROMPT % 1)
            yield child
            child.send("exit\r")
            child.expect(pexpect.EOF)
        finally:
            child.close(force=True)
            log.close()
    assert child.exitstatus == 0 or child.signalstatus is None


def test_complete_call_and_see_the_result(shell: Any) -> None:
    shell.send("demo.GotoPos\t")                        # a service name completes
    shell.expect(shown("GotoPosition"))
    shell.send("(pos\t")                                # so does a keyword argument
    shell.expect(shown("posRef="))
    shell.send("0.5, ack=True)\r")                      # returns at once with the request...
    shell.expect("<request demo::0 GotoPosition sent>")
    shell.expect(r"\[demo::0 GotoPosition done\]")      # ...whose end is printed when it comes
    shell.expect(PROMPT % 2)                            # and the prompt is drawn again below it
    shell.send('demo.SetSpeed(speedRef="F\t')          # enum values complete
    shell.expect(shown('"FAST"'))
    shell.send(")\r")
    shell.expect(PROMPT % 3)
    shell.send("demo.GetSpeed()\r")
    shell.expect("::demo::FAST")
    shell.send("requests()\r")
    shell.expect(r"demo::0\s+GotoPosition\s+done")
    shell.send("demo.GotoPosition?\r")                  # the generated documentation
    shell.expect("Move the robot to an absolute position")
    shell.expect("posRef")
