"""The render process yields to the gateway once it draws, and starts at the gateway's priority.

At ``nice`` 10 from its first instruction, its start (MuJoCo, the OpenGL context, the model) took six
times longer beside three CPU hogs, the cameras down all the while after a crash.
"""

from __future__ import annotations

import asyncio
import importlib.util
import os
import sys
from collections.abc import AsyncIterator

import pytest

from aiogenomix.components.core import ComponentHost
from aiogenomix.components.world import World
from aiogenomix.components.world import _render_worker
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


async def test_a_ready_render_process_runs_below_the_gateway(host: ComponentHost) -> None:
    world = await host.load("world", ["-size", "32x32", "-rate", "10"])
    assert isinstance(world, World) and world.rendering is not None and world.renderer is not None
    await world.rendering.wait_for(lambda r: r.up)
    await world.kemar_camera_left.wait_published()
    assert world.renderer.pid is not None
    assert niceness(world.renderer.pid) == min(19, niceness(os.getpid()) + NICENESS)


async def test_a_render_process_starts_at_the_gateways_priority() -> None:
    # The script as the world starts it, but told nothing to open: once it has answered, it is serving, not
    # yet ready to draw, and still at the gateway's priority (it took nice 10 first thing before).
    memory = os.memfd_create("render-pool")
    os.ftruncate(memory, 4096)
    worker = await asyncio.create_subprocess_exec(
        sys.executable, "-P", _render_worker.__file__, str(memory), str(os.getpid()),
        stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE, pass_fds=(memory,))
    os.close(memory)
    assert worker.stdin is not None and worker.stdout is not None
    try:
        worker.stdin.write(_render_worker.pack_message(("hello",)))
        await worker.stdin.drain()
        (length,) = _render_worker.HEADER.unpack(await worker.stdout.readexactly(_render_worker.HEADER.size))
        reply = _render_worker.unpack_message(await worker.stdout.readexactly(length))
        assert reply == ("error", "unexpected message 'hello'")
        assert niceness(worker.pid) == niceness(os.getpid())
    finally:
        worker.stdin.close()
        await worker.wait()
