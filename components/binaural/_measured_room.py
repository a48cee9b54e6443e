"""Measured rooms: binaural room impulse responses from a SOFA file, chosen by the head's azimuth.

A measured room is a set of binaural room impulse responses (BRIRs), each from one
loudspeaker (an *emitter*) to the ears of a head turned to one azimuth: what the
Two!Ears Binaural Simulator and the SoundScape Renderer's BRS mode play. SOFA keeps
them as ``MultiSpeakerBRIR`` (``Data.IR`` M × R × E × N, a head orientation per
measurement in ``ListenerView``), ``SingleRoomMIMOSRIR`` (M × R × N × E) or
``SingleRoomSRIR`` (M × R × N, the emitter of each measurement told by its
``SourcePosition``). :func:`read_sofa_room` reads the three (two receivers: a head's).

:class:`MeasuredRoomRenderer` renders sources, each at one emitter, at a head that
turns: every block, each source takes the BRIR measured with the head nearest its
azimuth; when that changes, the output fades linearly across the block from the
old response to the new (no click), as the scene's other renderers do.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from fractions import Fraction

import numpy as np
import numpy.typing as npt
from scipy import signal

from ._convolution import FadingConvolver
from ._errors import HrirError
from ._hrir_set import wrap_degrees

__all__ = ["MeasuredRoom", "MeasuredRoomRenderer"]


@dataclasses.dataclass(frozen=True, eq=False)
class MeasuredRoom:
    """Binaural room impulse responses measured from loudspeakers to a head turned to several azimuths.

    Attributes:
        rate: Sample rate of the taps, Hz.
        emitter: ``(k,)`` the loudspeaker of each response, 0 to ``emitters - 1``.
        view: ``(k,)`` the head's azimuth in the room for each response, degrees, positive to the left.
        taps: ``(k, length, 2)`` responses, left ear then right.
        source: What the set is.
    """

    rate: float
    emitter: npt.NDArray[np.int64]
    view: npt.NDArray[np.float64]
    taps: npt.NDArray[np.float64]
    source: str = ""

    def __post_init__(self) -> None:
        k = len(self.emitter)
        if self.taps.ndim != 3 or self.taps.shape[0] != k or self.taps.shape[2] != 2 or len(self.view) != k or not k:
            raise HrirError(f"a measured room needs (k,) emitters and views and (k, length, 2) taps, not "
                            f"{self.emitter.shape}, {self.view.shape} and {self.taps.shape}")
        if not self.rate > 0:
            raise HrirError(f"the sample rate must be positive, not {self.rate}")
        for array in (self.emitter, self.view, self.taps):
            array.setflags(write=False)

    @property
    def emitters(self) -> int:
        """How many loudspeakers were measured."""
        return int(self.emitter.max()) + 1

    def nearest(self, emitter: int, head_azimuth: float) -> int:
        """The response of *emitter* measured with the head nearest *head_azimuth* (degrees)."""
        rows = np.flatnonzero(self.emitter == emitter)
        if not len(rows):
            raise HrirError(f"{self.source or 'the measured room'} has no emitter {emitter} "
                            f"(it has {self.emitters})")
        return int(rows[np.argmin(np.abs(wrap_degrees(self.view[rows] - head_azimuth)))])

    def resampled(self, rate: float) -> MeasuredRoom:
        """The same responses at *rate* (polyphase, with the closest rational ratio)."""
        if rate == self.rate:
            return self
        return _resampled(self, float(rate))


@functools.lru_cache(maxsize=4)
def _resampled(room: MeasuredRoom, rate: float) -> MeasuredRoom:
    ratio = (Fraction(rate) / Fraction(room.rate)).limit_denominator(20_000)
    taps = signal.resample_poly(room.taps, ratio.numerator, ratio.denominator, axis=1)
    return MeasuredRoom(rate, room.emitter, room.view, np.ascontiguousarray(taps), room.source)


class MeasuredRoomRenderer:
    """Sources at a measured room's loudspeakers, heard at a head that turns (the BRIR nearest its azimuth).

    Args:
        rate: Sample rate in Hz (the responses are resampled to it).
        room: The measured responses.
        emitters: The loudspeaker of each source.
        sensor_noise: RMS of independent noise at each ear, dB re full scale, or None.
        seed: Seed of the sensor noise.
    """

    def __init__(self, rate: float, room: MeasuredRoom, emitters: Sequence[int], *,
                 sensor_noise: float | None = None, seed: int = 0) -> None:
        self.rate = float(rate)
        self.room = room.resampled(self.rate)
        self.emitters = [int(e) for e in emitters]
        for e in self.emitters:
            self.room.nearest(e, 0.0)                     # refuses an emitter the room does not have
        self.sources = len(self.emitters)
        self._convolver = FadingConvolver(self.sources, self.room.taps.shape[1])
        self._spectra: dict[int, npt.NDArray[np.complex128]] = {}
        self._chosen: list[int] | None = None
        self._rng = np.random.default_rng(seed)
        self._sensor = 10.0 ** (sensor_noise / 20.0) if sensor_noise is not None else 0.0
        self.frames_rendered = 0

    def _filters(self, chosen: list[int]) -> npt.NDArray[np.complex128]:
        for index in chosen:
            if index not in self._spectra:
                self._spectra[index] = self._convolver.spectra(self.room.taps[index][np.newaxis])[0]
        if not chosen:
            return np.zeros((0, 2, self._convolver.n_fft // 2 + 1), dtype=np.complex128)
        return np.stack([self._spectra[i] for i in chosen])

    def render(self, dry: npt.ArrayLike, head_azimuth: float) -> npt.NDArray[np.float64]:
        """The next ``(frames, 2)`` of the dry signals ``(sources, frames)``, the head at *head_azimuth* at the end."""
        signals = np.asarray(dry, dtype=np.float64).reshape(self.sources, -1)
        chosen = [self.room.nearest(e, head_azimuth) for e in self.emitters]
        previous, self._chosen = self._chosen, chosen
        end = self._filters(chosen)
        start = end if previous is None or previous == chosen else self._filters(previous)
        out = self._convolver.convolve(signals, start, None if start is end else end)
        if self._sensor:
            out = out + self._sensor * self._rng.standard_normal(out.shape)
        self.frames_rendered += signals.shape[1]
        return out
