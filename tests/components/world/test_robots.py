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

    from aiogenomix.components.audio import listener_of, shoebox_of
    from aiogenomix.components.world import SOUND_SOURCES

    assert scene("sim") is DEFAULT_SCENE                          # no virtual KEMAR yet: the default scene
    await host.load("morse_kemar")
    markers = scene("sim")
    assert markers is not None
    # The markers where the world draws them, heard from the KEMAR's head at (-2.0, 1.5), 1.47 m up, in the
    # room whose walls the cameras see: 10 x 8 x 3 m from (-4, -4).
    assert [s.position for s in markers.sources] == list(SOUND_SOURCES.values())
    assert [s.type for s in markers.sources] == ["noise", "tone"]
    assert listener_of(markers).position == (-2.0, 1.5, 1.47)
    room = shoebox_of(markers.room or {})
    assert room.dimensions == (10.0, 8.0, 3.0) and room.origin == (-4.0, -4.0, 0.0)
    assert room.eyring_rt60() == pytest.approx(0.5)
    assert scene("sim:my_scene.json") is None                     # a scene file of the user's wins
    await host.unload("morse_kemar")
    assert scene("sim") is DEFAULT_SCENE                          # gone with the component that provided it


async def test_the_pr2_carries_a_kemar_head_that_hears_the_markers_as_it_drives(host: ComponentHost) -> None:
    from aiogenomix.components.audio import HeadAzimuth, open_for_host
    from aiogenomix.components.audio._sim_backend import SimulatedSceneBackend
    from aiogenomix.components.world import SOUND_SOURCES

    pr2 = await host.load("pr2")
    backend = open_for_host(host, "sim", 44100, 2205, host.clock)
    assert isinstance(backend, SimulatedSceneBackend) and backend.listener is not None
    assert backend.scene is not None and [s.position for s in backend.scene.sources] == list(SOUND_SOURCES.values())
    # The head pans 0.067 m behind the base's centre at the origin, the KEMAR's ears 1.35 m up.
    assert backend.listener() == pytest.approx((-0.067, 0.0, 1.35), abs=1e-3)
    await _run(pr2, "go_to_position", x=1.0, y=0.5, w=0.3)
    await _run(pr2, "move_head", pan=0.5, tilt=0.0, time_to_finish=0.5)
    assert host.require(HeadAzimuth).read() == pytest.approx(math.degrees(0.8), abs=0.3)
    assert backend.azimuth() == pytest.approx(math.degrees(0.8), abs=0.3)
    head_x, head_y = 1.0 - 0.067 * math.cos(0.3), 0.5 - 0.067 * math.sin(0.3)
    assert backend.listener() == pytest.approx((head_x, head_y, 1.35), abs=0.01)


async def test_the_virtual_kemar_hears_the_markers_in_the_worlds_room(host: ComponentHost) -> None:
    import dataclasses

    from aiogenomix.components.audio import HeadAzimuth, RoomSceneRenderer, SoundScene
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
    ears = np.stack([port.left, port.right], axis=1)
    # The same scene rendered here, chunk by chunk at the head's azimuth, gives the same samples: the
    # markers at their places in the world's room, through the measured KEMAR, reflections and tail included.
    scene = host.require(SoundScene).scene
    head = host.require(HeadAzimuth).read()
    reference = RoomSceneRenderer(scene, 44100)
    expected = np.concatenate([reference.render(2205, head) for _ in range(10)])
    # (Within a millionth of full scale: the head's pose read at the first chunk may differ in its last digits.)
    assert np.max(np.abs(ears.astype(np.float64) - expected)) <= 1e-6 * np.abs(expected).max()
    # And the room is heard: 4 m from the noise, its reverberation carries more energy than the direct sound.
    free = RoomSceneRenderer(dataclasses.replace(scene, room=None), 44100)
    anechoic = np.concatenate([free.render(2205, head) for _ in range(10)]).astype(np.float64)
    assert np.sum(ears[8820:].astype(np.float64) ** 2) > 2.0 * np.sum(anechoic[8820:] ** 2)
