"""A set of head-related impulse responses as plain numpy arrays: directions, taps, sample rate."""

from __future__ import annotations

import dataclasses
import functools
from fractions import Fraction

import numpy as np
import numpy.typing as npt
from scipy import signal

from ._errors import HrirError

__all__ = ["HrirSet", "wrap_degrees"]

#: The largest denominator of the resampling ratio: exact for every integer rate pair
#: whose reduced ratio fits (44,100 → 24,414 is 7350/4069), and a close rational approximation otherwise.
_MAX_RATIO_TERM = 20_000


def wrap_degrees(angle: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Angles in degrees wrapped to [-180, 180)."""
    return (np.asarray(angle, dtype=np.float64) + 180.0) % 360.0 - 180.0


@dataclasses.dataclass(frozen=True, eq=False)
class HrirSet:
    """Head-related impulse responses measured at a set of directions.

    Conventions (those of the scenes and of the KEMAR head): azimuth in degrees,
    counter-clockwise seen from above, so positive is to the LEFT; elevation in
    degrees, positive up; taps ``(direction, sample, ear)`` with ear 0 the left.

    Attributes:
        rate: Sample rate of the taps in Hz.
        azimuth: ``(n,)`` degrees in [-180, 180).
        elevation: ``(n,)`` degrees.
        taps: ``(n, length, 2)`` impulse responses, left then right.
        source: What the set is (shown in messages and reports).

    Sets are shared between renderers and localisers: their arrays are read-only.
    """

    rate: float
    azimuth: npt.NDArray[np.float64]
    elevation: npt.NDArray[np.float64]
    taps: npt.NDArray[np.float64]
    source: str = ""

    def __post_init__(self) -> None:
        n = len(self.azimuth)
        if self.taps.ndim != 3 or self.taps.shape[0] != n or self.taps.shape[2] != 2 or len(self.elevation) != n:
            raise HrirError(f"an HRIR set needs (n,) azimuths and elevations and (n, length, 2) taps, not "
                            f"{self.azimuth.shape}, {self.elevation.shape} and {self.taps.shape}")
        if not self.rate > 0:
            raise HrirError(f"the sample rate must be positive, not {self.rate}")
        for array in (self.azimuth, self.elevation, self.taps):
            array.setflags(write=False)

    def __len__(self) -> int:
        return len(self.azimuth)

    @property
    def length(self) -> int:
        """Taps per impulse response."""
        return int(self.taps.shape[1])

    def index(self, azimuth: float, elevation: float = 0.0) -> int:
        """The measured direction nearest to (*azimuth*, *elevation*), by great-circle angle."""
        az, el = np.radians(self.azimuth), np.radians(self.elevation)
        a, e = np.radians(azimuth), np.radians(elevation)
        cosine = np.sin(el) * np.sin(e) + np.cos(el) * np.cos(e) * np.cos(az - a)
        return int(np.argmax(cosine))

    def horizontal(self) -> HrirSet:
        """The directions at elevation 0°, sorted by azimuth from -180°.

        Raises:
            HrirError: when the set has fewer than 3 directions in the horizontal plane.
        """
        rows = np.flatnonzero(np.abs(self.elevation) < 1e-6)
        if len(rows) < 3:
            raise HrirError(f"{self.source or 'the HRIR set'} has {len(rows)} directions at elevation 0°")
        rows = rows[np.argsort(self.azimuth[rows], kind="stable")]
        return HrirSet(self.rate, self.azimuth[rows].copy(), self.elevation[rows].copy(), self.taps[rows].copy(),
                       self.source)

    def resampled(self, rate: float) -> HrirSet:
        """The same responses at another sample rate (polyphase filtering with a rational ratio).

        The ratio is exact for integer rates whose reduced ratio has a denominator up to 20,000
        (44,100 Hz → 24,414 Hz is 4069/7350), else its closest such approximation. The
        filter is zero-phase, so onsets and interaural delays keep their times; the
        measured responses start with enough silence (≥ 29 samples for KEMAR) for its
        pre-ringing. Results are cached per set and rate.

        Args:
            rate: The new sample rate in Hz.
        """
        if not rate > 0:
            raise HrirError(f"the sample rate must be positive, not {rate}")
        if rate == self.rate:
            return self
        return _resampled(self, float(rate))


@functools.lru_cache(maxsize=16)
def _resampled(hrirs: HrirSet, rate: float) -> HrirSet:
    ratio = (Fraction(rate) / Fraction(hrirs.rate)).limit_denominator(_MAX_RATIO_TERM)
    taps = signal.resample_poly(hrirs.taps, ratio.numerator, ratio.denominator, axis=1)
    return HrirSet(rate, hrirs.azimuth, hrirs.elevation, np.ascontiguousarray(taps), hrirs.source)
