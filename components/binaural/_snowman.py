"""A head that is not the KEMAR: a rigid sphere on a spherical torso (the "snowman"), computed, not measured.

Localisation models are trained on one head and used on another; a test of that
needs a second head that is not the templates' and that needs no download. This
one is a model: the sound pressure on a rigid sphere of radius ``a`` for a plane
wave (Rayleigh's series, as Duda & Martens, "Range dependence of the response of
a spherical head model", JASA 104(5), 1998, give it), at ears 10° behind the
interaural axis and 1 cm below the centre, plus the specular reflection from a
torso sphere below it, as in the snowman model of Algazi, Duda, Duraiswami,
Gumerov & Tang ("Approximating the head-related transfer function using simple
geometric models of the head and torso", JASA 112(5), 2002): its delay follows
from the geometry, its amplitude from the spreading of a wave reflected by a
convex sphere (``(b/2) / (d + b/2)`` at a distance d from the reflection point
for a torso of radius b) and a reflection coefficient of 0.7. The torso's shadow
of sources below is not modelled. It has no pinnae, so its spectral cues differ
from the KEMAR's wholly, its interaural differences in detail.

Directions are those of the MIT KEMAR grid's rings (-40° to 90° every 10°,
azimuths every 5°), 512 taps at 44.1 kHz, onsets about 30 samples in, as the
KEMAR's: a drop-in :class:`~._hrir_set.HrirSet`.
"""

from __future__ import annotations

import functools

import numpy as np
import numpy.typing as npt
from scipy import special

from ._hrir_set import HrirSet

__all__ = ["snowman_hrirs"]

_RATE = 44_100.0
_TAPS = 512
#: Samples before a wave reaches the head's centre: the ipsilateral ear hears it about 11 samples earlier.
_BULK_DELAY = 40
#: Ears: 10° behind the interaural axis (Algazi et al. 2002 found ±100° fits best), 1 cm low.
_EAR_AZIMUTH = 100.0
_EAR_DROP = 0.01
_TORSO_REFLECTION = 0.7


def _sphere_spectrum(cos_angle: npt.NDArray[np.float64], ka: npt.NDArray[np.float64]) -> npt.NDArray[np.complex128]:
    """Pressure on a rigid sphere relative to the free field at its centre, for a plane wave.

    Args:
        cos_angle: ``(k,)`` cosine of the angle between the ear and the direction the wave comes from.
        ka: ``(bins,)`` wave number times radius (positive).

    Returns:
        ``(k, bins)`` transfer functions.
    """
    terms = int(np.max(ka)) + 30
    orders = np.arange(terms)
    legendre = np.stack([special.eval_legendre(m, cos_angle) for m in orders], axis=1)              # (k, m)
    with np.errstate(all="ignore"):   # high orders at low frequencies overflow: their terms vanish
        derivative = (special.spherical_jn(orders[:, np.newaxis], ka, derivative=True)
                      + 1j * special.spherical_yn(orders[:, np.newaxis], ka, derivative=True))      # (m, bins)
        weights = ((-1j) ** orders * (2 * orders + 1))[:, np.newaxis] / derivative                      # (m, bins)
    weights[~np.isfinite(weights)] = 0.0
    # The series is written for exp(-iωt) (Rayleigh's, as Duda & Martens give it): conjugated, a later
    # arrival has a falling phase, as the FFT below reads it.
    return np.asarray(np.conj((legendre @ weights) * (1j / ka**2)))


@functools.cache
def snowman_hrirs(radius: float = 0.0875, torso_radius: float = 0.169, neck: float = 0.053,
                  speed_of_sound: float = 343.0) -> HrirSet:
    """The snowman head's HRIRs at 44.1 kHz (made once per process, in about a second).

    Args:
        radius: The head sphere's radius, metres (8.75 cm: an average adult's, after Algazi et al.).
        torso_radius: The torso sphere's radius, metres.
        neck: The gap between head and torso, metres.
        speed_of_sound: Metres per second.
    """
    rings = np.arange(-40.0, 91.0, 10.0)
    azimuth = np.concatenate([np.arange(-180.0, 180.0, 5.0) if e < 90 else np.zeros(1) for e in rings])
    elevation = np.concatenate([np.full(72 if e < 90 else 1, e) for e in rings])
    a, e = np.radians(azimuth), np.radians(elevation)
    towards = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=1)           # (n, 3)
    n_fft = 2 * _TAPS
    frequency = np.fft.rfftfreq(n_fft, 1.0 / _RATE)
    omega = 2.0 * np.pi * frequency
    ka = np.maximum(omega / speed_of_sound * radius, 1e-6)
    torso_centre = np.array([0.0, 0.0, -(radius + neck + torso_radius)])
    taps = np.zeros((len(azimuth), _TAPS, 2))
    for ear, side in enumerate((1.0, -1.0)):                                   # left (+y) then right
        ear_angle = np.radians(side * _EAR_AZIMUTH)
        ear_direction = np.array([np.cos(ear_angle), np.sin(ear_angle), -_EAR_DROP / radius])
        ear_direction /= np.linalg.norm(ear_direction)
        spectrum = _sphere_spectrum(towards @ ear_direction, ka)
        spectrum[:, 0] = 1.0
        delay, gain = _torso_reflection(towards, ear_direction * radius, torso_centre, torso_radius, speed_of_sound)
        spectrum = spectrum + gain[:, np.newaxis] * np.exp(-1j * omega * delay[:, np.newaxis])
        spectrum *= np.exp(-1j * omega * _BULK_DELAY / _RATE)
        response = np.fft.irfft(spectrum, n_fft, axis=1)[:, :_TAPS]
        response[:, -64:] *= np.hanning(128)[64:]
        taps[:, :, ear] = response
    # Unit energy straight ahead, as the KEMAR's frontal responses have.
    ahead = int(np.argmin(np.abs(azimuth) + np.abs(elevation)))
    taps /= np.sqrt(np.sum(taps[ahead] ** 2) / 2.0)
    return HrirSet(_RATE, azimuth, elevation, taps,
                   f"snowman head (a = {radius * 100:g} cm, torso {torso_radius * 100:g} cm)")


def _torso_reflection(towards: npt.NDArray[np.float64], ear: npt.NDArray[np.float64], centre: npt.NDArray[np.float64],
                      radius: float, speed_of_sound: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Delay (s, after the direct wave at the head's centre) and amplitude of the torso's reflection to *ear*.

    A plane wave from each direction of *towards* meets the torso sphere; the point whose
    specular reflection reaches the ear is found among points of the sphere's upper
    half (the surface a head sits on), as the one whose reflected ray points closest
    to the ear. Directions from below the point's tangent plane reflect nothing.
    """
    polar = np.radians(np.arange(0.0, 90.1, 3.0))
    around = np.radians(np.arange(0.0, 360.0, 6.0))
    p, q = np.meshgrid(polar, around, indexing="ij")
    normals = np.stack([np.sin(p) * np.cos(q), np.sin(p) * np.sin(q), np.cos(p)], axis=-1).reshape(-1, 3)
    points = centre + radius * normals                                                               # (m, 3)
    to_ear = ear - points
    distance = np.linalg.norm(to_ear, axis=1)
    to_ear /= distance[:, np.newaxis]
    incoming = -towards                                                                               # (n, 3)
    along = incoming @ normals.T                                                                      # (n, m)
    reflected = incoming[:, np.newaxis, :] - 2.0 * along[..., np.newaxis] * normals[np.newaxis]
    fit = np.einsum("nmk,mk->nm", reflected, to_ear)
    fit = np.where(along < 0, fit, -np.inf)                                                           # lit side only
    best = np.argmax(fit, axis=1)
    lit = np.take_along_axis(fit, best[:, np.newaxis], axis=1)[:, 0] > np.cos(np.radians(6.0))
    path = -np.einsum("nk,nk->n", towards, points[best]) + distance[best]
    delay = np.maximum(path, 0.0) / speed_of_sound
    gain = np.where(lit, _TORSO_REFLECTION * (radius / 2) / (distance[best] + radius / 2), 0.0)
    return delay, gain
