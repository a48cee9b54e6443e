"""A recording's audio as WAV and its chunks and head azimuths as CSV: what MATLAB and Octave read.

For each recorded audio port ``instance/port``:

* ``instance_port.wav``: 32-bit PCM stereo at the capture's rate, exactly the recorded frames
  in order (a frame the recording missed is not there: the CSV says where a gap falls);
  RF64 when it would pass WAV's 4 GiB.
* ``instance_port.csv``: one row per recorded chunk, :data:`AUDIO_COLUMNS`; the azimuth is the
  one the chunk carries (``kemarcapture``), else the head state recorded beside it at the chunk's
  end (``kemar``'s ``currentState``), else NaN.

For each recorded head state (``::kemar::state``): ``instance_port.csv``, :data:`HEAD_COLUMNS`.
Blocking: run it off the event loop.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import soundfile

from ._conversions import number
from ._errors import NotARecording, RecordingError
from ._reader import AudioChunk, RecordingReader

__all__ = ["export_recording", "ExportedFile", "AUDIO_COLUMNS", "HEAD_COLUMNS"]

#: The columns of an audio port's CSV.
AUDIO_COLUMNS = ("chunk", "first_frame", "frames", "wav_first_sample", "lost_frames_before", "azimuth_deg",
                 "capture_time_s", "receive_time_s")
#: The columns of a head state's CSV.
HEAD_COLUMNS = ("capture_time_s", "receive_time_s", "position_deg", "speed_deg_s")
#: WAV's data chunk size is 32 bits: past this many bytes, RF64.
_WAV_LIMIT = 2**32 - 2**20
HEAD_STATE = "::kemar::state"


@dataclasses.dataclass(frozen=True)
class ExportedFile:
    """One file an export wrote.

    Attributes:
        path: Where.
        what: What it holds, in a few words.
        rows: Frames (WAV) or rows (CSV) written.
    """

    path: Path
    what: str
    rows: int


def _name(port: str) -> str:
    return port.replace("/", "_")


def _create(path: Path, overwrite: bool) -> Path:
    if path.exists() and not overwrite:
        raise RecordingError(f"{path} exists already: remove it or export with overwrite")
    return path


def export_recording(recording: str | os.PathLike[str], directory: str | os.PathLike[str], *,
                     overwrite: bool = False) -> list[ExportedFile]:
    """Write the WAV and CSV files of a recording into *directory* (made if missing); return what was written.

    Raises:
        NotARecording: when the file is not a recording, or holds neither audio nor a head state.
        RecordingError: when an output file exists already (and *overwrite* is false).
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written: list[ExportedFile] = []
    with open(recording, "rb") as stream, RecordingReader(stream, os.fspath(recording)) as reader:
        heads = [p for p in reader.ports() if reader.port_type(p).get("name") == HEAD_STATE]
        head_times, head_positions = _head_states(reader, heads, out, overwrite, written)
        audio = reader.audio_ports()
        if not audio and not heads:
            raise NotARecording(f"{recording} holds no audio and no head state to export")
        for port in audio:
            written += _export_audio(reader, port, out, overwrite, head_times, head_positions)
    return written


def _head_states(reader: RecordingReader, heads: Sequence[str], out: Path, overwrite: bool,
                 written: list[ExportedFile]) -> tuple[np.ndarray, np.ndarray]:
    """Write each head state's CSV; return the capture times and azimuths of the first, for the audio's rows."""
    times: list[float] = []
    positions: list[float] = []
    for index, port in enumerate(heads):
        path = _create(out / f"{_name(port)}.csv", overwrite)
        rows = 0
        with open(path, "w", newline="") as table:
            writer = csv.writer(table)
            writer.writerow(HEAD_COLUMNS)
            for message in reader.publications([port]):
                position = number(message.data.get("position"))
                writer.writerow((f"{message.capture_time:.9f}", f"{message.receive_time:.9f}", _text(position),
                                 _text(number(message.data.get("speed")))))
                rows += 1
                if index == 0:
                    times.append(message.capture_time)
                    positions.append(position)
        written.append(ExportedFile(path, f"head state of {port}", rows))
    order = np.argsort(np.asarray(times), kind="stable")
    return np.asarray(times)[order], np.asarray(positions)[order]


def _text(value: float) -> str:
    """A number as MATLAB's and Octave's csvread read it (``NaN``, not Python's ``nan``)."""
    return "NaN" if math.isnan(value) else repr(value)


def _export_audio(reader: RecordingReader, port: str, out: Path, overwrite: bool, head_times: np.ndarray,
                  head_positions: np.ndarray) -> list[ExportedFile]:
    chunks = reader.audio(port)
    first = next(chunks, None)
    if first is None:
        return []
    rate = first.sample_rate
    estimate = reader.message_count(f"/{port}") * len(first.frames) * 8
    wav_path = _create(out / f"{_name(port)}.wav", overwrite)
    csv_path = _create(out / f"{_name(port)}.csv", overwrite)
    frames = 0
    rows = 0
    with soundfile.SoundFile(wav_path, "w", samplerate=rate, channels=2, subtype="PCM_32",
                             format="RF64" if estimate > _WAV_LIMIT else "WAV") as wav, \
            open(csv_path, "w", newline="") as table:
        writer = csv.writer(table)
        writer.writerow(AUDIO_COLUMNS)
        chunk: AudioChunk | None = first
        while chunk is not None:
            if chunk.sample_rate != rate:
                raise NotARecording(f"{port} changes its rate from {rate} to {chunk.sample_rate} Hz at frame "
                                    f"{chunk.first_frame}: a WAV file has one rate")
            wav.write(chunk.frames)
            azimuth = chunk.head_azimuth
            if math.isnan(azimuth) and head_times.size:
                end = chunk.capture_time + len(chunk.frames) / rate
                at = int(np.searchsorted(head_times, end, side="right")) - 1
                azimuth = float(head_positions[at]) if at >= 0 else math.nan
            writer.writerow((chunk.chunk, chunk.first_frame, len(chunk.frames), frames + 1, chunk.lost_frames,
                             _text(azimuth), f"{chunk.capture_time:.9f}", f"{chunk.receive_time:.9f}"))
            frames += len(chunk.frames)
            rows += 1
            chunk = next(chunks, None)
    return [ExportedFile(wav_path, f"audio of {port}, {rate} Hz, 32-bit stereo", frames),
            ExportedFile(csv_path, f"chunks of {port}", rows)]
