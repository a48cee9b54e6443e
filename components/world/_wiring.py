"""How a robot component finds its world: load ``world`` if needed, then connect the default ports."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from ..core import Component, ComponentHost

if TYPE_CHECKING:
    from ._component import World

__all__ = ["attach", "virtual_head_azimuth"]

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


def virtual_head_azimuth(host: ComponentHost) -> Callable[[], float] | None:
    """The azimuth (degrees, positive = left) of the world's KEMAR head while ``morse_kemar`` drives it, or None.

    The simulated sound scene follows it then, as it follows the simulated ``kemar`` drive otherwise.
    The function reads a float the world updates at each physics step: safe from any thread.
    """
    instances = host.instances
    world = instances.get(WORLD_INSTANCE)
    if world is None or not any(c.genom_name == "morse_kemar" for c in instances.values()):
        return None
    return lambda: world.kemar_azimuth  # type: ignore[attr-defined, no-any-return]
