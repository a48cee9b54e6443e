"""How a robot component finds its world: load ``world`` if needed, then connect the default ports."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core import Component

if TYPE_CHECKING:
    from ._component import World

__all__ = ["attach"]

#: The instance name of the world robot components use.
WORLD_INSTANCE = "world"


async def attach(robot: Component, pairs: dict[str, str]) -> World:
    """Load ``world`` (unless an instance of that name runs) and wire ``{robot_port: world_port}``.

    As MORSE and GenoM3 met on ROS topics, the robot and the world meet on ports; ``connect_port``
    re-wires any of them afterwards (to another world, or to real drivers).
    """
    world = await robot.host.load("world", ["-i", WORLD_INSTANCE])
    world.wire(robot, pairs)  # type: ignore[attr-defined]
    return world  # type: ignore[return-value]
