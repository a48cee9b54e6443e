"""The ``binauloc`` component: binaural localisation on the measured KEMAR, after the Two!Ears ``binauloc``.

Reads ``bass/Audio`` by frame index (or a capture's chunks), publishes an estimate of the sources'
directions every few frames on ``Azimuths`` and in the numbered history ``Estimates``, and turns
whichever head a component provides to tell sources from their mirror images and face one
(``FaceSource``). The science is :mod:`aiogenomix.components.binaural`'s.
"""

from ._component import ANALYSES, AUDIO_PORTS, Binauloc
from ._feed import AudioBlock, PortFeed
from ._history import CAPACITY, EstimateHistory, EstimateWindow
from ._types import (
    MAX_SOURCES, AzimuthsData, EstimatesData, SourceAzimuthData, SourceData, Target, Window, e_head, e_noData,
    e_noHead, e_rate, e_setup,
)

__all__ = [
    "Binauloc", "AUDIO_PORTS", "ANALYSES", "AzimuthsData", "SourceData", "Window", "PortFeed", "AudioBlock",
    "SourceAzimuthData", "EstimatesData", "Target", "MAX_SOURCES", "EstimateHistory", "EstimateWindow", "CAPACITY",
    "e_setup", "e_noData", "e_rate", "e_noHead", "e_head",
]
