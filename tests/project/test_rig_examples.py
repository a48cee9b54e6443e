"""The KEMAR and capture examples run as a user would run them, against the simulated rig."""

from __future__ import annotations

import asyncio
import pathlib
import re
import sys

import pytest

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"


async def run(*args: str, timeout: float = 120) -> tuple[int, str, str]:
    process = await asyncio.create_subprocess_exec(sys.executable, *args, stdout=asyncio.subprocess.PIPE,
                                                   stderr=asyncio.subprocess.PIPE)
    out, err = await asyncio.wait_for(process.communicate(), timeout)
    return process.returncode or 0, out.decode(), err.decode()


async def test_kemar_sweep_homes_and_sweeps() -> None:
    gateway = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "aiogenomix.gateway", "--port", "0", "--audio-socket-port", "0", "--time-scale", "20",
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL)
    try:
        assert gateway.stdout is not None
        line = (await asyncio.wait_for(gateway.stdout.readline(), 60)).decode()
        address = re.search(r"http://(\S+)", line).group(1)  # type: ignore[union-attr]
        code, out, err = await run(str(EXAMPLES / "kemar_sweep.py"), "--address", address, "--amplitude", "40",
                                   "--sweeps", "1", "--period", "0.01")
        assert code == 0, err
        assert "homing" in out and "MoveAbsolutePosition(+40.0)" in out and "MoveAbsolutePosition(-40.0)" in out
        positions = [float(p) for p in re.findall(r"position\s+([+-]\d+\.\d+) deg", out)]
        assert max(positions) == pytest.approx(40, abs=0.1)
        assert min(positions) == pytest.approx(-40, abs=0.1)
    finally:
        gateway.terminate()
        await gateway.wait()


async def test_capture_sweep_plots_sound_and_head(tmp_path: pathlib.Path) -> None:
    out = tmp_path / "sweep.png"
    code, stdout, err = await run(str(EXAMPLES / "capture_sweep.py"), "--amplitude", "40", "--speed", "120",
                                  "--time-scale", "20", "--out", str(out))
    assert code == 0, err
    assert re.search(r"wrote .*: \d+ chunks, 0 lost", stdout), stdout
    assert out.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")


async def test_bass_socket_2015_streams_without_loss() -> None:
    import socket

    with socket.socket() as probe:                    # a free port for the dedicated socket
        probe.bind(("127.0.0.1", 0))
        audio_port = probe.getsockname()[1]
    gateway = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "aiogenomix.gateway", "--port", "0", "--audio-socket-port", str(audio_port),
        "--time-scale", "2", stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL)
    try:
        assert gateway.stdout is not None
        line = (await asyncio.wait_for(gateway.stdout.readline(), 60)).decode()
        address = re.search(r"http://(\S+)", line).group(1)  # type: ignore[union-attr]
        code, out, err = await run(str(EXAMPLES / "bass_socket_2015.py"), "--address", address,
                                   "--socket-port", str(audio_port), "--seconds", "1")
        assert code == 0, err
        ended = r"read \d+ frames \(1\.\d+ s\), 0 lost; socket done, acquisition ended \(::genom::interrupted\)"
        assert re.search(ended, out), out
        # The first block is audio: it starts at frame 1, the first captured one, and is not silent.
        first = re.search(r"frames\s+(\d+)…\s*(\d+)\s+lost\s+\d+\s+left\s+(\S+) dB", out)
        assert first is not None and first.group(1) == "1", out
        assert int(first.group(2)) >= 2205 and float(first.group(3)) > -60, out
    finally:
        gateway.terminate()
        await gateway.wait()
