"""The README as a first-time user follows it: its sections in order, against a fresh gateway, answering as shown.

Every line of the README's ``sh`` blocks runs, in order, in one bash (variables such as ``$G`` carry over, as
in the user's terminal); every ``python`` block runs as a script at its place. A ``# -> TEXT`` line under a
command shows what it prints:

* JSON is compared structurally: ``...`` stands for any value, or, as an object's last member or an array's
  last element, for any others; a number holds at the precision it is shown with (``1.0`` holds 0.996).
* Other text is compared with runs of blanks made one, ``...`` standing for anything.

A command whose output the README does not show must still not answer a genomix error. A block preceded by
``<!-- not replayed: REASON -->`` is left out (the gateway's own start, a second machine). The gateway is
``python -m aiogenomix.gateway`` on free ports (substituted for 8080 and 8081) and a faster clock: answers
are the same, sooner; its ``--record-dir`` is the directory the README's lines run in, as the README says.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import os
import re
import signal
import socket
import sys
from collections.abc import AsyncIterator
from decimal import Decimal
from pathlib import Path
from typing import Any

import pytest

from ..conftest import TEST_CAN_TIMEOUT

ROOT = Path(__file__).resolve().parents[2]
#: Runtime seconds per real second: homing the head and driving the PR2 take seconds, not tens. Not more:
#: the recording step must lose no audio frame, and a capture's window of 1 s is 1/TIME_SCALE s of real time
#: (at 10, 100 ms: one suite run of some twenty lost a chunk there); the replay takes about a minute either way.
TIME_SCALE = 3
#: What a step may take at most, on a busy machine (installing the TypeScript generator, running a notebook).
STEP_TIMEOUT = 180.0

#: The replay is heavy (a gateway, the virtual robots, Python processes): it runs once, on the default Python.
heavy = pytest.mark.skipif(os.environ.get("AIOGENOMIX_HEAVY") == "0",
                           reason="the README replay runs once, on the default Python (AIOGENOMIX_HEAVY=0)")


@dataclasses.dataclass
class Step:
    """A command line of a ``sh`` block, or a whole ``python`` block, with the output the README shows."""

    language: str
    code: str
    line: int
    shown: list[str] = dataclasses.field(default_factory=list)

    def __str__(self) -> str:
        return f"README.md:{self.line}: {self.code.splitlines()[0]}"


def readme_steps(text: str) -> list[Step]:
    """The steps of the README's replayed blocks, in order."""
    lines = text.splitlines()
    steps: list[Step] = []
    index = 0
    while index < len(lines):
        fence = re.fullmatch(r"```(\w*)", lines[index])
        if fence is None:
            index += 1
            continue
        end = lines.index("```", index + 1)
        body, first = lines[index + 1:end], index + 2
        if not (index and lines[index - 1].startswith("<!-- not replayed:")):
            if fence[1] == "sh":
                steps += _sh_steps(body, first)
            elif fence[1] == "python":
                shown = [line.strip().removeprefix("# -> ") for line in body if line.strip().startswith("# -> ")]
                steps.append(Step("python", "\n".join(body), first, shown))
        index = end + 1
    return steps


def _sh_steps(body: list[str], first: int) -> list[Step]:
    steps: list[Step] = []
    for number, line in enumerate(body, first):
        if line.startswith("# -> "):
            steps[-1].shown.append(line.removeprefix("# -> "))
        elif line.strip() and not line.startswith("#"):
            steps.append(Step("sh", line, number))
    return steps


# -- what the README shows, against what was printed ----------------------------------------------------------

_ANY, _MORE = "\u2026any", "\u2026more"


def _shown_json(text: str) -> Any:
    """The JSON a ``# ->`` line shows, its ``...`` made markers; raises ValueError when it is not JSON."""
    text = re.sub(r"(?<=[{,])\.\.\.(?=})", f'"{_MORE}":0', text)
    text = re.sub(r"(?<=[\[,])\.\.\.(?=])", f'"{_MORE}"', text)
    return json.loads(text.replace("...", f'"{_ANY}"'), parse_float=Decimal)


def _agrees(shown: Any, got: Any) -> bool:
    if shown == _ANY:
        return True
    if isinstance(shown, dict):
        members = {k: v for k, v in shown.items() if k != _MORE}
        return (isinstance(got, dict) and (_MORE in shown or members.keys() == got.keys())
                and all(k in got and _agrees(v, got[k]) for k, v in members.items()))
    if isinstance(shown, list):
        more = bool(shown) and shown[-1] == _MORE
        items = shown[:-1] if more else shown
        return (isinstance(got, list) and (len(got) >= len(items) if more else len(got) == len(items))
                and all(_agrees(a, b) for a, b in zip(items, got[:len(items)], strict=True)))
    if isinstance(got, bool) or isinstance(shown, bool):
        return shown is got
    if isinstance(shown, Decimal):  # half a unit of the last digit shown
        exponent = shown.as_tuple().exponent
        assert isinstance(exponent, int)
        return isinstance(got, int | float) and abs(Decimal(str(got)) - shown) <= Decimal(5).scaleb(exponent - 1)
    return type(shown) is type(got) and shown == got


def agrees(shown: str, printed: str) -> bool:
    """Whether *printed* is what the README's ``# ->`` lines (joined) show."""
    try:
        expected = _shown_json(shown)
    except ValueError:
        pattern = ".*".join(re.escape(part) for part in " ".join(shown.split()).split("..."))
        return re.fullmatch(pattern, " ".join(printed.split()), re.S) is not None
    try:
        return _agrees(expected, json.loads(printed))
    except ValueError:
        return False


def a_genomix_error(printed: str) -> bool:
    """Whether *printed* is an error reply or a request that ended in error."""
    try:
        reply = json.loads(printed)
    except ValueError:
        return False
    return isinstance(reply, dict) and ("ex" in reply or reply.get("status") == "error")


def test_the_conventions_read_the_readme_as_meant() -> None:
    assert agrees('{"Mobile":{"position":0.5,"speed":0.0}}', '{"Mobile":{"position":0.5,"speed":0.0}}')
    assert agrees('{"x":1.0,"w":0.3,...}', '{"x":0.9957,"w":0.29982,"vx":0.01}')
    assert not agrees('{"x":1.0,"w":0.3}', '{"x":0.9957,"w":0.29982,"vx":0.01}')   # a member not shown
    assert not agrees('{"x":1.0}', '{"x":1.06}')                                     # beyond the precision shown
    assert not agrees('{"limited":0}', '{"limited":1}')
    assert agrees('{"t":{...},"a":[1,...]}', '{"t":{"s":1},"a":[1,2,3]}')
    assert agrees("4410 ... ... 0", "        4410      302086      306496           0\n")
    assert not agrees("demo", "demo2")
    assert a_genomix_error('{"id":"bass::0","status":"error","exception":{"ex":"::bass::e_socket"}}')
    assert a_genomix_error('{"ex":"::genomix::no_such_module","message":"..."}')
    assert not a_genomix_error('{"id":"demo::0","status":"sent"}')
    steps = readme_steps((ROOT / "README.md").read_text())
    assert steps[0].code == "G=http://127.0.0.1:8080"          # the gateway's own start is not replayed
    assert not any("zenoh" in step.code for step in steps)      # nor the second machine


# -- running them ---------------------------------------------------------------------------------------------


def free_port() -> int:
    """A port free now (the dedicated socket needs a number the README's lines can be given)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.fixture
async def gateway(tmp_path: Path) -> AsyncIterator[tuple[int, int]]:
    """A fresh gateway in a process of its own; yields its HTTP and dedicated-socket ports."""
    socket_port = free_port()
    with open(tmp_path / "gateway.log", "wb") as log:
        process = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "aiogenomix.gateway", "--port", "0", "--audio-socket-port", str(socket_port),
            "--time-scale", str(TIME_SCALE), "--record-dir", str(tmp_path),
            # The drive's reply timeout is real time (decision 8); on a loaded machine the in-process
            # simulated drive may be starved past the default 0.5 s, which is not what this test reads.
            "--can-timeout", str(TEST_CAN_TIMEOUT), stdout=asyncio.subprocess.PIPE,
            stderr=log)
    try:
        assert process.stdout is not None
        line = (await asyncio.wait_for(process.stdout.readline(), 120)).decode()
        listening = re.match(r"aiogenomix gateway listening on http://127\.0\.0\.1:(\d+)", line)
        assert listening, line
        yield int(listening[1]), socket_port
        process.send_signal(signal.SIGINT)
        assert await asyncio.wait_for(process.wait(), 30) == 0
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()


class Terminal:
    """One bash running the README's lines in order; each line's output (background jobs' too) in a file."""

    def __init__(self, process: asyncio.subprocess.Process, folder: Path) -> None:
        self._process = process
        self._folder = folder
        self._count = 0

    @classmethod
    async def open(cls, folder: Path) -> Terminal:
        process = await asyncio.create_subprocess_exec(
            "bash", "--noprofile", "--norc", cwd=folder, stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE, start_new_session=True)
        return cls(process, folder)

    async def run(self, line: str) -> tuple[int, str, str]:
        """Run one line; its exit status, and what it printed on stdout and on stderr."""
        self._count += 1
        out, err = self._folder / f"{self._count}.out", self._folder / f"{self._count}.err"
        assert self._process.stdin is not None and self._process.stdout is not None
        self._process.stdin.write(f"{{\n{line}\n}} >{out} 2>{err}\necho \"replayed $?\"\n".encode())
        await self._process.stdin.drain()
        done = (await asyncio.wait_for(self._process.stdout.readline(), STEP_TIMEOUT)).decode()
        assert done.startswith("replayed "), done
        return int(done.split()[1]), out.read_text(), err.read_text()

    async def close(self) -> None:
        # The bash and what it left in the background (a listen stream after a failure): its session only.
        try:
            os.killpg(self._process.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        await self._process.wait()


@heavy
# Every section in turn, the generated clients (npm installs the TypeScript one) and a notebook included.
@pytest.mark.timeout(900)
async def test_the_readme_answers_as_written(gateway: tuple[int, int], tmp_path: Path) -> None:
    http_port, socket_port = gateway

    def here(code: str) -> str:
        # The ports of this gateway, the virtualenv's commands and the repository's examples (the README's
        # lines run from the repository's folder; here, from a folder of their own) wherever it names them.
        code = code.replace(".venv/bin/", f"{Path(sys.executable).parent}/")
        code = re.sub(r"(?<![\w/.])examples/", f"{ROOT}/examples/", code)
        return re.sub(r"\b8081\b", str(socket_port), re.sub(r"\b8080\b", str(http_port), code))

    examples = files_of(ROOT / "examples")

    terminal = await Terminal.open(tmp_path)
    try:
        for step in readme_steps((ROOT / "README.md").read_text()):
            if step.language == "sh":
                status, printed, errors = await terminal.run(here(step.code))
                assert status == 0, f"{step} exited with {status}: {errors}"
            else:
                script = await asyncio.create_subprocess_exec(
                    sys.executable, "-c", here(step.code), cwd=tmp_path,
                    stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
                out, err = await asyncio.wait_for(script.communicate(), STEP_TIMEOUT)
                printed, errors = out.decode(), err.decode()
                assert script.returncode == 0, f"{step} failed:\n{errors}"
            if step.shown:
                assert agrees("\n".join(step.shown), printed), (
                    f"{step}\n  printed: {printed!r}\n  README:  {' '.join(step.shown)!r}\n{errors}")
            else:
                assert not a_genomix_error(printed), f"{step} answered an error the README does not show: {printed}"
    finally:
        await terminal.close()
    # Running the notebooks wrote nothing into the repository: no figure, no executed copy.
    assert files_of(ROOT / "examples") == examples


def files_of(folder: Path) -> list[Path]:
    """The files under *folder*, but bytecode (the example scripts other tests run at the same time write some)."""
    return sorted(p for p in folder.rglob("*") if "__pycache__" not in p.parts)
