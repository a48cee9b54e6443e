"""The lazy import of MuJoCo, set for offscreen rendering on a CPU (OSMesa) unless told otherwise."""

from __future__ import annotations

import os
from types import ModuleType

__all__ = ["import_mujoco"]


def import_mujoco() -> ModuleType:
    """Import ``mujoco`` (hundreds of ms: only when a world is made, never when the gateway starts).

    ``MUJOCO_GL`` defaults to ``osmesa`` (Debian's ``libosmesa6``): the gateway runs on machines with
    no display and no GPU.  Set ``MUJOCO_GL=egl`` beforehand to render on a GPU.
    """
    os.environ.setdefault("MUJOCO_GL", "osmesa")
    if os.environ["MUJOCO_GL"] == "osmesa":
        os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
    import mujoco

    return mujoco
