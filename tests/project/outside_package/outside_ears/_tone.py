"""A capture backend of this package: a pure tone, opened by the device string ``tone:FREQUENCY``."""

from __future__ import annotations

import math
from typing import Self

import numpy as np
import numpy.typing as npt

from aiogenomix.components.audio import DeviceError, PacedBackend, SourceOptions
from aiogenomix.components.core import Clock

#: The tone's amplitude: half of full scale (int32).
AMPLITUDE = 2**30


class ToneBackend(PacedBackend):
    """A sine of the frequency after ``tone:`` (440 Hz when none), the same in both ears, paced by the clock."""

    kind = "tone"

    def __init__(self, device: str, rate: int, frames_per_chunk: int, clock: Clock, frequency: float) -> None:
        super().__init__(device, rate, frames_per_chunk, clock)
        self.frequency = frequency
        self._frame = 0

    @classmethod
    def for_device(cls, device: str, argument: str, rate: int, frames_per_chunk: int, clock: Clock,
                   options: SourceOptions) -> Self:
        """The tone ``tone:FREQUENCY`` names (a number of hertz below half the rate)."""
        try:
            frequency = float(argument or 440.0)
        except ValueError:
            raise DeviceError(f"{device!r}: a tone is tone:FREQUENCY, in hertz") from None
        if not 0 < frequency < rate / 2:
            raise DeviceError(f"{device!r}: a tone's frequency lies between 0 and {rate / 2:g} Hz")
        return cls(device, rate, frames_per_chunk, clock, frequency)

    def _produce(self, count: int) -> npt.NDArray[np.int32]:
        times = (self._frame + np.arange(count)) / self.rate
        self._frame += count
        wave = np.round(AMPLITUDE * np.sin(2 * math.pi * self.frequency * times)).astype(np.int32)
        return np.stack([wave, wave], axis=1)
