"""The world's render process: it runs with the world, frames never change once published, a lost one is replaced."""

from __future__ import annotations

import importlib.util
import logging
import os
import signal
from collections.abc import AsyncIterator

import numpy as np
import pytest

from aiogenomix.components.core import ComponentHost, LoadError, ScaledClock

from .conftest import child_processes

pytestmark = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco is not installed")


@pytest.fixture
async def host() -> AsyncIterator[ComponentHost]:
    async with ComponentHost(clock=ScaledClock(4)) as host:
        await host.load("world", ["-size", "32x32", "-rate", "10"])
        yield host


async def _frames(port, count: int) -> None:  # type: ignore[no-untyped-def]
    for _ in range(count):
        await port.wait_published()


async def test_the_world_renders_in_a_child_process_that_ends_with_it() -> None:
    async with ComponentHost(clock=ScaledClock(4)) as host:
        world = await host.load("world", ["-size", "32x32", "-rate", "10"])
        pid = world.renderer.pid
        assert pid is not None and pid != os.getpid() and pid in child_processes()
        await world.pr2_video.wait_published()
        image = world.pr2_video.read()
        assert image.data.size == 32 * 32 * 4 and not image.data.flags.owndata  # shared, not copied
        await host.unload("world")
        assert pid not in child_processes()
    assert image.pixels()[..., 3].min() == 255  # a frame stays readable after its world is gone


async def test_a_published_frame_never_changes_while_newer_ones_come(host: ComponentHost) -> None:
    world = host.get("world")
    kemar = await host.load("morse_kemar")
    await world.kemar_camera_left.wait_published()
    held = world.kemar_camera_left.read()
    before = np.array(held.data, copy=True)
    request = await kemar.send("MoveAbsolutePosition", {"target": 45.0, "velocity": 300.0})
    await request.task
    await _frames(world.kemar_camera_left, 10)  # more frames than the pool's slots for a camera
    assert np.array_equal(held.data, before)
    assert not held.data.flags.writeable
    assert not np.array_equal(world.kemar_camera_left.read().data, before)  # the view did turn
    assert world.renderer.pool.copies == 0  # one frame held: the pool had room for the rest


async def test_a_lost_render_process_is_replaced(host: ComponentHost, caplog: pytest.LogCaptureFixture) -> None:
    world = host.get("world")
    await world.pr2_video.wait_published()
    first = world.renderer.pid
    with caplog.at_level(logging.ERROR):
        os.kill(first, signal.SIGKILL)
        await _frames(world.pr2_video, 2)
    assert world.renderer.pid not in (None, first)
    assert "render process has ended (exit code -9)" in caplog.text


async def test_a_world_that_cannot_render_is_refused_and_leaves_no_process(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MUJOCO_GL", "no-such-backend")
    async with ComponentHost(clock=ScaledClock(4)) as host:
        with pytest.raises(LoadError, match="cannot render its cameras.*MUJOCO_GL"):
            await host.load("world", ["-size", "32x32"])
        assert "world" not in host.instances
