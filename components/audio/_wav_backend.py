"""The WAV file capture backend: a PCM WAV file released chunk by chunk at the capture rate.

Samples are left-justified into 32 bits (as a 16- or 24-bit card delivers
S32_LE), a mono file feeds both ears, and extra channels are ignored.  The
last chunk is completed with zeros and the capture ends with the file.
"""

from __future__ import annotations

import asyncio
import wave
from collections.abc import Sequence
from typing import BinaryIO, Self

import numpy as np
import numpy.typing as npt

from ..core import Clock
from ._backend import PacedBackend, SourceOptions
from ._errors import SceneError
from ._paths import confined_path, open_regular_file

__all__ = ["WavFileBackend", "decode_pcm"]


def decode_pcm(data: bytes, sample_width: int, channels: int) -> npt.NDArray[np.int32]:
    """Decode little-endian PCM bytes into ``(frames, 2)`` int32, left-justified.

    Raises:
        SceneError: for a sample width other than 1, 2, 3 or 4 bytes.
    """
    if sample_width == 1:
        # 8-bit WAV is unsigned with a bias of 128.
        samples = (np.frombuffer(data, dtype=np.uint8).astype(np.int32) - 128) << 24
    elif sample_width == 2:
        samples = np.frombuffer(data, dtype="<i2").astype(np.int32) << 16
    elif sample_width == 3:
        raw = np.frombuffer(data, dtype=np.uint8).reshape(-1, 3).astype(np.uint32)
        samples = ((raw[:, 0] << 8) | (raw[:, 1] << 16) | (raw[:, 2] << 24)).view(np.int32)
    elif sample_width == 4:
        samples = np.frombuffer(data, dtype="<i4").astype(np.int32)
    else:
        raise SceneError(f"WAV samples of {sample_width} bytes are not supported (1 to 4 bytes)")
    frames = samples.reshape(-1, channels)
    if channels == 1:
        return np.repeat(frames, 2, axis=1)
    return np.ascontiguousarray(frames[:, :2])


class WavFileBackend(PacedBackend):
    """Play a WAV file as if a sound card captured it.

    Args:
        device: The device string.
        rate: Frames per second; the file must have this rate.
        frames_per_chunk: Frames per chunk.
        clock: The runtime clock that paces the chunks.
        path: The WAV file.
        roots: The directories it may come from (None: anywhere).
    """

    kind = "WAV file"

    @classmethod
    def for_device(cls, device: str, argument: str, rate: int, frames_per_chunk: int, clock: Clock,
                   options: SourceOptions) -> Self:
        """The WAV file at the path *argument*, if it lies under the allowed roots."""
        return cls(device, rate, frames_per_chunk, clock, path=argument, roots=options.roots)

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock, *, path: str,
                 roots: Sequence[str] | None = None) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        self.path = path
        self._roots = roots
        self._wave: wave.Wave_read | None = None
        self._file: BinaryIO | None = None

    async def open(self) -> None:
        """Open the file off the event loop and start the clock.

        Raises:
            PathRefused: for a file outside the allowed directories.
            SceneError: for a file that is missing, not a regular file, not PCM WAV or at another rate.
        """
        self._wave, self._file = await asyncio.to_thread(self._open_file)
        await super().open()

    def _open_file(self) -> tuple[wave.Wave_read, BinaryIO]:
        stream = open_regular_file(confined_path(self.path, self._roots), self.path)
        try:
            reader = wave.open(stream, "rb")
        except (wave.Error, EOFError, OSError) as exc:
            stream.close()
            raise SceneError(f"{self.path!r} is not a PCM WAV file this backend reads: {exc}") from exc
        if reader.getframerate() != self.rate:
            reader.close()
            stream.close()
            raise SceneError(f"{self.path!r} is sampled at {reader.getframerate()} Hz, "
                             f"the capture asks for {self.rate} Hz (no resampling)")
        return reader, stream

    def _produce(self, count: int) -> npt.NDArray[np.int32] | None:
        reader = self._wave
        if reader is None:
            return None
        data = reader.readframes(count)
        frames = decode_pcm(data, reader.getsampwidth(), reader.getnchannels())
        if len(frames) == 0:
            return None
        if len(frames) < count:
            frames = np.concatenate([frames, np.zeros((count - len(frames), 2), dtype=np.int32)])
        return frames

    async def _close(self) -> None:
        # wave does not close a file object it was given: both are closed here.
        if self._wave is not None:
            self._wave.close()
            self._wave = None
        if self._file is not None:
            self._file.close()
            self._file = None
