"""``aiogenomix-record``: a recording made over HTTP, from any machine, with a session's request events.

The gateway's rig runs on a clock the test steps; the recording reads the gateway as any
remote client would (``watch?since=``, ``read?since=``, ``session/listen``).  Ctrl-C is tried
on the real command in a process of its own.
"""

from __future__ import annotations

import asyncio
import csv
import math
import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest

from aiogenomix.clients import aconnect
from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock, ScaledClock
from aiogenomix.components.recording import RecordingCounts, RecordingReader, export_recording
from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.record import PortNotFound, record_over_http
from aiogenomix.record import main as record_main

from .._cut_links import cuttable

FPC = 2205


class Progress:
    """The recording's progress as the command line reports it; awaitable until a port reaches an index."""

    def __init__(self) -> None:
        self.counts: RecordingCounts | None = None
        self.changed = asyncio.Event()

    def __call__(self, counts: RecordingCounts, elapsed: float) -> None:
        self.counts = counts
        self.changed.set()

    async def until(self, port: str, index: int) -> None:
        while self.counts is None or self.counts.ports.get(port, {}).get("index", 0) < index:
            self.changed.clear()
            await self.changed.wait()


async def test_a_recording_over_http_has_every_frame_once_and_the_sessions_requests(
        stepped: tuple[str, ManualClock], tmp_path: Path) -> None:
    url, clock = stepped
    output = tmp_path / "over_http.mcap"
    async with aconnect(url, session="lab") as lab:
        capture = await lab.load("kemarcapture")
        await clock.run_until(capture.Homing())
        await capture.StartCapture(device="sim", Port_chunks=400, ack=True)
        await clock.advance(1.0)
        stop, progress = asyncio.Event(), Progress()
        recording = asyncio.create_task(record_over_http(
            url, ["kemarcapture/Port", "kemarcapture/currentState"], str(output), session="lab", stop=stop,
            progress=progress, progress_period=0.02))
        await progress.until("kemarcapture/Port", 1)  # the recording follows the port
        await clock.run_until(capture.MoveAbsolutePosition(target=-30))
        await clock.advance(10.0 - clock.now() % 1)
        await capture.StopCapture()
        newest = (await capture.Port(since=2**62))[0].index
        await progress.until("kemarcapture/Port", newest)
        stop.set()
        path, counts, ended = await recording
        port, lost = await capture.Port(since=0)
    assert ended == "stopped" and path == str(output) and counts.lost_frames == 0
    assert output.stat().st_mode & 0o777 == 0o600   # microphones are their owner's (issue 29), whatever the umask
    with open(output, "rb") as stream, RecordingReader(stream) as reader:
        chunks = list(reader.audio("kemarcapture/Port"))
        told = list(reader.session_events("lab"))
    numbers = [c.chunk for c in chunks]
    assert numbers == list(range(numbers[0], newest + 1)) and len(numbers) > 150
    frames = np.concatenate([c.frames for c in chunks])
    start = (numbers[0] - (port.index - len(port.left) // FPC + 1)) * FPC
    np.testing.assert_array_equal(frames[:, 0], np.asarray(port.left)[start:start + len(frames)])
    np.testing.assert_array_equal(frames[:, 1], np.asarray(port.right)[start:start + len(frames)])
    # The session's requests, as its listen stream told them.
    moves = [e.data for e in told if e.event == "request" and e.data["id"].startswith("kemarcapture")]
    assert [m["status"] for m in moves if m.get("output", {}).get("position") is not None] == ["done"]
    assert any(m["status"] == "sent" for m in moves)
    # ... and in the export's events.csv, as the stream told them, at the times they came.
    assert record_main(["export", str(output), "-o", str(tmp_path / "out")]) == 0
    with open(tmp_path / "out" / "events.csv", newline="") as table:
        rows = [row for row in csv.DictReader(table) if row["instance"] == "kemarcapture"]
    assert [(row["session"], row["id"], row["status"]) for row in rows] == [
        ("lab", m["id"], m["status"]) for m in moves]
    assert [float(row["time_s"]) for row in rows] == pytest.approx(
        [e.receive_time for e in told if e.event == "request" and e.data["id"].startswith("kemarcapture")], abs=1e-6)


async def test_an_unknown_port_is_refused_before_any_file(stepped: tuple[str, ManualClock], tmp_path: Path) -> None:
    url, _ = stepped
    async with aconnect(url) as client:
        await client.load("kemarcapture")
    for port, why in (("kemarcapture/Nope", "kemarcapture has no out port 'Nope'"),
                      ("nobody/Port", "no instance 'nobody' is loaded"), ("Port", "name a port as INSTANCE/PORT")):
        with pytest.raises(PortNotFound, match=why):
            await record_over_http(url, ["kemarcapture/Port", port], str(tmp_path / "x.mcap"), duration=1)
    assert not (tmp_path / "x.mcap").exists()


async def test_ctrl_c_ends_the_command_cleanly_with_a_readable_file(tmp_path: Path) -> None:
    """The command line itself, in a process of its own, stopped by SIGINT as Ctrl-C stops it."""
    output = tmp_path / "ctrl_c.mcap"
    settings = HostSettings(audio_socket_port=0)
    async with ComponentHost(clock=ScaledClock(5.0), settings=settings) as host, \
            serve(GatewayConfig.of(port=0), host) as url:
        capture = await host.load("kemarcapture")
        running = await capture.send("StartCapture", {"device": "sim", "Port_chunks": 400})
        command = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "aiogenomix.record", url, "kemarcapture/Port", "-o", str(output),
            stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, env={**os.environ, "PYTHONUNBUFFERED": "1"})
        assert command.stderr is not None
        first = await asyncio.wait_for(command.stderr.readline(), 60)
        assert b" s " in first and b"frames lost" in first  # the progress line: the recording runs
        command.send_signal(signal.SIGINT)
        assert command.stdout is not None
        rest, errors = await asyncio.wait_for(asyncio.gather(command.stdout.read(), command.stderr.read()), 60)
        assert await command.wait() == 0
        await capture.interrupt(running, by="test")
    said = rest.decode()
    assert said.startswith(f"aiogenomix-record: {output}:") and said.rstrip().endswith("(stopped)")
    assert "Traceback" not in errors.decode()
    with open(output, "rb") as stream, RecordingReader(stream) as reader:
        assert reader.metadata()["aiogenomix.end"]["ended"] == "stopped"
        numbers = [c.chunk for c in reader.audio()]
    assert numbers and numbers == list(range(numbers[0], numbers[0] + len(numbers)))


@pytest.mark.parametrize(("instance", "port"), [("bass", "Audio"), ("kemarcapture", "Port")])
async def test_a_dropped_connection_loses_no_frame_and_repeats_none(
        stepped: tuple[str, ManualClock], tmp_path: Path, instance: str, port: str) -> None:
    """The watch stream drops (the network fails) three times: it is opened again where it was."""
    url, clock = stepped
    name, output = f"{instance}/{port}", tmp_path / "dropped.mcap"
    async with cuttable(url) as link, aconnect(url) as lab:
        module = await lab.load(instance)
        if instance == "bass":
            await module.Acquire(device="sim", nFramesPerChunk=FPC, nChunksOnPort=400, ack=True)
        else:
            await clock.run_until(module.Homing())
            await module.StartCapture(device="sim", Port_chunks=400, ack=True)
        window = getattr(module, port)

        async def newest() -> int:
            data = (await window(since=2**62))[0]
            return int(getattr(data, "index", getattr(data, "lastFrameIndex", 0)))

        await clock.advance(0.5)
        stop, progress = asyncio.Event(), Progress()
        recording = asyncio.create_task(record_over_http(link.url, [name], str(output), stop=stop,
                                                         progress=progress, progress_period=0.02))
        await progress.until(name, 1)
        for connections in (3, 4, 5):
            await clock.advance(1.0)
            await progress.until(name, await newest())
            assert link.cut() >= 1  # the watch's connection, at least
            await clock.advance(0.5)  # published while the recorder is cut off
            await link.connected(connections)
        await clock.advance(1.0)
        await (module.Stop() if instance == "bass" else module.StopCapture())
        await progress.until(name, await newest())
        stop.set()
        _, counts, ended = await recording
        held, _ = await window(since=0)
    assert ended == "stopped" and counts.lost_frames == 0
    with open(output, "rb") as stream, RecordingReader(stream) as reader:
        chunks = list(reader.audio(name))
    firsts = [c.first_frame for c in chunks]
    ends = [c.first_frame + len(c.frames) for c in chunks]
    assert firsts[1:] == ends[:-1] and ends[-1] - 1 == newest_frame(held)  # every frame once, in order
    assert ends[-1] - firsts[0] > 4 * 44100
    frames = np.concatenate([c.frames for c in chunks])
    np.testing.assert_array_equal(frames[:, 0], np.asarray(held.left)[firsts[0] - 1:ends[-1] - 1])
    np.testing.assert_array_equal(frames[:, 1], np.asarray(held.right)[firsts[0] - 1:ends[-1] - 1])


def newest_frame(data: object) -> int:
    """The newest frame of a port's data (bass counts frames; a capture counts chunks of FPC frames)."""
    if hasattr(data, "lastFrameIndex"):
        return int(data.lastFrameIndex)
    return int(data.index) * FPC  # type: ignore[attr-defined]


async def test_bass_audio_over_http_is_stamped_on_the_rigs_clock(tmp_path: Path) -> None:
    """A rig whose clock runs 20 times faster than real time: bass's audio (no time of its own) and the head's
    azimuths (stamped by the rig) are recorded on one clock, so the export finds each chunk's azimuth."""
    output = tmp_path / "scaled.mcap"
    settings = HostSettings(can_timeout=10.0, audio_socket_port=0)
    async with ComponentHost(clock=ScaledClock(20.0), settings=settings) as host, \
            serve(GatewayConfig.of(port=0), host) as url, aconnect(url) as lab:
        kemar, bass = await lab.load("kemar"), await lab.load("bass")
        await kemar.Homing()
        await bass.Acquire(device="sim", nChunksOnPort=400, ack=True)
        stop, progress = asyncio.Event(), Progress()
        recording = asyncio.create_task(record_over_http(url, ["bass/Audio", "kemar/currentState"], str(output),
                                                         stop=stop, progress=progress, progress_period=0.02))
        await progress.until("bass/Audio", 1)
        await kemar.MoveAbsolutePosition(target=40)
        await progress.until("bass/Audio", (await bass.Audio(since=2**62))[0].lastFrameIndex)
        stop.set()
        await recording
        await bass.Stop()
    export_recording(output, tmp_path / "export")
    with open(tmp_path / "export" / "bass_Audio.csv", newline="") as table:
        rows = list(csv.DictReader(table))
    with open(tmp_path / "export" / "kemar_currentState.csv", newline="") as table:
        heads = list(csv.DictReader(table))
    audio_start = float(rows[0]["capture_time_s"])
    audio_end = float(rows[-1]["capture_time_s"]) + int(rows[-1]["frames"]) / 44100
    head_end = float(heads[-1]["capture_time_s"])
    # The head's last state (the end of the move, its last publication) falls within the audio recorded
    # around it; audio stamped with real time would span a twentieth of it, elsewhere.
    assert audio_start <= head_end <= audio_end, (audio_start, head_end, audio_end)
    azimuths = [float(row["azimuth_deg"]) for row in rows]
    assert all(math.isfinite(a) for a in azimuths[1:])
    assert azimuths[-1] == pytest.approx(40.0, abs=0.5) and min(azimuths[1:]) < 10.0  # it turned while recorded
