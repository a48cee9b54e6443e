"""The render process yields to the gateway: frames are best effort, requests and audio come first."""

from __future__ import annotations

import importlib.util
import os
from collections.abc import AsyncIterator

import pytest

from aiogenomix.components.core import ComponentHost
from aiogenomix.components.world import World
from aiogenomix.components.world._render_worker import NICENESS

pytestmark = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco is not installed")


def niceness(pid: int) -> int:
    """A process's nice value, from the kernel's account of it."""
    with open(f"/proc/{pid}/stat") as stat:
        return int(stat.read().rsplit(")", 1)[1].split()[16])


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    async with ComponentHost() as host:
        yield host


async def test_the_render_process_runs_below_the_gateway(host: ComponentHost) -> None:
    world = await host.load("world", ["-size", "32x32", "-rate", "10"])
    assert isinstance(world, World) and world.rendering is not None and world.renderer is not None
    await world.rendering.wait_for(lambda r: r.up)
    await world.kemar_camera_left.wait_published()
    assert world.renderer.pid is not None
    assert niceness(world.renderer.pid) == min(19, niceness(os.getpid()) + NICENESS)
