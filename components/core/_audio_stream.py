"""The audio kind: a port of audio read by index, its numbering (chunks or frames) and its sample layout.

An audio port holds a window of the newest audio, numbered so that a reader asks for what came
after the last item it has (``since=``, :class:`~aiogenomix.components.core.Incremental`).  Ports
number it two ways: by chunk (``capture``'s ``index``: the newest chunk) or by frame (``bass``'s
``lastFrameIndex``: the newest frame).  :class:`AudioStream` says which, which members hold the
samples (one per channel, or one interleaved), the rate, the capture's start and the head's
azimuth at the end of each chunk; :meth:`AudioStream.read` turns the data of a ``since=`` read
into frames and the chunks they belong to (:class:`AudioRead`), the one reading every tool uses:
the recording, the live view, the localiser, a replay.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from ._chunked import ChunkedArray
from ._kinds import MemberNeed, PortKind, member_at, seconds_of

__all__ = ["AudioStream", "AudioRead", "AudioPiece", "FULL_SCALE"]

Json = Mapping[str, Any]

#: Full scale of the int32 frames an :class:`AudioRead` holds (samples of fewer bits are left-justified).
FULL_SCALE = 2.0**31
#: The sample formats of an audio port, by the IDL element type of its sample members.
_SAMPLES = {"long": "int32", "short": "int16", "float": "float32", "double": "float64"}
_DEGREES = 180 / math.pi


@dataclasses.dataclass(frozen=True)
class AudioPiece:
    """The frames of one chunk (or the part of one) that a read holds.

    Attributes:
        chunk: The port's number of the chunk (bass: ``(frame - 1) // frames per chunk + 1``).
        first_frame: The number of its first frame (frames count from 1 at the capture's start).
        offset: Its first frame within the read's frames.
        frames: How many frames.
        stamp: The capture time of its first frame (POSIX seconds on the rig's clock): from the
            capture's start when the port carries it, else counted back from the read's time.
        head_azimuth: The head's azimuth at the chunk's end, degrees, positive to the left (NaN: not carried).
    """

    chunk: int
    first_frame: int
    offset: int
    frames: int
    stamp: float
    head_azimuth: float


@dataclasses.dataclass(frozen=True)
class AudioRead:
    """The new audio of one read: frames in order, the chunks they belong to, what was lost before them.

    Attributes:
        frames: ``(n, channels)`` int32 frames, full scale :data:`FULL_SCALE` (16-bit and float samples
            are scaled to it).
        rate: Frames per second (0 when the port does not say yet).
        newest: The port's newest item after the read (chunk or frame index): read after it next.
        first_frame: The number of the first frame held (0 when none is).
        lost_frames: Frames between the last item read before and the first one held, which the port
            no longer held.
        chunk_frames: Frames per chunk (0 while unknown).
        pieces: The chunks (or parts of chunks) the frames belong to, in order.
        restarted: The port started a new capture since the reader's previous read (said by readers
            that follow a port: the frames are the new capture's, numbered from 1 again).
    """

    frames: npt.NDArray[np.int32]
    rate: int
    newest: int
    first_frame: int
    lost_frames: int
    chunk_frames: int
    pieces: tuple[AudioPiece, ...]
    restarted: bool = False

    @property
    def channels(self) -> int:
        """How many channels each frame has."""
        return int(self.frames.shape[1])

    def head_azimuths(self) -> npt.NDArray[np.float64]:
        """The head azimuth at the end of each piece, degrees (NaN where the port carries none)."""
        return np.array([piece.head_azimuth for piece in self.pieces], dtype=np.float64)


@dataclasses.dataclass(frozen=True, kw_only=True)
class AudioStream(PortKind, kind="audio"):
    """A port of audio read by index: ``capture``'s chunks, ``bass``'s frames, or any component's.

    ``@idl_struct("capture::port_t", carries=AudioStream(numbering="chunks", index="index",
    rate="transfer_rate", start="ts", ...))``.

    Attributes:
        numbering: ``chunks`` when the index numbers chunks (the newest chunk), ``frames`` when it
            numbers frames (the newest frame); items are numbered from 1 at the capture's start.
        index: The member holding the newest item's number.
        rate: The member holding the sample rate (Hz).
        channels: The members holding the samples, one per channel (left first), or the one member
            holding them all interleaved (``interleaved`` channels a frame).
        interleaved: 0 for one member per channel; else how many channels the one member interleaves.
        start: The member holding when the capture started (a timestamp struct): frame *j* was captured
            at ``start + (j - 1) / rate`` (None: the port carries no time).
        head_azimuth: The member holding the head's azimuth at the end of each chunk (a sequence, one
            per chunk of the data; its unit declared, degrees or radians).
        chunk_frames: The member holding the frames of a chunk (None: learnt from the reads).
    """

    numbering: str
    index: str
    rate: str
    channels: tuple[str, ...] = ("left", "right")
    interleaved: int = 0
    start: str | None = None
    head_azimuth: str | None = None
    chunk_frames: str | None = None

    needs: ClassVar[dict[str, MemberNeed]] = {
        "index": MemberNeed("integer"), "rate": MemberNeed("number"), "start": MemberNeed("time", optional=True),
        "head_azimuth": MemberNeed("numbers", "angle", optional=True),
        "chunk_frames": MemberNeed("integer", optional=True)}
    #: The sample format, learnt from the struct by bind(): int32, int16, float32 or float64.
    _sample: str = dataclasses.field(default="int32", init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.numbering not in ("chunks", "frames"):
            raise ValueError(f"numbering is chunks or frames, not {self.numbering!r}")
        if not self.channels or (self.interleaved and len(self.channels) != 1) or self.interleaved < 0:
            raise ValueError("channels names one member per channel, or one member with interleaved > 0")

    @property
    def channel_count(self) -> int:
        """How many channels a frame has."""
        return self.interleaved or len(self.channels)

    def describe(self) -> dict[str, Any]:
        """The ``carries`` object, with the sample format the struct's members hold."""
        return {**super().describe(), "sample": self._sample}

    def _bound(self, described: Json) -> None:
        formats = set()
        for name in self.channels:
            member = next((m for m in described.get("members", ()) if m.get("name") == name), None)
            element = ((member or {}).get("type") or {}).get("element") or {}
            sample = _SAMPLES.get(str(element.get("kind")))
            if sample is None:
                raise TypeError(f"AudioStream(channels=...): {described.get('name')} has no member {name!r} holding "
                                f"a sequence of long, short, float or double samples")
            formats.add(sample)
        if len(formats) != 1:
            raise TypeError(f"AudioStream: the channels of {described.get('name')} hold samples of different types")
        object.__setattr__(self, "_sample", formats.pop())

    def newest(self, data: Json) -> int:
        """The port's newest item (chunk or frame number) in *data*."""
        return int(member_at(data, self.index) or 0)

    def samples(self, data: Json) -> npt.NDArray[np.int32]:
        """The frames of *data* as ``(n, channels)`` int32 at :data:`FULL_SCALE`."""
        arrays = [_array(member_at(data, name)) for name in self.channels]
        if self.interleaved:
            flat = arrays[0]
            frames = flat[:flat.size - flat.size % self.interleaved].reshape(-1, self.interleaved)
        else:
            count = min(a.size for a in arrays)
            frames = np.empty((count, len(arrays)), dtype=arrays[0].dtype)
            for channel, array in enumerate(arrays):
                frames[:, channel] = array[:count]
        if frames.dtype.kind == "f":
            return np.clip(np.rint(frames * FULL_SCALE), -FULL_SCALE, FULL_SCALE - 1).astype(np.int32)
        if frames.dtype.itemsize == 2:
            return frames.astype(np.int32) << 16
        return frames.astype(np.int32, copy=False)

    def read(self, data: Json, *, since: int, lost: int = 0, now: float, chunk_frames: int = 0) -> AudioRead:
        """The items of a read after item *since*: its frames, the chunks they belong to, what was lost.

        Which items the data holds is read from the data itself (they end at its newest item), not
        taken on trust from *since*: items up to *since* are left out (a reader that got them
        before), those between *since* and the first one held are counted as lost.

        Args:
            data: JSON-ready data of the port (its arrays may stay numpy arrays), as ``since=`` answers.
            since: The last item the reader has.
            lost: Items the read says it no longer held (used only to learn a chunk's frames).
            now: The rig's time of the read: the time of data that carries none.
            chunk_frames: Frames per chunk, when a reader learnt it from an earlier read (0: unknown).

        Raises:
            ValueError: when a read of chunks does not hold whole chunks (it is not the read asked for).
        """
        newest = self.newest(data)
        frames = self.samples(data)
        rate = int(_finite(member_at(data, self.rate)))
        start = seconds_of(member_at(data, self.start)) if self.start is not None else None
        if self.numbering == "chunks":
            return self._read_chunks(data, frames, newest, since, lost, rate, start, now, chunk_frames)
        per_chunk = int(member_at(data, self.chunk_frames) or 0) if self.chunk_frames is not None else 0
        first = newest - len(frames) + 1
        skip = min(len(frames), max(0, since + 1 - first))
        kept = frames[skip:]
        first += skip
        pieces = []
        done = 0
        size = per_chunk or chunk_frames or max(1, len(kept))
        while done < len(kept):
            frame = first + done
            count = min(size - (frame - 1) % size, len(kept) - done)
            stamp = _stamp(start, rate, frame, now, newest - frame + 1)
            pieces.append(AudioPiece((frame - 1) // size + 1, frame, done, count, stamp, math.nan))
            done += count
        return AudioRead(kept, rate, newest, first if len(kept) else 0, max(0, first - since - 1) if len(kept) else 0,
                         per_chunk or chunk_frames, tuple(pieces))

    def _read_chunks(self, data: Json, frames: npt.NDArray[np.int32], newest: int, since: int, lost: int, rate: int,
                     start: float | None, now: float, chunk_frames: int) -> AudioRead:
        azimuths = self._azimuths(data)
        if not len(frames):
            return AudioRead(frames, rate, newest, 0, 0, chunk_frames, ())
        if azimuths is not None and len(azimuths):
            held = len(azimuths)
        elif chunk_frames and len(frames) % chunk_frames == 0:
            held = len(frames) // chunk_frames
        else:
            held = newest - since - lost
        if held <= 0 or len(frames) % held:
            raise ValueError(f"a read after chunk {since} up to chunk {newest} holds {len(frames)} frames, not "
                             f"{max(held, 0)} whole chunks")
        size = len(frames) // held
        first_chunk = newest - held + 1
        skip = min(held, max(0, since + 1 - first_chunk))  # chunks the reader has already
        pieces = []
        for k in range(skip, held):
            chunk = first_chunk + k
            frame = (chunk - 1) * size + 1
            azimuth = float(azimuths[k]) if azimuths is not None and k < len(azimuths) else math.nan
            pieces.append(AudioPiece(chunk, frame, (k - skip) * size, size,
                                     _stamp(start, rate, frame, now, (held - k) * size), azimuth))
        kept = frames[skip * size:]
        return AudioRead(kept, rate, newest, pieces[0].first_frame if pieces else 0,
                         max(0, first_chunk + skip - since - 1) * size if pieces else 0, size, tuple(pieces))

    def _azimuths(self, data: Json) -> npt.NDArray[np.float64] | None:
        """The head azimuth of each chunk of *data*, degrees (None: the port carries none)."""
        if self.head_azimuth is None:
            return None
        values = member_at(data, self.head_azimuth)
        if values is None:
            return None
        if isinstance(values, list):
            values = [math.nan if v is None else v for v in values]
        return _array(values).astype(np.float64).reshape(-1) * (self.scale("head_azimuth") * _DEGREES)


def _array(values: Any) -> npt.NDArray[Any]:
    if isinstance(values, ChunkedArray):
        return values.numpy()
    return np.asarray(values if values is not None else ()).reshape(-1)


def _finite(value: Any) -> float:
    number = math.nan if value is None else float(value)
    return number if math.isfinite(number) else 0.0


def _stamp(start: float | None, rate: int, frame: int, now: float, frames_to_now: int) -> float:
    """When *frame* was captured: from the capture's start, else counted back from the read's time *now*."""
    if not rate:
        return now
    if start is not None:
        return start + (frame - 1) / rate
    return now - frames_to_now / rate
