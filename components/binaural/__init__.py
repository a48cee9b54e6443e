"""Binaural science on measured HRIRs: the KEMAR set, a streaming renderer, and a localiser with head turns.

Pure computation (no I/O besides reading the HRIRs once): the capture scene
renders through :class:`BinauralRenderer`, and a ``binauloc`` component runs
:class:`SourceLocaliser` (several sources, glimpses placed in the room by the
head's azimuth) and turns a :class:`TurnableHead`. :class:`BinauralLocaliser`
is the dominant-source method of before, kept for comparison. Conventions throughout: azimuths in degrees,
counter-clockwise seen from above (positive to the LEFT), room or head frame
as named; ear 0 is the left; samples are floats with full scale 1; the
localiser reports radians in the head frame, as the Two!Ears code read
``binauloc.Azimuths()``. ``docs/localisation.md`` gives the methods, their
references and the measured figures.
"""

from ._active import FrontBackPolicy, HeadTurnFailed, TurnableHead
from ._cues import band_ilds, gcc_phat_itd, third_octave_centres
from ._errors import BinauralError, HrirError, HrirUnavailable, LocalisationError
from ._filters import AzimuthFilters, DiffuseFilters, azimuth_filters, diffuse_filters
from ._glimpses import GlimpseAnalyser, GlimpseParameters, Glimpses, erb_bands
from ._head_movement import MA_TURN, TurnPlanner, ma_combine, ma_turn, posterior_sum
from ._hrir_set import HrirSet, wrap_degrees
from ._interpolation import HorizontalInterpolator
from ._kemar import KEMAR_RATE, kemar_cache_path, load_kemar
from ._likelihood import GRID_DEGREES, AzimuthLikelihood, combine_in_room, radians
from ._localiser import (
    BATCH_SAMPLES, MOTION_TOLERANCE, WINDOWS, AzimuthEstimate, BinauralLocaliser, FrameAnalysis, LocaliserSetup,
    NoiseLearner, Window,
)
from ._mixture import RoomAzimuthFilter, SourceAzimuth, SourceCounting, mirror_image, pick_sources
from ._renderer import BinauralRenderer
from ._signals import SIGNALS, speech_like, tone_complex, white_noise
from ._source_localiser import SourceLocaliser, SourcesEstimate

__all__ = [
    # Measured HRIRs
    "HrirSet", "load_kemar", "kemar_cache_path", "KEMAR_RATE", "HorizontalInterpolator", "wrap_degrees",
    # Rendering
    "BinauralRenderer", "AzimuthFilters", "azimuth_filters", "DiffuseFilters", "diffuse_filters",
    # Localisation
    "BinauralLocaliser", "LocaliserSetup", "AzimuthEstimate", "AzimuthLikelihood", "combine_in_room", "GRID_DEGREES",
    "NoiseLearner", "Window", "WINDOWS", "MOTION_TOLERANCE", "BATCH_SAMPLES", "radians", "FrameAnalysis",
    # Several sources
    "SourceLocaliser", "SourcesEstimate", "SourceAzimuth", "RoomAzimuthFilter", "SourceCounting", "pick_sources",
    "mirror_image", "GlimpseAnalyser", "GlimpseParameters", "Glimpses", "erb_bands",
    # Head movements
    "TurnPlanner", "ma_turn", "ma_combine", "posterior_sum", "MA_TURN",
    # Active listening
    "TurnableHead", "FrontBackPolicy", "HeadTurnFailed",
    # Cues
    "gcc_phat_itd", "band_ilds", "third_octave_centres",
    # Test signals
    "white_noise", "speech_like", "tone_complex", "SIGNALS",
    # Errors
    "BinauralError", "HrirError", "HrirUnavailable", "LocalisationError",
]
