"""Streaming convolution of several inputs into two ears: one for filters that change, one for long fixed ones.

:class:`FadingConvolver` convolves by overlap-save with filters that may change at
every call: the call's output fades linearly from the convolution with the old
filters to the one with the new, so that every output sample is a convex mix of
two time-invariant convolutions and a change makes no discontinuity.

:class:`LateConvolver` convolves with long fixed filters (a room's late tail) by
uniformly partitioned overlap-save with a frequency-domain delay line: blocks of
B frames, partitions of B taps. A filter silent for its first B taps needs no
input later than B frames before its output, so each block's output is computed
as soon as the block before it is complete, one block ahead: any call, of any
number of frames, finds its output ready, and the block can be large (cheap per
frame) however small the calls are.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import fft

from ._errors import BinauralError
from ._filters import fft_size

__all__ = ["FadingConvolver", "LateConvolver", "StagedLateConvolver", "through_filters"]


def through_filters(spectra: npt.NDArray[np.complex128],
                    filters: npt.NDArray[np.complex128]) -> npt.NDArray[np.complex128]:
    """The ears' spectra of inputs through their filters: ``Σᵢ spectra[i][..., newaxis, :] · filters[i]``.

    Args:
        spectra: ``(inputs, ..., bins)`` the inputs' spectra (blocks of them, say).
        filters: ``(inputs, ..., ears, bins)`` their filters, broadcast against them.

    Returns:
        ``(..., ears, bins)``: the sum ``einsum("ikf,ikef->kef")`` and its kin make, as a product and a sum an
        input (einsum's complex loop has no vector instructions: it was a fifth of a room renderer's instructions).
    """
    shape = np.broadcast_shapes(spectra.shape[1:-1] + (1, spectra.shape[-1]), filters.shape[1:])
    out = np.empty(shape, dtype=np.complex128)
    if len(spectra) == 0:
        out[...] = 0.0
        return out
    np.multiply(spectra[0][..., np.newaxis, :], filters[0], out=out)
    term = np.empty_like(out)
    for signal, response in zip(spectra[1:], filters[1:], strict=True):
        np.multiply(signal[..., np.newaxis, :], response, out=term)
        out += term
    return out


class FadingConvolver:
    """Overlap-save convolution of ``inputs`` signals into 2 ears, with filters faded from call to call.

    Args:
        inputs: How many input signals.
        taps: The longest filter.
    """

    def __init__(self, inputs: int, taps: int) -> None:
        self.inputs = inputs
        self.taps = taps
        self.n_fft = fft_size(taps)
        self._keep = taps - 1
        self.block = self.n_fft - self._keep
        self._history = np.zeros((inputs, self._keep))
        self._fade: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None = None   # a call's ramp, 1 - ramp

    def spectra(self, responses: npt.NDArray[np.float64]) -> npt.NDArray[np.complex128]:
        """Filter spectra ``(inputs, 2, bins)`` of responses ``(inputs, taps, 2)``."""
        if responses.shape[1] > self.taps:
            raise BinauralError(f"responses of {responses.shape[1]} taps do not fit a convolver of {self.taps}")
        return np.asarray(fft.rfft(responses, self.n_fft, axis=1).transpose(0, 2, 1))

    def convolve(self, signals: npt.NDArray[np.float64], start: npt.NDArray[np.complex128],
                 end: npt.NDArray[np.complex128] | None = None) -> npt.NDArray[np.float64]:
        """The next ``(frames, 2)`` of the inputs through the filters, fading from *start* to *end*.

        Args:
            signals: ``(inputs, frames)``.
            start: ``(inputs, 2, bins)`` spectra at the start of these frames.
            end: The spectra at their end (None: *start* throughout).
        """
        frames = signals.shape[1]
        if frames == 0:
            return np.zeros((0, 2))
        count = math.ceil(frames / self.block)
        padded = np.zeros((self.inputs, self._keep + count * self.block))
        padded[:, :self._keep] = self._history
        padded[:, self._keep:self._keep + frames] = signals
        self._history = padded[:, frames:frames + self._keep].copy()
        # Overlapping views, made by the array's constructor (as_strided costs several times as much).
        step, sample = padded.strides
        segments = np.ndarray((self.inputs, count, self.n_fft), padded.dtype, padded, 0,
                              (step, self.block * sample, sample))
        # scipy's FFT (numpy's, the same, makes its plan at every call: a tenth of its time here).
        spectra = fft.rfft(segments, axis=-1)                                                   # (in, count, bins)
        out = self._inverse(through_filters(spectra, start[:, np.newaxis]), frames)
        if end is None or end is start:
            return out
        if self._fade is None or len(self._fade[0]) != frames:       # calls are mostly of one size: kept
            ramp = (np.arange(1, frames + 1) / frames)[:, np.newaxis]
            self._fade = (ramp, 1.0 - ramp)
        ramp, rest = self._fade
        return np.asarray(out * rest + self._inverse(through_filters(spectra, end[:, np.newaxis]), frames) * ramp)

    def _inverse(self, spectra: npt.NDArray[np.complex128], frames: int) -> npt.NDArray[np.float64]:
        count = spectra.shape[0]
        valid = fft.irfft(spectra, self.n_fft, axis=-1)[..., self._keep:self._keep + self.block]
        return np.ascontiguousarray(valid.transpose(0, 2, 1).reshape(count * self.block, 2)[:frames])


class LateConvolver:
    """Inputs through long fixed two-ear filters that are silent for their first *block* taps, in blocks.

    Args:
        responses: ``(inputs, taps, 2)`` filters; taps before *block* must be zero (they are ignored).
        block: Frames per block and taps per partition (a power of two is fastest).
    """

    def __init__(self, responses: npt.NDArray[np.float64], block: int) -> None:
        inputs, taps, _ = responses.shape
        self.inputs = inputs
        self.block = block
        shifted = responses[:, block:]                                   # the filter one block early
        partitions = max(1, math.ceil(shifted.shape[1] / block))
        padded = np.zeros((inputs, partitions * block, 2))
        padded[:, :shifted.shape[1]] = shifted
        parts = padded.reshape(inputs, partitions, block, 2)
        self._filters = np.fft.rfft(parts, 2 * block, axis=2).transpose(1, 0, 3, 2).copy()   # (part, in, ears, bins)
        # The delay line of input spectra, newest first, written twice (at q and q + partitions) so that the
        # window lines[q:q + partitions] is always in order without moving it: no roll per block.
        self._lines = np.zeros((2 * partitions, inputs, block + 1), dtype=np.complex128)
        self._newest = 0
        self._frame = np.zeros((inputs, 2 * block))  # the last complete block, then the one filling
        self._filled = 0                             # frames of the filling block, and of its output used
        self._ready = np.zeros((2, block))           # the output of the filling block (the first: silent)

    @property
    def partitions(self) -> int:
        """How many partitions of *block* taps the filters were cut into."""
        return int(self._filters.shape[0])

    def convolve(self, signals: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The next ``(frames, 2)`` of the inputs ``(inputs, frames)`` through the filters."""
        frames, block = signals.shape[1], self.block
        out = np.empty((frames, 2))
        done = 0
        while done < frames:
            filled = self._filled
            take = min(frames - done, block - filled)
            self._frame[:, block + filled:block + filled + take] = signals[:, done:done + take]
            out[done:done + take] = self._ready[:, filled:filled + take].T
            done += take
            self._filled = filled + take
            if self._filled == block:
                self._step()
        return out

    def _step(self) -> None:
        """The filling block is complete: the output of the next one."""
        block, partitions = self.block, self.partitions
        self._newest = (self._newest - 1) % partitions
        spectrum = fft.rfft(self._frame, axis=1)
        self._lines[self._newest] = spectrum
        self._lines[self._newest + partitions] = spectrum
        window = self._lines[self._newest:self._newest + partitions]
        mixed = through_filters(window.reshape(-1, block + 1), self._filters.reshape(-1, 2, block + 1))
        self._ready = fft.irfft(mixed, 2 * block, axis=-1)[:, block:]
        self._frame[:, :block] = self._frame[:, block:]
        self._filled = 0


class StagedLateConvolver:
    """A long fixed filter cut into stages of growing blocks: B, 4B, 16B... (non-uniform partitions).

    Stage *i* convolves with the taps from ``B·4^i`` to ``B·4^(i+1)`` in blocks of ``B·4^i``
    (:class:`LateConvolver`, three partitions each), the last stage with the rest: the
    stages grow geometrically, so the work per frame grows with the number of stages, not with the length.

    Args:
        responses: ``(inputs, taps, 2)`` filters, silent for their first *block* taps.
        block: The first stage's block (frames).
    """

    def __init__(self, responses: npt.NDArray[np.float64], block: int, growth: int = 4) -> None:
        taps = responses.shape[1]
        self.stages: list[LateConvolver] = []
        start = block
        while start < taps:
            end = taps if start * growth * 2 > taps else start * growth
            part = np.zeros((responses.shape[0], end, 2))
            part[:, start:end] = responses[:, start:end]
            self.stages.append(LateConvolver(part, start))
            start = end

    def convolve(self, signals: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The next ``(frames, 2)`` of the inputs ``(inputs, frames)`` through the filters."""
        out = np.zeros((signals.shape[1], 2))
        for stage in self.stages:
            out += stage.convolve(signals)
        return out
