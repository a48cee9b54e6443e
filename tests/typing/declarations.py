"""What a type checker says of component declarations (checked by mypy in ``./run test``, never run).

A line a type checker must refuse carries ``# type: ignore[<code>]``: mypy runs
with ``warn_unused_ignores``, so a refusal that stops happening fails the check.
``assert_type`` pins what the declarations give a component author.
"""

from __future__ import annotations

import dataclasses
from typing import Annotated, Any, assert_type

import numpy as np
from numpy.typing import NDArray

from aiogenomix.components.core import (
    Bound, Component, Double, GenomServices, InPort, InPortRuntime, Length, Long, OutPort, OutPortRuntime, String,
    activity, function, idl_struct, redeclare,
)


@idl_struct("rover::pose")
class Pose:
    """A struct: its generated ``__init__`` is checked like a dataclass's."""

    x: Double = 0.0
    y: Double = 0.0
    names: list[String] = dataclasses.field(default_factory=list)
    samples: Annotated[NDArray[np.int32], Bound(64)] = dataclasses.field(
        default_factory=lambda: np.zeros(0, np.int32))
    corner: Annotated[list[Long], Length(2)] = dataclasses.field(default_factory=lambda: [0, 0])


Pose(1.0, 2.0, ["a"])
Pose(x="far")  # type: ignore[arg-type]
Pose(1.0, 2.0, [], np.zeros(0, np.int32), [0, 0], 6)  # type: ignore[call-arg]


class Rover(Component, name="rover"):
    """A component whose ports are typed by their declarations."""

    Where = OutPort(Pose, doc="Where the rover is")
    Goal = InPort(Pose, doc="Where it goes")
    # An Annotated alias is no class: the port says its Python type.
    Speed: OutPort[float] = OutPort(Double, doc="Its speed in m/s")

    @function
    def Stop(self) -> None:
        """Stop."""

    @activity(interrupts=("Stop",), throws=(), motion=True)
    async def Goto(self, x: Double, label: Annotated[str, Bound(16)] = "") -> None:
        """Go."""
        assert_type(self.Where, OutPortRuntime[Pose])
        assert_type(self.Goal, InPortRuntime[Pose])
        assert_type(self.Goal.read(), Pose | None)
        assert_type(await self.Goal.wait_published(), int)
        self.Where.publish(Pose(x))
        self.Where.publish(3)  # type: ignore[arg-type]
        self.Speed.publish(1.5)
        self.Speed.publish("fast")  # type: ignore[arg-type]
        assert_type(self.Where.read(), Pose)

    # Misspelled and misshapen options are refused by the type checker too.
    @function(interupts=("Goto",))  # type: ignore[call-overload]
    def Typo(self) -> None:
        """A typo."""

    @function(throws=ValueError)  # type: ignore[call-overload]
    def WrongThrows(self) -> None:
        """Not a GenomException."""


assert_type(Rover.Where, OutPort[Pose])


class Merged(Rover, name="merged"):
    """A merged component redeclares a service of one of its parts."""

    @redeclare(Rover.Goto, doc="Go, and say so")
    async def Goto(self, **inputs: Any) -> None:
        await Rover.Goto(self, **inputs)

    @redeclare(Rover.Stop, interupts=("Goto",))  # type: ignore[call-arg]
    def Stop(self) -> None:
        """A typo."""


async def drive(merged: Merged) -> None:
    """The redeclared service keeps the original's signature."""
    await merged.Goto(1.0, "home")
    await merged.Goto("far")  # type: ignore[arg-type]


class Following(Rover, name="following"):
    """A component redeclares a genom3 standard service, as it redeclares a service of its parts."""

    @redeclare(GenomServices.connect_port, doc="Connect Goal to another rover's Where")
    async def connect_port(self, **inputs: Any) -> None:
        await GenomServices.connect_port(self, **inputs)


async def follow(following: Following) -> None:
    """The redeclared standard service keeps its signature: the component it serves, then the inputs."""
    await following.connect_port("Goal", "rover/Where")
    await GenomServices.kill(following)
