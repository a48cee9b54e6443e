"""``aiogenomix-shell`` through a pseudo-terminal: complete, call, see results, errors in one line, Ctrl-C."""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import json
import os
import re
import signal
import socket
import sys
import threading
from collections.abc import Iterator
from typing import Any

import pytest

from aiogenomix.components.core import ComponentHost, Component, ScaledClock, function
from aiogenomix.components.demo import Demo
from aiogenomix.gateway import GatewayConfig, serve

pexpect = pytest.importorskip("pexpect")
pytest.importorskip("IPython")
#: The prompt as IPython colours it: "In [", colours, the number, colours, "]".
PROMPT = r"In \[(?:\x1b\[[0-9;]*m)*%d(?:\x1b\[[0-9;]*m)*\]"
#: The session the shell joins, so that the test hears its events as the gateway sends them.
SESSION = "shelltest"
#: Terminal escapes (colours, cursor moves, modes).
ESCAPES = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]|\x1b[=>]")


def shown(text: str) -> str:
    """A pattern of *text* as the terminal shows it: redrawn in pieces, with escapes between any two characters."""
    return r"(?:\x1b\[[0-9;?]*[A-Za-z])*".join(re.escape(c) for c in text)


class Slow(Component, name="slow"):
    """A function that takes as long as the test wants: genom cannot abort a function."""

    async def on_start(self) -> None:
        self.released = asyncio.Event()

    @function
    async def Settle(self) -> None:
        """Return once Release is called."""
        await self.released.wait()

    @function
    def Release(self) -> None:
        """Let Settle return."""
        self.released.set()


@contextlib.contextmanager
def gateway_in_thread() -> Iterator[str]:
    """A gateway hosting demo and slow on an event loop of its own thread (the shell is another process)."""
    started: concurrent.futures.Future[tuple[str, asyncio.AbstractEventLoop, asyncio.Event]] = (
        concurrent.futures.Future())

    async def main() -> None:
        config = GatewayConfig.of(port=0, time_scale=20.0, audio_socket_port=0, preload=["demo", "slow"])
        # A short grace: Settle's send is answered "sent" (and announced) 0.1 s after it starts.
        host = ComponentHost(clock=ScaledClock(20.0), settings=config.host_settings(),
                             factories={"demo": Demo, "slow": Slow}, function_grace=0.1)
        try:
            async with host, serve(config, host) as url:
                stop = asyncio.Event()
                started.set_result((url, asyncio.get_running_loop(), stop))
                await stop.wait()
        except BaseException as exc:
            if not started.done():
                started.set_exception(exc)
            raise

    thread = threading.Thread(target=asyncio.run, args=(main(),), name="test-gateway")
    thread.start()
    try:
        url, loop, stop = started.result(timeout=60)
        yield url
        loop.call_soon_threadsafe(stop.set)
    finally:
        thread.join(timeout=60)


class SessionEvents:
    """The ``request`` events of the shell's session, read from the gateway as genomix clients read them."""

    def __init__(self, url: str) -> None:
        host, port = url.removeprefix("http://").rsplit(":", 1)
        self._socket = socket.create_connection((host, int(port)), timeout=30)
        self._socket.sendall(f"GET /session/listen?s={SESSION} HTTP/1.1\r\nHost: {host}\r\n\r\n".encode())
        self._buffer = b""
        assert self._until(b"\r\n\r\n").startswith(b"HTTP/1.1 200")

    def _until(self, end: bytes) -> bytes:
        while end not in self._buffer:
            received = self._socket.recv(65536)
            assert received, "the event stream ended"
            self._buffer += received
        block, self._buffer = self._buffer.split(end, 1)
        return block

    def next_request(self, request_id: str | None = None) -> dict[str, Any]:
        """The status object of the next ``request`` event (of *request_id*, when given)."""
        while True:
            block = self._until(b"\n\n")
            if block.startswith(b"event: request\n"):
                status: dict[str, Any] = json.loads(block.split(b"data: ", 1)[1])
                if request_id in (None, status["id"]):
                    return status

    def close(self) -> None:
        self._socket.close()


@pytest.fixture
def gateway() -> Iterator[str]:
    with gateway_in_thread() as url:
        yield url


@pytest.fixture
def events(gateway: str) -> Iterator[SessionEvents]:
    # Listening first starts the session; the shell joins it with --session.
    stream = SessionEvents(gateway)
    yield stream
    stream.close()


@contextlib.contextmanager
def running_shell(gateway: str, tmp_path: Any, sigint: Any = signal.SIG_DFL) -> Iterator[Any]:
    """The shell in a terminal of its own, at its first prompt; it exits by ``exit`` at the end.

    *sigint* is what the shell inherits for SIGINT: the default, as from an interactive terminal,
    whatever the test runner's own (a runner started in the background by a script ignores it).
    """
    # A private IPython directory (no history or profile of the user's); no cursor-position queries.
    # PAGER=cat: help (Service?) prints in place, whatever the test process's terminal size.
    # PYTHONFAULTHANDLER: a shell that hangs shows its threads when the teardown aborts it.
    env = dict(os.environ, IPYTHONDIR=str(tmp_path), TERM="xterm", PROMPT_TOOLKIT_NO_CPR="1", PAGER="cat",
               PYTHONFAULTHANDLER="1")
    child = pexpect.spawn(sys.executable,
                          ["-m", "aiogenomix.clients.shell", gateway.removeprefix("http://"), "--session", SESSION],
                          env=env, encoding="utf-8", timeout=30, dimensions=(40, 160),
                          preexec_fn=lambda: signal.signal(signal.SIGINT, sigint))
    log = open(tmp_path / "terminal.log", "w")  # what the terminal showed, for a failure's diagnosis
    child.logfile_read = log
    try:
        child.expect(r"Modules: demo, slow")
        child.expect(PROMPT % 1)
        yield child
        child.send("exit\r")
        try:
            child.expect(pexpect.EOF)
        except pexpect.TIMEOUT:
            child.kill(signal.SIGABRT)
            child.expect(pexpect.EOF, timeout=10)
            raise AssertionError("the shell hung; its threads:\n" + child.before[-6000:]) from None
    finally:
        child.close(force=True)
        log.close()
    assert child.exitstatus == 0 or child.signalstatus is None


@pytest.fixture
def shell(gateway: str, events: SessionEvents, tmp_path: Any) -> Iterator[Any]:
    with running_shell(gateway, tmp_path) as child:
        yield child


def printed_until_prompt(child: Any, number: int) -> list[str]:
    """The lines the terminal shows below a one-line command, above prompt *number*; no escapes, no blank lines.

    The shell writes through prompt_toolkit's stdout proxy, whose thread may write a line after the
    next prompt is drawn: it then erases that prompt, writes the line and draws the prompt again, so
    the screen shows the line above it.  Read on until a drawing of prompt *number* follows what the
    command printed (a command whose output never comes fails at pexpect's timeout).
    (The previous prompt was matched: what comes before this one starts with the rest of its line.)
    """
    child.expect(PROMPT % number)
    _, *lines = ESCAPES.sub("", child.before).splitlines()
    printed = _printed(lines)
    while not printed:
        child.expect(PROMPT % number)
        # After a drawing of the prompt: the rest of the prompt (": "), then what was written above it.
        printed = _printed(ESCAPES.sub("", child.before).removeprefix(":").splitlines())
    return printed


def _printed(lines: list[str]) -> list[str]:
    # The prompt line may be drawn again while the command runs (on a busy machine, as it is typed):
    # those redraws are not what the command printed.
    return [line.strip() for line in lines if line.strip() and not re.match(r"\s*In \[\d+\]:", line)]


def test_complete_call_and_see_the_result(shell: Any) -> None:
    shell.send("demo.GotoPos\t")                        # a service name completes
    shell.expect(shown("GotoPosition"))
    shell.send("(pos\t")                                # so does a keyword argument
    shell.expect(shown("posRef="))
    shell.send("0.5, ack=True)\r")                      # returns at once with the request...
    # At once: its status is "sent", or "done" already when the machine is slow to print it.
    shell.expect(r"<request demo::0 GotoPosition (sent|done)>")
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


def test_a_component_error_is_one_line_and_tb_shows_it_in_full(shell: Any) -> None:
    shell.send("demo.GotoPosition(2)\r")
    assert printed_until_prompt(shell, 2) == [
        "TOO_FAR_AWAY: overshoot=1.0 (GotoPosition, request demo::0)   (%tb shows the traceback)"]
    shell.send("demo.GotoPosition(posRef=-3)\r")        # the hint comes once
    (line,) = printed_until_prompt(shell, 3)
    # The client cleans the first request once it has its final event: its number may be reused.
    assert re.fullmatch(r"TOO_FAR_AWAY: overshoot=2\.0 \(GotoPosition, request demo::[01]\)", line)
    shell.send("%tb\r")                                 # the traceback, on demand
    shell.expect("Traceback")
    shell.expect("TOO_FAR_AWAY")
    shell.expect(PROMPT % 4)


def test_ctrl_c_in_a_blocking_activity_aborts_it_on_the_gateway(shell: Any, events: SessionEvents) -> None:
    shell.send("demo.Monitor(0.9)\r")                   # the robot stands at 0: it never gets there
    assert events.next_request() == {"id": "demo::0", "status": "sent"}
    shell.sendintr()
    assert printed_until_prompt(shell, 2) == [
        "^CCtrl-C: asked the gateway to abort Monitor (demo::0): interrupted by abort   (%tb shows the traceback)"]
    assert events.next_request() == {"id": "demo::0", "status": "error",
                                     "exception": {"ex": "::genom::interrupted", "detail": {"by": "abort"}}}


def test_ctrl_c_works_in_a_shell_started_with_sigint_ignored(gateway: str, events: SessionEvents,
                                                             tmp_path: Any) -> None:
    # As a script's background job (``cmd &`` without job control, nohup, some CI runners) starts it.
    with running_shell(gateway, tmp_path, sigint=signal.SIG_IGN) as shell:
        shell.send("demo.Monitor(0.9)\r")
        assert events.next_request() == {"id": "demo::0", "status": "sent"}
        shell.sendintr()
        assert printed_until_prompt(shell, 2) == [
            "^CCtrl-C: asked the gateway to abort Monitor (demo::0): interrupted by abort   (%tb shows the traceback)"]


def test_ctrl_c_in_a_blocking_function_lets_it_run_to_its_end(shell: Any, events: SessionEvents) -> None:
    shell.send("slow.Settle()\r")
    assert events.next_request() == {"id": "slow::0", "status": "sent"}
    shell.sendintr()
    assert printed_until_prompt(shell, 2) == [
        "^CCtrl-C: Settle (slow::0) is a function, which genom cannot abort: it runs to its end, printed here "
        "when it comes   (%tb shows the traceback)"]
    shell.send("slow.Release()\r")
    assert events.next_request("slow::0") == {"id": "slow::0", "status": "done", "output": {}}
    shell.expect(r"\[slow::0 Settle done\]")            # its end, printed when it came
    shell.expect(PROMPT % 3)
    shell.send("requests()\r")                          # and listed with the ack=True requests
    shell.expect(r"slow::0\s+Settle\s+done")


@pytest.mark.parametrize(("call", "line"), [
    ('demo.GotoPosition(posRef="x")',
     "TypeError: posRef: expected a number (double), got 'x' (GotoPosition: nothing was sent)"),
    ("demo.GotoPosition(posRe=1)",
     "TypeError: GotoPosition(posRef: float = 0.0): got an unexpected keyword argument 'posRe' "
     "(GotoPosition: nothing was sent)"),
    ("demo.GotoPosition(1, 2)",
     "TypeError: GotoPosition(posRef: float = 0.0): too many positional arguments (GotoPosition: nothing was sent)"),
    ('demo.Mobile(nme="x")', "TypeError: demo.Mobile() got an unexpected keyword argument 'nme'"),
    ('load("nosuchthing")', None),
])
def test_a_mistake_the_client_refuses_is_one_line_and_sends_nothing(
        shell: Any, events: SessionEvents, call: str, line: str | None) -> None:
    shell.send(call + "\r")
    printed = printed_until_prompt(shell, 2)
    assert len(printed) == 1, printed
    if line is not None:
        # Python 3.13 adds its own hint to a misspelt keyword ("Did you mean 'name'?"): kept as Python says it.
        hint = r"(\. Did you mean '\w+'\?)?"
        assert re.fullmatch(re.escape(line) + hint + re.escape("   (%tb shows the traceback)"), printed[0]), printed
    else:                                               # the gateway's refusal, as before
        assert printed[0].startswith("no_such_module: "), printed
    # Nothing reached the robot: the next request of the session is the first one.
    shell.send("demo.GotoPosition(0.1)\r")
    assert events.next_request() == {"id": "demo::0", "status": "sent"}
    shell.expect(PROMPT % 3)
    shell.send("%tb\r")                                 # the whole traceback, on demand
    shell.expect("Traceback")
    shell.expect(PROMPT % 4)


def test_an_error_of_the_users_own_code_keeps_ipythons_traceback(shell: Any) -> None:
    shell.send("def half(x): return x / 0\r")
    shell.expect(PROMPT % 2)
    shell.send("half(demo.Mobile().position)\r")
    printed = printed_until_prompt(shell, 3)
    assert printed[-1] == "ZeroDivisionError: float division by zero"
    assert any("return x / 0" in line for line in printed) and len(printed) > 1
