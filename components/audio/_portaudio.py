"""The PortAudio capture backend (sounddevice): int32 stereo blocks of one chunk from a callback.

The stream callback runs on PortAudio's own high-priority thread, so it only
copies the block and offers it to the bounded :class:`ThreadHandoff`.  PortAudio
flags lost input with ``status.input_overflow``; the gap is measured against
the clock and reported with the next chunk.
"""

from __future__ import annotations

import asyncio
from typing import Any, Self

import numpy as np

from ..core import Clock
from ._backend import CaptureBackend, Chunk, SourceOptions
from ._errors import BackendUnavailable, DeviceError, DeviceNotFound
from ._handoff import ThreadHandoff

__all__ = ["PortAudioBackend", "import_sounddevice", "portaudio_capture_devices"]


def import_sounddevice() -> Any:
    """Import sounddevice.

    Raises:
        BackendUnavailable: when the package or the PortAudio library is missing.
    """
    try:
        import sounddevice
    except ImportError as exc:
        raise BackendUnavailable(
            "the PortAudio backend needs sounddevice: pip install 'aiogenomix[audio]' (or use device 'sim')"
        ) from exc
    except OSError as exc:
        raise BackendUnavailable(
            f"sounddevice cannot load the PortAudio library ({exc}): apt-get install libportaudio2"
        ) from exc
    return sounddevice


def portaudio_capture_devices() -> list[str]:
    """Device strings of the PortAudio inputs with at least two channels."""
    sd = import_sounddevice()
    return [f"pa:{info['name']}" for info in sd.query_devices() if info["max_input_channels"] >= 2]


class PortAudioBackend(CaptureBackend):
    """Capture from a PortAudio input device.

    Args:
        device: The device string.
        rate: Frames per second.
        frames_per_chunk: Frames per chunk (the stream's block size).
        clock: The runtime clock (timestamps).
        name: A device index, a (part of a) device name, or empty for the default input.
        depth: Chunks that may wait for the event loop before new ones are dropped.
    """

    kind = "PortAudio"

    @classmethod
    def for_device(cls, device: str, argument: str, rate: int, frames_per_chunk: int, clock: Clock,
                   options: SourceOptions) -> Self:
        """The PortAudio input device named or numbered *argument* (empty: the default one)."""
        return cls(device, rate, frames_per_chunk, clock, name=argument)

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock, *,
                 name: str, depth: int = 8) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        self.name = name
        self._depth = depth
        self._stream: Any = None
        self._handoff: ThreadHandoff | None = None
        self._anchor: float | None = None
        self._frames = 0

    def _resolve(self, sd: Any) -> int:
        """The index of the input device to open."""
        available = portaudio_capture_devices()
        selector: int | str | None = None
        if self.name not in ("", "default"):
            selector = int(self.name) if self.name.isascii() and self.name.isdigit() else self.name
        try:
            info = sd.query_devices(selector, "input")
        except (ValueError, sd.PortAudioError) as exc:
            raise DeviceNotFound(self.device, available, self.kind) from exc
        if info["max_input_channels"] < 2:
            raise DeviceNotFound(self.device, available, self.kind)
        return int(info["index"])

    async def open(self) -> None:
        # Listing, opening and starting a PortAudio stream talk to the sound server and
        # may block: done in a thread, so the gateway keeps answering meanwhile.
        self._handoff = ThreadHandoff(asyncio.get_running_loop(), self._depth)
        self._stream = await asyncio.to_thread(self._open_stream)

    def _open_stream(self) -> Any:
        """Find the device, then open and start its stream (blocking)."""
        sd = import_sounddevice()
        index = self._resolve(sd)
        try:
            stream = sd.InputStream(samplerate=self.rate, blocksize=self.frames_per_chunk, device=index,
                                    channels=2, dtype="int32", latency="high", callback=self._callback)
            stream.start()
        except sd.PortAudioError as exc:
            raise DeviceError(f"PortAudio device {self.device!r} cannot capture int32 stereo at "
                              f"{self.rate} Hz: {exc}") from exc
        return stream

    def _callback(self, indata: np.ndarray, frames: int, time: Any, status: Any) -> None:
        handoff = self._handoff
        assert handoff is not None
        now = self.clock.wall() - frames / self.rate
        if self._anchor is None:
            self._anchor = now
        elif status.input_overflow:
            expected = self._anchor + self._frames / self.rate
            handoff.overrun(max(0, round((now - expected) * self.rate)))
            self._anchor, self._frames = now, 0
        handoff.put(indata.copy(), self._anchor + self._frames / self.rate)
        self._frames += frames

    async def _read(self) -> Chunk | None:
        if self._handoff is None:
            raise DeviceError(f"PortAudio device {self.device!r} is not open")
        return await self._handoff.get()

    async def _close(self) -> None:
        stream, self._stream = self._stream, None
        if stream is not None:
            # stop() waits for the pending callbacks, which may take a block; close() talks
            # to the sound server too.
            await asyncio.to_thread(lambda: (stream.stop(), stream.close()))
        if self._handoff is not None:
            self._handoff.end()
