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

from aiogenomix.components.core import (
    Component, ComponentHost, Double, HeadState, HostSettings, ManualClock, Odometry as OdometryKind, OutPort,
    carried_by,
)
from aiogenomix.components.core.runtime import idl_type
from aiogenomix.components.kemar import KemarState
from aiogenomix.components.world import Odometry
from aiogenomix.gateway._access import AccessPolicy
from aiogenomix.gateway._door import Door
from aiogenomix.gateway._foxglove import FoxgloveView

from .test_foxglove_view import advertised, decoder

pytestmark = pytest.mark.skipif(importlib.util.find_spec("foxglove") is None, reason="needs the Foxglove SDK")


class Robot(Component, name="robot"):
    """A head and a base whose states the test publishes."""

    Head = OutPort(KemarState, doc="The head's state")
    Odom = OutPort(Odometry, doc="The base's odometry")
    Level = OutPort(Double, doc="A reading without a time of its own")


@pytest.fixture
async def view() -> AsyncIterator[tuple[FoxgloveView, Any, ManualClock]]:
    clock = ManualClock()
    async with ComponentHost(clock=clock, settings=HostSettings(audio_socket_port=0),
                             factories={"robot": Robot}) as host:
        robot = await host.load("robot")
        shown = FoxgloveView("127.0.0.1", 0, Door(AccessPolicy(), None), clock=host.clock)
        await shown.start(host.instances)
        try:
            yield shown, robot, clock
        finally:
            await shown.stop()


async def shown_messages(shown: FoxgloveView, topics: list[str]) -> dict[str, tuple[int, Any]]:
    """Subscribe to *topics* and return the first message of each: its log time (ns) and its decoded payload."""
    import websockets

    async with websockets.connect(f"ws://127.0.0.1:{shown.port}", subprotocols=["foxglove.sdk.v1"],
                                  max_size=None, close_timeout=1) as viewer:
        await asyncio.wait_for(viewer.recv(), 30)  # serverInfo
        channels = await advertised(viewer, set(topics))
        await viewer.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": n, "channelId": channels[topic]["id"]} for n, topic in enumerate(topics)]}))
        decoded: dict[str, tuple[int, Any]] = {}
        while len(decoded) < len(topics):
            frame = await asyncio.wait_for(viewer.recv(), 30)
            if isinstance(frame, bytes) and frame[0] == 1:  # messageData: op, subscription, log time, payload
                channel = channels[topics[int.from_bytes(frame[1:5], "little")]]
                payload = frame[13:]
                message = json.loads(payload) if channel["encoding"] == "json" else decoder(channel).FromString(payload)
                decoded[channel["topic"]] = (int.from_bytes(frame[5:13], "little"), message)
    return decoded


async def test_odometry_moves_in_the_robots_frame_and_the_head_turns_in_radians(
        view: tuple[FoxgloveView, Any, ManualClock]) -> None:
    shown, robot, _ = view
    robot.Head.publish(KemarState(position=45.0, speed=-30.0))
    robot.Odom.publish(Odometry(x=1.0, y=2.0, w=math.pi / 2, vx=0.3, vy=0.0, vw=0.1))
    decoded = await shown_messages(shown, ["/robot/Head", "/robot/Odom"])
    joint = decoded["/robot/Head"][1].joints[0]
    assert (joint.name, joint.position, joint.velocity) == pytest.approx(("head_yaw", math.pi / 4, -math.pi / 6))
    moved = decoded["/robot/Odom"][1]
    assert moved.body_frame_id == "base_footprint" and moved.frame_id == "map"
    # Heading +y, moving along +x: to its own right (body y negative), nothing ahead.
    assert (moved.linear_velocity.x, moved.linear_velocity.y) == pytest.approx((0.0, -0.3), abs=1e-12)
    assert moved.angular_velocity.z == pytest.approx(0.1)
    assert (moved.pose.position.x, moved.pose.position.y) == pytest.approx((1.0, 2.0))
    assert (moved.pose.orientation.z, moved.pose.orientation.w) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5)))


async def test_data_without_a_time_is_stamped_on_the_rigs_clock(view: tuple[FoxgloveView, Any, ManualClock]) -> None:
    shown, robot, clock = view
    await clock.advance(3600.0)  # the rig's clock an hour ahead of this machine's
    robot.Level.publish(0.5)
    log_time, level = (await shown_messages(shown, ["/robot/Level"]))["/robot/Level"]
    assert level == 0.5 and log_time == pytest.approx(clock.wall() * 1e9, abs=1e6)


def test_the_recording_and_the_view_read_the_same_conversion() -> None:
    """One reading of the port's data, its kind's, serves both (the recording's JointState and Odometry use it too).

    The kind comes from the type's ``/info`` description, as a recording or another process has it.
    """
    head = carried_by(idl_type(KemarState).describe())
    assert isinstance(head, HeadState)
    state = head.read({"position": -90.0, "speed": None})  # the port says degrees
    assert state.position == pytest.approx(-math.pi / 2) and math.isnan(state.velocity)
    odometry = carried_by(idl_type(Odometry).describe())
    assert isinstance(odometry, OdometryKind)
    moved = odometry.read({"x": 0, "y": 0, "w": math.pi, "vx": 1.0, "vy": 0.5, "vw": 0})
    assert (moved.forward, moved.leftward) == pytest.approx((-1.0, -0.5))
