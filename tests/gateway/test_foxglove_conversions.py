"""The live view shows the head and odometry as the recording keeps them: radians, and velocities in the robot's frame.

``foxglove.Odometry`` defines its velocities in ``body_frame_id`` (as ``nav_msgs/Odometry`` in the
child frame): a robot heading 90° that moves along the room's x axis moves to its own right.
The head at a nonzero azimuth tells degrees from radians.  A plain WebSocket client decodes
what the view sends, with the schemas it advertises.
"""

from __future__ import annotations

import asyncio
import importlib.util
import json
import math
from collections.abc import AsyncIterator
from typing import Any

import pytest

from aiogenomix.components.core import Component, ComponentHost, HostSettings, OutPort, ScaledClock
from aiogenomix.components.kemar import KemarState
from aiogenomix.components.recording import head_state, planar_odometry
from aiogenomix.components.world import Odometry
from aiogenomix.gateway._foxglove import FoxgloveView

from .test_foxglove_view import advertised, decoder

pytestmark = pytest.mark.skipif(importlib.util.find_spec("foxglove") is None, reason="needs the Foxglove SDK")


class Robot(Component, name="robot"):
    """A head and a base whose states the test publishes."""

    Head = OutPort(KemarState, doc="The head's state")
    Odom = OutPort(Odometry, doc="The base's odometry")


@pytest.fixture
async def view() -> AsyncIterator[tuple[FoxgloveView, Any]]:
    async with ComponentHost(clock=ScaledClock(1.0), settings=HostSettings(audio_socket_port=0),
                             factories={"robot": Robot}) as host:
        robot = await host.load("robot")
        shown = FoxgloveView("127.0.0.1", 0)
        shown.start(host.instances)
        try:
            yield shown, robot
        finally:
            await shown.stop()


async def test_odometry_moves_in_the_robots_frame_and_the_head_turns_in_radians(
        view: tuple[FoxgloveView, Any]) -> None:
    import websockets

    shown, robot = view
    robot.Head.publish(KemarState(position=45.0, speed=-30.0))
    robot.Odom.publish(Odometry(x=1.0, y=2.0, w=math.pi / 2, vx=0.3, vy=0.0, vw=0.1))
    async with websockets.connect(f"ws://127.0.0.1:{shown.port}", subprotocols=["foxglove.sdk.v1"],
                                  max_size=None, close_timeout=1) as viewer:
        await asyncio.wait_for(viewer.recv(), 30)  # serverInfo
        channels = await advertised(viewer, {"/robot/Head", "/robot/Odom"})
        head, odometry = channels["/robot/Head"], channels["/robot/Odom"]
        await viewer.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 1, "channelId": head["id"]}, {"id": 2, "channelId": odometry["id"]}]}))
        decoded: dict[int, Any] = {}
        subscribed = {1: head, 2: odometry}
        while len(decoded) < 2:
            frame = await asyncio.wait_for(viewer.recv(), 30)
            if isinstance(frame, bytes) and frame[0] == 1:  # messageData: op, subscription, log time, payload
                subscription = int.from_bytes(frame[1:5], "little")
                decoded[subscription] = decoder(subscribed[subscription]).FromString(frame[13:])
    joint = decoded[1].joints[0]
    assert (joint.name, joint.position, joint.velocity) == pytest.approx(("head_yaw", math.pi / 4, -math.pi / 6))
    moved = decoded[2]
    assert moved.body_frame_id == "base_footprint" and moved.frame_id == "map"
    # Heading +y, moving along +x: to its own right (body y negative), nothing ahead.
    assert (moved.linear_velocity.x, moved.linear_velocity.y) == pytest.approx((0.0, -0.3), abs=1e-12)
    assert moved.angular_velocity.z == pytest.approx(0.1)
    assert (moved.pose.position.x, moved.pose.position.y) == pytest.approx((1.0, 2.0))
    assert (moved.pose.orientation.z, moved.pose.orientation.w) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5)))


def test_the_recording_and_the_view_read_the_same_conversion() -> None:
    """One reading of the port's data serves both (the recording's JointState and Odometry use it too)."""
    state = head_state({"position": -90.0, "speed": None})
    assert state.position == pytest.approx(-math.pi / 2) and math.isnan(state.velocity)
    moved = planar_odometry({"x": 0, "y": 0, "w": math.pi, "vx": 1.0, "vy": 0.5, "vw": 0})
    assert (moved.forward, moved.leftward) == pytest.approx((-1.0, -0.5))
