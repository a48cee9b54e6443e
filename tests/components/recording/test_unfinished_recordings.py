"""Issue 33, item 5: a recording its recorder never ended reads up to its last complete chunk, as ``mcap recover`` does.

A gateway killed while it records (SIGKILL, a real process) leaves a file without its summary and
footer, perhaps a chunk cut in the middle: the ``mcap`` library's seeking reader refuses it, and so
did ours, the capture's ``mcap:`` replay and ``aiogenomix-record export``.  Now each reads it up to
its last complete chunk, and says it is unfinished; what it reads is what the ``mcap`` library's
stream reader reads before it meets the tear, message for message.  Files cut at every kind of place
(in the first records, in a chunk, in its message indexes, in the summary) and with a crash's zeros
or a damaged last chunk are read the same way; one with nothing whole is refused as unfinished,
saying that nothing can be saved (a 0-byte file's reason used to be empty).
"""

from __future__ import annotations

import asyncio
import io
import json
import signal
import struct
import sys
from collections.abc import AsyncIterator
from pathlib import Path

import aiohttp
import numpy as np
import pytest
import soundfile
from mcap.data_stream import RecordBuilder
from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Metadata

from aiogenomix.components.audio import SceneError, open_backend
from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock, VirtualClock
from aiogenomix.components.kemarcapture import KemarCapture
from aiogenomix.components.recorder import Recorder
from aiogenomix.components.recording import NotARecording, RecordingReader
from aiogenomix.record import main as record_main

RATE, FPC = 44100, 2205
Message = tuple[str, int, int, bytes]


def stream_read(data: bytes) -> list[Message]:
    """The messages the ``mcap`` library's stream reader reads from *data*, until it meets the tear."""
    read: list[Message] = []
    try:
        for _, channel, message in NonSeekingReader(io.BytesIO(data)).iter_messages(log_time_order=False):
            read.append((channel.topic, message.sequence, message.log_time, message.data))
    except (McapError, struct.error, EOFError, ValueError):
        pass   # the torn end
    return read


def our_read(data: bytes) -> tuple[list[Message], RecordingReader]:
    reader = RecordingReader(io.BytesIO(data), "'cut.mcap'")
    messages = [(c.topic, m.sequence, m.log_time, m.data) for _, c, m in reader._reader.iter_messages(
        log_time_order=False)]
    return messages, reader


@pytest.fixture(scope="module")
def whole() -> bytes:
    """A recording ended properly: 8 s of kemarcapture's audio and head, on simulated time."""
    async def record(directory: str) -> None:
        settings = HostSettings(can_timeout=10.0, audio_socket_port=0, record_dirs=(directory,))
        async with ComponentHost(clock=VirtualClock(), settings=settings,
                                 factories={"kemarcapture": KemarCapture, "recorder": Recorder}) as host:
            capture = await host.load("kemarcapture")
            capturing = await capture.send("StartCapture", {"device": "sim"})
            recorder = await host.load("recorder")
            recording = await recorder.send("Start", {"path": "whole.mcap", "duration": 8,
                                                      "ports": ["kemarcapture/Port", "kemarcapture/currentState"]})
            await recording.ended.wait()
            assert recording.status == "done", recording.exception
            await capture.interrupt(capturing, by="test")

    import tempfile

    with tempfile.TemporaryDirectory() as directory:
        asyncio.run(record(directory))
        return (Path(directory) / "whole.mcap").read_bytes()


def chunk_offsets(data: bytes) -> list[tuple[int, int]]:
    """Where each Chunk record of *data* starts and ends (scanning the records from the magic)."""
    found, offset = [], 8
    while offset + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, offset)
        if opcode == 0x06:   # Chunk
            found.append((offset, offset + 9 + length))
        if opcode == 0x0F:   # DataEnd
            break
        offset += 9 + length
    return found


@pytest.mark.parametrize("place", ["in the first chunk", "in the third chunk", "right after a chunk",
                                   "in a chunk's message indexes", "in the summary", "before the footer's magic"])
def test_a_cut_recording_reads_what_the_stream_reader_reads_before_the_tear(whole: bytes, place: str) -> None:
    chunks = chunk_offsets(whole)
    assert len(chunks) >= 3
    cut = {"in the first chunk": chunks[0][0] + 1000, "in the third chunk": (chunks[2][0] + chunks[2][1]) // 2,
           "right after a chunk": chunks[1][1], "in a chunk's message indexes": chunks[1][1] + 20,
           "in the summary": len(whole) - 300, "before the footer's magic": len(whole) - 4}[place]
    data = whole[:cut]
    with pytest.raises((McapError, struct.error, EOFError, ValueError)):
        make_reader(io.BytesIO(data)).get_summary()   # the library's seeking reader: not a finished file
    if place == "in the first chunk":
        with pytest.raises(NotARecording, match="is unfinished and holds no complete chunk.*nothing can be saved"):
            RecordingReader(io.BytesIO(data), "'cut.mcap'")
        return
    expected = stream_read(data)
    messages, reader = our_read(data)
    assert messages == expected and len(messages) > 50
    assert reader.unfinished is not None and reader.unfinished.messages == len(messages)
    assert reader.unfinished.said.startswith("'cut.mcap' is unfinished: its recorder stopped without ending it")
    assert "read up to its last complete chunk" in reader.unfinished.said
    # What the summary says (counts, the recording's metadata) is what the file holds.
    assert reader.message_count("/kemarcapture/Port") == sum(1 for m in messages if m[0] == "/kemarcapture/Port")
    assert reader.metadata()["aiogenomix"]["ports"] == "kemarcapture/Port,kemarcapture/currentState"
    numbers = [chunk.chunk for chunk in reader.audio()]
    assert numbers == list(range(numbers[0], numbers[0] + len(numbers)))


def test_a_crash_s_zeros_and_a_damaged_last_chunk_are_left_out(whole: bytes) -> None:
    chunks = chunk_offsets(whole)
    # Zeros where the disk had not received the data when the machine went down.
    zeros = whole[:chunks[2][1]] + bytes(64 << 10)
    assert our_read(zeros)[0] == stream_read(whole[:chunks[2][1]])
    # A last chunk whose data does not check (its CRC): left out with what follows it, the chunks before are read.
    damaged = bytearray(whole[:chunks[2][1]] + metadata_record("after", {"written": "after the chunk"}))
    damaged[chunks[2][1] - 100] ^= 0xFF
    messages, reader = our_read(bytes(damaged))
    assert messages == stream_read(whole[:chunks[1][1]])
    assert reader.unfinished is not None and reader.unfinished.kept == chunks[2][0]
    assert set(reader.metadata()) == {"aiogenomix", "aiogenomix.end"}   # "after" went with the chunk


def metadata_record(name: str, values: dict[str, str]) -> bytes:
    builder = RecordBuilder()
    Metadata(name=name, metadata=values).write(builder)
    data: bytes = builder.end()  # type: ignore[no-untyped-call]
    return data


async def test_an_empty_recording_is_refused_as_unfinished_by_every_reader(tmp_path: Path,
                                                                          capsys: pytest.CaptureFixture[str]) -> None:
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    said = "'empty.mcap' is empty: an unfinished recording, stopped before its recorder wrote anything; " \
           "nothing can be saved"
    with pytest.raises(NotARecording) as refused, open(empty, "rb") as stream:
        RecordingReader(stream, "'empty.mcap'")
    assert str(refused.value) == said
    with pytest.raises(SceneError, match="is empty: an unfinished recording"):
        await open_backend("mcap:empty.mcap", RATE, FPC, ManualClock(), roots=(str(tmp_path),)).open()
    assert record_main(["export", str(empty), "-o", str(tmp_path / "out")]) == 1
    assert "is empty: an unfinished recording" in capsys.readouterr().err


# -- a gateway killed while it records ----------------------------------------------------------------


@pytest.fixture
async def gateway(tmp_path: Path) -> AsyncIterator[tuple[asyncio.subprocess.Process, str]]:
    """``aiogenomix-gateway`` in a process of its own, recordings allowed in tmp_path; always ended."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "aiogenomix.gateway", "--port", "0", "--audio-socket-port", "0", "--time-scale", "5",
        "--record-dir", str(tmp_path), stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.DEVNULL)
    assert process.stdout is not None
    try:
        async with asyncio.timeout(60):
            while b"listening on " not in (line := await process.stdout.readline()):
                assert line, "the gateway ended before it listened"
        yield process, line.decode().split("listening on ", 1)[1].split()[0]
    finally:
        if process.returncode is None:
            process.kill()
        await process.wait()


async def recorded_bytes(http: aiohttp.ClientSession, at_least: int) -> None:
    """Follow the recorder's Status port (a watch) until its file holds *at_least* bytes."""
    async with http.get("/module/recorder/watch/Status") as stream:
        async with asyncio.timeout(120):
            async for line in stream.content:
                if line.startswith(b"data: ") and json.loads(line[6:])["Status"]["bytes"] >= at_least:
                    return


async def test_a_recording_whose_gateway_was_killed_reads_up_to_its_last_chunk(
        gateway: tuple[asyncio.subprocess.Process, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    process, url = gateway
    async with aiohttp.ClientSession(base_url=url) as http:
        for name in ("kemarcapture", "recorder"):
            async with http.get(f"/load/{name}") as loaded:
                assert loaded.status == 200
        async with http.get("/module/kemarcapture/send/StartCapture", params={"input": '{"device":"sim"}'}) as sent:
            assert (await sent.json())["status"] == "sent"
        start = json.dumps({"path": "killed.mcap", "ports": ["kemarcapture/Port", "kemarcapture/currentState"]})
        async with http.get("/module/recorder/send/Start", params={"input": start}) as sent:
            assert (await sent.json())["status"] == "sent"
        await recorded_bytes(http, 3 << 20)
    process.send_signal(signal.SIGKILL)   # as a crash: nothing ends the file
    await process.wait()
    path = tmp_path / "killed.mcap"
    data = path.read_bytes()
    with pytest.raises((McapError, struct.error, EOFError, ValueError)):
        make_reader(io.BytesIO(data)).get_summary()
    messages, _ = our_read(data)
    assert messages == stream_read(data) and len(messages) > 100
    with open(path, "rb") as stream, RecordingReader(stream, "'killed.mcap'") as reader:
        assert reader.unfinished is not None
        chunks = list(reader.audio("kemarcapture/Port"))
    numbers = [chunk.chunk for chunk in chunks]
    assert numbers == list(range(numbers[0], numbers[0] + len(numbers))) and len(numbers) > 40
    recorded = np.concatenate([chunk.frames for chunk in chunks])
    # Exported up to there, saying so.
    assert record_main(["export", str(path), "-o", str(tmp_path / "out")]) == 0
    assert f"aiogenomix-record: {path} is unfinished: its recorder stopped" in capsys.readouterr().err
    wav, rate = soundfile.read(tmp_path / "out" / "kemarcapture_Port.wav", dtype="int32")
    assert rate == RATE
    np.testing.assert_array_equal(wav, recorded)
    # Played again as a capture device, frame for frame.
    clock = ManualClock()
    delivered = []
    async with open_backend("mcap:killed.mcap", RATE, FPC, clock, roots=(str(tmp_path),)) as backend:
        while (chunk := await clock.run_until(backend.read())) is not None:
            delivered.append(chunk.frames)
    np.testing.assert_array_equal(np.concatenate(delivered), recorded)
