"""A recording's audio as WAV and its chunks and head azimuths as CSV: what MATLAB and Octave read.

For each recorded audio port ``instance/port``:

* ``instance_port.wav``: 32-bit PCM at the capture's rate (its channels: stereo for a binaural
  capture), exactly the recorded frames
  in order (a frame the recording missed is not there: the CSV says where a gap falls);
  RF64 when it would pass WAV's 4 GiB.
* ``instance_port.csv``: one row per recorded chunk, :data:`AUDIO_COLUMNS`; the azimuth is the
  one the chunk carries (``kemarcapture``), else the head state recorded beside it at the chunk's
  end (``kemar``'s ``currentState``), else NaN.

For each recorded head state (a port whose type carries :class:`~aiogenomix.components.core.HeadState`,
such as ``kemar``'s ``currentState``): ``instance_port.csv``, :data:`HEAD_COLUMNS`, in degrees.

When the ``recorder`` component kept its host's requests and events: ``events.csv``, one row an
event (:data:`~aiogenomix.components.recording.EVENT_COLUMNS`: the rig's time, the request's id,
service, input as JSON, status, output or exception).

Each file is made new in the output directory, by name, never through a symbolic link: a link
planted there (to ``/tmp/victim``, or to a file of another user's) is refused, or with
``overwrite`` replaced by the file itself, never written through.  The files are as private as
the recording they come from (its permission bits, within the umask).  Blocking: run it off the
event loop.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import io
import math
import os
import stat
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import BinaryIO, TextIO

import numpy as np
import soundfile

from ..core import HeadState, carried_by
from ._commands import write_events_csv
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


_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)


class _Output:
    """The directory an export writes into, open once: each file is made new in it, never through a link.

    Args:
        directory: Where (made if missing; a link the user named as the directory is theirs to follow).
        overwrite: Replace a file of the same name (a link of that name is removed, never followed).
        mode: The new files' permissions (within the umask).
    """

    def __init__(self, directory: Path, overwrite: bool, mode: int) -> None:
        directory.mkdir(parents=True, exist_ok=True)
        self.directory, self.overwrite, self.mode = directory, overwrite, mode
        self._fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | _CLOEXEC)

    def close(self) -> None:
        os.close(self._fd)

    def __enter__(self) -> _Output:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def create(self, name: str) -> tuple[Path, BinaryIO]:
        """The new file *name*, open for reading and writing, and its path.

        Raises:
            RecordingError: when something is there already (a file without *overwrite*, a link, a
                directory), or the file cannot be made.
        """
        path = self.directory / name
        if self.overwrite:
            self._remove(name, path)
        flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | _NOFOLLOW | _CLOEXEC
        try:
            fd = os.open(name, flags, self.mode, dir_fd=self._fd)
        except FileExistsError:
            raise self._taken(name, path) from None
        except OSError as exc:
            raise RecordingError(f"cannot create {path}: {exc.strerror or exc}") from exc
        return path, os.fdopen(fd, "w+b")

    def _remove(self, name: str, path: Path) -> None:
        """Remove what *overwrite* replaces: a file, or a link itself (never what it points to)."""
        try:
            if stat.S_ISDIR(os.stat(name, dir_fd=self._fd, follow_symlinks=False).st_mode):
                raise RecordingError(f"{path} is a directory: an export replaces only files")
            os.unlink(name, dir_fd=self._fd)
        except FileNotFoundError:
            pass
        except OSError as exc:
            raise RecordingError(f"cannot replace {path}: {exc.strerror or exc}") from exc

    def _taken(self, name: str, path: Path) -> RecordingError:
        with contextlib.suppress(OSError):
            if stat.S_ISLNK(os.stat(name, dir_fd=self._fd, follow_symlinks=False).st_mode):
                return RecordingError(f"{path} is a symbolic link: an export never writes through a link (remove "
                                      f"it, or export with overwrite to replace the link by the file)")
        return RecordingError(f"{path} exists already: remove it or export with overwrite")

    @contextlib.contextmanager
    def text(self, name: str) -> Iterator[tuple[Path, TextIO]]:
        """The new text file *name* (for the csv module), and its path."""
        path, raw = self.create(name)
        with io.TextIOWrapper(raw, encoding="utf-8", newline="") as table:
            yield path, table


def export_recording(recording: str | os.PathLike[str], directory: str | os.PathLike[str], *,
                     overwrite: bool = False, notice: Callable[[str], None] | None = None) -> list[ExportedFile]:
    """Write the WAV and CSV files of a recording into *directory* (made if missing); return what was written.

    A recording its recorder did not end (killed, crashed) is exported up to its last complete
    chunk; *notice*, when given, is told so in a sentence first.

    Raises:
        NotARecording: when the file is not a recording, or holds no audio, head state or events.
        RecordingError: when an output file exists already (and *overwrite* is false), or a link or a
            directory has its name.
    """
    written: list[ExportedFile] = []
    with open(recording, "rb") as stream, RecordingReader(stream, os.fspath(recording)) as reader:
        if reader.unfinished is not None and notice is not None:
            notice(reader.unfinished.said)
        # As private as the recording: one its owner alone reads makes files its owner alone reads.
        mode = os.fstat(stream.fileno()).st_mode & 0o666
        with _Output(Path(directory), overwrite, mode) as out:
            heads = {p: kind for p in reader.ports() if isinstance(kind := carried_by(reader.port_type(p)), HeadState)}
            head_times, head_positions = _head_states(reader, heads, out, written)
            audio = reader.audio_ports()
            events = reader.has_events()
            if not audio and not heads and not events:
                raise NotARecording(f"{recording} holds no audio, no head state and no events to export")
            if events:
                with out.text("events.csv") as (path, table):
                    written.append(ExportedFile(path, "requests and events", write_events_csv(reader.events(), table)))
            for port in audio:
                written += _export_audio(reader, port, out, head_times, head_positions)
    return written


def _head_states(reader: RecordingReader, heads: Mapping[str, HeadState], out: _Output,
                 written: list[ExportedFile]) -> tuple[np.ndarray, np.ndarray]:
    """Write each head state's CSV; return the first's capture times and azimuths (degrees), for the audio's rows."""
    times: list[float] = []
    positions: list[float] = []
    for index, (port, kind) in enumerate(heads.items()):
        rows = 0
        with out.text(f"{_name(port)}.csv") as (path, table):
            writer = csv.writer(table)
            writer.writerow(HEAD_COLUMNS)
            for message in reader.publications([port]):
                head = kind.read(message.data)
                position = math.degrees(head.position)
                writer.writerow((f"{message.capture_time:.9f}", f"{message.receive_time:.9f}", _text(position),
                                 _text(math.degrees(head.velocity))))
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


def _export_audio(reader: RecordingReader, port: str, out: _Output, head_times: np.ndarray,
                  head_positions: np.ndarray) -> list[ExportedFile]:
    chunks = reader.audio(port)
    first = next(chunks, None)
    if first is None:
        return []
    rate, channels = first.sample_rate, first.frames.shape[1]
    estimate = reader.message_count(f"/{port}") * first.frames.nbytes
    frames = 0
    rows = 0
    wav_path, wav_file = out.create(f"{_name(port)}.wav")
    with wav_file, soundfile.SoundFile(wav_file, "w", samplerate=rate, channels=channels, subtype="PCM_32",
                                       format="RF64" if estimate > _WAV_LIMIT else "WAV") as wav, \
            out.text(f"{_name(port)}.csv") as (csv_path, table):
        writer = csv.writer(table)
        writer.writerow(AUDIO_COLUMNS)
        chunk: AudioChunk | None = first
        while chunk is not None:
            if chunk.sample_rate != rate:
                raise NotARecording(f"{port} changes its rate from {rate} to {chunk.sample_rate} Hz at frame "
                                    f"{chunk.first_frame}: a WAV file has one rate")
            if chunk.frames.shape[1] != channels:
                raise NotARecording(f"{port} changes from {channels} to {chunk.frames.shape[1]} channels at frame "
                                    f"{chunk.first_frame}: a WAV file has one layout")
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
    layout = "stereo" if channels == 2 else f"{channels} channels"
    return [ExportedFile(wav_path, f"audio of {port}, {rate} Hz, 32-bit {layout}", frames),
            ExportedFile(csv_path, f"chunks of {port}", rows)]
