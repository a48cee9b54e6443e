"""The spherical-head binaural renderer: Woodworth delays and Brown–Duda head shadow.

Kept for comparison with the measured KEMAR (a scene's ``"head": "spherical"``):
a sphere is symmetric front to back, so a source at 30° and one at 150° give the
same interaural cues, which is why the simulated scene renders through the
measured HRIRs by default (:mod:`._renderers`).

Each source reaches each ear with the delay of a rigid sphere (Brown & Duda
1998, eq. 3, which sums to the Woodworth ITD ``a/c·(θ + sin θ)`` with ears at
±90°) and through the one-pole/one-zero head-shadow filter of the same paper::

    H(ω, θ) = (1 + j·α(θ)·ω/(2ω0)) / (1 + j·ω/(2ω0)),   ω0 = c/a
    α(θ)    = (1 + αmin/2) + (1 − αmin/2)·cos(θ/θmin·π),  αmin = 0.1, θmin = 150°

where θ is the angle between the source and the ear's axis.  Both depend on
the head azimuth, which may change within a chunk, so they are interpolated
per sample between the azimuth at the start and at the end of the chunk, and
every filter and delay line keeps its state across chunks: a turning head
gives a smooth signal.  Two facts keep this vectorised:

* the fractional delay is a 4-tap Lagrange interpolator read at per-sample
  positions from a short history of each source;
* after the bilinear transform the filter's pole does not depend on θ (only
  the zero does), so each source's time-varying numerator is applied sample
  by sample with numpy, the sources are summed, and one fixed all-pole
  ``lfilter`` per ear finishes the job.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from scipy import signal

from ..binaural import HrirSet
from ._scene import Scene, SourceSignal

__all__ = ["SphericalHeadRenderer", "sphere_hrirs", "woodworth_itd", "ear_delay", "shadow_alpha", "to_int32"]

ALPHA_MIN = 0.1
THETA_MIN = 150.0
#: Ears sit on the interaural axis, at +90° (left) and −90° (right) from the nose.
EAR_AZIMUTHS = (90.0, -90.0)
#: Extra delay, in samples, so the 4-tap interpolator never reads a future sample.
_LAGRANGE_LATENCY = 2.0
_FULL_SCALE = 2.0**31


def to_int32(frames: npt.NDArray[np.float64]) -> npt.NDArray[np.int32]:
    """Convert float full-scale frames to S32 samples, clipping."""
    scaled = np.rint(frames * _FULL_SCALE)
    return np.clip(scaled, -_FULL_SCALE, _FULL_SCALE - 1).astype(np.int32)


def woodworth_itd(azimuth: float, head_radius: float = 0.0875, speed_of_sound: float = 343.0) -> float:
    """Woodworth's interaural time difference, right-ear arrival minus left-ear arrival.

    Args:
        azimuth: Source azimuth relative to the nose, degrees, positive to the left.
        head_radius: In metres.
        speed_of_sound: In metres per second.

    Returns:
        Seconds; positive for a source on the left.
    """
    wrapped = (azimuth + 180.0) % 360.0 - 180.0
    # Sources behind the interaural axis have the same ITD as their front mirror image.
    lateral = math.radians(math.copysign(min(abs(wrapped), 180.0 - abs(wrapped)), wrapped))
    return head_radius / speed_of_sound * (lateral + math.sin(lateral))


def ear_delay(angle: npt.NDArray[np.float64], head_radius: float, speed_of_sound: float) -> npt.NDArray[np.float64]:
    """Arrival delay (s) at an ear from the angle (degrees, 0…180) between source and ear axis.

    Brown & Duda's sphere delay shifted by ``a/c`` so it is never negative.
    """
    theta = np.radians(angle)
    scale = head_radius / speed_of_sound
    return scale * (1.0 + np.where(theta < np.pi / 2, -np.cos(theta), theta - np.pi / 2))


def shadow_alpha(angle: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The high-frequency gain α of the head-shadow filter at an ear-to-source angle in degrees."""
    return (1.0 + ALPHA_MIN / 2.0) + (1.0 - ALPHA_MIN / 2.0) * np.cos(np.radians(angle) / np.radians(THETA_MIN) * np.pi)


def sphere_hrirs(radius: float = 0.0875, speed_of_sound: float = 343.0, rate: float = 44_100.0,
                 taps: int = 512) -> HrirSet:
    """The same spherical head as head-related impulse responses: a head for any HRIR renderer or localiser.

    Brown & Duda's sphere (the delays and head shadow :class:`SphericalHeadRenderer` applies),
    ears on the interaural axis, no torso, no pinnae: front and back alike. Directions on the
    rings of the MIT KEMAR grid (elevations -40° to 90° every 10°, azimuths every 5°), each
    response delayed by 40 samples so that none starts before its first tap, and its last 64 taps
    faded out. ``examples/localisation_training.py`` trains on it as a head the templates never saw.

    Args:
        radius: The head's radius, metres.
        speed_of_sound: Metres per second.
        rate: Sample rate of the taps, Hz.
        taps: Samples per response.
    """
    rings = np.arange(-40.0, 91.0, 10.0)
    azimuth = np.concatenate([np.arange(-180.0, 180.0, 5.0) if e < 90 else np.zeros(1) for e in rings])
    elevation = np.concatenate([np.full(72 if e < 90 else 1, e) for e in rings])
    a, e = np.radians(azimuth), np.radians(elevation)
    lateral = np.cos(e) * np.sin(a)                          # towards the left ear
    omega = 2.0 * np.pi * np.fft.rfftfreq(2 * taps, 1.0 / rate)
    corner = 2.0 * speed_of_sound / radius
    responses = np.zeros((len(azimuth), taps, 2))
    for ear, side in enumerate((1.0, -1.0)):
        angle = np.degrees(np.arccos(np.clip(side * lateral, -1.0, 1.0)))          # source to the ear's axis
        shadow = (1.0 + 1j * shadow_alpha(angle)[:, np.newaxis] * omega / corner) / (1.0 + 1j * omega / corner)
        delay = ear_delay(angle, radius, speed_of_sound)[:, np.newaxis] + 40.0 / rate
        response = np.fft.irfft(shadow * np.exp(-1j * omega * delay), 2 * taps, axis=1)[:, :taps]
        response[:, -64:] *= np.hanning(128)[64:]
        responses[:, :, ear] = response
    return HrirSet(rate, azimuth, elevation, responses, f"spherical head (a = {radius * 100:g} cm)")


def _lagrange(position: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.float64], tuple[npt.NDArray[np.float64], ...]]:
    """Integer read positions and third-order Lagrange weights of taps base-1 … base+2."""
    base = np.floor(position)
    frac = position - base
    fp1, fm1, fm2 = frac + 1.0, frac - 1.0, frac - 2.0
    return base, (frac * fm1 * fm2 / -6.0, fp1 * fm1 * fm2 / 2.0, fp1 * frac * fm2 / -2.0, fp1 * frac * fm1 / 6.0)


def _ear_angles(relative: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Angles (0…180°) between sources at *relative* azimuths and each ear; adds a leading ear axis."""
    ears = np.asarray(EAR_AZIMUTHS).reshape((2,) + (1,) * relative.ndim)
    return np.abs((relative[np.newaxis] - ears + 180.0) % 360.0 - 180.0)


class SphericalHeadRenderer:
    """Renders a :class:`Scene` at the ears of a turning spherical head.

    Args:
        scene: The sources and head parameters.
        rate: Sample rate in Hz.

    The head starts at the azimuth given to the first :meth:`render` call.
    """

    def __init__(self, scene: Scene, rate: int) -> None:
        self.scene = scene
        self.rate = rate
        self.frames_rendered = 0
        a, c = scene.head_radius, scene.speed_of_sound
        self._signals = [SourceSignal(s, rate, s.seed if s.seed is not None else scene.seed + i)
                         for i, s in enumerate(scene.sources)]
        self._azimuths = np.array([s.azimuth for s in scene.sources], dtype=np.float64)
        max_delay = rate * a / c * (1.0 + math.pi / 2.0) + _LAGRANGE_LATENCY
        self._history_len = math.ceil(max_delay) + 3
        nsrc = len(self._signals)
        self._history = np.zeros((nsrc, self._history_len))
        # The last delayed sample of each source at each ear: the x[n-1] of the next numerator.
        self._last_delayed = np.zeros((2, nsrc))
        w0 = c / a / rate
        self._norm = 1.0 + w0
        self._w0 = w0
        self._pole = np.array([1.0, -(1.0 - w0) / (1.0 + w0)])
        self._zi = np.zeros((1, 2))
        self._head: float | None = None
        self._start_params: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None = None
        self._floor_rng = np.random.default_rng(scene.seed + 1_000_003)
        self._floor = 10.0 ** (scene.noise_floor / 20.0) if scene.noise_floor is not None else 0.0

    @property
    def head_azimuth(self) -> float | None:
        """The head azimuth at the end of the last chunk (None before the first)."""
        return self._head

    def render(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
               listener: Sequence[float] | None = None) -> npt.NDArray[np.int32]:
        """Render the next *count* frames while the head moves to *head_azimuth*.

        Args:
            count: Frames to render.
            head_azimuth: Head azimuth (degrees, positive to the left) at the end
                of these frames; it moves linearly from the previous value, the
                short way round.
            source_azimuths: The sources' room azimuths at the end of these frames
                (None: as before; at first, the scene's).
            listener: Ignored: the sphere hears azimuths only.

        Returns:
            ``(count, 2)`` int32 frames, left then right.
        """
        return to_int32(self.render_float(count, head_azimuth, source_azimuths))

    def render_float(self, count: int, head_azimuth: float, source_azimuths: npt.ArrayLike | None = None,
                     listener: Sequence[float] | None = None) -> npt.NDArray[np.float64]:
        """Like :meth:`render`, as float frames in [-1, 1) full scale."""
        if source_azimuths is not None:
            # The delays and shadows move from their values at the previous block's end to these.
            self._azimuths = np.asarray(source_azimuths, dtype=np.float64).reshape(len(self._signals))
        start = self._head if self._head is not None else head_azimuth
        step = (head_azimuth - start + 180.0) % 360.0 - 180.0
        self._head = start + step
        out = np.zeros((count, 2))
        if self._signals:
            delay0, alpha0 = self._start_params if self._start_params is not None else self._params(start)
            delay1, alpha1 = self._params(start + step)
            self._start_params = (delay1, alpha1)
            if step == 0.0:
                delay, alpha = delay1[..., np.newaxis], alpha1[..., np.newaxis]      # (ear, src, 1)
            else:
                # Delay and shadow move linearly from their values at the start of the
                # chunk to those at its end: continuous, so a turning head gives no click.
                ramp = np.arange(1, count + 1, dtype=np.float64) / count
                delay = delay0[..., np.newaxis] + (delay1 - delay0)[..., np.newaxis] * ramp
                alpha = alpha0[..., np.newaxis] + (alpha1 - alpha0)[..., np.newaxis] * ramp
            dry = np.stack([s.next(count) for s in self._signals])                # (src, n)
            out += self._shadow(self._delay(dry, delay), alpha)
        if self._floor:
            out += self._floor * self._floor_rng.standard_normal((count, 2))
        self.frames_rendered += count
        return out

    def _params(self, head: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Delay (samples) and shadow α of every source at each ear, shape (ear, src), for a head azimuth."""
        angles = _ear_angles(self._azimuths - head)
        delay = ear_delay(angles, self.scene.head_radius, self.scene.speed_of_sound) * self.rate
        return delay + _LAGRANGE_LATENCY, shadow_alpha(angles)

    def _delay(self, dry: npt.NDArray[np.float64], delay: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Read each source at each ear *delay* samples late (delay: (ear, src, 1) or (ear, src, n))."""
        nsrc, count = dry.shape
        hist = self._history_len
        buffer = np.concatenate([self._history, dry], axis=1)                      # (src, H + n)
        self._history = buffer[:, -hist:].copy()
        result = np.empty((2, nsrc, count))
        if delay.shape[-1] == 1:
            # A still head: one fixed fractional delay per source and ear, read with slices.
            base, weights = _lagrange(hist - delay[..., 0])
            for ear in range(2):
                for src in range(nsrc):
                    lo = int(base[ear, src]) - 1
                    taps = [buffer[src, lo + tap:lo + tap + count] for tap in range(4)]
                    result[ear, src] = sum(w[ear, src] * t for w, t in zip(weights, taps, strict=True))
            return result
        base, weights = _lagrange(hist + np.arange(count) - delay)                  # (ear, src, n)
        index = base.astype(np.intp) + (np.arange(nsrc) * buffer.shape[1])[:, np.newaxis]
        flat = buffer.ravel()
        result[:] = 0.0
        for tap, weight in enumerate(weights):                                       # 4 taps, not samples
            result += weight * np.take(flat, index + (tap - 1))
        return result

    def _shadow(self, delayed: npt.NDArray[np.float64], alpha: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Apply each source's head shadow at each ear and sum the sources: (count, ear) frames."""
        b0 = (alpha + self._w0) / self._norm
        b1 = (self._w0 - alpha) / self._norm
        previous = np.concatenate([self._last_delayed[:, :, np.newaxis], delayed[:, :, :-1]], axis=2)
        self._last_delayed = delayed[:, :, -1].copy()
        numerator = (b0 * delayed + b1 * previous).sum(axis=1)                       # (ear, n)
        shaped, self._zi = signal.lfilter([1.0], self._pole, numerator.T, axis=0, zi=self._zi)
        return np.asarray(shaped)

    @staticmethod
    def to_int32(frames: npt.NDArray[np.float64]) -> npt.NDArray[np.int32]:
        """Convert float full-scale frames to S32 samples, clipping."""
        return to_int32(frames)
