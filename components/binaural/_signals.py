"""Seeded test signals for localisation: broadband noise, a speech-like signal and a harmonic tone complex.

All have an RMS of 1 (full scale 1), so a level in dB re full scale is a gain.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import signal

__all__ = ["white_noise", "speech_like", "tone_complex", "SIGNALS", "VOICES"]

#: Vowel formants (F1, F2, F3) in Hz of an adult male voice (Peterson & Barney 1952): /a/, /i/, /u/, /e/, /o/.
_VOWELS = ((730.0, 1090.0, 2440.0), (270.0, 2290.0, 3010.0), (300.0, 870.0, 2240.0),
           (530.0, 1840.0, 2480.0), (570.0, 840.0, 2410.0))
_FORMANT_BANDWIDTHS = (90.0, 110.0, 170.0)
#: Voices of :func:`speech_like`: (mean fundamental in Hz, formant scale). Adult women's formants lie
#: some 17 % above men's, children's some 30 % (Peterson & Barney 1952).
VOICES = {"male": (125.0, 1.0), "female": (210.0, 1.17), "child": (270.0, 1.3)}


def _unit_rms(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    return np.asarray(x / max(float(np.sqrt(np.mean(x**2))), 1e-30))


def white_noise(seconds: float, rate: float, rng: np.random.Generator) -> npt.NDArray[np.float64]:
    """Gaussian white noise."""
    return _unit_rms(rng.standard_normal(round(seconds * rate)))


def tone_complex(seconds: float, rate: float, rng: np.random.Generator, fundamental: float = 250.0,
                 harmonics: int = 12) -> npt.NDArray[np.float64]:
    """Equal-amplitude harmonics 1…*harmonics* of *fundamental* (Hz), in random phases: a sparse spectrum."""
    t = np.arange(round(seconds * rate)) / rate
    orders = np.arange(1, harmonics + 1)
    orders = orders[orders * fundamental < 0.45 * rate]
    phases = rng.uniform(0.0, 2.0 * np.pi, len(orders))
    return _unit_rms(np.sin(2.0 * np.pi * fundamental * orders[:, np.newaxis] * t + phases[:, np.newaxis]).sum(0))


def _resonator(frequency: float, bandwidth: float,
               rate: float) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """A two-pole resonance of unit gain at 0 Hz."""
    radius = math.exp(-math.pi * bandwidth / rate)
    a = np.array([1.0, -2.0 * radius * math.cos(2.0 * math.pi * frequency / rate), radius**2])
    return np.array([a.sum()]), a


def speech_like(seconds: float, rate: float, rng: np.random.Generator, voice: str = "male") -> npt.NDArray[np.float64]:
    """A speech-like signal: voiced syllables with formants and a syllabic rhythm, and fricative bursts.

    Syllables of 120–300 ms at about 4 per second, with pauses between them. Each
    is a harmonic voice (a falling fundamental near 120 Hz with vibrato, harmonics
    falling at 6 dB per octave up to 5 kHz) through the three formants of a vowel
    drawn at random, under a raised-cosine envelope; a third of them start with
    40–80 ms of high-pass noise, like a fricative consonant. Another *voice* (:data:`VOICES`)
    raises the fundamental and the formants as a woman's or a child's; the draws from *rng*
    are the same, so talkers of one seed keep their rhythm.

    Raises:
        ValueError: for a voice not in :data:`VOICES`.
    """
    if voice not in VOICES:
        raise ValueError(f"voice must be one of {', '.join(VOICES)}, not {voice!r}")
    pitch, scale = VOICES[voice]
    total = round(seconds * rate)
    out = np.zeros(total)
    position = int(rng.integers(0, round(0.05 * rate)))
    while position < total:
        length = round(rng.uniform(0.12, 0.30) * rate)
        t = np.arange(length) / rate
        f0 = (pitch / 125.0 * rng.uniform(100.0, 150.0) * (1.0 - 0.15 * t / t[-1])
              * (1.0 + 0.01 * np.sin(2 * np.pi * 5.0 * t)))
        phase = 2.0 * np.pi * np.cumsum(f0) / rate
        orders = np.arange(1, int(min(5000.0, 0.45 * rate) / f0.max()) + 1)
        sound = (np.sin(orders[:, np.newaxis] * phase) / orders[:, np.newaxis]).sum(0)
        for frequency, bandwidth in zip(_VOWELS[int(rng.integers(len(_VOWELS)))], _FORMANT_BANDWIDTHS, strict=True):
            if frequency * scale < 0.45 * rate:
                sound = signal.lfilter(*_resonator(frequency * scale, bandwidth * scale, rate), sound)
        envelope = np.sin(np.pi * np.arange(length) / length) ** 2
        syllable = _unit_rms(sound) * envelope
        if rng.random() < 1.0 / 3.0:
            burst = round(rng.uniform(0.04, 0.08) * rate)
            high = signal.butter(4, min(3000.0, 0.3 * rate), "highpass", fs=rate, output="sos")
            noise = signal.sosfilt(high, rng.standard_normal(burst)) * np.hanning(burst)
            syllable = np.concatenate([0.5 * _unit_rms(noise), syllable])
        end = min(total, position + len(syllable))
        out[position:end] += syllable[:end - position]
        position = end + round(rng.uniform(0.03, 0.12) * rate)
    return _unit_rms(out)


#: The signals of the localisation experiment, by name.
SIGNALS = {"noise": white_noise, "speech-like": speech_like, "tone complex": tone_complex}
