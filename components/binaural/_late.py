"""The late reverberation of a room at the two ears: noise that decays with the room's RT60 per octave band.

Past the early reflections a room's response is dense enough to be heard as a
diffuse field that decays exponentially. Its expected energy per second at a
point, for a source heard at unit amplitude 1 m away, follows from the images:
``4π r² dr / V`` of them lie between r and r + dr, each of energy ``1/r²``, so the
response's power is ``4π c / V`` decaying by 60 dB in the band's RT60 (the
images' wall meetings make Eyring's decay; Kuttruff, *Room Acoustics*, ch. 5).

At the ears the field has the head's own diffuse-field cross-spectrum, which
:class:`~._filters.DiffuseFilters` makes from two independent noises: the tail is
those two noises through its filters, split into the octave bands (weights that
sum to one), each band shaped by its own decaying envelope, then added. It fades
in over a few milliseconds where the early reflections fade out (cos² and sin²,
so the energy stays continuous), at the *mixing time*.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ._filters import DiffuseFilters, fft_size
from ._room import band_weights

__all__ = ["late_tail", "tail_power"]

#: The tail ends where every band has decayed by this many dB.
_TAIL_DEPTH_DB = 60.0


def tail_power(volume: float, speed_of_sound: float) -> float:
    """The diffuse field's power per second at its start, ``4π c / V``, for a source of unit amplitude at 1 m."""
    return float(4.0 * np.pi * speed_of_sound / volume)


def late_tail(diffuse: DiffuseFilters, rt60: npt.NDArray[np.float64], *, volume: float, speed_of_sound: float,
              start: float, fade: float, rng: np.random.Generator,
              max_seconds: float = 3.0) -> npt.NDArray[np.float64]:
    """A binaural late tail: ``(taps, 2)``, silent before ``start − fade`` seconds.

    Args:
        diffuse: The head's diffuse-field filters, at the rendering rate.
        rt60: ``(7,)`` reverberation times of the octave bands, seconds.
        volume: The room's volume, cubic metres.
        speed_of_sound: Metres per second.
        start: The mixing time, seconds: the tail is at full level from here.
        fade: Seconds of its fade-in (sin²) before *start*.
        rng: The noise's generator.
        max_seconds: The longest tail kept.
    """
    rate = diffuse.rate
    length = int(np.ceil(min(max_seconds, start + float(np.max(rt60)) * _TAIL_DEPTH_DB / 60.0) * rate))
    n_fft = fft_size(length + diffuse.taps)
    noise = rng.standard_normal((2, length + diffuse.taps))
    spectrum = np.fft.rfft(noise, n_fft, axis=-1)
    ears = np.einsum("nf,nef->ef", spectrum, np.fft.rfft(diffuse.responses, n_fft, axis=-1))   # (ears, bins)
    # Drop the filters' start-up: the noise's first taps - 1 outputs had no full history.
    weights = band_weights(np.fft.rfftfreq(n_fft, 1.0 / rate))
    t = np.arange(length) / rate
    level = np.sqrt(tail_power(volume, speed_of_sound) / rate)                                     # per sample
    tail = np.zeros((length, 2))
    for band, seconds in enumerate(rt60):
        shaped = np.fft.irfft(ears * weights[band], n_fft, axis=-1)[:, diffuse.taps:diffuse.taps + length]
        tail += (shaped * np.exp(-3.0 * np.log(10.0) * t / seconds)).T
    opening = np.clip((t - (start - fade)) / fade, 0.0, 1.0) if fade > 0 else (t >= start).astype(float)
    return np.asarray(level * tail * np.sin(0.5 * np.pi * opening)[:, np.newaxis])
