"""Issue 10 acceptance through HTTP: the virtual PR2 and KEMAR in the MuJoCo world, on what a user sees."""

from __future__ import annotations

import importlib.util
import json
import math
from collections.abc import AsyncIterator

import aiohttp
import numpy as np
import pytest

from aiogenomix.clients import Interrupted, aconnect
from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.gateway import GatewayConfig, serve

# Not imported here: the world imports MuJoCo itself, after choosing offscreen rendering.
pytestmark = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco is not installed")

#: Small, slow cameras keep the suite light: the world still renders them off the event loop.
WORLD_OPTIONS = ("-size", "64x64", "-rate", "2")
SCALE = 3.0


@pytest.fixture
async def rig() -> AsyncIterator[tuple[ComponentHost, str]]:
    """A gateway whose host we can reach (to await camera publications).

    Its simulated time moves when the world has nothing else to do, at most 3× real time: where
    the robots stop does not depend on how busy the machine is.
    """
    async with ComponentHost(clock=VirtualClock(SCALE), settings=HostSettings(audio_socket_port=0)) as host:
        async with serve(GatewayConfig.of(port=0), host=host) as url:
            yield host, url


def _pixels(image: object) -> np.ndarray:
    data = np.asarray(image.data, dtype=np.uint8)  # type: ignore[attr-defined]
    return data.reshape(image.height, image.width, 4)  # type: ignore[attr-defined]


def _centroid_x(image: object, channel: int) -> float | None:
    """Where the pixels of one pure colour are, as a fraction of the width (None: none in view)."""
    pixels = _pixels(image).astype(int)
    others = [c for c in range(3) if c != channel]
    colour = pixels[..., channel]
    mask = (colour > 80) & (colour > 1.8 * pixels[..., others[0]]) & (colour > 1.8 * pixels[..., others[1]])
    if mask.sum() < 2:
        return None
    return float(np.nonzero(mask)[1].mean() + 0.5) / pixels.shape[1]


async def _fresh_frame(host: ComponentHost, port: str) -> None:
    """Wait for a frame rendered after now (the one in flight may show the scene before)."""
    world = host.get("world").port(port)
    await world.wait_published()  # type: ignore[union-attr]
    await world.wait_published()  # type: ignore[union-attr]


async def test_go_to_position_reaches_the_pose_and_a_second_goal_interrupts_the_first(rig) -> None:
    _, url = rig
    async with aconnect(url, timeout=60) as client:
        await client.load("world", *WORLD_OPTIONS)
        pr2 = await client.load("pr2")
        world = await client.load("world")
        first = await pr2.go_to_position(-2.0, -2.0, 0.0, ack=True)
        await pr2.go_to_position(1.0, 0.5, 0.3)
        with pytest.raises(Interrupted) as interrupted:
            await first.result()
        assert interrupted.value.by == "go_to_position"
        odom = await world.pr2_odom()
        assert math.hypot(odom.x - 1.0, odom.y - 0.5) <= 0.02
        assert abs(math.degrees(odom.w - 0.3)) <= 1.0
        assert (await pr2.Port_gotoposition()).x == 1.0  # the goal the world was sent


async def test_move_head_moves_the_centred_object_to_the_side_the_pan_implies(rig) -> None:
    host, url = rig
    async with aconnect(url, timeout=60) as client:
        await client.load("world", *WORLD_OPTIONS)
        pr2 = await client.load("pr2")
        await _fresh_frame(host, "pr2_video")
        before = _centroid_x(await pr2.Image(), channel=0)  # the red box, through pr2's in port
        assert before is not None and abs(before - 0.5) < 0.1

        await pr2.move_head(0.5, 0, 1.0)
        await _fresh_frame(host, "pr2_video")
        after = _centroid_x(await pr2.Image(), channel=0)
        # Panning left (positive pan) moves what was ahead to the right of the picture.
        assert after is not None and after > 0.7
        head = await pr2.Port_head()
        assert (head.pan, head.tilt, head.time_to_finish) == (0.5, 0.0, 1.0)


async def test_move_torso_refuses_out_of_range_and_reaches_its_goal_in_time(rig) -> None:
    host, url = rig
    times: dict[tuple[str, str], float] = {}  # (request id, status): when the host announced it, on its clock
    host.add_request_listener(lambda request: times.__setitem__((request.id, request.status), host.clock.now()))
    async with aconnect(url, timeout=60) as client:
        await client.load("world", *WORLD_OPTIONS)
        pr2 = await client.load("pr2")
        world = await client.load("world")
        with pytest.raises(pr2.INVALID_TORSO):
            await pr2.move_torso(0.5, 1)
        async with aiohttp.ClientSession() as http:  # a validate refusal is a request error, HTTP 200
            async with http.get(f"{url}/module/pr2/send/move_torso",
                                params={"input": json.dumps({"torso": 0.5, "time_to_finish": 1})}) as reply:
                assert reply.status == 200

        moved = await pr2.move_torso(0.2, 1, ack=True)
        await moved.result()
        joints = await world.pr2_joints()
        torso = joints.position[list(joints.name).index("torso_lift_joint")]
        assert torso == pytest.approx(0.2, abs=0.005)
        # The motion's own time, from the request's start to its end on the simulated clock (HTTP
        # latency, real time, is not part of it).
        took = times[(moved.id, "done")] - times[(moved.id, "sent")]
        assert took == pytest.approx(1.0, abs=0.05)


async def test_morse_kemar_turns_the_eye_cameras_and_robot_pose_by_45_degrees(rig) -> None:
    host, url = rig
    async with aconnect(url, timeout=60) as client:
        await client.load("world", *WORLD_OPTIONS)
        kemar = await client.load("morse_kemar")
        await _fresh_frame(host, "kemar_camera_left")
        for eye in (kemar.CameraL, kemar.CameraR):
            image = await eye()
            assert abs(_centroid_x(image, channel=1) - 0.5) < 0.1  # the green cylinder straight ahead
            assert _centroid_x(image, channel=2) is None  # the blue sphere, 45° to the left, out of view

        await kemar.MoveAbsolutePosition(45, 90)
        await _fresh_frame(host, "kemar_camera_left")
        pose = (await kemar.RobotPose()).pose.orientation
        assert math.degrees(2 * math.atan2(pose.z, pose.w)) == pytest.approx(45, abs=0.5)
        for eye in (kemar.CameraL, kemar.CameraR):
            image = await eye()
            assert abs(_centroid_x(image, channel=2) - 0.5) < 0.1
            assert _centroid_x(image, channel=1) is None
