"""Issue 26, acceptance 5: bad input ends with a clear error, and what was written stays readable.

A path outside ``--record-dir`` (or through a link out of it, or with recordings disabled), an
unknown port, an existing file, and a disk that fills up: a small tmpfs (as root) and a file
size limit (``RLIMIT_FSIZE``, anyone, in a process of its own).  The rig runs on simulated time
(``VirtualClock``).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader

from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.kemarcapture import KemarCapture
from aiogenomix.components.recorder import Recorder
from aiogenomix.components.recording import RecordingReader

ROOT = Path(__file__).resolve().parents[3]


def rig(record_dirs: tuple[str, ...] | None) -> ComponentHost:
    return ComponentHost(clock=VirtualClock(), settings=HostSettings(
        can_timeout=10.0, audio_socket_port=0, record_dirs=record_dirs),
        factories={"kemarcapture": KemarCapture, "recorder": Recorder})


async def start(host: ComponentHost, **inputs: Any) -> dict[str, Any]:
    """Send Start and wait for its end; return how it ended."""
    recorder = await host.load("recorder")
    request = await recorder.send("Start", {"duration": 5, **inputs})
    await request.ended.wait()
    return {"status": request.status, "exception": request.exception, "output": request.output}


@pytest.fixture
async def capturing(tmp_path: Path) -> AsyncIterator[ComponentHost]:
    """A rig capturing the simulated scene, recordings allowed in tmp_path/records."""
    (tmp_path / "records").mkdir()
    async with rig((str(tmp_path / "records"),)) as host:
        capture = await host.load("kemarcapture")
        request = await capture.send("StartCapture", {"device": "sim"})
        yield host
        await capture.interrupt(request, by="test")


async def test_a_path_outside_the_record_directory_is_refused_without_a_file(capturing: ComponentHost,
                                                                            tmp_path: Path) -> None:
    for path in (str(tmp_path / "elsewhere.mcap"), "../elsewhere.mcap", "/etc/x.mcap"):
        ended = await start(capturing, path=path, ports=["kemarcapture/Port"])
        assert ended["status"] == "error"
        assert ended["exception"]["ex"] == "::recorder::PATH_REFUSED"
        assert "--record-dir" in ended["exception"]["detail"]["what"]
    assert not (tmp_path / "elsewhere.mcap").exists()


async def test_a_path_with_a_control_character_is_refused(capturing: ComponentHost, tmp_path: Path) -> None:
    ended = await start(capturing, path="cut\x00short.mcap", ports=["kemarcapture/Port"])
    assert ended["exception"]["ex"] == "::recorder::PATH_REFUSED"
    assert "holds a control character ('\\x00')" in ended["exception"]["detail"]["what"]
    assert list((tmp_path / "records").iterdir()) == []


async def test_a_link_out_of_the_record_directory_is_refused(capturing: ComponentHost, tmp_path: Path) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (tmp_path / "records" / "escape").symlink_to(outside)
    ended = await start(capturing, path="escape/x.mcap", ports=["kemarcapture/Port"])
    assert ended["exception"]["ex"] == "::recorder::PATH_REFUSED"
    assert "symbolic link" in ended["exception"]["detail"]["what"]
    assert list(outside.iterdir()) == []


async def test_an_existing_file_is_never_overwritten(capturing: ComponentHost, tmp_path: Path) -> None:
    kept = tmp_path / "records" / "kept.mcap"
    kept.write_bytes(b"precious")
    ended = await start(capturing, path="kept.mcap", ports=["kemarcapture/Port"])
    assert ended["exception"]["ex"] == "::recorder::BAD_RECORDING"
    assert "exists already" in ended["exception"]["detail"]["what"]
    assert kept.read_bytes() == b"precious"


async def test_without_a_record_directory_recordings_are_disabled(tmp_path: Path) -> None:
    async with rig(()) as host:
        await host.load("kemarcapture")
        ended = await start(host, path=str(tmp_path / "x.mcap"), ports=["kemarcapture/Port"])
    assert ended["exception"]["ex"] == "::recorder::PATH_REFUSED"
    assert ended["exception"]["detail"]["what"].startswith("recordings are disabled on this host")


@pytest.mark.parametrize(("port", "why"), [
    ("kemarcapture/Nope", "kemarcapture has no out port 'Nope' (out ports: currentState, Port, Indexes"),
    ("nobody/Port", "no instance 'nobody' is loaded"),
    ("Port", "name a port as instance/port"),
])
async def test_an_unknown_port_is_refused_before_any_file(capturing: ComponentHost, tmp_path: Path, port: str,
                                                         why: str) -> None:
    ended = await start(capturing, path="x.mcap", ports=["kemarcapture/Port", port])
    assert ended["exception"]["ex"] == "::recorder::NO_SUCH_PORT"
    assert ended["exception"]["detail"]["port"] == port
    assert ended["exception"]["detail"]["what"].startswith(why)
    assert list((tmp_path / "records").iterdir()) == []


def _readable_and_contiguous(path: Path) -> int:
    """Check a recording cut short: every reader opens it, its chunks follow each other; return their count."""
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
        assert summary is not None and summary.statistics is not None
    with open(path, "rb") as stream, RecordingReader(stream) as reader:
        chunks = [chunk.chunk for chunk in reader.audio()]
    assert chunks and np.all(np.diff(chunks) == 1)
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as bag:
        frames = [c for c in bag.connections if c.topic == "/kemarcapture/Port/frames"]
        assert sum(1 for _ in bag.messages(connections=frames)) == len(chunks)
    return len(chunks)


@contextlib.contextmanager
def small_tmpfs(where: Path, size: str) -> Iterator[Path]:
    where.mkdir()
    try:
        subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)], check=True,
                       capture_output=True)
    except (OSError, subprocess.CalledProcessError) as exc:
        pytest.skip(f"cannot mount a tmpfs here (needs root): {exc}")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False, capture_output=True)


async def test_a_full_disk_ends_the_recording_with_its_file_readable(tmp_path: Path) -> None:
    with small_tmpfs(tmp_path / "small", "2m") as small:
        async with rig((str(small),)) as host:
            capture = await host.load("kemarcapture")
            capturing = await capture.send("StartCapture", {"device": "sim"})
            ended = await start(host, path="full.mcap", ports=["kemarcapture/Port", "kemarcapture/currentState"],
                                duration=60)
            await capture.interrupt(capturing, by="test")
        assert ended["status"] == "error"
        failure = ended["exception"]
        assert failure["ex"] == "::recorder::WRITE_FAILED"
        assert failure["detail"]["what"] == os.strerror(28)  # No space left on device
        path = small / "full.mcap"
        assert failure["detail"]["path"] == "full.mcap" and failure["detail"]["bytes"] == path.stat().st_size
        assert 0 < failure["detail"]["seconds"] < 60
        assert _readable_and_contiguous(path) > 10


#: The recording under a file size limit, in a process of its own: the limit is the whole process's, and
#: nothing else of the test run must meet it.
_UNDER_A_SIZE_LIMIT = """
import asyncio, json, resource, sys
from tests.components.recorder.test_recorder_refusals import rig, start

async def main(records, limit):
    async with rig((records,)) as host:
        capture = await host.load("kemarcapture")
        capturing = await capture.send("StartCapture", {"device": "sim"})
        # Python ignores SIGXFSZ: a write past the limit fails with EFBIG instead of ending the process.
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
        ended = await start(host, path="big.mcap", ports=["kemarcapture/Port"], duration=60)
        await capture.interrupt(capturing, by="test")
    print(json.dumps(ended["exception"]))

asyncio.run(main(sys.argv[1], int(sys.argv[2])))
"""


async def test_a_file_size_limit_ends_the_recording_with_its_file_readable(tmp_path: Path) -> None:
    (tmp_path / "records").mkdir()
    limit = 3 << 20
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-c", _UNDER_A_SIZE_LIMIT, str(tmp_path / "records"), str(limit),
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, cwd=ROOT)
    said, errors = await asyncio.wait_for(process.communicate(), 120)
    assert process.returncode == 0, errors.decode()[-2000:]
    failure = json.loads(said.decode().strip().splitlines()[-1])
    assert failure["ex"] == "::recorder::WRITE_FAILED" and failure["detail"]["what"] == os.strerror(27)
    path = tmp_path / "records" / "big.mcap"
    assert path.stat().st_size <= limit
    assert _readable_and_contiguous(path) > 10
