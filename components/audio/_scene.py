"""Simulated sound scenes: fixed virtual sources, their seeded signals, and the JSON scene file.

A scene file is JSON (every key optional)::

    {
      "seed": 7,                       # base seed; source i defaults to seed + i
      "head_radius": 0.0875,           # metres (KEMAR)
      "speed_of_sound": 343.0,         # metres per second
      "noise_floor": -80,              # dBFS of uncorrelated noise per ear, or null
      "sources": [
        {"type": "noise",  "azimuth": 30,  "level": -26},
        {"type": "tone",   "azimuth": -60, "level": -30, "frequency": 500},
        {"type": "clicks", "azimuth": 120, "level": -12, "rate": 2}
      ]
    }

Azimuths are degrees in the room, counter-clockwise seen from above, so a
positive azimuth is on the head's left when it faces 0° (as for the KEMAR
head, whose positive positions turn it to the left).  ``level`` is in dB
relative to full scale: of the RMS for noise and tones, of the peak for clicks.
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

__all__ = ["Scene", "Source", "SourceKind", "load_scene", "DEFAULT_SCENE", "SourceSignal"]

SourceKind = Literal["noise", "tone", "clicks"]
_KINDS = ("noise", "tone", "clicks")


@dataclasses.dataclass(frozen=True)
class Source:
    """One fixed virtual source.

    Attributes:
        type: ``noise`` (white, Gaussian), ``tone`` (a sine) or ``clicks`` (one-sample impulses).
        azimuth: Direction in the room, degrees, positive to the left of 0°.
        level: dB re full scale (RMS for noise and tones, peak for clicks).
        frequency: Tone frequency in Hz.
        rate: Clicks per second.
        seed: Noise seed (None: the scene seed plus the source's position in the list).
    """

    type: SourceKind = "noise"
    azimuth: float = 0.0
    level: float = -26.0
    frequency: float = 500.0
    rate: float = 2.0
    seed: int | None = None


@dataclasses.dataclass(frozen=True)
class Scene:
    """A set of fixed sources around a spherical head.

    Attributes:
        sources: The virtual sources.
        seed: Base seed of the noise sources.
        head_radius: Sphere radius in metres.
        speed_of_sound: In metres per second.
        noise_floor: dBFS RMS of independent noise added at each ear, or None.
    """

    sources: tuple[Source, ...] = ()
    seed: int = 0
    head_radius: float = 0.0875
    speed_of_sound: float = 343.0
    noise_floor: float | None = None

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Scene:
        """Build a scene from decoded JSON.

        Raises:
            SceneError: naming the bad key or value.
        """
        if not isinstance(data, Mapping):
            raise SceneError("a scene is a JSON object")
        known = {f.name for f in dataclasses.fields(cls)}
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
                sources.append(Source(**raw))
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
        if not (self.head_radius > 0 and self.speed_of_sound > 0):
            raise SceneError("head_radius and speed_of_sound must be positive")
        for i, source in enumerate(self.sources):
            if not all(math.isfinite(v) for v in (source.azimuth, source.level, source.frequency, source.rate)):
                raise SceneError(f"sources[{i}] has a non-finite value")
            if source.type == "clicks" and not source.rate > 0:
                raise SceneError(f"sources[{i}].rate must be positive")
            if source.type == "tone" and not source.frequency >= 0:
                raise SceneError(f"sources[{i}].frequency must not be negative")


#: The scene of ``sim``: noise ahead-left, a tone on the right, clicks behind-left.
DEFAULT_SCENE = Scene(
    sources=(
        Source("noise", azimuth=30.0, level=-26.0),
        Source("tone", azimuth=-60.0, level=-30.0, frequency=500.0),
        Source("clicks", azimuth=120.0, level=-12.0, rate=2.0),
    ),
    seed=7,
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
    return Scene.from_dict(description)


class SourceSignal:
    """The dry signal of one source, generated block after block.

    Blocks depend only on the sample position, so a capture and a reference
    rendering of the same scene produce identical samples.

    Args:
        source: What to generate.
        rate: Sample rate in Hz.
        seed: Seed of a noise source.
    """

    def __init__(self, source: Source, rate: int, seed: int) -> None:
        self.source = source
        self.rate = rate
        self.amplitude = 10.0 ** (source.level / 20.0)
        self._rng = np.random.default_rng(seed)
        self._position = 0
        period = rate / source.rate if source.type == "clicks" else 0.0
        self._click_period = max(1, round(period))

    def next(self, count: int) -> npt.NDArray[np.float64]:
        """The next *count* samples."""
        start, self._position = self._position, self._position + count
        kind = self.source.type
        if kind == "noise":
            return self.amplitude * self._rng.standard_normal(count)
        n = np.arange(start, start + count, dtype=np.int64)
        if kind == "tone":
            # Reduce the phase modulo one period in exact integer arithmetic first,
            # so hours of signal keep full float precision.
            cycles = (n * round(self.source.frequency * 1000) % (self.rate * 1000)) / (self.rate * 1000)
            return self.amplitude * math.sqrt(2.0) * np.sin(2.0 * np.pi * cycles)
        return np.where(n % self._click_period == 0, self.amplitude, 0.0)
