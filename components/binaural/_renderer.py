"""The streaming binaural renderer: sources through measured HRIRs at the ears of a turning head.

Each call renders the next block of frames. The head azimuth (and each source's
room azimuth) moves linearly from its value at the end of the previous block to
the one given, the short way round. The block is cut into sub-blocks of at
least half an FFT. Each sub-block is convolved by overlap-save with two filters
per source and ear: those of the directions at its start and at its end. The
two results are cross-faded linearly across the sub-block. Every output sample
is then a convex mix of two time-invariant convolutions of the whole input, so
a turning head gives no discontinuity: the filter at the end of one sub-block
is the one at the start of the next. The sources are summed in the frequency
domain, so a sub-block costs one forward FFT per source and four inverse FFTs
whatever the number of sources. A still head needs one filter per sub-block and
two inverse FFTs.

A diffuse field (:class:`~._filters.DiffuseFilters`) joins as two more noise
inputs with fixed filters. Independent white sensor noise is added at each ear.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import fft

from ._convolution import through_filters
from ._directions import DirectionFilters, direction_filters
from ._errors import HrirError
from ._filters import azimuth_filters, diffuse_filters
from ._hrir_set import HrirSet, wrap_degrees
from ._kemar import load_kemar

__all__ = ["BinauralRenderer"]


def _short_way(start: npt.NDArray[np.float64], end: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The step from *start* to *end* (degrees), the short way round."""
    return wrap_degrees(end - start)


class BinauralRenderer:
    """Renders sources at given room azimuths to the two ears of a head that may turn.

    Args:
        rate: Sample rate in Hz (the HRIRs are resampled to it).
        sources: How many sources each block brings.
        hrirs: The measured set (default: the MIT KEMAR set, :func:`load_kemar`).
        diffuse_level: RMS of the diffuse noise field at the ears in dB re full scale
            (mean power of the two ears), or None for none.
        sensor_noise: RMS of the independent noise added at each ear, dB re full scale, or None.
        seed: Seed of the diffuse field and the sensor noise.
        resolution: Degrees between the precomputed filters (linear interpolation between them).

    A source with a dry signal of RMS 1 straight ahead gives ear signals of RMS
    about 1 (KEMAR's frontal responses have unit energy within 0.01 dB).
    """

    def __init__(self, rate: float, sources: int, *, hrirs: HrirSet | None = None,
                 diffuse_level: float | None = None, sensor_noise: float | None = None, seed: int = 0,
                 resolution: float = 0.5) -> None:
        if sources < 0:
            raise HrirError(f"the number of sources cannot be negative ({sources})")
        hrirs = hrirs if hrirs is not None else load_kemar()
        self.rate = float(rate)
        self.sources = sources
        self.hrirs = hrirs
        self.filters = azimuth_filters(hrirs, self.rate, resolution)
        self._directions: DirectionFilters | None = None
        self.n_fft = self.filters.n_fft
        self._keep = self.filters.taps - 1                       # input history overlap-save needs
        self.block = self.n_fft - self._keep                     # frames per sub-block
        self._history = np.zeros((sources, self._keep))
        self._head: float | None = None
        self._azimuths: npt.NDArray[np.float64] | None = None
        self._elevations = np.zeros(sources)
        self._rng = np.random.default_rng(seed)
        self._diffuse = None
        self._diffuse_history = np.zeros((0, self._keep))
        if diffuse_level is not None:
            diffuse = diffuse_filters(hrirs, self.rate)
            self._diffuse = diffuse.spectra * 10.0 ** (diffuse_level / 20.0)          # (noise, ear, bins)
            self._diffuse_history = np.zeros((2, self._keep))
        self._sensor = 10.0 ** (sensor_noise / 20.0) if sensor_noise is not None else 0.0
        self._fade: tuple[int, npt.NDArray[np.float64], npt.NDArray[np.float64]] | None = None  # frames, ramp, 1 - ramp
        self.frames_rendered = 0

    @property
    def head_azimuth(self) -> float | None:
        """The head azimuth at the end of the last block (degrees; None before the first)."""
        return self._head

    def render(self, dry: npt.ArrayLike, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
               source_elevations: npt.ArrayLike | None = None) -> npt.NDArray[np.float64]:
        """Render the next block.

        Args:
            dry: ``(sources, frames)`` dry signals, at their levels (full scale 1).
            head_azimuth: Head azimuth at the end of the block, degrees in the room,
                positive to the left. It moves linearly from the previous block's.
            source_azimuths: ``(sources,)`` room azimuths at the end of the block
                (degrees, positive to the left); None keeps the previous ones (required
                on the first call when there are sources).
            source_elevations: ``(sources,)`` elevations at the end of the block relative to the ears'
                horizontal plane, degrees, positive up (moving linearly from the previous block's);
                None keeps the previous ones (at first, 0°). Elevations other than 0° are heard
                through :class:`~._directions.DirectionFilters`.

        Returns:
            ``(frames, 2)`` float samples, left then right.
        """
        signals = np.asarray(dry, dtype=np.float64)
        if signals.ndim == 1 and self.sources == 1:
            signals = signals[np.newaxis]
        if signals.ndim != 2 or signals.shape[0] != self.sources:
            raise HrirError(f"dry signals must be ({self.sources}, frames), not {signals.shape}")
        frames = signals.shape[1]
        head_end = float(head_azimuth)
        if source_azimuths is not None:
            azimuth_end = np.asarray(source_azimuths, dtype=np.float64).reshape(self.sources)
        elif self._azimuths is not None or self.sources == 0:
            azimuth_end = self._azimuths if self._azimuths is not None else np.zeros(0)
        else:
            raise HrirError("the first block needs the sources' azimuths")
        elevation_start = self._elevations
        if source_elevations is not None:
            self._elevations = np.asarray(source_elevations, dtype=np.float64).reshape(self.sources)
            if self._head is None:
                elevation_start = self._elevations
        elevation_end = self._elevations
        head_start = self._head if self._head is not None else head_end
        azimuth_start = self._azimuths if self._azimuths is not None else azimuth_end
        head_step = float(_short_way(np.asarray(head_start), np.asarray(head_end)))
        azimuth_step = _short_way(azimuth_start, azimuth_end)
        self._head = head_start + head_step
        self._azimuths = azimuth_start + azimuth_step
        if frames == 0:
            return np.zeros((0, 2))

        count = math.ceil(frames / self.block)
        ends = np.minimum(np.arange(1, count + 1) * self.block, frames)
        # Where each sub-block starts and ends, as a fraction of the block: (count + 1,) boundaries.
        fraction = np.concatenate([[0.0], ends / frames])
        relative = (azimuth_start[:, np.newaxis] + azimuth_step[:, np.newaxis] * fraction
                    - (head_start + head_step * fraction))                                   # (sources, count + 1)
        moving = (head_step != 0.0 or bool(np.any(azimuth_step != 0.0))
                  or bool(np.any(elevation_end != elevation_start)))
        elevated = bool(elevation_start.any() or elevation_end.any())
        elevation = (elevation_start[:, np.newaxis] + (elevation_end - elevation_start)[:, np.newaxis] * fraction
                     if elevated else None)

        spectra = self._segments(signals, count, self._history)                              # (src, count, bins)
        self._history = self._advance(self._history, signals)
        if moving:
            filters = self._filters_at(relative, elevation)                                  # (src, count+1, 2, bins)
            start = through_filters(spectra, filters[:, :-1])
            end = through_filters(spectra, filters[:, 1:])
        else:
            filters = self._filters_at(relative[:, 0], None if elevation is None else elevation[:, 0])  # (src, 2, bins)
            start = through_filters(spectra, filters[:, np.newaxis])
            end = start
        if self._diffuse is not None:
            noise = self._rng.standard_normal((2, frames))
            diffuse = through_filters(self._segments(noise, count, self._diffuse_history), self._diffuse[:, np.newaxis])
            self._diffuse_history = self._advance(self._diffuse_history, noise)
            start += diffuse                                  # in place: both are new (or one, when still)
            if moving:
                end += diffuse
        out = self._inverse(start, count, frames)
        if moving:
            # Fade from the start filters to the end filters across each sub-block.
            ramp, rest = self._fade_of(frames, ends)
            out = out * rest + self._inverse(end, count, frames) * ramp
        if self._sensor:
            out += self._sensor * self._rng.standard_normal((frames, 2))
        self.frames_rendered += frames
        return out

    def _filters_at(self, azimuths: npt.NDArray[np.float64],
                    elevations: npt.NDArray[np.float64] | None) -> npt.NDArray[np.complex128]:
        """The filters at head azimuths (and elevations, if any is not 0°) of one shape."""
        if elevations is None:
            return self.filters.at(azimuths)
        if self._directions is None:
            self._directions = direction_filters(self.hrirs, self.rate)
        return self._directions.at(azimuths, elevations)

    def _segments(self, signals: npt.NDArray[np.float64], count: int,
                  history: npt.NDArray[np.float64]) -> npt.NDArray[np.complex128]:
        """Spectra of the overlap-save input segments: ``(inputs, count, bins)``."""
        inputs, frames = signals.shape
        padded = np.zeros((inputs, self._keep + count * self.block + (self.n_fft - self.block - self._keep)))
        padded[:, :self._keep] = history
        padded[:, self._keep:self._keep + frames] = signals
        # Overlapping views of the padded signals, made by the array's constructor (sliding_window_view's checks
        # cost a third of the FFTs here, as_strided several times what the constructor costs).
        step, sample = padded.strides
        segments = np.ndarray((inputs, count, self.n_fft), padded.dtype, padded, 0, (step, self.block * sample, sample))
        return np.asarray(fft.rfft(segments, axis=-1))       # scipy's: numpy's makes its plan every call

    def _advance(self, history: npt.NDArray[np.float64], signals: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The last ``taps − 1`` input samples after *signals*."""
        return np.concatenate([history, signals], axis=1)[:, -self._keep:] if self._keep else history

    def _inverse(self, spectra: npt.NDArray[np.complex128], count: int, frames: int) -> npt.NDArray[np.float64]:
        """``(frames, 2)`` output samples from the ``(count, ears, bins)`` output spectra of the sub-blocks."""
        valid = fft.irfft(spectra, self.n_fft, axis=-1)[..., self._keep:self._keep + self.block]
        return np.ascontiguousarray(valid.transpose(0, 2, 1).reshape(count * self.block, 2)[:frames])

    def _fade_of(self, frames: int, ends: npt.NDArray[np.intp]) -> tuple[npt.NDArray[np.float64],
                                                                         npt.NDArray[np.float64]]:
        """The sub-blocks' fades in a block of *frames* whose sub-blocks end at *ends*: ``(frames, 1)``, and 1 minus it.

        Frame j of a sub-block has faded by (j + 1) / its length, reaching 1 at its end. Kept for the next block
        of as many frames (a stream's blocks are mostly of one size).
        """
        if self._fade is None or self._fade[0] != frames:
            starts = np.concatenate([[0], ends[:-1]])
            lengths = ends - starts
            within = np.arange(int(ends[-1])) - np.repeat(starts, lengths)
            ramp = ((within + 1) / np.repeat(lengths, lengths))[:, np.newaxis]
            self._fade = (frames, ramp, 1.0 - ramp)
        return self._fade[1], self._fade[2]
