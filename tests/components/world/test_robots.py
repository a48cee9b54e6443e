"""The world and its robots in-process: laser, load options, limits, speed control, re-wiring."""

from __future__ import annotations

import importlib.util
import math
from collections.abc import AsyncIterator

import numpy as np
import pytest

from aiogenomix.components.core import ComponentHost, LoadError, VirtualClock
from aiogenomix.components.morse_kemar import yaw_of

pytestmark = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco is not installed")

WORLD_OPTIONS = ["-size", "32x32", "-rate", "2"]


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    """A host whose simulated time moves whenever the world and its robots have nothing else to do.

    Where a head or an arm stops is then the same on a quiet machine and on a busy one.
    """
    async with ComponentHost(clock=VirtualClock()) as host:
        await host.load("world", WORLD_OPTIONS)
        yield host


async def _run(component, service: str, **inputs):  # type: ignore[no-untyped-def]
    request = await component.send(service, inputs)
    if request.task is not None:
        await request.task
    return request


async def test_the_base_laser_sees_the_stand_ahead_and_not_the_robot(host: ComponentHost) -> None:
    world = host.get("world")
    await world.pr2_scan.wait_published()
    scan = world.pr2_scan.read()
    assert len(scan.ranges) == 271 and scan.angle_min == pytest.approx(-math.radians(135))
    ahead = scan.ranges[135]
    assert ahead == pytest.approx(3.0 - 0.275 - 0.03, abs=0.01)  # the red box's stand, 3 m ahead of the base
    assert np.all(scan.ranges > 0.3)  # its own base and arms are not in the way


@pytest.mark.parametrize("options", [["-size", "4x4"], ["-size", "big"], ["-rate", "0"], ["-rate", "nan"]])
async def test_bad_load_options_are_refused(options: list[str]) -> None:
    async with ComponentHost(clock=VirtualClock()) as host:
        with pytest.raises(LoadError):
            await host.load("world", ["-i", "other", *options])
        assert "other" not in host.instances


async def test_arm_goals_beyond_the_limits_stop_at_them(host: ComponentHost) -> None:
    pr2 = await host.load("pr2")
    request = await _run(pr2, "move_r_arm", r_shoulder_pan_joint=-3.0, r_elbow_flex_joint=1.0, time_to_finish=0.5)
    assert request.status == "done"
    state = host.get("world").pr2_joints.read()
    names = list(state.name)
    assert state.position[names.index("r_shoulder_pan_joint")] == pytest.approx(-2.2854, abs=0.005)
    assert state.position[names.index("r_elbow_flex_joint")] == pytest.approx(0.0, abs=0.005)
    refused = await _run(pr2, "move_head", pan=math.nan)
    assert refused.status == "error" and refused.exception["ex"] == "::pr2::INVALID_VALUE"
    outside = await _run(pr2, "go_to_position", x=100.0)
    assert outside.exception["ex"] == "::pr2::INVALID_VALUE"


async def test_morse_kemar_speed_control_stops_before_the_limit(host: ComponentHost) -> None:
    kemar = await host.load("morse_kemar")
    request = await _run(kemar, "ControlInSpeed", velocity=200.0)
    assert request.status == "done"
    # It stops 3° before the limit, give or take what the head turns in one physics step (4° at
    # 200°/s); never past the limit switch.
    assert 87.0 <= kemar.currentPosition <= 90.0
    assert kemar.RobotMotion.read().angular.z == 0.0  # stopped
    rotate = await _run(kemar, "Rotate", z=-30.0)
    assert rotate.status == "done" and kemar.RobotMotion.read().angular.z == pytest.approx(math.radians(-30))
    # The request ended; the head still turns: the dead-man switch of a component host stops it thus.
    await kemar.stop_motions()
    assert kemar.RobotMotion.read().angular.z == 0.0
    assert (await _run(kemar, "MoveRelativePosition", target=-20.0, velocity=0.0)).exception["ex"] == \
        "::morse_kemar::INVALID_VALUE"
    await _run(kemar, "Rotate", z=0.0)
    world = host.get("world")
    await world.kemar_pose.wait_published()
    start = yaw_of(world.kemar_pose.read())
    await _run(kemar, "MoveRelativePosition", target=-20.0, velocity=200.0)
    assert yaw_of(world.kemar_pose.read()) == pytest.approx(start - 20.0, abs=0.3)


async def test_connect_port_rewires_a_robot_to_another_camera(host: ComponentHost) -> None:
    pr2 = await host.load("pr2")
    request = await _run(pr2, "connect_port", local="Image", remote="world/kemar_camera_left")
    assert request.status == "done"
    world = host.get("world")
    await world.kemar_camera_left.wait_published()
    assert pr2.Image.read() is world.kemar_camera_left.read()


async def test_the_simulated_sound_scene_follows_the_virtual_kemar(host: ComponentHost) -> None:
    from aiogenomix.components.audio import HeadAzimuth, open_for_host
    from aiogenomix.components.audio._sim_backend import SimulatedSceneBackend

    assert host.find(HeadAzimuth) is None
    kemar = await host.load("morse_kemar")
    backend = open_for_host(host, "sim", 44100, 2205, host.clock)
    assert isinstance(backend, SimulatedSceneBackend)
    assert backend.azimuth() == pytest.approx(0.0, abs=0.1)
    await _run(kemar, "MoveAbsolutePosition", target=30.0, velocity=200.0)
    assert backend.azimuth() == pytest.approx(30.0, abs=0.15)
    assert host.require(HeadAzimuth).read() == pytest.approx(30.0, abs=0.15)


async def test_the_simulated_sound_sources_are_the_worlds_markers(host: ComponentHost) -> None:
    from aiogenomix.components.audio import DEFAULT_SCENE, Scene, open_for_host
    from aiogenomix.components.audio._sim_backend import SimulatedSceneBackend

    def scene(device: str) -> Scene | None:
        backend = open_for_host(host, device, 44100, 2205, host.clock)
        assert isinstance(backend, SimulatedSceneBackend)
        return backend.scene

    assert scene("sim") is DEFAULT_SCENE                          # no virtual KEMAR yet: the default scene
    await host.load("morse_kemar")
    markers = scene("sim")
    assert markers is not None
    # source_1 at (2.0, 2.5) and source_2 at (-1.0, -2.5), heard from the KEMAR at (-2.0, 1.5), facing +x.
    assert [round(s.azimuth, 2) for s in markers.sources] == [14.04, -75.96]
    assert [s.type for s in markers.sources] == ["noise", "tone"]
    assert scene("sim:my_scene.json") is None                     # a scene file of the user's wins
    await host.unload("morse_kemar")
    assert scene("sim") is DEFAULT_SCENE                          # gone with the component that provided it


async def test_the_pr2_carries_a_kemar_head_that_hears_the_markers_as_it_drives(host: ComponentHost) -> None:
    from aiogenomix.components.audio import HeadAzimuth, open_for_host
    from aiogenomix.components.audio._sim_backend import SimulatedSceneBackend
    from aiogenomix.components.world import SOUND_SOURCES

    pr2 = await host.load("pr2")
    backend = open_for_host(host, "sim", 44100, 2205, host.clock)
    assert isinstance(backend, SimulatedSceneBackend) and backend.source_azimuths is not None
    start = backend.source_azimuths()
    # The head pans 0.067 m behind the base's centre at the origin; source_1 is at (2.0, 2.5).
    assert start[0] == pytest.approx(math.degrees(math.atan2(2.5, 2.067)), abs=0.01)
    await _run(pr2, "go_to_position", x=1.0, y=0.5, w=0.3)
    await _run(pr2, "move_head", pan=0.5, tilt=0.0, time_to_finish=0.5)
    assert host.require(HeadAzimuth).read() == pytest.approx(math.degrees(0.8), abs=0.3)
    assert backend.azimuth() == pytest.approx(math.degrees(0.8), abs=0.3)
    head_x, head_y = 1.0 - 0.067 * math.cos(0.3), 0.5 - 0.067 * math.sin(0.3)
    expected = [math.degrees(math.atan2(y - head_y, x - head_x)) for x, y, _z in SOUND_SOURCES.values()]
    assert backend.source_azimuths() == pytest.approx(expected, abs=0.05)


async def test_the_virtual_kemar_hears_the_markers_through_the_measured_hrirs(host: ComponentHost) -> None:
    from aiogenomix.components.binaural import gcc_phat_itd, load_kemar
    from aiogenomix.components.capture import Capture

    kemar = await host.load("morse_kemar")
    await _run(kemar, "MoveAbsolutePosition", target=-20.0, velocity=200.0)
    capture = await host.load("capture")
    assert isinstance(capture, Capture)
    request = await capture.send("StartCapture", {"device": "sim", "Port_chunks": 10})
    while capture.Port.read().index < 10:
        await capture.Port.wait_published()
    await capture.send("StopCapture")
    await request.ended.wait()
    port = capture.Port.read()
    ears = np.stack([port.left, port.right], axis=1)[4096:].astype(np.float64)
    # The noise of source_1, 14° to the left of the KEMAR's stand, is 34° to the left of a head at -20°:
    # the ITD of the measured response there (the tone of source_2 is a few frequencies among many).
    hrirs = load_kemar()
    measured = gcc_phat_itd(*hrirs.taps[hrirs.index(35.0)].T, max_lag=50)
    assert gcc_phat_itd(*ears.T, max_lag=40) == pytest.approx(measured, abs=1.5)
