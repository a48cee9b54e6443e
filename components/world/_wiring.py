"""How a robot component finds its world: load ``world`` if needed, then connect the default ports."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..core import Component, ComponentHost

if TYPE_CHECKING:
    from ._component import World

__all__ = ["attach", "virtual_head_azimuth", "virtual_scene", "marker_scene"]

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
    return lambda: world.kemar_azimuth  # type: ignore[attr-defined]


def marker_scene() -> Any:
    """The binaural scene of the world's sound-source markers, as heard from the KEMAR's place.

    Each marker becomes a source in its direction from the KEMAR (degrees, positive to the left
    of the KEMAR's front at azimuth 0): the first a noise, the second a tone, the next clicks.
    """
    from ..audio import Scene, Source
    from ._mjcf import KEMAR_ORIGIN, SOUND_SOURCES

    kinds = (dict(type="noise", level=-26.0), dict(type="tone", level=-30.0, frequency=500.0),
             dict(type="clicks", level=-12.0, rate=2.0))
    sources = []
    for i, (x, y, _z) in enumerate(SOUND_SOURCES.values()):
        azimuth = math.degrees(math.atan2(y - KEMAR_ORIGIN[1], x - KEMAR_ORIGIN[0]))
        sources.append(Source(azimuth=round(azimuth, 6), **kinds[i % len(kinds)]))  # type: ignore[arg-type]
    return Scene(sources=tuple(sources), seed=7, noise_floor=-80.0)


def virtual_scene(host: ComponentHost) -> Any:
    """The scene of the world's markers while ``morse_kemar`` drives the world's KEMAR, or None."""
    return marker_scene() if virtual_head_azimuth(host) is not None else None
