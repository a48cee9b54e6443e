"""Opt-in tests on a real sound card (``AIOGENOMIX_HW=1``; device from ``AIOGENOMIX_AUDIO_DEVICE``, default hw:1,0)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from aiogenomix.components.audio import open_backend
from aiogenomix.components.audio._portaudio import portaudio_capture_devices
from aiogenomix.components.core import RealClock

pytestmark = pytest.mark.hardware

DEVICE = os.environ.get("AIOGENOMIX_AUDIO_DEVICE", "hw:1,0")
FPC = 2205


async def test_alsa_card_delivers_paced_chunks() -> None:
    async with open_backend(DEVICE, 44100, FPC, RealClock()) as backend:
        chunks = [await backend.read() for _ in range(20)]
    assert all(c is not None and c.frames.shape == (FPC, 2) for c in chunks)
    times = np.array([c.time for c in chunks if c is not None])
    # A real card is paced: consecutive chunks start 50 ms apart on the card's clock.
    np.testing.assert_allclose(np.diff(times), 0.05, atol=0.005)
    assert backend.overruns == 0


async def test_portaudio_default_input_delivers_chunks() -> None:
    if not portaudio_capture_devices():
        pytest.skip("no PortAudio input device")
    async with open_backend("pa", 44100, FPC, RealClock()) as backend:
        chunks = [await backend.read() for _ in range(10)]
    assert all(c is not None and c.frames.shape == (FPC, 2) and c.frames.dtype == np.int32 for c in chunks)
