"""Glimpses: the evidence of each time-frequency unit about the direction of the one source that dominates it.

Speech is sparse in time and frequency: in a mixture of talkers most units
(one frame, one auditory band) are dominated by one of them, and in a room the
units where the direct sound leads (onsets) say more than those the
reverberation fills. So the ears' signals are judged unit by unit, as the
Two!Ears front end and Ma, May & Brown (IEEE/ACM TASLP 25(12), 2017) judged
them per gammatone channel and frame, and each unit says how well each
direction explains it and how much it should count:

1. **Units.** Short-time spectra (the setup's window, frame and hop), their
   bins grouped into bands one ERB wide (Glasberg & Moore, Hearing Research 47,
   1990) from the lowest to the highest frequency analysed: an FFT stand-in for
   a gammatone filterbank, at a fraction of its cost.
2. **Match.** For each template direction θ (the measured horizontal HRIRs, as
   for :class:`~._localiser.BinauralLocaliser`), the normalised steering
   vector h_θ(f) = (H_L, H_R)/‖·‖ and the unit's ear spectra x(f): the share of
   the unit's energy that h_θ explains, Σ_f |h_θᴴ x|² / Σ_f ‖x‖², 1 for a unit
   of that direction alone. It weighs interaural phase and level together, bin
   by bin (the steered-response form of GCC-PHAT with the HRTF's own phase).
3. **Likelihood.** The unit's log-likelihood of θ is its match less the best
   match, times a sharpness that grows with the square root of the bins in the
   band (a band of more bins is a surer witness), carried from the templates
   to the 1° grid by a periodic cubic spline. :func:`tempered` splits it into
   a lateral part (θ and its front/back mirror image together) and the
   templates' preference between them, and weighs the latter.
4. **Weight** (how much the unit counts), the product of:
   - its level, compressed (power^0.3, as loudness grows), so that quiet units
     count less without loud ones taking all;
   - its signal-to-noise ratio ρ/(1 + ρ), when the noise was learnt (and the
     unit's evidence is shared in that proportion with the background: noise
     alone looks like a source straight ahead or behind). The noise's power in
     a band of k bins fluctuates from frame to frame by about 1/√k of its mean
     (two ears, Hann-windowed bins); ρ counts only the power above the mean plus
     ``noise_margin`` such deviations, so that noise alone makes almost no unit
     that counts. What the unit's noise share would weigh is kept too
     (:attr:`Glimpses.noise_weight`): against the weights, it says how much of
     what was heard rose above the noise at all;
   - its interaural coherence (Faller & Merimaa, JASA 116(5), 2004), raised to
     a power: |⟨X_L X_R*⟩| / √(⟨|X_L|²⟩⟨|X_R|²⟩) averaged over a few frames
     (recursively, causal) and over the band. One plane wave gives 1;
     reverberation, diffuse noise and overlapping talkers lower it, and their
     units mislead;
   - an onset bonus (the precedence effect: the direct sound arrives first):
     1 + the rise of the band's power since the previous frame (the natural
     logarithm of their ratio, clipped at 3).

The parameters are the :class:`GlimpseParameters` (set on training scenes
that the experiment's test scenes never use, ``examples/localisation_training.py``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt
from scipy import interpolate

from ._errors import LocalisationError
from ._hrir_set import HrirSet
from ._likelihood import GRID_DEGREES

__all__ = ["GlimpseParameters", "GlimpseAnalyser", "Glimpses", "erb_bands", "tempered"]

#: Each azimuth of the 1° grid's front/back mirror image across the interaural axis (180° − θ), as an index.
_MIRROR = np.mod(180 - np.arange(len(GRID_DEGREES)), len(GRID_DEGREES))


@dataclasses.dataclass(frozen=True)
class GlimpseParameters:
    """How units are judged and weighed (see the module's docstring).

    Attributes:
        sharpness: Log-likelihood per unit of match, for a band of one bin (times √bins).
        level_power: Exponent of a unit's power in its weight.
        coherence_power: Exponent of a unit's interaural coherence in its weight.
        coherence_memory: Weight of the past in the recursive average of the cross-spectra (0: none).
        onset_gain: Weight of the rise of a band's power since the previous frame (natural log of the ratio).
        bands_per_erb: Bands per ERB (1: bands one ERB wide).
        noise_margin: Deviations of the noise's band power above its mean that a unit's power must pass
            before any of it counts as signal (0: its mean).
    """

    sharpness: float = 8.0
    level_power: float = 0.3
    coherence_power: float = 4.0
    coherence_memory: float = 0.5
    onset_gain: float = 1.0
    bands_per_erb: float = 1.0
    noise_margin: float = 3.0


def _erb_number(frequency: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The ERB-number (Cams) of *frequency* in Hz (Glasberg & Moore 1990)."""
    return np.asarray(21.4 * np.log10(1.0 + 0.00437 * frequency))


def erb_bands(frequencies: npt.ArrayLike, per_erb: float = 1.0) -> list[npt.NDArray[np.intp]]:
    """The indices of *frequencies* (ascending, Hz) grouped into consecutive bands 1/*per_erb* ERB wide.

    Bands that would hold no frequency are left out, so a low band of one bin stands alone.
    """
    values = np.asarray(frequencies, dtype=np.float64)
    if len(values) == 0:
        return []
    number = _erb_number(values) * per_erb
    band = np.floor(number - number[0]).astype(np.intp)
    return [np.flatnonzero(band == b) for b in np.unique(band)]


@dataclasses.dataclass(frozen=True)
class Glimpses:
    """The evidence of consecutive frames, unit by unit (frames × bands).

    Attributes:
        log_likelihood: ``(frames, bands, 360)`` head-frame log-likelihoods on the 1° grid (0 at each unit's best).
        weight: ``(frames, bands)`` how much each unit counts (0: not at all).
        power: ``(frames, bands)`` the units' power at the ears (for telling loud sources from quiet ones).
        reliability: ``(frames, bands)`` the share of each unit that is not noise, ρ/(1 + ρ) for its
            signal-to-noise ratio ρ (1 when no noise was learnt): the rest of its evidence is the
            background's (a unit of diffuse noise alone looks like a source straight ahead or behind).
        noise_weight: ``(frames, bands)`` what each unit's noise share weighs (its level, coherence and
            onset factors times 1/(1 + ρ)); None when no noise was learnt. Against :attr:`weight`, it says
            how much of what was heard rose above the noise at all.
    """

    log_likelihood: npt.NDArray[np.float32]
    weight: npt.NDArray[np.float64]
    power: npt.NDArray[np.float64]
    reliability: npt.NDArray[np.float64] | None = None
    noise_weight: npt.NDArray[np.float64] | None = None

    @property
    def frames(self) -> int:
        """Frames these glimpses come from."""
        return int(self.weight.shape[0])


class GlimpseAnalyser:
    """Turns the spectra of consecutive frames into :class:`Glimpses`, keeping what the next frames need.

    Args:
        hrirs: The measured set at the analysis rate; its horizontal directions are the templates.
        frame: Frame size in samples (the FFT size).
        bins: The FFT bins analysed.
        parameters: How units are judged and weighed.

    The coherence and onset of a frame depend on the frames before it: :meth:`reset` when the
    next frames do not follow those analysed (a gap, a new stream).
    """

    def __init__(self, hrirs: HrirSet, frame: int, bins: npt.NDArray[np.intp],
                 parameters: GlimpseParameters = GlimpseParameters()) -> None:
        from ._interpolation import HorizontalInterpolator

        interpolator = HorizontalInterpolator(hrirs)
        self.template_azimuths = np.sort(np.mod(interpolator.azimuths, 360.0))
        self.parameters = parameters
        frequencies = np.fft.rfftfreq(frame, 1.0 / hrirs.rate)[bins]
        bands = erb_bands(frequencies, parameters.bands_per_erb)
        if not bands:
            raise LocalisationError("no frequency bin to analyse")
        #: ``(bins, bands)`` which band each bin belongs to.
        self.membership = np.zeros((len(bins), len(bands)))
        for index, members in enumerate(bands):
            self.membership[members, index] = 1.0
        counts = self.membership.sum(axis=0)
        self._scale = parameters.sharpness * np.sqrt(counts)
        #: ``(bands,)`` the least ratio of a unit's power to the noise's mean that holds any signal.
        self._noise_threshold = 1.0 + parameters.noise_margin / np.sqrt(counts)
        steering = np.fft.rfft(interpolator.at(self.template_azimuths), frame, axis=1)[:, bins]   # (T, bins, 2)
        steering /= np.maximum(np.linalg.norm(steering, axis=-1, keepdims=True), 1e-300)
        # (bins, 2, templates): one product per bin gives every template's projection of a frame.
        self._steering_conj = np.ascontiguousarray(np.conj(steering).transpose(1, 2, 0))
        self._spline = _spline_matrix(self.template_azimuths).T.astype(np.float32)          # (T, 360)
        self.reset()

    @property
    def bands(self) -> int:
        """Bands of a frame."""
        return int(self.membership.shape[1])

    def reset(self) -> None:
        """Forget the frames before: the next ones start a new stream."""
        self._cross: npt.NDArray[np.complex128] | None = None
        self._auto: npt.NDArray[np.float64] | None = None
        self._last_level: npt.NDArray[np.float64] | None = None

    def analyse(self, spectra: npt.NDArray[np.complex128],
                noise: npt.NDArray[np.float64] | None = None) -> Glimpses:
        """The glimpses of ``(frames, bins, 2)`` spectra that follow those analysed before.

        Args:
            spectra: The windowed spectra of consecutive frames at the analysed bins.
            noise: The noise's power per bin at the two ears together (summed), or None when unknown.
        """
        count = spectra.shape[0]
        bands = self.bands
        if count == 0:
            return Glimpses(np.zeros((0, bands, len(GRID_DEGREES)), np.float32), np.zeros((0, bands)),
                            np.zeros((0, bands)))
        left, right = spectra[..., 0], spectra[..., 1]
        auto = np.stack([left.real**2 + left.imag**2, right.real**2 + right.imag**2], axis=-1)   # (n, bins, 2)
        power = auto.sum(axis=-1)                                                                 # (n, bins)
        # Each template's explained energy, bin by bin (two products per bin and template: broadcast, which
        # is faster than a batched einsum), then summed per band (one matrix product).
        projection = (spectra[..., 0, np.newaxis] * self._steering_conj[np.newaxis, :, 0, :]
                      + spectra[..., 1, np.newaxis] * self._steering_conj[np.newaxis, :, 1, :])      # (n, bins, T)
        energy = (projection.real**2 + projection.imag**2).transpose(0, 2, 1)                  # (n, T, bins)
        explained = (energy @ self.membership).transpose(0, 2, 1)                              # (n, bands, T)
        band_power = power @ self.membership                                                      # (n, bands)
        match = explained / np.maximum(band_power, 1e-300)[..., np.newaxis]
        log_likelihood = (self._scale[:, np.newaxis] * (match - match.max(axis=-1, keepdims=True))).astype(np.float32)
        on_grid = log_likelihood @ self._spline                                                   # (n, bands, 360)
        reliability = None
        if noise is not None:
            noise_band = np.maximum(noise @ self.membership, 1e-300)
            ratio = np.maximum(band_power - self._noise_threshold * noise_band, 0.0) / noise_band
            reliability = ratio / (1.0 + ratio)
        weight = self._weights(left * np.conj(right), auto, power, band_power)
        if reliability is None:
            return Glimpses(on_grid, weight, band_power)
        return Glimpses(on_grid, weight * reliability, band_power, reliability, weight * (1.0 - reliability))

    def _weights(self, cross: npt.NDArray[np.complex128], auto: npt.NDArray[np.float64],
                 power: npt.NDArray[np.float64], band_power: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Each unit's weight but for its noise: level, coherence and onset."""
        parameters = self.parameters
        weight = np.maximum(band_power, 1e-300) ** parameters.level_power
        if parameters.coherence_power:
            coherence = self._coherence(cross, auto)
            weight = weight * ((coherence * power) @ self.membership / np.maximum(band_power, 1e-300)) \
                ** parameters.coherence_power
        if parameters.onset_gain:
            level = np.log(np.maximum(band_power, 1e-300))
            previous = np.concatenate([level[:1] if self._last_level is None else self._last_level[np.newaxis],
                                       level[:-1]])
            self._last_level = level[-1]
            weight = weight * (1.0 + parameters.onset_gain * np.clip(level - previous, 0.0, 3.0))
        return np.asarray(weight)

    def _coherence(self, cross: npt.NDArray[np.complex128], auto: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """The interaural coherence of each frame and bin, from cross- and auto-spectra averaged recursively."""
        memory = self.parameters.coherence_memory
        smoothed_cross = np.empty_like(cross)
        smoothed_auto = np.empty_like(auto)
        previous_cross, previous_auto = self._cross, self._auto
        for index in range(cross.shape[0]):
            if previous_cross is None or previous_auto is None:
                previous_cross, previous_auto = cross[index], auto[index]
            else:
                previous_cross = memory * previous_cross + (1.0 - memory) * cross[index]
                previous_auto = memory * previous_auto + (1.0 - memory) * auto[index]
            smoothed_cross[index], smoothed_auto[index] = previous_cross, previous_auto
        self._cross, self._auto = previous_cross, previous_auto
        return np.asarray(np.abs(smoothed_cross) / np.sqrt(np.maximum(smoothed_auto.prod(axis=-1), 1e-300)))


def tempered(log_likelihood: npt.NDArray[np.float32], front_back_weight: float) -> npt.NDArray[np.float32]:
    """Head-frame log-likelihoods on the 1° grid with the templates' front/back preference weighed.

    The lateral evidence, θ and its mirror image 180° − θ together (their likelihoods' mean),
    counts whole; the preference between them counts *front_back_weight* of its log (1: all,
    0: none, the evidence is then the lateral angle's alone, the same for θ and its mirror image).

    The lateral angle rests on the interaural time and level differences, which heads have much
    alike; the front/back preference rests on the pinnae's and torso's spectral detail, which is the
    templates' head's own and misleads on another head. A head that turns tells front from back by
    geometry alone (a mirror image moves in the room, a source does not), on any head: a filter fed
    by a turning head needs little of the templates' preference.
    """
    if front_back_weight == 1.0:
        return log_likelihood
    lateral = np.logaddexp(log_likelihood, log_likelihood[..., _MIRROR]) - np.float32(np.log(2.0))
    weighed = lateral + np.float32(front_back_weight) * (log_likelihood - lateral)
    return np.asarray(weighed - weighed.max(axis=-1, keepdims=True), dtype=np.float32)


def _spline_matrix(azimuths: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The periodic cubic spline through values at *azimuths* (sorted, [0, 360)) as a ``(360, templates)`` matrix."""
    x = np.append(azimuths, azimuths[0] + 360.0)
    basis = np.eye(len(azimuths))
    spline = interpolate.CubicSpline(x, np.vstack([basis, basis[:1]]), bc_type="periodic")
    return np.asarray(spline(np.where(GRID_DEGREES < x[0], GRID_DEGREES + 360.0, GRID_DEGREES)))
