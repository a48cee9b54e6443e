"""Binaural localisation by matching the ears' spatial covariance against HRTF steering vectors.

Method (the one the Two!Ears ``binauloc`` component's names suggest: it learnt
the noise, then took pre-tabulated projections on steering vectors):

1. Short-time spectra of both ears (Hann window, ``frame`` samples, ``hop`` apart).
2. Per frequency bin, the 2×2 spatial covariance averaged over the frames of an
   estimate, less the noise covariance learnt beforehand from noise alone
   (:meth:`BinauralLocaliser.learn_noise`).
3. Its principal eigenvector u(f): the pair of ear transfer functions of the
   dominant source, up to a complex factor, interaural phase and level together.
4. For each template direction θ, the steering vector h_θ(f) = (H_L, H_R) of the
   measured HRIRs, normalised; the match |h_θᴴ u|² is 1 for a perfect fit. With
   equal levels at the ears it is (1 + cos Δφ)/2 of the interaural phase error
   Δφ: the generalised cross-correlation with phase transform (Knapp & Carter
   1976) with the HRTF's own interaural phase instead of a pure delay, plus the
   level difference, bin by bin.
5. The log-likelihood of θ sums the matches over bins, each weighted by
   ρ/(1 + ρ) for the bin's source-to-noise ratio ρ, so that bins without the
   source (a tone complex's gaps, the noise-dominated edges) count for little;
   it is scaled by the number of frames, since more frames mean a surer estimate.

Templates come from the measured HRIRs only (by default the 72 measured
directions of the horizontal plane, every 5°); nothing is learnt from the
signals to be localised. The log-likelihood on the template grid is carried to
a 1° grid by a periodic cubic spline. Estimates at several head azimuths combine
in the room frame (:func:`combine_in_room`).

A head that turns while an estimate's frames go by: :meth:`BinauralLocaliser.feed`
takes the head azimuth of every sample (from the positions carried with the
audio). The frames of an estimate are split into runs within which the head
moves less than :data:`MOTION_TOLERANCE`; each run is matched in its own head
frame, turned into the room frame with its head azimuth, and the runs add there.
The estimate is then seen from the head at its last frame. A still head is one run.

Memory stays bounded whatever the setup and however the audio comes: frames are
transformed a batch at a time (:data:`BATCH_SAMPLES`) and summed into their
run's covariance as they come; a run that ends is kept only as its likelihood.
Learning the noise streams the same way (:class:`NoiseLearner`).
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np
import numpy.typing as npt
from scipy import interpolate

from ._errors import LocalisationError
from ._hrir_set import HrirSet
from ._kemar import load_kemar
from ._likelihood import GRID_DEGREES, AzimuthLikelihood, combine_in_room, radians

__all__ = ["LocaliserSetup", "FrameAnalysis", "BinauralLocaliser", "AzimuthEstimate", "NoiseLearner", "Window",
           "WINDOWS", "MOTION_TOLERANCE", "BATCH_SAMPLES"]

#: How sharp the log-likelihood is for each frame and unit of weighted match: chosen so that the
#: confidence (posterior within ±10° of the peak) follows how often estimates are that close.
_SHARPNESS = 0.1
#: The analysis windows, by name (``binauloc``'s ``::binauloc::HANNING``, ...).
Window = Literal["hanning", "hamming", "blackman", "rectangular"]
WINDOWS: tuple[Window, ...] = ("hanning", "hamming", "blackman", "rectangular")
#: Degrees the head may turn within the frames matched in one head frame (a fifth of the templates' spacing).
MOTION_TOLERANCE = 1.0
#: Samples of the frames transformed at once: their spectra (about 4 MB, whatever the frame size) and the
#: sums they add to are all the localiser holds of them, whatever the smoothing and the size of a block.
BATCH_SAMPLES = 1 << 18


def _window(name: str, frame: int) -> npt.NDArray[np.float64]:
    """The periodic *name* window of *frame* samples (the DFT-even form: its frames overlap-add evenly)."""
    if name == "rectangular":
        return np.ones(frame)
    make = {"hanning": np.hanning, "hamming": np.hamming, "blackman": np.blackman}[name]
    return np.asarray(make(frame + 1)[:frame])


@dataclasses.dataclass(frozen=True)
class LocaliserSetup:
    """The analysis parameters (those of the Two!Ears ``binauloc`` ``Setup`` service).

    Attributes:
        rate: Sample rate in Hz.
        max_frequency: Highest frequency used, Hz.
        frame: Frame size in samples.
        hop: Samples between frame starts (``binauloc`` called its 512 the overlap: a frame of
            1024 every 512 samples).
        smoothing: Frames per estimate when streaming.
        min_frequency: Lowest frequency used, Hz.
        window: The analysis window: ``hanning``, ``hamming``, ``blackman`` or ``rectangular``.
    """

    rate: float = 24_414.0
    max_frequency: float = 5000.0
    frame: int = 1024
    hop: int = 512
    smoothing: int = 10
    min_frequency: float = 100.0
    window: Window = "hanning"

    def check(self) -> None:
        """Refuse parameters that make no analysis.

        Raises:
            LocalisationError: naming the parameter.
        """
        if not self.rate > 0:
            raise LocalisationError(f"the sample rate must be positive, not {self.rate}")
        if self.frame < 16 or self.frame & (self.frame - 1):
            raise LocalisationError(f"the frame size must be a power of two of at least 16, not {self.frame}")
        if not 0 < self.hop <= self.frame:
            raise LocalisationError(f"the hop must be between 1 and the frame size, not {self.hop}")
        if self.smoothing < 1:
            raise LocalisationError(f"an estimate needs at least one frame, not {self.smoothing}")
        if not 0 <= self.min_frequency < self.max_frequency:
            raise LocalisationError("the frequency range is empty")
        if self.min_frequency > self.rate / 2:
            raise LocalisationError("the lowest frequency is above the Nyquist frequency")
        if self.window not in WINDOWS:
            raise LocalisationError(f"the window is one of {', '.join(WINDOWS)}, not {self.window!r}")


@dataclasses.dataclass(frozen=True)
class AzimuthEstimate:
    """One localisation result.

    Attributes:
        azimuth: The most likely azimuth, radians in (-π, π], head frame, positive to the left.
        confidence: Posterior probability within ±10° of it (about 0.5 when front and back tie).
        likelihood: The whole head-frame likelihood (for combining with others).
        frames: Analysis frames it rests on.
        end: Sample index (since the stream started) just after its last frame.
        head_azimuth: The head's room azimuth at the last frame, degrees (None when the audio
            carried none); the head frame is the head's there.
    """

    azimuth: float
    confidence: float
    likelihood: AzimuthLikelihood
    frames: int
    end: int
    head_azimuth: float | None = None

    @property
    def degrees(self) -> float:
        """:attr:`azimuth` in degrees."""
        return float(np.degrees(self.azimuth))

    @property
    def room(self) -> AzimuthLikelihood | None:
        """The likelihood in the room frame (None when the head azimuth is unknown)."""
        return None if self.head_azimuth is None else self.likelihood.in_room(self.head_azimuth)


class _Covariance:
    """Sums of the per-bin 2×2 spatial covariance over frames: (r11, r22, r12), r12 = E[X_L X_R*]."""

    def __init__(self, bins: int) -> None:
        self.r11 = np.zeros(bins)
        self.r22 = np.zeros(bins)
        self.r12 = np.zeros(bins, dtype=np.complex128)
        self.frames = 0

    def add(self, spectra: npt.NDArray[np.complex128]) -> None:
        """Add ``(frames, bins, 2)`` spectra."""
        left, right = spectra[..., 0], spectra[..., 1]
        self.r11 += np.sum(left.real**2 + left.imag**2, axis=0)
        self.r22 += np.sum(right.real**2 + right.imag**2, axis=0)
        self.r12 += np.sum(left * np.conj(right), axis=0)
        self.frames += spectra.shape[0]

    def merge(self, other: _Covariance) -> None:
        """Add the sums of *other*."""
        self.r11 += other.r11
        self.r22 += other.r22
        self.r12 += other.r12
        self.frames += other.frames


class _Framer:
    """Samples cut into the analysis frames as they arrive; what a frame does not use yet waits for more.

    Args:
        frame: Samples per frame.
        hop: Samples between frame starts.
    """

    def __init__(self, frame: int, hop: int) -> None:
        self.frame, self.hop = frame, hop
        self.pending = np.zeros((0, 2))
        #: The head azimuth of each pending sample (None when unknown).
        self.heads: npt.NDArray[np.float64] | None = None

    def add(self, samples: npt.NDArray[np.float64], heads: npt.ArrayLike | None = None) -> None:
        """Append samples (and the head azimuth of each, when known)."""
        if heads is None:
            self.heads = None
        else:
            given = np.asarray(heads, dtype=np.float64).reshape(len(samples))
            if self.heads is None or len(self.heads) != len(self.pending):
                # Azimuths unknown so far: the earlier samples take the first one given.
                self.heads = np.full(len(self.pending), given[0] if len(given) else 0.0)
            self.heads = np.concatenate([self.heads, given])
        self.pending = np.concatenate([self.pending, samples])

    def ready(self) -> int:
        """Whole frames the pending samples hold."""
        return 0 if len(self.pending) < self.frame else (len(self.pending) - self.frame) // self.hop + 1

    def take(self, count: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64] | None]:
        """The samples of the next *count* frames, and the head azimuth at each frame's centre (None: unknown)."""
        samples = self.pending[:(count - 1) * self.hop + self.frame]
        heads = None
        if self.heads is not None:
            heads = self.heads[np.arange(count) * self.hop + self.frame // 2]
            self.heads = self.heads[count * self.hop:]
        self.pending = self.pending[count * self.hop:]
        return samples, heads


class NoiseLearner:
    """The noise's spatial covariance learnt from audio fed piece by piece, as it arrives (``LearnNoise``).

    Args:
        localiser: The localiser whose analysis (frames, window, bins) it uses.

    Only the covariance's sums and less than a frame of samples are held, however long the noise.
    """

    def __init__(self, localiser: FrameAnalysis) -> None:
        #: The localiser it learns for.
        self.localiser = localiser
        self._framer = _Framer(localiser.setup.frame, localiser.setup.hop)
        self._covariance = _Covariance(len(localiser._bins))

    @property
    def frames(self) -> int:
        """Analysis frames learnt so far."""
        return self._covariance.frames

    def feed(self, audio: npt.ArrayLike) -> None:
        """Learn from the next ``(frames, 2)`` samples of noise alone (following those fed before)."""
        self._framer.add(self.localiser._checked(audio))
        while count := min(self._framer.ready(), self.localiser.batch):
            samples, _ = self._framer.take(count)
            self._covariance.add(self.localiser._spectra(samples))

    def gap(self) -> None:
        """The next samples do not follow those fed before (frames lost): no frame spans the gap."""
        self._framer = _Framer(self._framer.frame, self._framer.hop)

    def learnt(self) -> None:
        """Make what was learnt the localiser's noise.

        Raises:
            LocalisationError: when not a single frame was learnt.
        """
        if self._covariance.frames == 0:
            raise LocalisationError(f"learning the noise needs at least one frame of {self._framer.frame} samples")
        self.localiser._noise = self._covariance


class FrameAnalysis:
    """What every localiser here shares: the setup checked, the frames' spectra, the noise learnt.

    Args:
        setup: The analysis parameters.
        hrirs: The measured set the templates come from (default: the MIT KEMAR set).

    Attributes:
        setup: The analysis parameters.
        measured: The measured set at the analysis rate.
        batch: Frames transformed at once.
    """

    def __init__(self, setup: LocaliserSetup | None = None, *, hrirs: HrirSet | None = None) -> None:
        self.setup = setup if setup is not None else LocaliserSetup()
        self.setup.check()
        self.measured = (hrirs if hrirs is not None else load_kemar()).resampled(self.setup.rate)
        freqs = np.fft.rfftfreq(self.setup.frame, 1.0 / self.setup.rate)
        self._bins = np.flatnonzero((freqs >= self.setup.min_frequency) & (freqs <= self.setup.max_frequency))
        if len(self._bins) == 0:
            raise LocalisationError("no frequency bin between the lowest and highest frequency")
        self._window = _window(self.setup.window, self.setup.frame)
        self.batch = max(1, BATCH_SAMPLES // self.setup.frame)
        self._noise: _Covariance | None = None

    # -- noise ---------------------------------------------------------------------------------

    def learn_noise(self, audio: npt.ArrayLike) -> None:
        """Learn the noise's spatial covariance from audio without the sources (``binauloc``'s LearnNoise).

        Args:
            audio: ``(frames, 2)`` samples of the noise alone (to learn from audio as it arrives:
                :meth:`noise_learner`).
        """
        learner = self.noise_learner()
        learner.feed(audio)
        learner.learnt()

    def noise_learner(self) -> NoiseLearner:
        """A learner of the noise fed piece by piece; its :meth:`NoiseLearner.learnt` makes it this localiser's."""
        return NoiseLearner(self)

    def forget_noise(self) -> None:
        """Localise without a noise estimate again."""
        self._noise = None

    @staticmethod
    def _checked(audio: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """``(frames, 2)`` float samples.

        Raises:
            LocalisationError: for another shape.
        """
        samples = np.asarray(audio, dtype=np.float64)
        if samples.ndim != 2 or samples.shape[1] != 2:
            raise LocalisationError(f"audio must be (frames, 2), not {samples.shape}")
        return samples

    def _spectra(self, samples: npt.NDArray[np.float64]) -> npt.NDArray[np.complex128]:
        """``(frames, bins, 2)`` windowed spectra of every full frame, at the analysed bins."""
        frame, hop = self.setup.frame, self.setup.hop
        if samples.ndim != 2 or samples.shape[1] != 2:
            raise LocalisationError(f"audio must be (frames, 2), not {samples.shape}")
        if len(samples) < frame:
            return np.zeros((0, len(self._bins), 2), dtype=np.complex128)
        frames = np.lib.stride_tricks.sliding_window_view(samples, frame, axis=0)[::hop]    # (n, 2, frame)
        spectra = np.fft.rfft(frames * self._window, axis=-1)[..., self._bins]
        return np.ascontiguousarray(spectra.transpose(0, 2, 1))


class BinauralLocaliser(FrameAnalysis):
    """Estimates the azimuth of the dominant source from two ear signals.

    Args:
        setup: The analysis parameters.
        hrirs: The measured set the templates come from (default: the MIT KEMAR set).
        template_azimuths: Template directions in the horizontal plane, degrees (default: the
            measured ones; other azimuths are interpolated, see :class:`HorizontalInterpolator`).

    Use :meth:`localise` on a block of audio for one estimate, or :meth:`feed` to stream
    audio and get an estimate every ``setup.smoothing`` frames.
    """

    def __init__(self, setup: LocaliserSetup | None = None, *, hrirs: HrirSet | None = None,
                 template_azimuths: npt.ArrayLike | None = None) -> None:
        from ._interpolation import HorizontalInterpolator

        super().__init__(setup, hrirs=hrirs)
        interpolator = HorizontalInterpolator(self.measured)
        azimuths = interpolator.azimuths if template_azimuths is None else np.sort(
            np.mod(np.asarray(template_azimuths, dtype=np.float64), 360.0))
        self.template_azimuths = np.mod(np.asarray(azimuths, dtype=np.float64), 360.0)
        order = np.argsort(self.template_azimuths)
        self.template_azimuths = self.template_azimuths[order]
        responses = interpolator.at(self.template_azimuths)
        # A frame shorter than the responses cuts their tails (of little energy after 200 samples).
        steering = np.fft.rfft(responses, self.setup.frame, axis=1)[:, self._bins]    # (templates, bins, 2)
        steering /= np.maximum(np.linalg.norm(steering, axis=-1, keepdims=True), 1e-300)
        self._steering_conj = np.conj(steering)
        self._spline = self._spline_matrix()
        self.reset_stream()

    def reset_stream(self) -> None:
        """Start a new stream: forget the samples and frames fed since the last estimate (after a gap)."""
        self._framer = _Framer(self.setup.frame, self.setup.hop)
        self._consumed = 0
        self._new_estimate()

    def _new_estimate(self) -> None:
        """Forget the frames of the estimate being made (it was made, or the stream starts again)."""
        bins = len(self._bins)
        #: The frames of the estimate, in runs of a nearly still head: those ended (as their sums and their
        #: likelihood with their mean head azimuth) and the one going on.
        self._ended = _Covariance(bins)
        self._runs: list[tuple[AzimuthLikelihood, float]] = []
        self._run = _Covariance(bins)
        self._run_heads = 0.0            # the sum of the run's head azimuths
        self._run_first = 0.0            # the head azimuth at its first frame
        self._first_head: float | None = None
        self._last_head = 0.0
        self._headless = False           # a frame of the estimate came without the head's azimuth

    # -- estimates -----------------------------------------------------------------------------

    def localise(self, audio: npt.ArrayLike) -> AzimuthEstimate:
        """One estimate from a block of audio (every full frame in it).

        Args:
            audio: ``(frames, 2)`` samples, left then right.

        Raises:
            LocalisationError: when the block holds no full frame.
        """
        samples = self._checked(audio)
        covariance = _Covariance(len(self._bins))
        for start in range(0, max(0, len(samples) - self.setup.frame) + 1, self.batch * self.setup.hop):
            covariance.add(self._spectra(samples[start:start + (self.batch - 1) * self.setup.hop + self.setup.frame]))
        if covariance.frames == 0:
            raise LocalisationError(f"an estimate needs at least one frame of {self.setup.frame} samples")
        end = (covariance.frames - 1) * self.setup.hop + self.setup.frame
        return self._estimate(covariance, end)

    def feed(self, audio: npt.ArrayLike, heads: npt.ArrayLike | None = None) -> list[AzimuthEstimate]:
        """Stream audio in; an estimate comes out every ``setup.smoothing`` frames.

        Args:
            audio: ``(frames, 2)`` samples following those fed before.
            heads: The head's room azimuth at each of these samples, degrees (from the positions
                carried with the audio), or None when unknown. The estimates then account for a
                head that turned during their frames, and carry the head azimuth of their last frame.

        Returns:
            The estimates completed by this audio, oldest first.
        """
        frame, hop, smoothing = self.setup.frame, self.setup.hop, self.setup.smoothing
        self._framer.add(self._checked(np.asarray(audio, dtype=np.float64).reshape(-1, 2)), heads)
        estimates = []
        while take := min(smoothing - self._frames_so_far(), self._framer.ready(), self.batch):
            samples, frame_heads = self._framer.take(take)
            self._add_frames(self._spectra(samples), frame_heads)
            self._consumed += take * hop
            if self._frames_so_far() == smoothing:
                estimates.append(self._streamed_estimate(self._consumed - hop + frame))
                self._new_estimate()
        return estimates

    def _frames_so_far(self) -> int:
        return self._ended.frames + self._run.frames

    def _add_frames(self, spectra: npt.NDArray[np.complex128], heads: npt.NDArray[np.float64] | None) -> None:
        """Sum frames into the estimate, each into its run of a nearly still head (one run when heads are unknown)."""
        if heads is None or self._headless:
            self._headless = True  # the estimate cannot be turned into the room: one sum of every frame
            self._run.add(spectra)
            return
        if self._first_head is None:
            self._first_head = self._run_first = float(heads[0])
        start = 0
        for index, head in enumerate(heads.tolist()):
            if self._run.frames + index - start and abs(head - self._run_first) > MOTION_TOLERANCE:
                self._run.add(spectra[start:index])
                self._run_heads += float(np.sum(heads[start:index]))
                self._end_run()
                self._run_first, start = head, index
        self._run.add(spectra[start:])
        self._run_heads += float(np.sum(heads[start:]))
        self._last_head = float(heads[-1])

    def _end_run(self) -> None:
        """Keep the run that ended as its likelihood in its mean head frame; start the next."""
        self._runs.append((self._log_likelihood(self._run), self._run_heads / self._run.frames))
        self._ended.merge(self._run)
        self._run, self._run_heads = _Covariance(len(self._bins)), 0.0

    def _streamed_estimate(self, end: int) -> AzimuthEstimate:
        """The estimate of the frames summed, the head turning through their runs, or unknown."""
        if self._headless or self._first_head is None:
            self._ended.merge(self._run)
            return self._estimate(self._ended, end)
        last = self._last_head
        if not self._runs and self._first_head == last:
            return dataclasses.replace(self._estimate(self._run, end), head_azimuth=last)
        frames = self._frames_so_far()
        self._end_run()
        likelihood = combine_in_room(self._runs).relative_to(last)
        peak = likelihood.peak()
        return AzimuthEstimate(radians(peak), likelihood.mass_near(peak), likelihood, frames, end, last)

    def _estimate(self, covariance: _Covariance, end: int) -> AzimuthEstimate:
        likelihood = self._log_likelihood(covariance)
        peak = likelihood.peak()
        return AzimuthEstimate(radians(peak), likelihood.mass_near(peak), likelihood, covariance.frames, end)

    def _log_likelihood(self, covariance: _Covariance) -> AzimuthLikelihood:
        """The head-frame likelihood of the frames summed in *covariance*."""
        count = covariance.frames
        a, d, b = covariance.r11 / count, covariance.r22 / count, covariance.r12 / count
        if self._noise is not None:
            n = self._noise.frames
            noise11, noise22 = self._noise.r11 / n, self._noise.r22 / n
            a, d, b = a - noise11, d - noise22, b - self._noise.r12 / n
            noise = 0.5 * (noise11 + noise22)
        half_sum, root = 0.5 * (a + d), np.sqrt((0.5 * (a - d)) ** 2 + np.abs(b) ** 2)
        largest, smallest = half_sum + root, half_sum - root
        if self._noise is None:
            noise = np.maximum(smallest, 0.0)   # what is left besides the dominant source
        # The principal eigenvector, from whichever of its two forms is the better conditioned.
        left_louder = a >= d
        first = np.where(left_louder, largest - d, b)
        second = np.where(left_louder, np.conj(b), largest - a)
        vector = np.stack([first, second], axis=-1)
        vector /= np.maximum(np.linalg.norm(vector, axis=-1, keepdims=True), 1e-300)
        ratio = np.maximum(largest, 0.0) / np.maximum(noise, 1e-30 * np.maximum(largest, 1e-300))
        weight = ratio / (1.0 + ratio)
        match = np.abs(np.einsum("tfe,fe->tf", self._steering_conj, vector)) ** 2              # (templates, bins)
        score = match @ weight
        log_likelihood = _SHARPNESS * count * (score - score.max())
        return AzimuthLikelihood(self._on_grid(log_likelihood), "head")

    def _on_grid(self, values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Template values carried to the 1° grid by a periodic cubic spline."""
        return np.asarray(self._spline @ values)

    def _spline_matrix(self) -> npt.NDArray[np.float64]:
        """The periodic cubic spline through the templates as a matrix (1° grid × templates).

        A spline is linear in the values it passes through: its matrix, made once from the
        templates' unit vectors, carries any values to the grid in one product (an estimate of a
        turning head makes one likelihood per run of frames).
        """
        x = np.append(self.template_azimuths, self.template_azimuths[0] + 360.0)
        basis = np.eye(len(self.template_azimuths))
        spline = interpolate.CubicSpline(x, np.vstack([basis, basis[:1]]), bc_type="periodic")
        return np.asarray(spline(np.where(GRID_DEGREES < x[0], GRID_DEGREES + 360.0, GRID_DEGREES)))
