"""Frequency-domain filters for block convolution: HRIR spectra on a fine azimuth grid, and the diffuse field's.

Both are made for overlap-save convolution with an FFT of ``n_fft`` points,
which takes responses of at most ``n_fft − block + 1`` taps: the HRIRs at the
rendering rate fit in half the FFT (``n_fft`` is the power of two at least
twice their length), so each block renders at least ``n_fft / 2`` frames.
"""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt

from ._hrir_set import HrirSet, wrap_degrees
from ._interpolation import HorizontalInterpolator

__all__ = ["AzimuthFilters", "azimuth_filters", "DiffuseFilters", "diffuse_filters", "fft_size"]


def fft_size(taps: int) -> int:
    """The FFT size for responses of *taps* samples: the power of two at least twice as long."""
    return 1 << (2 * taps - 1).bit_length()


class AzimuthFilters:
    """HRIR spectra every *resolution* degrees round the horizontal plane, read with linear interpolation.

    Neighbouring entries are 0.5° apart, where an ear's delay differs by at most a
    fifth of a sample at 44.1 kHz: mixing their spectra linearly loses at most
    0.2 dB at 16 kHz, and makes the filters a continuous function of the azimuth.

    Args:
        hrirs: The measured set, at the rendering rate.
        resolution: Degrees between table entries (360 / resolution must be an integer).

    Attributes:
        taps: Length of the responses.
        n_fft: The FFT size of the spectra.
        spectra: ``(entries, 2, n_fft // 2 + 1)`` complex spectra, left then right.
    """

    def __init__(self, hrirs: HrirSet, resolution: float = 0.5) -> None:
        entries = round(360.0 / resolution)
        interpolator = HorizontalInterpolator(hrirs)
        self.rate = hrirs.rate
        self.resolution = 360.0 / entries
        self.taps = interpolator.length
        self.n_fft = fft_size(self.taps)
        grid = np.arange(entries) * self.resolution
        responses = interpolator.at(grid)                                              # (entries, taps, 2)
        self.spectra = np.ascontiguousarray(np.fft.rfft(responses, self.n_fft, axis=1).transpose(0, 2, 1))
        self.spectra.setflags(write=False)

    def at(self, azimuths: npt.ArrayLike) -> npt.NDArray[np.complex128]:
        """Spectra ``(*shape, 2, bins)`` at azimuths of any *shape* (degrees, head frame, positive left)."""
        position = (wrap_degrees(azimuths) % 360.0) / self.resolution
        lower = np.floor(position).astype(np.intp)
        weight = (position - lower)[..., np.newaxis, np.newaxis]
        entries = len(self.spectra)
        lower %= entries
        upper = (lower + 1) % entries
        # In place, with three temporaries fewer (a turning head's renderer asks every block), and the weights
        # applied to the real and imaginary parts as reals (numpy would first make them complex): the same sum.
        result: npt.NDArray[np.complex128] = self.spectra.take(lower, axis=0)
        result.view(np.float64)[...] *= 1.0 - weight
        above = self.spectra.take(upper, axis=0)
        above.view(np.float64)[...] *= weight
        result += above
        return result


@functools.lru_cache(maxsize=8)
def azimuth_filters(hrirs: HrirSet, rate: float, resolution: float = 0.5) -> AzimuthFilters:
    """The :class:`AzimuthFilters` of *hrirs* resampled to *rate*, made once per set, rate and resolution."""
    return AzimuthFilters(hrirs.resampled(rate), resolution)


class DiffuseFilters:
    """Two noises in, two ears out: filters whose outputs have the statistics of a diffuse field.

    Independent white noises from D directions, each through its HRIRs, give ear
    signals that are Gaussian with the cross-spectral matrix
    ``C(f) = 1/D · Σ_d h_d(f) h_d(f)ᴴ`` (h_d: the pair of ear transfer functions).
    Two independent white noises through ``A(f)``, the Cholesky factor of ``C(f)``
    (left = a11·n1, right = a21·n1 + a22·n2), give ear signals with the same matrix,
    hence the same stationary Gaussian process, at the cost of two sources instead
    of D (Habets, Cohen & Gannot, "Generating nonstationary multisensor signals
    under a spatial coherence constraint", JASA 124(5), 2008, mix sensors this way).
    The factors are zero-phase; they are made causal with a delay of half the
    response length and tapered to that length, so they fit the block convolution.

    The filters are scaled so that unit-variance noises give a mean power of 1 over
    the two ears.

    Args:
        hrirs: The measured set, at the rendering rate.
        azimuths: Directions of the field in the horizontal plane, degrees (default: every
            measured one; KEMAR: 72, every 5°).

    Attributes:
        spectra: ``(2 noises, 2 ears, bins)`` complex spectra for an FFT of ``n_fft`` points.
    """

    def __init__(self, hrirs: HrirSet, azimuths: npt.ArrayLike | None = None) -> None:
        interpolator = HorizontalInterpolator(hrirs)
        directions = interpolator.azimuths if azimuths is None else np.atleast_1d(np.asarray(azimuths, float))
        self.rate = hrirs.rate
        self.taps = interpolator.length
        self.n_fft = fft_size(self.taps)
        self.directions = directions
        h = np.fft.rfft(interpolator.at(directions), self.n_fft, axis=1)              # (D, bins, ears)
        c11 = np.mean(np.abs(h[..., 0]) ** 2, axis=0)
        c22 = np.mean(np.abs(h[..., 1]) ** 2, axis=0)
        c21 = np.mean(h[..., 1] * np.conj(h[..., 0]), axis=0)
        a11 = np.sqrt(c11)
        a21 = c21 / np.maximum(a11, 1e-300)
        a22 = np.sqrt(np.maximum(c22 - np.abs(a21) ** 2, 0.0))
        zero = np.zeros_like(a11)
        factors = np.stack([np.stack([a11, a21]), np.stack([zero, a22])])             # (noise, ear, bins)
        # Zero-phase responses, centred at taps/2 and tapered to taps samples.
        responses = np.roll(np.fft.irfft(factors, self.n_fft, axis=-1), self.taps // 2, axis=-1)[..., :self.taps]
        responses *= np.hanning(self.taps + 2)[1:-1]
        power = np.sum(responses**2, axis=(0, 2))                                      # per ear
        responses /= np.sqrt(power.mean())
        self.responses = responses
        self.spectra = np.fft.rfft(responses, self.n_fft, axis=-1)
        self.spectra.setflags(write=False)


@functools.lru_cache(maxsize=8)
def diffuse_filters(hrirs: HrirSet, rate: float) -> DiffuseFilters:
    """The :class:`DiffuseFilters` of *hrirs*' horizontal plane at *rate*, made once per set and rate."""
    return DiffuseFilters(hrirs.resampled(rate))
