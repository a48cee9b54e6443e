"""The ears: a component that hears a sound device and publishes its own audio blocks and loudness.

Its port type is its own (``ears::block``: 16-bit samples, interleaved, numbered by chunk) and says
what it carries (``AudioStream``), so that aiogenomix records, exports, replays, shows and localises
it without a table naming it.  Its settings (``--ears-gain``) and its loudness kind are its own too.
"""

from __future__ import annotations

import collections
import dataclasses
import math
from typing import Annotated, ClassVar

import numpy as np
from numpy.typing import NDArray

from aiogenomix.components.audio import AudioError, open_for_host
from aiogenomix.components.core import (
    AudioStream, Component, Double, GenomException, MemberNeed, Out, OutPort, PortKind, SettingsGroup, String, ULong,
    Unit, activity, function, idl_struct, setting,
)

RATE, FRAMES = 44100, 2205
#: The chunks the ears hold: a reader slower than this loses some (counted, never silent).
HELD = 50


def _gain(value: object) -> str | None:
    """The refusal of a gain the ears cannot apply."""
    fits = isinstance(value, (int, float)) and -60.0 <= value <= 20.0
    return None if fits else "takes a gain from -60 to 20 dB"


@dataclasses.dataclass(frozen=True)
class EarsSettings(SettingsGroup, section="ears", about="the ears of the outside-ears package"):
    """What the operator tells the ears (``aiogenomix-gateway --ears-gain -6``).

    Attributes:
        gain: The gain applied to what the ears hear, in dB.
    """

    gain: float = setting(0.0, flag="--ears-gain", unit="dB", metavar="DB", refuse=_gain,
                          help="gain the ears apply to what they hear, in dB")


@dataclasses.dataclass(frozen=True, kw_only=True)
class Loudness(PortKind, kind="ears_loudness"):
    """How loud a sound is, in dB of full scale: a kind of this package.

    Attributes:
        level: The member holding the level.
    """

    level: str = "level"

    needs: ClassVar[dict[str, MemberNeed]] = {"level": MemberNeed("number")}


class EARS_DEVICE(GenomException):
    """The ears cannot hear the device (``what`` says why: no such backend, no such device...)."""

    what: String


@idl_struct("ears::block", carries=AudioStream(numbering="chunks", index="last", rate="rate", channels=("samples",),
                                               interleaved=2, start="began", chunk_frames="frames"))
class Block:
    """The ears' newest chunks: 16-bit samples, left and right interleaved."""

    rate: Annotated[ULong, "Frames per second"] = 0
    frames: Annotated[ULong, "Frames per chunk"] = 0
    last: Annotated[ULong, "The newest chunk's number (from 1)"] = 0
    began: Annotated[Double, "When the first chunk began (POSIX seconds)"] = 0.0
    samples: NDArray[np.int16] = dataclasses.field(default_factory=lambda: np.zeros(0, np.int16))


@idl_struct("ears::level", carries=Loudness(level="level"))
class Level:
    """How loud the newest chunk is."""

    level: Annotated[Double, Unit("dB"), "Root mean square of both ears, dB of full scale"] = -math.inf


class Held:
    """The last chunks the ears heard, numbered, published as a ``Block`` (readers ask for those after one)."""

    def __init__(self, began: float = 0.0) -> None:
        self.rate, self.frames, self.began = RATE, FRAMES, began
        self.last = 0
        self._chunks: collections.deque[NDArray[np.int16]] = collections.deque(maxlen=HELD)

    def add(self, interleaved: NDArray[np.int16]) -> None:
        """Hold one more chunk."""
        self._chunks.append(interleaved)
        self.last += 1

    @property
    def index(self) -> int:
        """The newest chunk's number."""
        return self.last

    @property
    def samples(self) -> NDArray[np.int16]:
        """Every chunk held, in order."""
        return np.concatenate(self._chunks) if self._chunks else np.zeros(0, np.int16)

    def since(self, index: int) -> tuple[Block, int]:
        """The chunks after *index*, and how many after it the ears no longer hold."""
        first_held = self.last - len(self._chunks) + 1
        start = max(index + 1, first_held)
        kept = list(self._chunks)[start - first_held:]
        block = Block(rate=self.rate, frames=self.frames, last=self.last, began=self.began,
                      samples=np.concatenate(kept) if kept else np.zeros(0, np.int16))
        return block, max(0, first_held - index - 1)


class Ears(Component, name="ears"):
    """Binaural ears of another package: they hear a sound device and publish their own blocks."""

    Ears = OutPort(Block, doc="The newest chunks heard", view=Held)
    Loudness = OutPort(Level, doc="How loud the newest chunk is")

    async def on_start(self) -> None:
        #: The operator's settings (the gateway's --ears-gain), or their defaults.
        self.settings = self.host.settings.of(EarsSettings)
        #: Every sample published, in order (what a test compares the others with).
        self.heard: list[NDArray[np.int16]] = []
        self.Ears.publish(Held())
        self.Loudness.publish(Level())

    @function
    def Gain(self) -> Annotated[Double, Out("gain", "The gain applied, in dB (--ears-gain)")]:
        """The gain the ears apply to what they hear."""
        return self.settings.gain

    @activity(throws=(EARS_DEVICE,))
    async def Listen(self, device: Annotated[String, "The sound device"] = "sim",
                     seconds: Annotated[Double, "How long"] = 1.0) -> None:
        """Hear the device for a while, publishing each chunk."""
        scale = 10 ** (self.settings.gain / 20)
        try:
            backend = open_for_host(self.host, device, RATE, FRAMES, self.clock)
            await backend.open()
        except AudioError as exc:
            raise EARS_DEVICE(what=str(exc)) from exc
        try:
            held = Held(self.clock.wall())
            for _ in range(math.ceil(seconds * RATE / FRAMES)):
                chunk = await backend.read()
                if chunk is None:
                    break
                scaled = np.clip(np.round(chunk.frames * scale) / 2**16, -(2**15), 2**15 - 1)
                interleaved = scaled.astype(np.int16).ravel()
                self.heard.append(interleaved)
                held.add(interleaved)
                self.Ears.publish(held)
                power = float(np.mean(np.square(interleaved / 2**15)))
                self.Loudness.publish(Level(10 * math.log10(power) if power > 0 else -math.inf))
        finally:
            await backend.aclose()
