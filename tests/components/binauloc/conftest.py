"""Fixtures of the binauloc tests: scenes of one source, a rig on simulated time, request helpers."""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest

from aiogenomix.components.bass import Bass
from aiogenomix.components.binauloc import Binauloc
from aiogenomix.components.capture import Capture
from aiogenomix.components.core import Component, ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.kemar import Kemar
from aiogenomix.components.kemarcapture import KemarCapture

FACTORIES = {"bass": Bass, "binauloc": Binauloc, "capture": Capture, "kemarcapture": KemarCapture, "kemar": Kemar}


def source_scene(directory: Path, azimuth: float, *, seed: int, kind: str = "noise", onset: float = 1.5,
                 snr: float = 20.0) -> str:
    """A ``sim:`` device: one source at *azimuth* (room, degrees) starting at *onset* s, in a diffuse field."""
    path = directory / f"source-{azimuth:g}-{seed}-{kind}.json"
    path.write_text(json.dumps({"seed": seed, "diffuse_level": -snr, "noise_floor": -80, "sources": [
        {"type": kind, "azimuth": azimuth, "level": -26, "onset": onset}]}))
    return f"sim:{path}"


async def done(component: Component, service: str, inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    """Run a request to its end; return its output (failing the test on an error)."""
    request = await component.send(service, inputs or {})
    await request.ended.wait()
    assert request.status == "done", (service, request.exception)
    return request.output or {}


@pytest.fixture
async def rig() -> AsyncIterator[ComponentHost]:
    """Audio components, the simulated KEMAR drive and binauloc, on simulated time that waits for them."""
    async with ComponentHost(clock=VirtualClock(), factories=FACTORIES,
                             settings=HostSettings(can_timeout=10.0, audio_socket_port=0)) as host:
        yield host
