"""binauloc in one process reads bass of another by frame index, as it reads a bass of its own."""

from __future__ import annotations

import math
import os

import pytest

from aiogenomix.clients import Interrupted, aconnect

from ._processes import Process
from .test_ports_across_hosts import reader_and_writer_hosts

#: Three processes on Zenoh: ./run runs it once, on the default Python (AIOGENOMIX_HEAVY=0 on the others).
pytestmark = pytest.mark.skipif(os.environ.get("AIOGENOMIX_HEAVY") == "0",
                                reason="runs once, on the default Python (AIOGENOMIX_HEAVY=0)")


async def test_binauloc_in_one_host_localises_on_bass_in_another(started: list[Process]) -> None:
    url = await reader_and_writer_hosts(started, writer="bass", reader="binauloc")
    async with aconnect(url) as client:
        bass = await client.load("bass")
        binauloc = await client.load("binauloc")
        # Audio reads any port whose type carries audio: the other process's is known by its description.
        await binauloc.connect_port("Audio", "bass/Audio")
        acquiring = await bass.Acquire(device="sim", ack=True)        # the default scene, 44.1 kHz
        assert await binauloc.LocalizeSources(nEstimates=3) == 3
        estimate = await binauloc.Azimuths()
        # The last of three estimates of ten frames each, 512 samples apart, read by frame from the mirror.
        assert estimate.estimate == 3 and estimate.nFrames == 10 and len(estimate.logLikelihood) == 360
        assert estimate.frameIndex <= (await bass.Audio()).lastFrameIndex
        # The default scene's noise, 30° to the left of a head at 0° (no head here: the lateral angle).
        assert abs(math.degrees(math.asin(math.sin(estimate.azimuth))) - 30.0) < 5.0
        await bass.Stop()
        with pytest.raises(Interrupted):
            await acquiring
