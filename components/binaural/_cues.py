"""Interaural cues measured from two ear signals: the GCC-PHAT time difference and third-octave level differences.

The GCC-PHAT (Knapp & Carter 1976, "The generalized correlation method for
estimation of time delay", IEEE Trans. ASSP 24(4)) whitens the cross-spectrum so
that every frequency counts alike, which sharpens the correlation peak.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["gcc_phat_itd", "third_octave_centres", "band_edges", "band_ilds"]


def gcc_phat_itd(left: npt.ArrayLike, right: npt.ArrayLike, max_lag: int | None = None) -> float:
    """The interaural time difference by GCC-PHAT: right-ear arrival minus left-ear arrival.

    Args:
        left: Left-ear samples.
        right: Right-ear samples (same length).
        max_lag: Largest lag searched, in samples (default: the whole signal).

    Returns:
        Samples (fractional, by a parabola through the peak and its neighbours); positive
        when the left ear leads, that is for a source on the left.
    """
    x = np.asarray(left, dtype=np.float64)
    y = np.asarray(right, dtype=np.float64)
    n = len(x)
    n_fft = 1 << (2 * n - 1).bit_length()
    cross = np.conj(np.fft.rfft(x, n_fft)) * np.fft.rfft(y, n_fft)
    cross /= np.maximum(np.abs(cross), 1e-300)
    correlation = np.fft.irfft(cross, n_fft)
    limit = n - 1 if max_lag is None else min(max_lag, n - 1)
    lags = np.arange(-limit, limit + 1)
    values = correlation[lags % n_fft]
    peak = int(np.argmax(values))
    offset = 0.0
    if 0 < peak < len(values) - 1:
        below, at, above = values[peak - 1], values[peak], values[peak + 1]
        curvature = below - 2.0 * at + above
        if curvature < 0:
            offset = 0.5 * (below - above) / curvature
    return float(lags[peak] + offset)


def third_octave_centres(low: float = 125.0, high: float = 16_000.0) -> npt.NDArray[np.float64]:
    """The base-10 third-octave centre frequencies (1000 Hz · 10^(k/10)) from *low* to *high* Hz."""
    first = int(np.ceil(10.0 * np.log10(low / 1000.0) - 1e-9))
    last = int(np.floor(10.0 * np.log10(high / 1000.0) + 1e-9))
    return np.asarray(1000.0 * 10.0 ** (np.arange(first, last + 1) / 10.0))


def band_edges(centres: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """``(bands, 2)`` lower and upper edges of third-octave bands around *centres*."""
    c = np.asarray(centres, dtype=np.float64)
    return np.stack([c * 10.0 ** -0.05, c * 10.0 ** 0.05], axis=-1)


def band_ilds(left: npt.ArrayLike, right: npt.ArrayLike, rate: float,
              centres: npt.ArrayLike | None = None) -> npt.NDArray[np.float64]:
    """Interaural level differences per band, left over right, in dB.

    Works on impulse responses (their transfer functions' band energies) and on long
    signals alike (the band energies of their spectra).

    Args:
        left: Left-ear samples.
        right: Right-ear samples.
        rate: Sample rate in Hz.
        centres: Band centres in Hz (default: the third octaves from 125 Hz to 16 kHz
            that lie below 0.45 × *rate*).
    """
    x = np.asarray(left, dtype=np.float64)
    y = np.asarray(right, dtype=np.float64)
    if centres is None:
        centres = third_octave_centres(125.0, min(16_000.0, 0.45 * rate / 10.0 ** 0.05))
    edges = band_edges(centres)
    # Short responses are zero-padded, so that the narrow low bands hold several frequencies.
    n_fft = max(len(x), 8192)
    freqs = np.fft.rfftfreq(n_fft, 1.0 / rate)
    power_left = np.abs(np.fft.rfft(x, n_fft)) ** 2
    power_right = np.abs(np.fft.rfft(y, n_fft)) ** 2
    inside = (freqs[np.newaxis, :] >= edges[:, :1]) & (freqs[np.newaxis, :] < edges[:, 1:])
    energy_left = inside @ power_left
    energy_right = inside @ power_right
    return np.asarray(10.0 * np.log10(np.maximum(energy_left, 1e-300) / np.maximum(energy_right, 1e-300)))
