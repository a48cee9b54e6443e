"""The world's sound-source markers as a simulated sound scene, heard from where a robot's head is.

A capture of the ``sim`` device renders these sources through the measured KEMAR HRIRs when a robot
of the world provides them (``morse_kemar`` for the KEMAR on its stand, ``pr2`` for the KEMAR head on
its moving base): the robot offers a :class:`~aiogenomix.components.audio.SoundScene` and a
:class:`~aiogenomix.components.audio.HeadAzimuth`, the capture finds them by type.  Directions are
in the horizontal plane: the markers' height is not rendered.
"""

from __future__ import annotations

import dataclasses
import math

from ..audio import Scene, Source
from ._mjcf import SOUND_SOURCES

__all__ = ["marker_azimuths", "marker_scene"]

#: What each marker plays, in the order of SOUND_SOURCES (cycled): a noise, a tone, clicks.
_KINDS = (Source(type="noise", level=-26.0), Source(type="tone", level=-30.0, frequency=500.0),
          Source(type="clicks", level=-12.0, rate=2.0))


def marker_azimuths(x: float, y: float) -> list[float]:
    """The room azimuth of each marker seen from (*x*, *y*), degrees, counter-clockwise from +x (positive = left)."""
    return [math.degrees(math.atan2(my - y, mx - x)) for mx, my, _z in SOUND_SOURCES.values()]


def marker_scene(x: float, y: float) -> Scene:
    """The markers as sources, in their directions from (*x*, *y*): the first a noise, the second a tone, then clicks.

    Heard by the measured KEMAR, with a quiet diffuse field and the capture's noise floor.
    """
    sources = tuple(dataclasses.replace(_KINDS[i % len(_KINDS)], azimuth=round(azimuth, 6))
                    for i, azimuth in enumerate(marker_azimuths(x, y)))
    return Scene(sources=sources, seed=7, diffuse_level=-30.0, noise_floor=-80.0)
