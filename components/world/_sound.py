"""The world's sound-source markers as a simulated sound scene: heard in the world's room, from a robot's head.

A capture of the ``sim`` device renders these sources when a robot of the world provides them
(``morse_kemar`` for the KEMAR on its stand, ``pr2`` for the KEMAR head on its moving base): the
robot offers a :class:`~aiogenomix.components.audio.SoundScene` and a
:class:`~aiogenomix.components.audio.HeadAzimuth`, the capture finds them by type.  One world for
eyes and ears: the markers are heard where they are drawn, in the room whose walls the cameras see
(its floor ``ROOM`` up to ``WALL_HEIGHT``), with its early reflections and its reverberation, through
the measured KEMAR HRIRs.  The room's walls have no acoustic material in the MuJoCo model: they are
given a reverberation time of 0.5 s, an ordinary furnished room's.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

from ..audio import Scene, Source
from ._mjcf import ROOM, SOUND_SOURCES, WALL_HEIGHT

__all__ = ["marker_azimuths", "marker_scene", "WORLD_ROOM"]

#: What each marker plays, in the order of SOUND_SOURCES (cycled): a noise, a tone, clicks.
_KINDS = (Source(type="noise", level=-26.0), Source(type="tone", level=-30.0, frequency=500.0),
          Source(type="clicks", level=-12.0, rate=2.0))
#: The room of the scene: the world's walls, and a reverberation time.
WORLD_ROOM = {"dimensions": [ROOM[1] - ROOM[0], ROOM[3] - ROOM[2], WALL_HEIGHT], "origin": [ROOM[0], ROOM[2], 0.0],
              "rt60": 0.5}


def marker_azimuths(x: float, y: float) -> list[float]:
    """The room azimuth of each marker seen from (*x*, *y*), degrees, counter-clockwise from +x (positive = left)."""
    return [math.degrees(math.atan2(my - y, mx - x)) for mx, my, _z in SOUND_SOURCES.values()]


def marker_scene(listener: Sequence[float]) -> Scene:
    """The markers as sources at their places in the world's room, heard from *listener* (x, y, z in metres).

    The first marker plays a noise, the second a tone, then clicks; levels are 1 m away. A quiet
    diffuse field and the capture's noise floor join them, as in the default scene.
    """
    sources = tuple(dataclasses.replace(_KINDS[i % len(_KINDS)], position=(float(x), float(y), float(z)))
                    for i, (x, y, z) in enumerate(SOUND_SOURCES.values()))
    x, y, z = (float(v) for v in listener)
    return Scene(sources=sources, seed=7, diffuse_level=-30.0, noise_floor=-80.0, room=WORLD_ROOM,
                 listener={"x": x, "y": y, "z": z, "facing": 0.0})
