"""Camera frames and laser sweeps, computed off the event loop on a thread of their own.

OpenGL contexts belong to the thread that made them, so one worker thread owns the renderer for
its whole life.  It draws from its own copy of the scene's data, set from a snapshot of the joint
positions: the physics keeps stepping on the loop meanwhile, with no lock between the two.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import math
from typing import Any

import numpy as np

from ._mjcf import PR2_GEOM_GROUP

__all__ = ["SensorRenderer", "LASER"]

#: The base laser (a Hokuyo UTM-30LX like the PR2's): 270° in 1° steps, 0.023 to 30 m.
LASER = {"angle_min": -math.radians(135.0), "angle_max": math.radians(135.0),
         "angle_increment": math.radians(1.0), "range_min": 0.023, "range_max": 30.0}


class SensorRenderer:
    """Renders named cameras and the base laser of a MuJoCo model on a dedicated thread.

    Args:
        mujoco: The mujoco module.
        model: The compiled model (read-only from here).
        width: Frame width in pixels.
        height: Frame height in pixels.
    """

    def __init__(self, mujoco: Any, model: Any, width: int, height: int) -> None:
        self._mujoco = mujoco
        self._model = model
        self.width, self.height = width, height
        self._executor = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="world-render")
        self._renderer: Any = None
        self._data: Any = None
        count = int(round((LASER["angle_max"] - LASER["angle_min"]) / LASER["angle_increment"])) + 1
        self._angles = LASER["angle_min"] + LASER["angle_increment"] * np.arange(count)
        # The laser sees the room and the KEMAR, not the robot carrying it.
        self._groups = np.ones(6, np.uint8)
        self._groups[PR2_GEOM_GROUP] = 0

    async def open(self) -> None:
        """Make the renderer on its thread (an OpenGL context: fails here, not at every frame, without one).

        Raises:
            Exception: whatever MuJoCo raises when it cannot render (no OSMesa, no display...).
        """
        await asyncio.wrap_future(self._executor.submit(self._open))

    def _open(self) -> None:
        if self._renderer is None:
            self._renderer = self._mujoco.Renderer(self._model, self.height, self.width)
            self._data = self._mujoco.MjData(self._model)

    async def render(self, qpos: np.ndarray, cameras: tuple[str, ...], laser: str | None = None
                     ) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
        """Frames of *cameras* (``(height, width, 4)`` RGBA octets) and the ranges of *laser*, for *qpos*."""
        future = self._executor.submit(self._render, qpos, cameras, laser)
        return await asyncio.wrap_future(future)

    def _render(self, qpos: np.ndarray, cameras: tuple[str, ...], laser: str | None
                ) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
        mujoco, model = self._mujoco, self._model
        self._open()
        data = self._data
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)
        frames = {}
        for camera in cameras:
            self._renderer.update_scene(data, camera)
            rgb = self._renderer.render()
            rgba = np.empty((self.height, self.width, 4), np.uint8)
            rgba[..., :3] = rgb
            rgba[..., 3] = 255
            frames[camera] = rgba
        return frames, (self._scan(laser) if laser is not None else None)

    def _scan(self, site: str) -> np.ndarray:
        mujoco, model, data = self._mujoco, self._model, self._data
        origin = np.array(data.site(site).xpos)
        frame = np.array(data.site(site).xmat).reshape(3, 3)
        directions = np.stack([np.cos(self._angles), np.sin(self._angles), np.zeros_like(self._angles)], axis=1)
        vec = (directions @ frame.T).reshape(-1)
        count = len(self._angles)
        geomid = np.zeros(count, np.int32)
        dist = np.zeros(count, np.float64)
        mujoco.mj_multiRay(model, data, origin, vec, self._groups, 1, -1, geomid, dist, None, count,
                           LASER["range_max"])
        ranges = np.where(geomid < 0, LASER["range_max"], np.clip(dist, LASER["range_min"], LASER["range_max"]))
        return ranges.astype(np.float32)

    async def aclose(self) -> None:
        """Free the renderer on its own thread, then end the thread."""
        future = self._executor.submit(self._close)
        await asyncio.wrap_future(future)
        self._executor.shutdown(wait=True)

    def _close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
