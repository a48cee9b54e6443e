"""The simulated scene as captured: Woodworth interaural delays, the sign flip as the head turns, no clicks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from aiogenomix.components.audio import DEFAULT_SCENE, SphericalHeadRenderer, woodworth_itd
from aiogenomix.components.capture import Capture

RATE = 44100
MAX_LAG = 40  # samples; more than the largest ITD (29 samples)


def interaural_delay(frames: np.ndarray) -> int:
    """Samples by which the right ear lags the left, from the cross-correlation peak."""
    left, right = frames[:, 0].astype(np.float64), frames[:, 1].astype(np.float64)
    core = slice(MAX_LAG, len(left) - MAX_LAG)
    lags = np.arange(-MAX_LAG, MAX_LAG + 1)
    correlation = [np.dot(left[core], right[MAX_LAG + lag:len(right) - MAX_LAG + lag]) for lag in lags]
    return int(lags[int(np.argmax(correlation))])


@pytest.fixture
def noise_scene(tmp_path: Path) -> str:
    """A scene with one noise source straight ahead of the room's 0°."""
    path = tmp_path / "noise.json"
    path.write_text(json.dumps({"seed": 11, "sources": [{"type": "noise", "azimuth": 0, "level": -20}]}))
    return f"sim:{path}"


async def capture_chunks(capture: Capture, device: str, chunks: int) -> np.ndarray:
    """Run a capture until *chunks* chunks are on the port; return them as (N, 2) frames."""
    request = await capture.send("StartCapture", {"device": device, "Port_chunks": chunks})
    while capture.Port.read().index < chunks:
        await capture.Port.wait_published()
    await capture.send("StopCapture")
    await request.ended.wait()
    port = capture.Port.read()
    return np.stack([port.left, port.right], axis=1)


@pytest.mark.parametrize("relative", [0.0, 30.0, -30.0, 60.0, -60.0])
async def test_interaural_delay_follows_woodworth(capture: Capture, noise_scene: str, relative: float) -> None:
    # The source is at 0°: a head turned to -θ hears it at +θ (on its left).
    capture.head_azimuth = lambda: -relative
    frames = await capture_chunks(capture, noise_scene, 6)
    expected = woodworth_itd(relative) * RATE
    assert abs(interaural_delay(frames) - expected) <= 1.0
    if relative > 0:
        assert np.std(frames[:, 0]) > np.std(frames[:, 1])  # the near ear is louder


async def test_delay_flips_sign_when_the_head_turns_past_the_source(capture: Capture, noise_scene: str) -> None:
    # The head turns 1° per chunk (20°/s) from -40° to +49°, past the source at 0°.
    azimuths = iter(range(-40, 1000))
    capture.head_azimuth = lambda: float(next(azimuths))
    frames = await capture_chunks(capture, noise_scene, 90)
    early, late = frames[:10 * 2205], frames[-10 * 2205:]
    assert interaural_delay(early) >= 10      # the source is on the head's left
    assert interaural_delay(late) <= -10      # now on its right


def test_rendering_is_deterministic_and_click_free_while_turning() -> None:
    first, second = SphericalHeadRenderer(DEFAULT_SCENE, RATE), SphericalHeadRenderer(DEFAULT_SCENE, RATE)
    sweep = [min(90.0, 4.0 * k) for k in range(40)]  # 80°/s, then still
    a = np.concatenate([first.render(2205, az) for az in sweep])
    b = np.concatenate([second.render(2205, az) for az in sweep])
    np.testing.assert_array_equal(a, b)
    tone = SphericalHeadRenderer(DEFAULT_SCENE.__class__(
        sources=(DEFAULT_SCENE.sources[1],), seed=1), RATE)
    out = np.concatenate([tone.render_float(2205, az) for az in sweep])
    steps = np.abs(np.diff(out, axis=0))
    # A click would be a jump at a chunk boundary far above the tone's own sample-to-sample change.
    boundaries = steps[2204::2205]
    assert boundaries.max() <= 1.5 * np.percentile(steps, 99.9)


def test_facing_a_source_gives_no_interaural_difference() -> None:
    renderer = SphericalHeadRenderer(DEFAULT_SCENE.__class__(sources=(DEFAULT_SCENE.sources[0],), seed=3), RATE)
    frames = np.concatenate([renderer.render(2205, 30.0) for _ in range(4)])  # the noise is at 30°
    np.testing.assert_array_equal(frames[:, 0], frames[:, 1])
