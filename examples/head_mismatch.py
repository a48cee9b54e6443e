"""What a head that is not the templates' looks like to the localiser, band by band.

A localiser whose templates come from one head (the MIT KEMAR) hears another head's
interaural cues as those of other directions. This prints, for talkers at a few azimuths
heard in the free field from a still head, the direction each auditory band points to
(the peak of its units' posteriors summed with the weights the localiser gives them) and
the band's share of those weights: the KEMAR itself (the templates' own head) beside the
head asked for. Each band's direction is given as its lateral angle (0° ahead or behind,
90° at an ear; a mirror image across the interaural axis has the same), and marked
``b`` when it points behind the ear axis.

Run it with the project's virtualenv (a few seconds)::

    .venv/bin/python examples/head_mismatch.py                        # the snowman head
    .venv/bin/python examples/head_mismatch.py --head sphere --azimuths 45 90
    .venv/bin/python examples/head_mismatch.py --head my_head.sofa    # any SOFA set

The scene is the talkers experiment's (``binaural.talkers_experiment``): a speech-like talker
1.5 m away at the ears' height, a diffuse field about 25 dB below it and sensor noise, the noise
learnt from half a second of it alone, 1 s analysed at 24,414 Hz.
"""

from __future__ import annotations

import argparse
import dataclasses
import pathlib

import numpy as np
import numpy.typing as npt

from aiogenomix.components.audio import sphere_hrirs
from aiogenomix.components.binaural import (
    GRID_DEGREES, HrirSet, LocaliserSetup, Pose, SourceLocaliser, Talker, load_kemar, read_sofa, render_scene,
    speech_like,
)
from aiogenomix.components.binaural.talkers_experiment import head_set

RATE = 24_414.0
SECONDS = 1.0
LISTENER = Pose(0.0, 0.0, 1.5)


#: The heads named rather than read from a file.
NAMED = ("kemar", "snowman", "sphere")


def head(name: str) -> HrirSet:
    """The head *name*: one of :data:`NAMED` or a SOFA file."""
    if name == "sphere":
        return sphere_hrirs()
    return head_set(name) if name in NAMED else read_sofa(name)


@dataclasses.dataclass(frozen=True)
class BandDirections:
    """Where each band hears a talker.

    Attributes:
        lateral: ``(bands,)`` the lateral angle of the band's peak, degrees (0 ahead or behind, 90 at the ear).
        behind: ``(bands,)`` whether the peak is behind the ear axis.
        weight: ``(bands,)`` the band's share of the units' weights.
    """

    lateral: npt.NDArray[np.float64]
    behind: npt.NDArray[np.bool_]
    weight: npt.NDArray[np.float64]

    def cell(self, band: int) -> str:
        """The band's lateral angle as the table shows it."""
        return f"{self.lateral[band]:.0f}{'b' if self.behind[band] else ''}"


def band_centres(localiser: SourceLocaliser) -> npt.NDArray[np.float64]:
    """Each band's centre frequency, Hz (the mean of its FFT bins')."""
    setup = localiser.setup
    frequencies = np.fft.rfftfreq(setup.frame, 1.0 / setup.rate)
    frequencies = frequencies[(frequencies >= setup.min_frequency) & (frequencies <= setup.max_frequency)]
    membership = localiser.analyser.membership                                    # (bins, bands)
    return np.asarray(frequencies @ membership / membership.sum(axis=0))


def heard(hrirs: HrirSet, talker: Talker, seconds: float, seed: int) -> npt.NDArray[np.float64]:
    """The ears' signals of *talker* in the free field through *hrirs*, with the experiment's noises."""
    return render_scene([talker], LISTENER, rate=RATE, seconds=seconds, hrirs=hrirs, diffuse_level=-50.0,
                        sensor_noise=-70.0, seed=seed)


def band_directions(localiser: SourceLocaliser, hrirs: HrirSet, azimuth: float) -> BandDirections:
    """Where each band of *localiser* hears a talker at *azimuth* heard through *hrirs*."""
    talker = Talker(speech_like(SECONDS + 0.5, RATE, np.random.default_rng(25)), LISTENER.at(azimuth, distance=1.5),
                    level=-20.0)
    # The noise alone (a silent talker: the renderer wants one source at least), learnt as the experiment learns it.
    localiser.learn_noise(heard(hrirs, Talker(np.zeros(1), LISTENER.at(0.0, distance=1.0)), 0.5, seed=2))
    ears = heard(hrirs, talker, SECONDS, seed=1)
    glimpses, _ = localiser.glimpses(ears)
    posterior = np.exp(glimpses.log_likelihood.astype(np.float64))
    posterior /= posterior.sum(axis=-1, keepdims=True)
    votes = np.einsum("fb,fbg->bg", glimpses.weight, posterior)                     # (bands, 360)
    peaks = GRID_DEGREES[np.argmax(votes, axis=-1)]
    weight = glimpses.weight.sum(axis=0)
    return BandDirections(np.abs(np.degrees(np.arcsin(np.sin(np.radians(peaks))))),
                          np.cos(np.radians(peaks)) < -1e-9, weight / max(float(weight.sum()), 1e-300))


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description="What a head that is not the templates' looks like, band by band.")
    parser.add_argument("--head", default="snowman", help="kemar, snowman, sphere or a SOFA file (snowman)")
    parser.add_argument("--azimuths", type=float, nargs="+", default=[30.0, 60.0, 90.0, 120.0],
                        help="the talkers' azimuths, degrees, positive to the left (30 60 90 120)")
    args = parser.parse_args()
    localiser = SourceLocaliser(LocaliserSetup(rate=RATE))
    label = args.head if args.head in NAMED else pathlib.Path(args.head).stem
    heads = {"kemar": load_kemar(), label: head(args.head)}                       # the KEMAR alone if asked
    columns = {(name, azimuth): band_directions(localiser, hrirs, azimuth)
               for azimuth in args.azimuths for name, hrirs in heads.items()}
    print("Each band's lateral angle, degrees (b: behind the ear axis), talkers in the free field, still head\n")
    print("| band, Hz | " + " | ".join(f"{name} at {azimuth:.0f}°" for name, azimuth in columns)
          + " | weight, % (" + " / ".join(heads) + f", at {args.azimuths[0]:.0f}°) |")
    print("|---:|" + "---:|" * (len(columns) + 1))
    first = [columns[name, args.azimuths[0]].weight for name in heads]
    for band, centre in enumerate(band_centres(localiser)):
        cells = [columns[key].cell(band) for key in columns]
        shares = " / ".join(f"{100 * share[band]:.0f}" for share in first)
        print(f"| {centre:.0f} | " + " | ".join(cells) + f" | {shares} |")


if __name__ == "__main__":
    main()
