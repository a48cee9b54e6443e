"""The simulated scene as captured: KEMAR's measured cues (issue 25, acceptance 1), no clicks, the spherical head.

The captured audio of ``capture``, ``kemarcapture`` (its head turned by the simulated drive) and ``bass``
is compared with the MIT KEMAR HRIRs directly: for a source at θ relative to the head, the GCC-PHAT ITD
within 1 sample of the measured response's at θ, its third-octave ILDs within 2 dB RMS.
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from pathlib import Path

import numpy as np
import pytest

from aiogenomix.components.audio import KemarSceneRenderer, Scene, Source, SphericalHeadRenderer, woodworth_itd
from aiogenomix.components.bass import Bass
from aiogenomix.components.binaural import HrirSet, band_ilds, gcc_phat_itd, load_kemar, third_octave_centres
from aiogenomix.components.capture import Capture
from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.kemarcapture import KemarCapture

RATE = 44100
FPC = 2205
MAX_LAG = 40  # samples; more than the largest ITD (32 samples)
RELATIVE = (30.0, 75.0, 120.0, 150.0)


@pytest.fixture(scope="module")
def kemar() -> HrirSet:
    return load_kemar()


def interaural_delay(frames: np.ndarray) -> int:
    """Samples by which the right ear lags the left, from the cross-correlation peak."""
    left, right = frames[:, 0].astype(np.float64), frames[:, 1].astype(np.float64)
    core = slice(MAX_LAG, len(left) - MAX_LAG)
    lags = np.arange(-MAX_LAG, MAX_LAG + 1)
    correlation = [np.dot(left[core], right[MAX_LAG + lag:len(right) - MAX_LAG + lag]) for lag in lags]
    return int(lags[int(np.argmax(correlation))])


def scene_file(tmp_path: Path, name: str, **scene: object) -> str:
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(scene))
    return f"sim:{path}"


def noise_at(tmp_path: Path, azimuth: float, seed: int) -> str:
    """A scene of one noise source at *azimuth* in the room, nothing else (no noise floor)."""
    return scene_file(tmp_path, f"noise{azimuth:g}", seed=seed,
                      sources=[{"type": "noise", "azimuth": azimuth, "level": -20}])


def assert_cues_are_kemars(frames: np.ndarray, kemar: HrirSet, relative: float, rate: float = RATE,
                           centres: np.ndarray | None = None) -> None:
    """The acceptance: ITD within 1 sample, third-octave ILDs within 2 dB RMS, of the measured response at θ."""
    ears = frames[2048:].astype(np.float64)           # past the filters' start
    measured = kemar.taps[kemar.index(relative)]
    itd = gcc_phat_itd(*ears.T, max_lag=MAX_LAG)
    expected = gcc_phat_itd(*measured.T, max_lag=50) * rate / kemar.rate
    assert abs(itd - expected) <= 1.0, (relative, itd, expected)
    difference = band_ilds(*ears.T, rate, centres) - band_ilds(*measured.T, kemar.rate, centres)
    assert np.sqrt(np.mean(difference**2)) <= 2.0, (relative, difference)


async def captured(component: Capture, device: str, chunks: int, **inputs: object) -> np.ndarray:
    """Run a capture until *chunks* chunks are on the port; return them as (N, 2) frames."""
    before = component.window
    request = await component.send("StartCapture", {"device": device, "Port_chunks": chunks, **inputs})
    # The port shows the previous capture until this one's scene is open (its renderer is built off the loop).
    while component.window is before or component.Port.read().index < chunks:
        await component.Port.wait_published()
    await component.send("StopCapture")
    await request.ended.wait()
    assert request.exception == {"ex": "::genom::interrupted", "detail": {"by": "StopCapture"}}
    port = component.Port.read()
    return np.stack([port.left, port.right], axis=1)


@pytest.fixture
async def rig() -> AsyncIterator[ComponentHost]:
    """The simulated rig on simulated time: the KEMAR drive on a virtual CAN bus, the audio components."""
    async with ComponentHost(clock=VirtualClock(), settings=HostSettings(can_timeout=10.0, audio_socket_port=0),
                             factories={"capture": Capture, "kemarcapture": KemarCapture, "bass": Bass}) as host:
        yield host


@pytest.mark.parametrize("relative", RELATIVE)
async def test_capture_hears_a_source_with_kemars_cues(rig: ComponentHost, kemar: HrirSet, tmp_path: Path,
                                                        relative: float) -> None:
    capture = await rig.load("capture")
    assert isinstance(capture, Capture)
    frames = await captured(capture, noise_at(tmp_path, relative, seed=int(relative)), 20)  # one second
    assert_cues_are_kemars(frames, kemar, relative)


async def test_kemarcapture_turned_to_40_degrees_hears_the_relative_angle(rig: ComponentHost, kemar: HrirSet,
                                                                         tmp_path: Path) -> None:
    merged = await rig.load("kemarcapture")
    assert isinstance(merged, KemarCapture)
    for service, inputs in (("Homing", {}), ("MoveAbsolutePosition", {"target": 40.0})):
        request = await merged.send(service, inputs)
        await request.ended.wait()
        assert request.status == "done", request.exception
    for relative in RELATIVE:
        frames = await captured(merged, noise_at(tmp_path, 40.0 + relative, seed=int(relative) + 1), 20)
        np.testing.assert_allclose(merged.Port.read().positions, 40.0, atol=0.05)   # the head stood at 40°
        assert_cues_are_kemars(frames, kemar, relative)


async def test_bass_at_24414_hz_hears_the_resampled_cues(rig: ComponentHost, kemar: HrirSet, tmp_path: Path) -> None:
    bass = await rig.load("bass")
    assert isinstance(bass, Bass)
    request = await bass.send("Acquire", {"device": noise_at(tmp_path, 75.0, seed=3), "sampleRate": 24414,
                                          "nFramesPerChunk": 4096, "nChunksOnPort": 8})
    while bass.snapshot.last_frame_index < 8 * 4096:
        await bass.Audio.wait_published()
    await bass.send("Stop")
    await request.ended.wait()
    port = bass.snapshot.data
    frames = np.stack([port.left, port.right], axis=1)
    assert_cues_are_kemars(frames, kemar, 75.0, rate=24414, centres=third_octave_centres(200.0, 10_000.0))


def largest_jump(ears: np.ndarray) -> float:
    return float(np.max(np.abs(np.diff(ears.astype(np.float64), axis=0))))


async def test_a_head_sweep_is_captured_without_a_click(rig: ComponentHost, tmp_path: Path) -> None:
    # A low tone changes little from sample to sample, so that a jump in the filters would stand out.
    # The head turns at 120°/s (6° a chunk) past a tone on its left, as the capture reads it chunk by chunk.
    scene = {"seed": 1, "sources": [{"type": "tone", "azimuth": 60, "level": -20, "frequency": 125}]}
    capture = await rig.load("capture")
    assert isinstance(capture, Capture)
    chunks = 24
    heads = [min(90.0, 6.0 * k) for k in range(1, chunks + 1)]
    turning = iter(heads)
    capture.head_azimuth = lambda: next(turning)
    sweep = await captured(capture, scene_file(tmp_path, "tone", **scene), chunks)
    tone = Scene.from_dict(scene)
    statics = {}
    for head in [0.0, *heads]:
        renderer = KemarSceneRenderer(tone, RATE)
        statics[head] = np.concatenate([renderer.render(FPC, head) for _ in range(chunks)])
    skip = 2048   # the filters' start-up
    bound = 1.1 * max(largest_jump(ears[skip:]) for ears in statics.values())
    assert largest_jump(sweep[skip:]) <= bound
    # The same sweep with the filters switched at the chunks' edges, not cross-faded, would click.
    switched = np.concatenate([statics[heads[i]][i * FPC:(i + 1) * FPC] for i in range(chunks)])
    assert largest_jump(switched[skip:]) > 1.5 * bound


async def test_the_spherical_head_stays_available_by_name(rig: ComponentHost, tmp_path: Path) -> None:
    capture = await rig.load("capture")
    assert isinstance(capture, Capture)
    for relative in (30.0, -60.0):
        device = scene_file(tmp_path, f"sphere{relative:g}", seed=11, head="spherical",
                            sources=[{"type": "noise", "azimuth": relative, "level": -20}])
        frames = await captured(capture, device, 6)
        assert abs(interaural_delay(frames) - woodworth_itd(relative) * RATE) <= 1.0


def test_the_measured_head_tells_front_from_back_where_the_sphere_cannot() -> None:
    # 30° and 150° lie on one cone of confusion: a sphere gives both the same ear signals' levels,
    # KEMAR's pinnae and torso do not.
    noise = np.random.default_rng(4)
    levels = {}
    for head, renderer in (("spherical", SphericalHeadRenderer), ("kemar", KemarSceneRenderer)):
        for azimuth in (30.0, 150.0):
            scene = Scene(sources=(Source("noise", azimuth=azimuth, level=-20.0, seed=int(noise.integers(99))),),
                          head=head)  # type: ignore[arg-type]
            ears = renderer(scene, RATE).render_float(RATE, 0.0)[2048:]
            levels[head, azimuth] = band_ilds(*ears.T, RATE, third_octave_centres(1000.0, 12_500.0))
    sphere = levels["spherical", 30.0] - levels["spherical", 150.0]
    measured = levels["kemar", 30.0] - levels["kemar", 150.0]
    assert np.sqrt(np.mean(sphere**2)) < 0.5
    assert np.sqrt(np.mean(measured**2)) > 3.0


def test_facing_a_source_gives_no_interaural_difference_on_the_sphere() -> None:
    scene = Scene(sources=(Source("noise", azimuth=30.0, level=-26.0),), seed=3, head="spherical")
    renderer = SphericalHeadRenderer(scene, RATE)
    frames = np.concatenate([renderer.render(FPC, 30.0) for _ in range(4)])  # the noise is at 30°
    np.testing.assert_array_equal(frames[:, 0], frames[:, 1])
