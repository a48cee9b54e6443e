"""The virtual robots recorded (cameras, laser, odometry, joints, pose) and their ports replayed by ``replay``.

Pictures are ``sensor_msgs/Image`` with every pixel; other ports are JSON as the port gave them
plus their standard companion (``nav_msgs/Odometry``, ``sensor_msgs/LaserScan``...), read back
with the mcap reader and the ROS 2 decoder.  ``replay`` then publishes them again, under their
names and recorded types, at their recorded timing.  Simulated time.
"""

from __future__ import annotations

import asyncio
import importlib.util
import math
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import numpy as np
import orjson
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock, OutPortRuntime, VirtualClock
from aiogenomix.components.recording import RecordingReader

pytestmark = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco is not installed")

PORTS = ["world/kemar_camera_left", "world/pr2_odom", "world/pr2_scan", "world/pr2_joints", "world/kemar_pose"]


@pytest.fixture
async def world_recording(tmp_path: Path) -> AsyncIterator[tuple[Path, list[dict[str, Any]]]]:
    """Two seconds of the world recorded while the PR2 drives, and the left camera's frames as published."""
    settings = HostSettings(audio_socket_port=0, audio_files=(), record_dirs=(str(tmp_path),))
    async with ComponentHost(clock=VirtualClock(), settings=settings) as host:
        world = await host.load("world", ["-size", "32x24", "-rate", "5"])
        pr2 = await host.load("pr2")
        recorder = await host.load("recorder")
        camera = world.port("kemar_camera_left")
        assert isinstance(camera, OutPortRuntime)
        frames: list[dict[str, Any]] = []
        recording = await recorder.send("Start", {"path": "world.mcap", "ports": PORTS, "duration": 2})
        await pr2.send("go_to_position", {"x": 1.0, "y": 0.0, "w": 0.5})
        while recording.running:
            await camera.wait_published()
            frames.append(camera.type.encode(camera.read()))
        assert recording.status == "done", recording.exception
        assert recording.output["status"]["ports"][0]["coalesced"] == 0
    yield tmp_path / "world.mcap", frames


async def test_the_world_is_recorded_in_the_types_robotics_tools_show(
        world_recording: tuple[Path, list[dict[str, Any]]]) -> None:
    path, published = world_recording
    by_topic: dict[str, list[Any]] = {}
    json_ports: dict[str, list[Any]] = {}
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, message in reader.iter_messages():
            if channel.message_encoding == "json":
                json_ports.setdefault(channel.topic, []).append(orjson.loads(message.data))
        for _, channel, _, decoded in reader.iter_decoded_messages(topics=[
                "/world/kemar_camera_left", "/world/pr2_odom/odometry", "/world/pr2_scan/scan",
                "/world/pr2_joints/joint_state", "/world/kemar_pose/pose"]):
            by_topic.setdefault(channel.topic, []).append(decoded)
    images = by_topic["/world/kemar_camera_left"]
    assert 8 <= len(images) <= 11                         # 5 frames a second for two seconds
    # Every recorded picture is one the port published, pixel for pixel.
    pictures = {bytes(np.asarray(frame["data"], np.uint8)) for frame in published}
    for image in images:
        assert (image.width, image.height, image.encoding, image.step) == (32, 24, "rgba8", 128)
        assert bytes(image.data) in pictures
    odometry, pose = json_ports["/world/pr2_odom"], by_topic["/world/pr2_odom/odometry"]
    assert len(odometry) == len(pose) and odometry[-1]["x"] > odometry[0]["x"]  # the PR2 drove
    for state, standard in zip(odometry, pose, strict=True):
        assert standard.pose.pose.position.x == state["x"] and standard.pose.pose.position.y == state["y"]
        yaw = 2 * math.atan2(standard.pose.pose.orientation.z, standard.pose.pose.orientation.w)
        assert yaw == pytest.approx(state["w"], abs=1e-12)
        # The twist in the robot's frame (ROS), the port's in the room's.
        forward = math.cos(state["w"]) * state["vx"] + math.sin(state["w"]) * state["vy"]
        assert standard.twist.twist.linear.x == pytest.approx(forward, abs=1e-12)
    scans = by_topic["/world/pr2_scan/scan"]
    assert len(scans) == len(json_ports["/world/pr2_scan"]) >= 8
    assert len(scans[-1].ranges) == len(json_ports["/world/pr2_scan"][-1]["ranges"]) == 271
    joints = by_topic["/world/pr2_joints/joint_state"][-1]
    assert "torso_lift_joint" in joints.name and len(joints.position) == len(joints.name)
    assert by_topic["/world/kemar_pose/pose"][-1].header.frame_id == "map"


async def test_replay_publishes_the_recorded_ports_at_their_timing(
        world_recording: tuple[Path, list[dict[str, Any]]]) -> None:
    path, _ = world_recording
    with open(path, "rb") as stream, RecordingReader(stream) as reader:
        recorded = [(m.port, m.capture_time, m.data) for m in reader.publications()]
    clock = ManualClock()
    settings = HostSettings(record_dirs=(str(path.parent),), audio_files=())
    async with ComponentHost(clock=clock, settings=settings) as host:
        replay = await host.load("replay", ["-file", path.name])
        described = {p["name"]: p for p in replay.description()["ports"]}
        assert described["kemar_camera_left"]["type"]["name"] == "::subscriber::sensor_msgs__Image"
        assert described["pr2_odom"]["type"]["name"] == "::world::odometry"
        seen: list[tuple[str, float, Any]] = []
        ports = {name: replay.port(name) for name in ("kemar_camera_left", "pr2_odom", "pr2_scan", "pr2_joints",
                                                      "kemar_pose")}

        async def watch(name: str, port: OutPortRuntime[Any]) -> None:
            while True:
                await port.wait_published()
                seen.append((name, clock.now(), port.type.encode(port.read())))

        watchers = [asyncio.create_task(watch(n, p)) for n, p in ports.items()]
        play = await replay.send("Play", {"speed": 2})
        await clock.run_until(play.ended.wait())
        for task in watchers:
            task.cancel()
        assert play.status == "done" and play.output["published"] == len(recorded)
    # Each publication came when its recorded time (at twice the speed) came, with its recorded data.
    first = recorded[0][1]
    expected = [(port.split("/")[1], (t - first) / 2) for port, t, _ in recorded]
    got = [(name, at) for name, at, _ in seen]
    assert [n for n, _ in got] == [n for n, _ in expected]
    np.testing.assert_allclose([at for _, at in got], [at for _, at in expected], atol=1e-6)
    odometry = [data for name, _, data in seen if name == "pr2_odom"]
    assert odometry == [data for port, _, data in recorded if port == "world/pr2_odom"]
