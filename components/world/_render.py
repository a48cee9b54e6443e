"""Camera frames and laser sweeps, computed in a render process of the world's own.

Rendering on a thread of the gateway's process held the interpreter's lock between MuJoCo's and
OpenGL's calls, and the event loop waited for it (up to 60 ms stalls, other components' requests
twice as slow).  Here a child process (:mod:`._render_worker`) owns the OpenGL context and a copy of
the model; the world sends it the joint positions of the moment, and it draws the frames into memory
both processes share (:mod:`._frames`), so the event loop only sends a request and publishes arrays
over that memory.  The physics keeps stepping on the loop meanwhile, with no lock between the two.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from . import _render_worker
from ._frames import FramePool
from ._mjcf import PR2_GEOM_GROUP

__all__ = ["SensorRenderer", "RenderError", "LASER", "CLOSE_TIMEOUT", "START_TIMEOUT", "FRAME_TIMEOUT"]

#: The base laser (a Hokuyo UTM-30LX like the PR2's): 270° in 1° steps, 0.023 to 30 m.
LASER = {"angle_min": -math.radians(135.0), "angle_max": math.radians(135.0),
         "angle_increment": math.radians(1.0), "range_min": 0.023, "range_max": 30.0}
#: Frames of each camera that readers may hold before the world publishes copies (the newest, one
#: being written to a client, one being drawn, and one more).
SLOTS_PER_CAMERA = 4
#: Seconds the render process gets to end after its input closes, before it is killed.  It holds
#: nothing that outlives it (the shared frames are the world's), and a frame it is drawing may take
#: a second at 2048x2048: waiting for it would push the gateway's stop past its two seconds.
CLOSE_TIMEOUT = 0.2
#: Real seconds a render process has to start (import MuJoCo, compile the scene, make its OpenGL
#: context) before it is taken for hung and ended: several times what a busy two-core machine takes.
START_TIMEOUT = 60.0
#: Real seconds a frame may take before the render process is taken for hung and ended.
FRAME_TIMEOUT = 30.0


def _cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _kill(process: asyncio.subprocess.Process) -> None:
    with contextlib.suppress(ProcessLookupError):
        process.kill()


class RenderError(RuntimeError):
    """The render process could not start, or ended, or failed to draw (the message says which)."""


class SensorRenderer:
    """Renders named cameras and a laser of a MuJoCo model in a process of its own.

    Args:
        xml: The model's MJCF (the render process compiles its own copy).
        width: Frame width in pixels.
        height: Frame height in pixels.
        cameras: The cameras drawn together at each :meth:`render` (sizes the shared frames).
        laser: The site the laser sweeps from.
        on_spawn: Called with the id of each render process as soon as it exists (before it is ready).
    """

    def __init__(self, xml: str, width: int, height: int, cameras: tuple[str, ...], laser: str,
                 on_spawn: Callable[[int], None] | None = None) -> None:
        self._xml = xml
        self.width, self.height = width, height
        self.cameras = cameras
        self._laser = dict(LASER, site=laser, hidden_group=PR2_GEOM_GROUP,
                           count=int(round((LASER["angle_max"] - LASER["angle_min"]) / LASER["angle_increment"])) + 1)
        self.pool: FramePool | None = None
        self._process: asyncio.subprocess.Process | None = None
        self._seq = 0
        # Slots of requests whose reply was not read (the renderer was cancelled while waiting):
        # the process may still draw into them, so they are given back when their reply comes.
        self._pending: dict[int, list[int]] = {}
        self._on_spawn = on_spawn

    @property
    def pid(self) -> int | None:
        """The render process's id while it runs."""
        return self._process.pid if self._process is not None and self._process.returncode is None else None

    async def open(self) -> None:
        """Start the render process and make its OpenGL context (fails here, not at every frame, without one).

        Raises:
            RenderError: when the process cannot start or render (no OSMesa, no display...).
        """
        if self._process is not None:
            return
        self.pool = FramePool(self.width * self.height * 4, SLOTS_PER_CAMERA * len(self.cameras), len(self.cameras))
        env = dict(os.environ)
        env.setdefault("MUJOCO_GL", "osmesa")  # no display or GPU needed
        if env["MUJOCO_GL"] == "osmesa":
            env.setdefault("PYOPENGL_PLATFORM", "osmesa")
            # OSMesa's rasteriser (llvmpipe) starts a thread per core, besides the render process's own
            # thread, which draws too when there are none: leave one core to the gateway.  On two cores
            # that is no rasteriser thread, which also draws 256x256 frames faster than one (the hand-off
            # costs more than it saves) and, measured, lets the gateway wake without waiting for a core.
            env.setdefault("LP_NUM_THREADS", str(max(0, _cores() - 2)))
        fd = self.pool.fileno()
        try:
            # -P: the script's folder is not put on the import path (it holds modules named like others).
            # The parent's id: the process ends itself if this one dies (see _render_worker).
            self._process = await asyncio.create_subprocess_exec(
                sys.executable, "-P", str(Path(_render_worker.__file__)), str(fd), str(os.getpid()),
                stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE, pass_fds=(fd,), env=env)
            self.pool.forget_file()
            if self._on_spawn is not None:
                self._on_spawn(self._process.pid)
            self._send(("open", self._xml, self.width, self.height, self._laser))
            try:
                async with asyncio.timeout(START_TIMEOUT):
                    reply = await self._receive()
            except TimeoutError:
                raise RenderError(f"the render process did not start within {START_TIMEOUT:g} s") from None
        except OSError as exc:
            await self.aclose()
            raise RenderError(f"the render process cannot start ({exc})") from exc
        except BaseException:
            await self.aclose()
            raise
        if reply[0] != "ready":
            await self.aclose()
            raise RenderError(reply[1])

    async def render(self, qpos: np.ndarray, with_laser: bool = True
                     ) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
        """Frames of the cameras and the laser's ranges for joint positions *qpos*.

        Frames are read-only 1-D arrays of ``height * width * 4`` octets (RGBA, top row first),
        valid as long as they are referenced; ranges are float32 metres, or None without the laser.

        Raises:
            RenderError: when the process ended or failed to draw.
        """
        pool = self.pool
        if pool is None or self._process is None:
            raise RenderError("the renderer is not open")
        self._seq += 1
        seq = self._seq
        slots = [pool.take(spare) for spare in range(len(self.cameras))]
        try:
            self._send(("render", seq, np.asarray(qpos, np.float64), list(zip(self.cameras, slots, strict=True)),
                        with_laser))
        except RenderError:
            for slot in slots:
                pool.give_back(slot)
            raise
        self._pending[seq] = slots
        while True:
            try:
                # Cancelled here: the slots stay pending until the reply.  (asyncio.timeout: on
                # Python 3.11 wait_for loses a cancellation that comes in the turn a reply arrives.)
                async with asyncio.timeout(FRAME_TIMEOUT):
                    reply = await self._receive()
            except TimeoutError:
                raise RenderError(f"the render process drew no frame in {FRAME_TIMEOUT:g} s") from None
            if reply[1] == seq:
                break
            for slot in self._pending.pop(reply[1], ()):
                pool.give_back(slot)
        del self._pending[seq]
        if reply[0] != "frames":
            for slot in slots:
                pool.give_back(slot)
            raise RenderError(f"the render process failed to draw: {reply[2]}")
        frames = {camera: pool.publish(slot) for camera, slot in zip(self.cameras, slots, strict=True)}
        return frames, reply[2]

    def _send(self, message: Any) -> None:
        assert self._process is not None and self._process.stdin is not None
        if self._process.stdin.is_closing():
            raise RenderError(f"the render process has ended (exit code {self._process.returncode})")
        self._process.stdin.write(_render_worker.pack_message(message))

    async def _receive(self) -> Any:
        assert self._process is not None and self._process.stdout is not None
        try:
            (length,) = _render_worker.HEADER.unpack(await self._process.stdout.readexactly(_render_worker.HEADER.size))
            return _render_worker.unpack_message(await self._process.stdout.readexactly(length))
        except asyncio.IncompleteReadError:
            code = await self._process.wait()
            raise RenderError(f"the render process has ended (exit code {code}); "
                              "its messages, if any, are on the gateway's standard error") from None

    async def aclose(self) -> None:
        """End the render process: its input closes, and it is killed unless it ends within :data:`CLOSE_TIMEOUT`.

        Cancelled meanwhile (a stop that ran out of time), it kills the process before it lets go:
        no render process outlives its world.
        """
        process, self._process = self._process, None
        try:
            if process is not None:
                if process.stdin is not None:
                    process.stdin.close()
                    with contextlib.suppress(ConnectionError):
                        await process.stdin.wait_closed()
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(CLOSE_TIMEOUT):
                        await process.wait()
                if process.returncode is None:
                    _kill(process)
                    await process.wait()
        except BaseException:
            if process is not None and process.returncode is None:
                _kill(process)  # cancelled (a stop out of time): the loop's child watcher reaps it
            raise
        finally:
            if self.pool is not None:
                self.pool.close()
