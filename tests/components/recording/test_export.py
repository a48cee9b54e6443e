"""Issue 26, acceptance 2: a recording exported to WAV and CSV, read back as MATLAB and Octave users would.

The WAV holds exactly the recorded frames (soundfile reads them back as int32); the CSV has one
row per chunk with its frame index, head azimuth and times (read with Python's csv).
"""

from __future__ import annotations

import csv
import math
from collections.abc import AsyncIterator
from pathlib import Path

import numpy as np
import pytest
import soundfile
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from aiogenomix.components.capture import Capture
from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.kemar import Kemar
from aiogenomix.components.kemarcapture import KemarCapture
from aiogenomix.components.recorder import Recorder
from aiogenomix.components.recording import AUDIO_COLUMNS, RecordingError, export_recording
from aiogenomix.record import main as record_main


@pytest.fixture
async def host(tmp_path: Path) -> AsyncIterator[ComponentHost]:
    settings = HostSettings(can_timeout=10.0, audio_socket_port=0, record_dirs=(str(tmp_path),))
    async with ComponentHost(clock=VirtualClock(), settings=settings, factories={
            "kemarcapture": KemarCapture, "capture": Capture, "kemar": Kemar, "recorder": Recorder}) as running:
        yield running


async def record(host: ComponentHost, head: str, audio: str, ports: list[str], path: str) -> None:
    """Home the head, capture, record four seconds while the head turns to 40°."""
    head_component = await host.load(head)
    homing = await head_component.send("Homing")
    await homing.ended.wait()
    capture = await host.load(audio)
    capturing = await capture.send("StartCapture", {"device": "sim"})
    recorder = await host.load("recorder")
    recording = await recorder.send("Start", {"path": path, "ports": ports, "duration": 4})
    await head_component.send("MoveAbsolutePosition", {"target": 40})
    await recording.ended.wait()
    assert recording.status == "done", recording.exception
    await capture.interrupt(capturing, by="test")


def recorded(path: Path, topic: str) -> tuple[np.ndarray, list[dict[str, float]]]:
    """The samples and frame indexes of an audio port, as the mcap reader and the ROS 2 decoder give them."""
    audio, rows = [], []
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, decoded in reader.iter_decoded_messages(topics=[topic, topic + "/frames"]):
            if channel.topic == topic:
                audio.append(np.frombuffer(bytes(decoded.audio.data), "<i4").reshape(-1, 2))
            else:
                rows.append({"chunk": decoded.chunk, "first_frame": decoded.first_frame, "frames": decoded.frames,
                             "azimuth": decoded.head_azimuth})
    return np.concatenate(audio), rows


def table(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as stream:
        return list(csv.DictReader(stream))


async def test_the_wav_has_exactly_the_recorded_frames_and_the_csv_a_row_per_chunk(host: ComponentHost,
                                                                                  tmp_path: Path) -> None:
    await record(host, "kemarcapture", "kemarcapture", ["kemarcapture/Port", "kemarcapture/currentState"],
                 "head.mcap")
    written = export_recording(tmp_path / "head.mcap", tmp_path / "out")
    assert {f.path.name for f in written} == {"kemarcapture_Port.wav", "kemarcapture_Port.csv",
                                              "kemarcapture_currentState.csv"}
    samples, rows = recorded(tmp_path / "head.mcap", "/kemarcapture/Port")
    wav, rate = soundfile.read(tmp_path / "out" / "kemarcapture_Port.wav", dtype="int32")
    info = soundfile.info(tmp_path / "out" / "kemarcapture_Port.wav")
    assert (rate, info.channels, info.subtype, info.format) == (44100, 2, "PCM_32", "WAV")
    np.testing.assert_array_equal(wav, samples)              # bit for bit, every recorded frame once
    chunks = table(tmp_path / "out" / "kemarcapture_Port.csv")
    assert list(chunks[0]) == list(AUDIO_COLUMNS)
    assert len(chunks) == len(rows) >= 75                    # four seconds of 50 ms chunks
    position = 1
    for row, expected in zip(chunks, rows, strict=True):
        assert int(row["chunk"]) == expected["chunk"] and int(row["first_frame"]) == expected["first_frame"]
        assert int(row["wav_first_sample"]) == position and int(row["lost_frames_before"]) == 0
        assert float(row["azimuth_deg"]) == expected["azimuth"]
        position += int(row["frames"])
    assert float(chunks[0]["azimuth_deg"]) < 5 and float(chunks[-1]["azimuth_deg"]) == pytest.approx(40, abs=0.5)
    times = [float(row["capture_time_s"]) for row in chunks]
    assert np.allclose(np.diff(times), 0.05)
    head = table(tmp_path / "out" / "kemarcapture_currentState.csv")
    assert float(head[-1]["position_deg"]) == pytest.approx(40, abs=0.5)


async def test_a_capture_beside_a_head_takes_its_azimuths_from_the_recorded_head_state(host: ComponentHost,
                                                                                     tmp_path: Path) -> None:
    await record(host, "kemar", "capture", ["capture/Port", "kemar/currentState"], "apart.mcap")
    export_recording(tmp_path / "apart.mcap", tmp_path / "out")
    chunks = table(tmp_path / "out" / "capture_Port.csv")
    azimuths = [float(row["azimuth_deg"]) for row in chunks]
    assert not any(math.isnan(a) for a in azimuths)          # every chunk has the head's azimuth at its end
    assert azimuths[0] < 5 and azimuths[-1] == pytest.approx(40, abs=0.5)
    assert azimuths == sorted(azimuths)                      # the head only turned left meanwhile


async def test_an_export_never_overwrites_unless_asked(host: ComponentHost, tmp_path: Path) -> None:
    await record(host, "kemarcapture", "kemarcapture", ["kemarcapture/Port"], "again.mcap")
    export_recording(tmp_path / "again.mcap", tmp_path / "out")
    with pytest.raises(RecordingError, match="exists already"):
        export_recording(tmp_path / "again.mcap", tmp_path / "out")
    assert len(export_recording(tmp_path / "again.mcap", tmp_path / "out", overwrite=True)) == 2


async def test_an_export_never_writes_through_a_link_planted_in_its_directory(
        host: ComponentHost, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Issue 29, item 5: ``ln -s /tmp/victim out/kemar_currentState.csv``, then ``export ... -o out``."""
    await record(host, "kemar", "capture", ["capture/Port", "kemar/currentState"], "planted.mcap")
    out, victim = tmp_path / "out", tmp_path / "victim"
    out.mkdir()
    (out / "kemar_currentState.csv").symlink_to(victim)
    (out / "capture_Port.wav").symlink_to(tmp_path / "planted.mcap")   # an existing file of someone's
    before = (tmp_path / "planted.mcap").read_bytes()
    assert record_main(["export", str(tmp_path / "planted.mcap"), "-o", str(out)]) == 1
    said = capsys.readouterr().err
    assert said.startswith("aiogenomix-record: ") and "is a symbolic link: an export never writes through" in said
    assert not victim.exists()
    # Asked to overwrite, the links are replaced by the files themselves, never written through.
    assert record_main(["export", str(tmp_path / "planted.mcap"), "-o", str(out), "--overwrite"]) == 0
    assert not victim.exists() and (tmp_path / "planted.mcap").read_bytes() == before
    for name in ("kemar_currentState.csv", "capture_Port.wav", "capture_Port.csv"):
        assert (out / name).is_file() and not (out / name).is_symlink()
    # As private as the recording they come from.
    assert {(out / name).stat().st_mode & 0o777 for name in ("capture_Port.wav", "capture_Port.csv")} == {0o600}
    assert soundfile.info(str(out / "capture_Port.wav")).frames > 0
