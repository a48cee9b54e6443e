"""Binaural science on measured HRIRs: the KEMAR set, rooms, other heads, streaming renderers, a localiser.

Pure computation (no I/O besides reading the HRIRs once): the capture scene
renders through :class:`BinauralRenderer`, and a ``binauloc`` component runs
:class:`SourceLocaliser` (several sources, glimpses placed in the room by the
head's azimuth) and turns a :class:`TurnableHead`. :class:`BinauralLocaliser`
is the dominant-source method of before, kept for comparison. Conventions
throughout: azimuths in degrees, counter-clockwise seen from above (positive to
the LEFT), room or head frame as named; ear 0 is the left; samples are floats with full scale 1; the
localiser reports radians in the head frame, as the Two!Ears code read
``binauloc.Azimuths()``. ``docs/localisation.md`` gives the methods, their
references and the measured figures.

Scenes offline (the API experiments use; numpy in, numpy out)::

    rate = 44_100
    room = Shoebox.with_rt60((6.0, 4.0, 3.0), 0.5)          # or Shoebox.with_absorption(dims, alpha)
    listener = Pose(3.0, 2.0, 1.5, facing=0.0)              # metres; facing in degrees, positive left
    rng = np.random.default_rng(1)
    talkers = [Talker(speech_like(3.0, rate, rng), listener.at(30.0, distance=1.5)),
               Talker(speech_like(3.0, rate, rng, voice="female"), (5.0, 3.0, 1.6), level=-3.0, onset=0.5)]
    ears = render_scene(talkers, listener, rate=rate, seconds=3.0, room=room,
                        head=lambda t: 20.0 * t,            # the head's room azimuth at t seconds
                        hrirs=snowman_hrirs())              # a head the localiser's templates do not come from
    brir = room_response((5.0, 3.0, 1.6), listener, rate=rate, room=room)   # (frames, 2)

Heads: :func:`load_kemar` (the default), :func:`snowman_hrirs` (a sphere on a torso,
computed), :func:`read_sofa` (any SOFA ``SimpleFreeFieldHRIR`` file; the ``sofa``
extra); :func:`write_sofa` writes one. :class:`RoomRenderer` renders block by block
for a capture. Measured rooms: :func:`read_sofa_room` (SOFA BRIRs with head orientations) and
:class:`MeasuredRoomRenderer`.
"""

from ._active import FrontBackPolicy, HeadTurnFailed, TurnableHead
from ._cues import band_ilds, gcc_phat_itd, third_octave_centres
from ._errors import BinauralError, HrirError, HrirUnavailable, LocalisationError
from ._filters import AzimuthFilters, DiffuseFilters, azimuth_filters, diffuse_filters
from ._glimpses import GlimpseAnalyser, GlimpseParameters, Glimpses, erb_bands, tempered
from ._head_movement import MA_TURN, TurnPlanner, ma_combine, ma_turn, posterior_sum
from ._hrir_set import HrirSet, wrap_degrees
from ._geometry import Pose, Position, directions, position_at
from ._interpolation import HorizontalInterpolator
from ._kemar import KEMAR_RATE, kemar_cache_path, load_kemar
from ._likelihood import GRID_DEGREES, AzimuthLikelihood, combine_in_room, radians
from ._localiser import (
    BATCH_SAMPLES, MOTION_TOLERANCE, WINDOWS, AzimuthEstimate, BinauralLocaliser, FrameAnalysis, LocaliserSetup,
    NoiseLearner, Window,
)
from ._measured_room import MeasuredRoom, MeasuredRoomRenderer
from ._mixture import (
    TURNING_FRONT_BACK_WEIGHT, RoomAzimuthFilter, SourceAzimuth, SourceCounting, mirror_image, pick_sources,
)
from ._offline import Path, Talker, render_scene, room_response
from ._renderer import BinauralRenderer
from ._room import OCTAVE_BANDS, SPEED_OF_SOUND, WALLS, ImageSources, Shoebox, band_weights, image_sources
from ._room_renderer import RoomRenderer
from ._signals import SIGNALS, VOICES, speech_like, tone_complex, white_noise
from ._snowman import snowman_hrirs
from ._sofa import ROOM_CONVENTIONS, SOFA_CONVENTION, SofaError, read_sofa, read_sofa_room, write_sofa
from ._source_localiser import SourceLocaliser, SourcesEstimate

__all__ = [
    # Measured HRIRs
    "HrirSet", "load_kemar", "kemar_cache_path", "KEMAR_RATE", "HorizontalInterpolator", "wrap_degrees",
    # Other heads
    "snowman_hrirs", "read_sofa", "write_sofa", "SofaError", "SOFA_CONVENTION",
    # Measured rooms
    "read_sofa_room", "MeasuredRoom", "MeasuredRoomRenderer", "ROOM_CONVENTIONS",
    # Rendering
    "BinauralRenderer", "AzimuthFilters", "azimuth_filters", "DiffuseFilters", "diffuse_filters",
    # Scenes in rooms
    "render_scene", "room_response", "Talker", "Path", "Pose", "Position", "directions", "position_at",
    "RoomRenderer", "Shoebox", "image_sources", "ImageSources", "band_weights", "OCTAVE_BANDS", "WALLS",
    "SPEED_OF_SOUND",
    # Localisation
    "BinauralLocaliser", "LocaliserSetup", "AzimuthEstimate", "AzimuthLikelihood", "combine_in_room", "GRID_DEGREES",
    "NoiseLearner", "Window", "WINDOWS", "MOTION_TOLERANCE", "BATCH_SAMPLES", "radians", "FrameAnalysis",
    # Several sources
    "SourceLocaliser", "SourcesEstimate", "SourceAzimuth", "RoomAzimuthFilter", "SourceCounting", "pick_sources",
    "mirror_image", "GlimpseAnalyser", "GlimpseParameters", "Glimpses", "erb_bands", "tempered",
    "TURNING_FRONT_BACK_WEIGHT",
    # Head movements
    "TurnPlanner", "ma_turn", "ma_combine", "posterior_sum", "MA_TURN",
    # Active listening
    "TurnableHead", "FrontBackPolicy", "HeadTurnFailed",
    # Cues
    "gcc_phat_itd", "band_ilds", "third_octave_centres",
    # Test signals
    "white_noise", "speech_like", "tone_complex", "SIGNALS", "VOICES",
    # Errors
    "BinauralError", "HrirError", "HrirUnavailable", "LocalisationError",
]
