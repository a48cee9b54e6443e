"""Simulated sound scenes: fixed virtual sources, their seeded signals, and the JSON scene file.

A scene file is JSON (every key optional)::

    {
      "seed": 7,                       # base seed; source i defaults to seed + i
      "head": "kemar",                 # "kemar" (measured HRIRs, the default), "snowman" or "spherical"
      "hrtf": "subject.sofa",          # a SOFA file (SimpleFreeFieldHRIR) to hear through instead of "head"
      "diffuse_level": -20,            # dB of a diffuse noise field re the sources' total dry power, or null
      "noise_floor": -80,              # dBFS of uncorrelated noise per ear, or null
      "head_radius": 0.0875,           # metres (the spherical head only)
      "speed_of_sound": 343.0,         # metres per second
      "room": {"dimensions": [6, 4, 3], "rt60": 0.5},       # or "absorption": see _room_scene
      "listener": {"x": 3, "y": 2, "z": 1.5, "facing": 0},  # where the head is, when no robot says
      "sources": [
        {"type": "noise",  "azimuth": 30,  "level": -26},
        {"type": "tone",   "azimuth": -60, "level": -30, "frequency": 500},
        {"type": "clicks", "azimuth": 120, "level": -12, "rate": 2},
        {"type": "speech", "azimuth": 150, "distance": 2, "level": -26, "onset": 2, "voice": "female"},
        {"type": "file",   "file": "talker.wav", "position": [1, 1, 1.6], "loop": false},
        {"type": "speech", "path": {"waypoints": [[1, 1, 1.6], [5, 1, 1.6]], "speed": 0.5}}
      ]
    }

Azimuths are degrees in the room, counter-clockwise seen from above, so a
positive azimuth is on the head's left when it faces 0° (as for the KEMAR
head, whose positive positions turn it to the left).  ``level`` is in dB
relative to full scale: of the RMS for noise, tones and speech, of the peak for
clicks.  A source is silent for its first ``onset`` seconds (a noise field to
learn before it starts).

``head`` names the renderer: ``kemar`` renders every source through the MIT
KEMAR HRIRs (Gardner & Martin 1995), interpolated between measured directions
(``aiogenomix.components.binaural``); ``spherical`` is the rigid sphere of
Brown & Duda (1998), kept for comparison: it is symmetric front to back.  The
diffuse field (``kemar`` only) is uncorrelated noise from every measured
horizontal direction through the HRIRs; ``diffuse_level`` is its power at the
ears relative to the sources' total dry power (−20: 20 dB below it).  Dry, not at
the ears: a source's power at the ears depends on its direction (KEMAR's frontal
responses have unit energy, so a source straight ahead is as loud at the ears as
dry; a lateral one is louder at the near ear and softer at the far one), while the
field's level should not move with the sources' directions.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from ._errors import SceneError

__all__ = ["Scene", "Source", "SourceKind", "HeadModel", "load_scene", "DEFAULT_SCENE", "SourceSignal"]

SourceKind = Literal["noise", "tone", "clicks", "speech", "file"]
_KINDS = ("noise", "tone", "clicks", "speech", "file")
#: The heads of a scene, by name: two sets of HRIRs and the rigid sphere renderer.
HeadModel = Literal["kemar", "snowman", "spherical"]
_HEADS = ("kemar", "snowman", "spherical")
#: Seconds of speech-like signal generated once per source and played in a loop.
_SPEECH_LOOP = 8.0


@dataclasses.dataclass(frozen=True)
class Source:
    """One fixed virtual source.

    Attributes:
        type: ``noise`` (white, Gaussian), ``tone`` (a sine), ``clicks`` (one-sample impulses),
            ``speech`` (a speech-like signal: voiced syllables with formants, pauses and fricatives) or
            ``file`` (a WAV file's samples, its channels mixed, resampled to the capture's rate).
        azimuth: Direction in the room, degrees, positive to the left of 0°.
        level: dB re full scale (RMS for noise, tones, speech and files; peak for clicks); 1 m away
            when the scene is in metres.
        frequency: Tone frequency in Hz.
        rate: Clicks per second.
        seed: Noise or speech seed (None: the scene seed plus the source's position in the list).
        onset: Seconds of silence before the source starts.
        elevation: Degrees above the listener's ears (with *azimuth* and *distance*).
        distance: Metres from the listener (with *azimuth* and *elevation*).
        position: (x, y, z) in the room frame, metres (instead of azimuth, elevation and distance).
        path: Waypoints walked at a speed: ``{"waypoints": [[x, y, z], ...], "speed": m/s, "loop": false}``.
        file: The WAV file of a ``file`` source.
        loop: Play a file (or the speech) again and again; false plays it once.
        voice: The speech's voice: ``male``, ``female`` or ``child``.
        emitter: In a measured room (``"room": {"sofa": FILE}``), the loudspeaker the source plays from.
    """

    type: SourceKind = "noise"
    azimuth: float = 0.0
    level: float = -26.0
    frequency: float = 500.0
    rate: float = 2.0
    seed: int | None = None
    onset: float = 0.0
    elevation: float = 0.0
    distance: float | None = None
    position: tuple[float, float, float] | None = None
    path: Mapping[str, Any] | None = None
    file: str | None = None
    loop: bool = True
    voice: str = "male"
    emitter: int | None = None

    @property
    def placed(self) -> bool:
        """Whether the source is placed in a room: a position, a distance, an elevation, a path or an emitter."""
        return (self.position is not None or self.distance is not None or self.path is not None
                or self.elevation != 0 or self.emitter is not None)

    def power(self, rate: float) -> float:
        """The source's mean power once it has started (full scale 1), at *rate* Hz."""
        amplitude2 = 10.0 ** (self.level / 10.0)
        if self.type == "clicks":
            return amplitude2 * min(1.0, self.rate / rate)
        return amplitude2


@dataclasses.dataclass(frozen=True)
class Scene:
    """A set of fixed sources around a head, and the noise it hears besides them.

    Attributes:
        sources: The virtual sources.
        seed: Base seed of the noise sources, the diffuse field and the sensor noise.
        head: The head: ``kemar`` (measured HRIRs), ``snowman`` (a sphere on a torso, computed: a head the
            localiser's templates do not come from) or ``spherical`` (the rigid sphere renderer).
        diffuse_level: Power of a diffuse noise field at the ears in dB relative to the sources'
            total dry power (their power at the ears straight ahead), or None for none (``kemar`` only).
        noise_floor: dBFS RMS of independent noise added at each ear, or None.
        head_radius: Sphere radius in metres (``spherical`` only).
        speed_of_sound: In metres per second.
        hrtf: A SOFA file to hear through (instead of *head*'s HRIRs), relative to the scene file.
        room: The shoebox: ``dimensions``, ``absorption`` or ``rt60``, ``origin``, ``max_order``,
            ``mixing_time`` (:func:`~._room_scene.shoebox_of`); or a measured room, ``{"sofa": FILE}``
            (binaural room impulse responses with head orientations), each source at a loudspeaker (``emitter``).
        listener: Where the head is when no robot says: ``x``, ``y``, ``z`` (m) and ``facing`` (°).
        base: The directory of the scene file (relative files are found there); not a JSON key.
    """

    sources: tuple[Source, ...] = ()
    seed: int = 0
    head: HeadModel = "kemar"
    diffuse_level: float | None = None
    noise_floor: float | None = None
    head_radius: float = 0.0875
    speed_of_sound: float = 343.0
    hrtf: str | None = None
    room: Mapping[str, Any] | None = None
    listener: Mapping[str, float] | None = None
    base: str | None = None

    @property
    def placed(self) -> bool:
        """Whether the scene is in metres (a room, a listener, or a placed source): see :mod:`._room_scene`."""
        return self.room is not None or self.listener is not None or any(s.placed for s in self.sources)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Scene:
        """Build a scene from decoded JSON.

        Raises:
            SceneError: naming the bad key or value.
        """
        if not isinstance(data, Mapping):
            raise SceneError("a scene is a JSON object")
        known = {f.name for f in dataclasses.fields(cls)} - {"base"}
        unknown = set(data) - known
        if unknown:
            raise SceneError(f"unknown scene key {sorted(unknown)[0]!r} (keys: {', '.join(sorted(known))})")
        sources = []
        for i, raw in enumerate(data.get("sources", ())):
            if not isinstance(raw, Mapping):
                raise SceneError(f"sources[{i}] is not an object")
            fields = {f.name for f in dataclasses.fields(Source)}
            if set(raw) - fields:
                raise SceneError(f"sources[{i}]: unknown key {sorted(set(raw) - fields)[0]!r}")
            if raw.get("type", "noise") not in _KINDS:
                raise SceneError(f"sources[{i}].type must be one of {', '.join(_KINDS)}, not {raw['type']!r}")
            try:
                fields_ = dict(raw)
                if isinstance(fields_.get("position"), list):
                    fields_["position"] = tuple(fields_["position"])
                sources.append(Source(**fields_))
            except TypeError as exc:
                raise SceneError(f"sources[{i}]: {exc}") from None
        scene = cls(sources=tuple(sources), **{k: v for k, v in data.items() if k != "sources"})
        scene.check()
        return scene

    def check(self) -> None:
        """Refuse physically meaningless values.

        Raises:
            SceneError: naming the value.
        """
        if self.head not in _HEADS:
            raise SceneError(f"head must be one of {', '.join(_HEADS)}, not {self.head!r}")
        if not (self.head_radius > 0 and self.speed_of_sound > 0):
            raise SceneError("head_radius and speed_of_sound must be positive")
        for name in ("diffuse_level", "noise_floor"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int | float)
                                      or not math.isfinite(value)):
                raise SceneError(f"{name} must be a number of dB or null, not {value!r}")
        if self.diffuse_level is not None:
            if self.head != "kemar":
                raise SceneError("the diffuse field is rendered through the measured HRIRs: use head \"kemar\"")
            if not self.sources:
                raise SceneError("diffuse_level is relative to the sources' power: the scene has no source")
        if self.hrtf is not None and (not isinstance(self.hrtf, str) or self.head == "spherical"):
            raise SceneError("hrtf names a SOFA file (a string), heard instead of a head's HRIRs (not the sphere's)")
        if self.placed:
            from ._room_scene import check_placed

            check_placed(self)
        for i, source in enumerate(self.sources):
            if source.type == "file" and not isinstance(source.file, str):
                raise SceneError(f"sources[{i}] is a file source: give its WAV file as \"file\"")
            if not isinstance(source.loop, bool) or source.voice not in ("male", "female", "child"):
                raise SceneError(f"sources[{i}]: loop is true or false, voice male, female or child")
            values = (source.azimuth, source.level, source.frequency, source.rate, source.onset, source.elevation)
            if not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in values):
                raise SceneError(f"sources[{i}] has a value that is not a finite number")
            if source.onset < 0:
                raise SceneError(f"sources[{i}].onset must not be negative")
            if source.type == "clicks" and not source.rate > 0:
                raise SceneError(f"sources[{i}].rate must be positive")
            if source.type == "tone" and not source.frequency >= 0:
                raise SceneError(f"sources[{i}].frequency must not be negative")


#: The scene of ``sim``: noise ahead-left, a tone on the right, clicks behind-left, heard by the KEMAR
#: in a quiet diffuse field.
DEFAULT_SCENE = Scene(
    sources=(
        Source("noise", azimuth=30.0, level=-26.0),
        Source("tone", azimuth=-60.0, level=-30.0, frequency=500.0),
        Source("clicks", azimuth=120.0, level=-12.0, rate=2.0),
    ),
    seed=7,
    diffuse_level=-30.0,
    noise_floor=-80.0,
)


def load_scene(path: str | os.PathLike[str], *, shown: str | None = None) -> Scene:
    """Read a JSON scene file (a regular file of at most 1 MiB; this blocks on the disk).

    Args:
        path: The file.
        shown: How to name it in messages (default: *path*).

    Raises:
        SceneError: when the file cannot be read or describes no valid scene.
    """
    from ._paths import read_regular_file

    name = shown if shown is not None else os.fspath(path)
    data = read_regular_file(os.fspath(path), name)
    try:
        description = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
        raise SceneError(f"scene file {name!r} is not JSON: {exc}") from exc
    return dataclasses.replace(Scene.from_dict(description), base=os.path.dirname(os.path.abspath(path)))


class SourceSignal:
    """The dry signal of one source, generated block after block.

    Blocks depend only on the sample position, so a capture and a reference
    rendering of the same scene produce identical samples.

    Args:
        source: What to generate.
        rate: Sample rate in Hz.
        seed: Seed of a noise source.
        samples: The samples of a ``file`` source at *rate* (read by :func:`~._room_scene.read_wav`).
    """

    def __init__(self, source: Source, rate: int, seed: int,
                 samples: npt.NDArray[np.float64] | None = None) -> None:
        self.source = source
        self.rate = rate
        self.amplitude = 10.0 ** (source.level / 20.0)
        self._rng = np.random.default_rng(seed)
        self._position = 0
        self._onset = round(source.onset * rate)
        period = rate / source.rate if source.type == "clicks" else 0.0
        self._click_period = max(1, round(period))
        self._speech: npt.NDArray[np.float64] | None = None
        if source.type == "speech":
            from ..binaural import speech_like

            self._speech = self.amplitude * speech_like(_SPEECH_LOOP, rate, self._rng, voice=source.voice)
        elif source.type == "file":
            if samples is None:
                raise SceneError(f"the file source {source.file!r} was not read")
            rms = float(np.sqrt(np.mean(samples**2))) if len(samples) else 0.0
            self._speech = self.amplitude * samples / rms if rms > 0 else np.zeros(max(1, len(samples)))

    def next(self, count: int) -> npt.NDArray[np.float64]:
        """The next *count* samples (zeros before the onset)."""
        start, self._position = self._position, self._position + count
        if start + count <= self._onset:
            return np.zeros(count)
        silent = max(0, self._onset - start)
        samples = self._generate(start + silent - self._onset, count - silent)
        return np.concatenate([np.zeros(silent), samples]) if silent else samples

    def _generate(self, start: int, count: int) -> npt.NDArray[np.float64]:
        """*count* samples of the signal from its sample *start* (0 at the onset)."""
        kind = self.source.type
        if kind == "noise":
            return self.amplitude * self._rng.standard_normal(count)
        if self._speech is not None:
            if self.source.loop:
                return np.take(self._speech, np.arange(start, start + count), mode="wrap")
            played = np.zeros(count)
            inside = self._speech[start:start + count]
            played[:len(inside)] = inside
            return played
        n = np.arange(start, start + count, dtype=np.int64)
        if kind == "tone":
            # Reduce the phase modulo one period in exact integer arithmetic first,
            # so hours of signal keep full float precision.
            cycles = (n * round(self.source.frequency * 1000) % (self.rate * 1000)) / (self.rate * 1000)
            return self.amplitude * math.sqrt(2.0) * np.sin(2.0 * np.pi * cycles)
        return np.where(n % self._click_period == 0, self.amplitude, 0.0)
