"""How a robot component finds its world: load ``world`` if needed, then connect the default ports."""

from __future__ import annotations

from ..core import Component, LoadError
from ._component import World

__all__ = ["attach", "WORLD_INSTANCE"]

#: The instance name of the world robot components use.
WORLD_INSTANCE = "world"


async def attach(robot: Component, pairs: dict[str, str]) -> World:
    """Load ``world`` (unless an instance of that name runs) and wire ``{robot_port: world_port}``.

    As MORSE and GenoM3 met on ROS topics, the robot and the world meet on ports; ``connect_port``
    re-wires any of them afterwards (to another world, or to real drivers).

    Raises:
        LoadError: when the instance of that name is not a world.
    """
    world = await robot.host.load(World.genom_name, ["-i", WORLD_INSTANCE])
    if not isinstance(world, World):  # another process's world: its ports are wired by connect_port
        raise LoadError(f"{WORLD_INSTANCE} is a {world.genom_name} here, not a world {robot.instance} can wire")
    world.wire(robot, pairs)
    return world
