"""A tiny component with a camera port, for the console's browser tests (the real cameras are ``world``'s)."""

from __future__ import annotations

import dataclasses
from typing import Annotated

import numpy as np

from aiogenomix.components.core import (
    Component, Double, Octet, OutPort, String, ULong, UShort, function, idl_struct, sequence,
)


@idl_struct("camera::image")
class Image:
    """An ``rgba8`` picture, top row first."""

    width: ULong = 0
    height: ULong = 0
    encoding: String = "rgba8"
    data: sequence(Octet, numpy=True) = dataclasses.field(default_factory=lambda: np.zeros(0, np.uint8))


@idl_struct("camera::odometry")
class Odometry:
    """Where the robot carrying the camera is on the floor (m) and its heading (rad)."""

    x: Double = 0.0
    y: Double = 0.0
    w: Double = 0.0


def checkerboard(size: int, shade: int) -> Image:
    """A *size* × *size* checkerboard of *shade* and white."""
    cells = (np.add.outer(np.arange(size) // 4, np.arange(size) // 4) % 2).astype(bool)
    pixels = np.full((size, size, 4), 255, np.uint8)
    pixels[cells, :3] = (shade, 60, 160)
    return Image(size, size, "rgba8", pixels.reshape(-1))


class Camera(Component, name="camera", version="1.0"):
    """A camera that shows a checkerboard."""

    Frame = OutPort(Image, doc="The newest picture")
    Odom = OutPort(Odometry, doc="The robot's place on the floor")

    async def on_start(self) -> None:
        """Show the first picture."""
        self.Frame.publish(checkerboard(32, 200))
        self.Odom.publish(Odometry())

    @function
    def Shade(self, red: Annotated[UShort, "Red of the dark squares"] = 200) -> None:
        """Publish a picture with another red."""
        self.Frame.publish(checkerboard(32, min(red, 255)))

    @function
    def Drive(self, x: Annotated[Double, "x (m)"] = 0.0, y: Annotated[Double, "y (m)"] = 0.0) -> None:
        """Put the robot at (x, y), heading away from where it was."""
        self.Odom.publish(Odometry(x, y, 0.5))
