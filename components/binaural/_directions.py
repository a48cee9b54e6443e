"""HRIRs in any direction: the direct sound's filters between elevation rings, the reflections' nearest measurement.

**The direct sound** is the cue a listener localises, so it is interpolated
finely. Measured sets come in rings of constant elevation (the MIT KEMAR:
-40° to 90° every 10°, each ring every 5° to 30° in azimuth). Within a ring,
responses come from :class:`~._filters.AzimuthFilters` (time-aligned
interpolation between measured azimuths, tabulated every 0.5° in the
horizontal plane and every 1° elsewhere). Between rings, the spectra of the two
rings either side are mixed linearly: neighbouring rings 10° apart differ in an
ear's delay by under half a sample near the horizontal plane, where sources
usually are. Below the lowest ring and above the highest, the outer ring serves.
A ring of fewer than three directions gives its nearest measurement at every
azimuth. Tables are made the first time a ring is needed.

**Reflections** arrive from many directions at once and are heard as the room,
not localised one by one: each takes the measured response nearest its
direction, by great-circle angle (at most 3.6° away on the MIT KEMAR's grid).
"""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt

from ._filters import AzimuthFilters, fft_size
from ._hrir_set import HrirSet, wrap_degrees

__all__ = ["DirectionFilters", "direction_filters", "NearestDirections", "unit_vectors"]

#: Rings closer than this to each other (degrees) are one ring.
_RING_TOLERANCE = 0.05


def unit_vectors(azimuth: npt.ArrayLike, elevation: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """``(n, 3)`` unit vectors of directions in degrees (x ahead, y left, z up)."""
    a, e = np.radians(np.atleast_1d(azimuth)), np.radians(np.atleast_1d(elevation))
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)


class _ConstantRing:
    """A ring too sparse to interpolate: its measurement nearest in azimuth, as a spectrum."""

    def __init__(self, ring: HrirSet, n_fft: int) -> None:
        self.azimuth = ring.azimuth
        self.spectra = np.fft.rfft(ring.taps, n_fft, axis=1).transpose(0, 2, 1)            # (n, ears, bins)

    def at(self, azimuths: npt.ArrayLike) -> npt.NDArray[np.complex128]:
        az = np.asarray(azimuths, dtype=np.float64)
        distance = np.abs(wrap_degrees(az[..., np.newaxis] - self.azimuth))
        result: npt.NDArray[np.complex128] = self.spectra[np.argmin(distance, axis=-1)]
        return result


class DirectionFilters:
    """Spectra of the HRIRs at any (azimuth, elevation), for the block convolution of the direct sound.

    Args:
        hrirs: The measured set, at the rendering rate.
        horizontal: The table of the 0° ring, if already made (shared with the plain azimuth renderer).

    Attributes:
        rings: The measured elevations, sorted, degrees.
        taps: Length of the responses; n_fft: the FFT size of the spectra.
    """

    def __init__(self, hrirs: HrirSet, horizontal: AzimuthFilters | None = None) -> None:
        self.hrirs = hrirs
        rounded = np.round(hrirs.elevation / _RING_TOLERANCE) * _RING_TOLERANCE
        self.rings = np.unique(rounded)
        self._rounded = rounded
        self.taps = hrirs.length
        self.n_fft = fft_size(self.taps)
        self._tables: dict[int, AzimuthFilters | _ConstantRing] = {}
        if horizontal is not None and 0.0 in self.rings:
            self._tables[int(np.flatnonzero(self.rings == 0.0)[0])] = horizontal

    def _table(self, index: int) -> AzimuthFilters | _ConstantRing:
        table = self._tables.get(index)
        if table is None:
            rows = np.flatnonzero(self._rounded == self.rings[index])
            ring = HrirSet(self.hrirs.rate, self.hrirs.azimuth[rows].copy(), np.zeros(len(rows)),
                           self.hrirs.taps[rows].copy(), self.hrirs.source)
            if len(rows) >= 3:
                table = AzimuthFilters(ring, 0.5 if self.rings[index] == 0.0 else 1.0)
            else:
                table = _ConstantRing(ring, self.n_fft)
            self._tables[index] = table
        return table

    def at(self, azimuths: npt.ArrayLike, elevations: npt.ArrayLike) -> npt.NDArray[np.complex128]:
        """Spectra ``(*shape, 2, bins)`` at head azimuths and elevations (degrees) of one *shape*."""
        az = np.asarray(azimuths, dtype=np.float64)
        el = np.clip(np.broadcast_to(np.asarray(elevations, dtype=np.float64), az.shape), self.rings[0],
                     self.rings[-1])
        last = len(self.rings) - 1
        lower = np.clip(np.searchsorted(self.rings, el, side="right") - 1, 0, max(last - 1, 0))
        upper = np.minimum(lower + 1, last)
        span = self.rings[upper] - self.rings[lower]
        weight = np.clip((el - self.rings[lower]) / np.where(span > 0, span, 1.0), 0.0, 1.0)
        result = np.zeros((*az.shape, 2, self.n_fft // 2 + 1), dtype=np.complex128)
        for rings, share in ((lower, 1.0 - weight), (upper, weight)):
            for index in np.unique(rings[share > 0]):
                used = (rings == index) & (share > 0)
                result[used] += share[used][:, np.newaxis, np.newaxis] * self._table(int(index)).at(az[used])
        return result


@functools.lru_cache(maxsize=8)
def direction_filters(hrirs: HrirSet, rate: float) -> DirectionFilters:
    """The :class:`DirectionFilters` of *hrirs* at *rate*, sharing the horizontal table of the azimuth renderer."""
    from ._filters import azimuth_filters

    resampled = hrirs.resampled(rate)
    horizontal = azimuth_filters(hrirs, rate, 0.5) if np.any(np.abs(resampled.elevation) < _RING_TOLERANCE) else None
    return DirectionFilters(resampled, horizontal)


class NearestDirections:
    """The measured response nearest to each of many directions (for reflections).

    Args:
        hrirs: The measured set, at the rendering rate.
    """

    def __init__(self, hrirs: HrirSet) -> None:
        self.hrirs = hrirs
        self._measured = np.ascontiguousarray(unit_vectors(hrirs.azimuth, hrirs.elevation).T)   # (3, n)
        # Directions per matrix product: OpenBLAS threads products of over 2¹⁸ multiplications; keep to half that.
        self._rows = max(1, (1 << 17) // (3 * max(1, len(hrirs.azimuth))))

    def indices(self, azimuths: npt.ArrayLike, elevations: npt.ArrayLike) -> npt.NDArray[np.intp]:
        """Indices into the set of the measured directions nearest (*azimuths*, *elevations*), degrees."""
        # A matrix product (einsum's loop over three coordinates takes ten times as long), in slices of rows small
        # enough that BLAS keeps to one thread: a threaded call waits for its threads on a busy machine.
        wanted = unit_vectors(azimuths, elevations)
        found = np.empty(len(wanted), dtype=np.intp)
        for first in range(0, len(wanted), self._rows):
            found[first:first + self._rows] = np.argmax(wanted[first:first + self._rows] @ self._measured, axis=1)
        return found
