"""The ALSA capture backend (pyalsaaudio): S32_LE stereo, period = chunk, blocking reads in a thread.

This mirrors the original BASS capture: interleaved S32_LE, two channels, the
rate refused unless the card gives exactly it, one period per chunk and a ring
buffer of a few chunks.  Reads block in a dedicated thread; chunks reach the
event loop through a bounded :class:`ThreadHandoff`.  An overrun (``-EPIPE``
from ``read``) is counted and the lost frames are estimated from the clock,
then reported with the next chunk.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import threading
from typing import Any, Self

import numpy as np

from ..core import Clock
from ._backend import CaptureBackend, Chunk, SourceOptions
from ._errors import BackendUnavailable, DeviceError, DeviceNotFound, FormatRefused
from ._handoff import ThreadHandoff

__all__ = ["AlsaBackend", "import_alsaaudio", "alsa_capture_devices"]

log = logging.getLogger(__name__)

#: Ring buffer size in periods (chunks); BASS used 3.
PERIODS = 3


def import_alsaaudio() -> Any:
    """Import pyalsaaudio.

    Raises:
        BackendUnavailable: with the command that installs it.
    """
    try:
        import alsaaudio
    except ImportError as exc:
        raise BackendUnavailable(
            "the ALSA backend needs pyalsaaudio: apt-get install libasound2-dev, "
            "then pip install 'aiogenomix[audio]' (or use device 'sim')"
        ) from exc
    return alsaaudio


def alsa_capture_devices() -> list[str]:
    """The ALSA capture devices a user can name: the PCMs, then ``hw:<card>,0`` per card."""
    alsaaudio = import_alsaaudio()
    names = list(alsaaudio.pcms(alsaaudio.PCM_CAPTURE))
    for card in alsaaudio.card_indexes():
        names.append(f"hw:{card},0")
    return names


class AlsaBackend(CaptureBackend):
    """Capture from an ALSA PCM.

    Args:
        device: The device string.
        rate: Frames per second (the card must support it exactly).
        frames_per_chunk: Frames per chunk, used as the ALSA period size.
        clock: The runtime clock (timestamps).
        pcm_name: The ALSA PCM name (``hw:1,0``, ``default``, ``null``, ...).
        depth: Chunks that may wait for the event loop before new ones are dropped.
    """

    kind = "ALSA"

    @classmethod
    def for_device(cls, device: str, argument: str, rate: int, frames_per_chunk: int, clock: Clock,
                   options: SourceOptions) -> Self:
        """The PCM *argument* (``hw:1,0``, ``default``, ...)."""
        return cls(device, rate, frames_per_chunk, clock, pcm_name=argument)

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock, *,
                 pcm_name: str, depth: int = 8) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        self.pcm_name = pcm_name or "default"
        self._depth = depth
        self._pcm: Any = None
        self._alsa: Any = None
        self._thread: threading.Thread | None = None
        self._stopping = threading.Event()
        self._handoff: ThreadHandoff | None = None

    async def open(self) -> None:
        # Opening an ALSA device can block for as long as another process holds it:
        # done in a thread, so the gateway keeps answering meanwhile.
        self._pcm = await asyncio.to_thread(self._open_pcm)
        self._handoff = ThreadHandoff(asyncio.get_running_loop(), self._depth)
        self._thread = threading.Thread(target=self._run, name=f"alsa capture {self.pcm_name}", daemon=True)
        self._thread.start()

    def _open_pcm(self) -> Any:
        """Open and check the PCM (blocking)."""
        alsaaudio = self._alsa = import_alsaaudio()
        try:
            pcm = alsaaudio.PCM(
                type=alsaaudio.PCM_CAPTURE, mode=alsaaudio.PCM_NORMAL, device=self.pcm_name,
                rate=self.rate, channels=2, format=alsaaudio.PCM_FORMAT_S32_LE,
                periodsize=self.frames_per_chunk, periods=PERIODS,
            )
        except (alsaaudio.ALSAAudioError, ValueError) as exc:  # ValueError: a name pyalsaaudio cannot pass on
            message = str(exc)
            if "No such file or directory" in message or "No such device" in message:
                raise DeviceNotFound(self.device, alsa_capture_devices(), self.kind) from exc
            raise DeviceError(f"ALSA device {self.pcm_name!r} cannot capture S32_LE stereo at "
                              f"{self.rate} Hz: {message}") from exc
        try:
            self._check_configuration(pcm.info())
        except DeviceError:
            pcm.close()
            raise
        return pcm

    def _check_configuration(self, info: dict[str, Any]) -> None:
        # ALSA sets the nearest rate and period the card supports; like BASS we refuse
        # anything but the exact values, since chunk timing and indices depend on them.
        got = (info.get("rate"), info.get("channels"), info.get("format_name"))
        if got != (self.rate, 2, "S32_LE"):
            raise FormatRefused(f"ALSA device {self.pcm_name!r} gives {got[0]} Hz, {got[1]} channels, "
                              f"{got[2]}; capture needs {self.rate} Hz, 2 channels, S32_LE")
        if info.get("period_size") != self.frames_per_chunk:
            log.warning("ALSA device %s uses periods of %s frames, not %s: chunks are reassembled",
                        self.pcm_name, info.get("period_size"), self.frames_per_chunk)

    def _run(self) -> None:
        """The capture thread: blocking reads, reassembled into whole chunks."""
        handoff, pcm = self._handoff, self._pcm
        assert handoff is not None
        fpc = self.frames_per_chunk
        pending = np.empty((fpc, 2), dtype=np.int32)
        filled = 0
        anchor: float | None = None   # wall time of frame `frames` below
        frames = 0                    # frames delivered or counted lost since the anchor
        resync = False
        try:
            while not self._stopping.is_set():
                count, data = pcm.read()
                if count < 0:
                    if count != -errno.EPIPE:
                        reason = errno.errorcode.get(-count, count)
                        raise DeviceError(f"ALSA read from {self.pcm_name!r} failed: {reason}")
                    # Overrun: the card overwrote frames we had not read.  The next
                    # read resumes; the gap is measured against the clock then.
                    resync = True
                    continue
                if count == 0:
                    continue
                block = np.frombuffer(data, dtype="<i4", count=2 * count).reshape(count, 2)
                now = self.clock.wall() - (count + self._avail(pcm)) / self.rate
                if anchor is None:
                    # The first frames: whatever overran before them was never ours.
                    anchor, frames, resync = now, 0, False
                elif resync:
                    expected = anchor + frames / self.rate
                    handoff.overrun(max(0, round((now - expected) * self.rate)) + filled)
                    anchor, frames, filled, resync = now, 0, 0, False
                while len(block):
                    take = min(fpc - filled, len(block))
                    pending[filled:filled + take] = block[:take]
                    filled += take
                    block = block[take:]
                    if filled == fpc:
                        handoff.put(pending.copy(), anchor + frames / self.rate)
                        frames += fpc
                        filled = 0
        except Exception as exc:
            handoff.fail(exc if isinstance(exc, DeviceError) else DeviceError(f"ALSA capture failed: {exc}"))
        finally:
            pcm.close()
            handoff.end()

    def _avail(self, pcm: Any) -> int:
        # Frames already waiting behind the ones just read: they are newer, so the
        # first frame read is older than "now" by both counts.  pyalsaaudio < 0.10
        # has no avail(); the estimate is then one read later, which is acceptable.
        try:
            return max(0, int(pcm.avail()))
        except (AttributeError, self._alsa.ALSAAudioError):
            return 0

    async def _read(self) -> Chunk | None:
        if self._handoff is None:
            raise DeviceError(f"ALSA device {self.pcm_name!r} is not open")
        return await self._handoff.get()

    async def _close(self) -> None:
        self._stopping.set()
        thread = self._thread
        if thread is not None:
            # A blocking read returns within one period on a working card.
            await asyncio.to_thread(thread.join, 10 * self.chunk_duration + 1.0)
            if thread.is_alive():
                log.warning("ALSA capture thread for %s did not stop; it is left as a daemon", self.pcm_name)
        elif self._pcm is not None:
            self._pcm.close()
