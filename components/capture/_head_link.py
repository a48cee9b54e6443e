"""Where the simulated scene finds the head azimuth: the host's simulated KEMAR drive, if any."""

from __future__ import annotations

from ..core import ComponentHost
from ..audio import Azimuth, Scene, split_device

__all__ = ["simulated_head_azimuth", "scene_azimuth", "simulated_scene"]


def simulated_head_azimuth(host: ComponentHost) -> Azimuth | None:
    """The azimuth (degrees, positive = left) of the host's simulated KEMAR head, or None.

    There is a simulated head when the host's CAN bus is ``virtual``; the drive is
    shared through the host (``kemar.rig``), so the scene turns when the ``kemar``
    or ``kemarcapture`` component moves the head.  On a real bus there is none
    (and real microphones hear the real room).  When ``morse_kemar`` is loaded (before
    the capture starts), the scene follows the virtual KEMAR of ``world`` instead.
    """
    # Imported here: plain capture must not pay for the CAN stack unless it simulates.
    from ..kemar import simulated_rig
    from ..world import virtual_head_azimuth

    virtual = virtual_head_azimuth(host)  # the KEMAR of the MuJoCo world, when morse_kemar drives it
    if virtual is not None:
        return virtual
    rig = simulated_rig(host)
    if rig is None:
        return None
    return lambda: rig.head_azimuth


def scene_azimuth(host: ComponentHost, device: str, chosen: Azimuth | None) -> Azimuth | None:
    """The head azimuth a capture of *device* should follow.

    *chosen* (set from a script or a test) wins; otherwise a simulated scene
    follows the host's simulated KEMAR head, and any other device none.
    """
    if chosen is not None or split_device(device)[0] != "sim":
        return chosen
    return simulated_head_azimuth(host)


def simulated_scene(host: ComponentHost, device: str) -> Scene | None:
    """The scene the plain ``sim`` device renders (None: the default scene).

    While ``morse_kemar`` drives the virtual KEMAR, the sources are the world's
    sound-source markers, heard from where the KEMAR stands.  A scene file
    (``sim:PATH``) always wins.
    """
    if device != "sim":
        return None
    from ..world import virtual_scene

    scene: Scene | None = virtual_scene(host)
    return scene
