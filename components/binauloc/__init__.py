"""The ``binauloc`` component: binaural localisation on the measured KEMAR, after the Two!Ears ``binauloc``.

Reads ``bass/Audio`` by frame index (or a capture's chunks), publishes an estimate of the dominant
source's direction every few frames on ``Azimuths``, and turns whichever head a component provides
to tell front from back (``FaceSource``). The science is :mod:`aiogenomix.components.binaural`'s.
"""

from ._component import ANALYSES, AUDIO_PORTS, Binauloc
from ._feed import AudioBlock, PortFeed
from ._types import AzimuthsData, SourceData, Window, e_head, e_noData, e_noHead, e_rate, e_setup

__all__ = [
    "Binauloc", "AUDIO_PORTS", "ANALYSES", "AzimuthsData", "SourceData", "Window", "PortFeed", "AudioBlock",
    "e_setup", "e_noData", "e_rate", "e_noHead", "e_head",
]
