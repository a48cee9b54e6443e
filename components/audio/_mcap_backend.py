"""The recording capture backend (``mcap:PATH``): a recorded capture played again, frame for frame, at its rate.

A recording's audio (``aiogenomix-record``, the ``recorder`` component) comes back as a capture
would deliver it: chunks of the capture's size released by the runtime clock at the rate they
were captured, the recorded samples unchanged.  The recording's frame numbers say where each
frame belongs in time, so a gap in the recording (frames it missed) stays a gap: its chunks are
not delivered, the next chunk comes at its time and says how many frames were lost before it.
A chunk cut by a gap or by the end is completed with zeros (as a WAV file's last chunk).  A rate
other than the recording's is refused (no resampling).

A recording may hold a capture that started again (its frames numbered from 1 again): the new
capture plays after the one before, the pause between them kept as a gap (from their capture
times, as recorded on the rig's clock).  Each capture's rate is checked: one of another rate
ends the replay there, saying so.

Each chunk carries the head's azimuth at its end as the recording has it (a port whose kind carries
the head's azimuth with each chunk, ``kemarcapture``'s), linear between the recorded chunks' ends, so
that a capture that publishes azimuths publishes the recorded ones, not its live head's.

``mcap:PATH`` plays the recording's only audio port; ``mcap:PATH#instance/port`` names one.
Files come from the directories the operator allowed for audio files (``--audio-files``) and for
recordings (``--record-dir``), reached without following links.
"""

from __future__ import annotations

import asyncio
import bisect
import logging
import math
from collections.abc import Iterator, Sequence
from typing import Self

import numpy as np
import numpy.typing as npt

from ..core import Clock, ThrottledLog
from ..recording import AudioChunk, NotARecording, PathRefused as RecordingPathRefused, RecordingError
from ..recording import RecordingReader, open_recording
from ._backend import CaptureBackend, Chunk, SourceOptions
from ._errors import FormatRefused, SceneError
from ._paths import PathRefused

__all__ = ["RecordingBackend"]

#: A client may name an unfinished recording again and again: said a few times a minute.
log = ThrottledLog(logging.getLogger(__name__))


class RecordingBackend(CaptureBackend):
    """Play the audio of an MCAP recording as if a sound card captured it.

    Args:
        device: The device string.
        rate: Frames per second; the recording must have this rate.
        frames_per_chunk: Frames per chunk.
        clock: The runtime clock that paces the chunks.
        path: The recording.
        port: Its audio port to play (``instance/port``; None: its only one).
        roots: The directories it may come from (None: anywhere).
    """

    kind = "recording"

    @classmethod
    def for_device(cls, device: str, argument: str, rate: int, frames_per_chunk: int, clock: Clock,
                   options: SourceOptions) -> Self:
        """The recording at the path *argument* (``PATH`` or ``PATH#instance/port``)."""
        path, _, port = argument.partition("#")
        return cls(device, rate, frames_per_chunk, clock, path=path, port=port or None, roots=options.roots)

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock, *, path: str,
                 port: str | None = None, roots: Sequence[str] | None = None) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        self.path, self.port, self._roots = path, port, roots
        self._reader: RecordingReader | None = None
        self._chunks: Iterator[AudioChunk] | None = None
        #: Recorded chunks read and not delivered yet, each with its replay position (of its first frame).
        self._pending: list[tuple[int, AudioChunk]] = []
        # Where the recording's current capture is: its first frame number and where it plays, where the last
        # chunk read ends (replay position, capture time) and its first frame number.
        self._capture_first = 0
        self._capture_start = 0
        self._end = 0
        self._end_time = 0.0
        self._last_first: int | None = None
        self._origin = 0.0
        self._start_wall = 0.0
        self._next = 0  # the replay chunk to deliver next (its frames start at _next * frames_per_chunk)
        self._ended = False
        #: Where the recorded chunks read so far end (replay positions) and the head's azimuth there.
        self._head_ends: list[int] = []
        self._heads: list[float] = []

    async def open(self) -> None:
        """Open the recording off the event loop, check its rate, start the clock.

        Raises:
            PathRefused: for a file outside the allowed directories.
            SceneError: for a file that is missing, not a recording, or without that audio port.
            FormatRefused: for a recording of another rate.
        """
        # A simulated clock waits for the disk, as a sound card's open would be waited for.
        with self.clock.holding():
            self._reader, first = await asyncio.to_thread(self._open_file)
        if first is not None:
            self._pending.append(self._place(first))
        self._origin = self.clock.now()
        self._start_wall = self.clock.wall()

    def _open_file(self) -> tuple[RecordingReader, AudioChunk | None]:
        try:
            stream, _ = open_recording(self.path, self._roots)
        except RecordingPathRefused as exc:
            raise PathRefused(str(exc).replace("(--record-dir)", "(--audio-files, --record-dir)")) from exc
        except RecordingError as exc:
            raise SceneError(str(exc)) from exc
        try:
            reader = RecordingReader(stream, repr(self.path))
            if reader.unfinished is not None:
                log.warning("%s: %s", self.device, reader.unfinished.said)
            self._chunks = reader.audio(self.port)
            first = next(self._chunks, None)
        except NotARecording as exc:
            stream.close()
            raise SceneError(str(exc)) from exc
        except BaseException:
            stream.close()
            raise
        if first is not None and first.sample_rate != self.rate:
            reader.close()
            raise FormatRefused(f"{self.path!r} was recorded at {first.sample_rate} Hz, the capture asks for "
                                f"{self.rate} Hz (no resampling)")
        return reader, first

    def _place(self, chunk: AudioChunk) -> tuple[int, AudioChunk]:
        """The recorded chunk with its replay position: its frame number within its capture, after the ones before.

        Raises:
            FormatRefused: for a capture of another rate than the replay's.
        """
        restarted = self._last_first is not None and chunk.first_frame <= self._last_first
        if chunk.sample_rate != self.rate:
            which = "of its next capture " if restarted else ""
            raise FormatRefused(f"{self.path!r} goes on from frame {chunk.first_frame} {which}at {chunk.sample_rate} "
                                f"Hz, the capture plays {self.rate} Hz (no resampling): the replay ends there")
        if self._last_first is None or restarted:
            # A new capture (numbered from 1 again): it plays after the last one, the pause between them kept.
            pause = round((chunk.capture_time - self._end_time) * self.rate) if restarted else 0
            self._capture_first, self._capture_start = chunk.first_frame, self._end + max(0, pause)
        position = self._capture_start + chunk.first_frame - self._capture_first
        self._end, self._end_time = position + len(chunk.frames), chunk.capture_time + len(chunk.frames) / self.rate
        self._last_first = chunk.first_frame
        if self._head_ends and self._end <= self._head_ends[-1]:
            self._head_ends, self._heads = [], []  # frames played again: the head's path starts anew
        self._head_ends.append(self._end)
        self._heads.append(chunk.head_azimuth)
        return position, chunk

    def _head_at(self, position: int) -> float | None:
        """The recorded head's azimuth at the replay *position* (a chunk's end), degrees; None when not recorded.

        Linear between the ends of the recorded chunks around it, as the head moved between them; the
        chunks read so far reach past it (a delivered chunk is complete, or the recording has ended).
        """
        at = bisect.bisect_left(self._head_ends, position)
        if at == len(self._heads):
            at -= 1  # past the last recorded end (the recording ended): the last azimuth
        if at < 0:
            return None
        after = self._heads[at]
        if at == 0 or self._head_ends[at] == position:
            azimuth = after
        else:
            start, end, before = self._head_ends[at - 1], self._head_ends[at], self._heads[at - 1]
            azimuth = before + (after - before) * (position - start) / (end - start)
        del self._head_ends[:max(0, at - 1)], self._heads[:max(0, at - 1)]  # what later chunks need is kept
        return azimuth if math.isfinite(azimuth) else None

    def _more(self) -> AudioChunk | None:
        """The next recorded chunk (blocking: read off the event loop)."""
        assert self._chunks is not None
        try:
            return next(self._chunks, None)
        except NotARecording as exc:
            raise SceneError(str(exc)) from exc

    async def _read(self) -> Chunk | None:
        fpc = self.frames_per_chunk
        lost = 0
        while True:
            start = self._next * fpc  # replay position of the chunk's first frame
            frames, covered = await self._frames(start, fpc)
            if frames is None:
                return None
            self._next += 1
            if covered:
                break
            lost += fpc  # a chunk the recording does not have at all: a gap, not delivered
        # Released when the clock reaches its end, as a sound card delivers it.
        await self.clock.sleep_until(self._origin + (self._next * fpc) / self.rate)
        lost += fpc - covered
        return Chunk(frames, self._start_wall + start / self.rate, overrun=lost > 0, lost_frames=lost,
                     head_azimuth=self._head_at(start + fpc))

    async def _frames(self, start: int, count: int) -> tuple[npt.NDArray[np.int32] | None, int]:
        """The frames of replay positions ``start … start + count`` (zeros where the recording has none).

        Returns the frames and how many of them the recording has (None once the recording has ended).
        """
        out = np.zeros((count, 2), dtype=np.int32)
        covered = 0
        end = start + count
        while True:
            if not self._pending and not self._ended:
                with self.clock.holding():  # the chunk is released at its time, however long the disk takes
                    chunk = await asyncio.to_thread(self._more)
                if chunk is None:
                    self._ended = True
                else:
                    self._pending.append(self._place(chunk))
            if not self._pending:
                return (out if covered else None), covered
            first, chunk = self._pending[0]
            last = first + len(chunk.frames)
            if first >= end:
                return out, covered  # the recording resumes after this replay chunk
            if last <= start:
                self._pending.pop(0)  # frames played already (a recording that repeats them): once is enough
                continue
            lo, hi = max(first, start), min(last, end)
            out[lo - start:hi - start] = chunk.frames[lo - first:hi - first]
            covered += hi - lo
            if last <= end:
                self._pending.pop(0)
            if last >= end:
                return out, covered

    async def _close(self) -> None:
        if self._reader is not None:
            await asyncio.to_thread(self._reader.close)
            self._reader = None
